"""Friction parameters and particle spins held by the C resolver (``struct rs_resolver``).

The glue between the declaration of the friction models (``physics.friction.FRICTION``,
``INERTIA_FACTOR``) and the C library: checking and packing the parameters, and reading
and writing the resolver's spin array (3 doubles per particle, by particle index, relative
to the rotating frame of the sheet, [rad/s]; ``physics.friction`` states the conventions).
The array keeps x, y in the axes the rotating frame had at t = 0 (a torque-free spin is
constant in inertial space, so its components in the frame's axes turn at -Omega); the
readers turn them to the frame's axes at a frame angle, the checkpoint keeps them as
stored.
``engine.resolver.ResolverHandle`` calls these; nothing else should touch the C fields.
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping
from typing import Any

import numpy as np

from ringsim.engine.native import _LIB, FRICTION_CODES
from ringsim.physics import friction as fr


def checked_friction(friction: Mapping[str, Any] | None, inertia_factor: Any
                     ) -> tuple[str, dict[str, float], float]:
    """(model, parameters, k) of a friction mapping and inertia factor.

    ``friction`` None (no ``friction:`` section) is ``("none", {}, k)``: smooth spheres, the
    resolver's path without friction.  ValueError starting with the offending key.
    """
    k = fr.INERTIA_FACTOR.check(inertia_factor)
    if friction is None:
        return "none", {}, k
    if not isinstance(friction, Mapping):
        raise ValueError(f"friction: expected a mapping, got {type(friction).__name__}")
    model, params = fr.friction_parameters(friction)
    return model, params, k


def install_friction(address: int, model: str, params: Mapping[str, float], k: float) -> None:
    """Set a checked friction model in the C resolver at ``address``.

    The C checks the declared ranges again (``rs_friction_valid``); ValueError if it refuses.
    """
    values = (0.0, 0.0, 0.0) if model == "none" else \
        fr.FRICTION[model].pack(params, fr.FRICTION.n_slots)
    if not _LIB.rs_resolver_set_friction(address, FRICTION_CODES[model], *values, k):
        raise ValueError(f"friction: the C resolver refused model {model!r} with {values} "
                         f"and inertia_factor {k!r} (outside the declared ranges)")


def frame_angle(sim: Any) -> float:
    """Angle [rad] of the rotating frame at ``sim.t`` (``rs_spin_frame_angle``): REBOUND's
    ``OMEGA * t`` (the frame of Hill's equations; OMEGA = 0, its default: inertial)."""
    if sim is None:
        return 0.0
    return float(_LIB.rs_spin_frame_angle(ctypes.addressof(sim), sim.t))


def read_spins(address: int, n: int, theta: float) -> np.ndarray:
    """Spins of particles 0..n-1 in the rotating frame's axes at frame angle ``theta``
    [rad], (n, 3) [rad/s] (zero where never set; ``rs_spins_read``)."""
    out = np.zeros((n, 3))
    if n > 0:
        _LIB.rs_spins_read(address, theta, n, out.ctypes.data)
    return out


def write_spins(address: int, spins: Any, n: int | None, theta: float) -> None:
    """Set the spins of particles 0..len(spins)-1 from rotating-frame values [rad/s] at
    frame angle ``theta`` [rad]; the rest of the array is zeroed (``rs_spins_write``).

    ``n``: the particle count of the simulation, if attached (the shape must match it).
    """
    values = _checked_spins(spins, n)
    if not _LIB.rs_spins_write(address, theta, values.shape[0], values.ctypes.data):
        raise MemoryError(f"could not allocate spins for {values.shape[0]} particles")


def read_spin_state(struct: Any, n: int) -> np.ndarray:
    """Copy of the stored spins of particles 0..n-1, (n, 3) [rad/s]: x, y in the axes the
    rotating frame had at t = 0, z as is (for checkpoints: restored bit for bit)."""
    out = np.zeros((n, 3))
    held = min(n, int(struct.spin_capacity))
    if held > 0:
        out[:held] = np.ctypeslib.as_array(struct.spin, shape=(held, 3))
    return out


def write_spin_state(address: int, struct: Any, spins: Any, n: int | None) -> None:
    """Set the stored spins (:func:`read_spin_state`) of particles 0..len(spins)-1; the
    rest of the array is zeroed."""
    values = _checked_spins(spins, n)
    if not _LIB.rs_spin_reserve(address, max(values.shape[0], 1)):
        raise MemoryError(f"could not allocate spins for {values.shape[0]} particles")
    buffer = np.ctypeslib.as_array(struct.spin, shape=(int(struct.spin_capacity), 3))
    buffer[:values.shape[0]] = values
    buffer[values.shape[0]:] = 0.0


def _checked_spins(spins: Any, n: int | None) -> np.ndarray:
    values = np.ascontiguousarray(spins, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3 or (n is not None and values.shape[0] != n):
        expected = f"({n}, 3)" if n is not None else "(N, 3)"
        raise ValueError(f"spins: expected shape {expected}, got {values.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError("spins: must be finite")
    return values
