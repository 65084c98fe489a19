"""Friction parameters and particle spins held by the C resolver (``struct rs_resolver``).

The glue between the declaration of the friction models (``physics.friction.FRICTION``,
``INERTIA_FACTOR``) and the C library: checking and packing the parameters, and reading
and writing the resolver's spin array (3 doubles per particle, by particle index, relative
to the rotating frame of the sheet, [rad/s]; ``physics.friction`` states the conventions).
``engine.resolver.ResolverHandle`` calls these; nothing else should touch the C fields.
"""

from __future__ import annotations

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


def read_spins(struct: Any, n: int) -> np.ndarray:
    """Copy of the spins of particles 0..n-1, (n, 3) [rad/s] (zero where never set)."""
    out = np.zeros((n, 3))
    held = min(n, int(struct.spin_capacity))
    if held > 0:
        out[:held] = np.ctypeslib.as_array(struct.spin, shape=(held, 3))
    return out


def write_spins(address: int, struct: Any, spins: Any, n: int | None) -> None:
    """Set the spins of particles 0..len(spins)-1 [rad/s]; the rest of the array is zeroed.

    ``n``: the particle count of the simulation, if attached (the shape must match it).
    """
    values = np.asarray(spins, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3 or (n is not None and values.shape[0] != n):
        expected = f"({n}, 3)" if n is not None else "(N, 3)"
        raise ValueError(f"spins: expected shape {expected}, got {values.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError("spins: must be finite")
    if not _LIB.rs_spin_reserve(address, max(values.shape[0], 1)):
        raise MemoryError(f"could not allocate spins for {values.shape[0]} particles")
    buffer = np.ctypeslib.as_array(struct.spin, shape=(int(struct.spin_capacity), 3))
    buffer[:values.shape[0]] = values
    buffer[values.shape[0]:] = 0.0

