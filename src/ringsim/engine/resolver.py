"""ringsim's native collision resolver for REBOUND (its pure-Python twin, for tests, is
``ringsim.testing.PythonReferenceResolver``).

The resolver (``ringsim/csrc/rs_resolver.c``) replaces REBOUND's hard-sphere resolver.
It applies the normal impulse of a coefficient of restitution eps(v, R_bar, M_bar) of
Dilley (1993, Icarus 105, 225) or of one of the laws it compares with (Bridges et al.
1984, Andrews, Tabor, a constant), keeps REBOUND's ``minimum_collision_velocity``,
``collisions_plog`` and ``collisions_log_n`` semantics, and accumulates collision
statistics in C.  Any REBOUND user can put it into a simulation of their own::

    handle = install_resolver(sim, {"model": "dilley", "xi0": 0.16, "p": 0.65,
                                    "kappa": 0.1})
    sim.integrate(t_end)
    handle.stats()["mean_epsilon"]

Collision search: with REBOUND's ``tree`` or ``direct`` search a pair is resolved if it
overlaps and approaches at the end of the step; with ``line`` or ``linetree`` at its first
contact on the straight relative path within the step, after which both particles move on
with their new velocities for the rest of the step (see the header of the C file).
``install_resolver(..., collision_detection="line")`` replaces REBOUND's search by
ringsim's own swept-sphere search for shearing sheets (``ringsim/csrc/rs_sheet_detect.c``):
cells in the shear frame, searches widened by the speeds relative to the shear flow only,
contacts resolved as in ``linetree`` mode.  Its cost per particle-step does not grow with the box.

Lifetime: the handle owns the C memory of parameters and statistics and frees it when
closed or garbage-collected.  ``install_resolver`` stores the handle in the simulation
(``sim._extras_ref``, the slot REBOUND reserves for this) and the handle keeps the
simulation, so neither is collected while the other is in use.  The C struct is found
from the simulation through ``sim.extras``, so the resolver cannot be combined with
REBOUNDx, which uses the same pointer.

REBOUND does not save function pointers in its binary files: after loading a checkpoint
call ``handle.reinstall(new_sim)``, which keeps the parameters and the statistics.

Statistics (``ResolverHandle.stats``): the collisions resolved, their mean coefficient of
restitution and impact speed, histograms of impact speed and dissipation, a sampled log of
collisions, multiple encounters within a step and collisions outside the law's measured
ranges; ``engine.statistics`` lists them with their units.
"""

from __future__ import annotations

import ctypes
import math
import weakref
from collections.abc import Mapping
from typing import Any, cast

import numpy as np
import rebound
from rebound.simulation import COLRFF, CollisionS

from ringsim.engine import detector as _detector
from ringsim.engine import spins as _spins
from ringsim.engine import statistics as _statistics
from ringsim.engine.native import (
    _CONSTANT_COR_ADDRESS,
    _LIB,
    _POST_TIMESTEP,
    _RESOLVE_ADDRESS,
    _SHEET_STEP_ADDRESS,
    COLLISION_DETECTIONS,
    COLLISION_DTYPE,
    LOG_DTYPE,
    MODEL_CODES,
    _free_resolver,
    _function_address,
    _Resolver,
)
from ringsim.physics import restitution as rs


def _validated(restitution: Mapping[str, Any]) -> tuple[str, dict[str, float]]:
    """Model name and complete parameters, checked against the declaration
    (``restitution.RESTITUTION``); ValueError naming the key if invalid."""
    if not isinstance(restitution, Mapping):
        raise ValueError(f"restitution: expected a mapping, got {type(restitution).__name__}")
    return rs.model_parameters(restitution)


def _packed(model: str, params: Mapping[str, float]) -> tuple[int, tuple[float, ...]]:
    """The C model code and ``param[]`` of a validated law (slots from the declaration)."""
    law = rs.RESTITUTION[model]
    return MODEL_CODES[model], law.pack(params, rs.RESTITUTION.n_slots)


def _detach(sim: rebound.Simulation, handle: ResolverHandle) -> None:
    """Remove ``handle``'s resolver from ``sim`` if it is still installed there."""
    if sim.extras == handle._address:
        sim.extras = None
        if _function_address(sim._post_timestep_modifications) == _SHEET_STEP_ADDRESS:
            sim._post_timestep_modifications = _POST_TIMESTEP()
    if getattr(sim, "_extras_ref", None) is handle:
        sim._extras_ref = None


def measured_range(model: str) -> tuple[float, float, float, float]:
    """(v_min, v_max [m/s], R_min, R_max [m]) the law's parameters were measured over, from
    its declaration (``physics.restitution.RESTITUTION``); (0, inf) where not stated.  The
    resolver counts the collisions outside them (``outside_speeds``, ``outside_sizes``)."""
    measured = rs.RESTITUTION[model].measured
    speeds = measured.speeds or (0.0, math.inf)
    sizes = measured.sizes or (0.0, math.inf)
    return (float(speeds[0]), float(speeds[1]), float(sizes[0]), float(sizes[1]))


def measured_masses(model: str) -> tuple[float, float]:
    """(M_min, M_max) [kg], the reduced masses the law's parameters were measured at, from
    its declaration; (0, inf) where not stated.  The resolver counts the collisions below
    and above them (``masses_below``, ``masses_above``)."""
    masses = rs.RESTITUTION[model].measured.masses or (0.0, math.inf)
    return (float(masses[0]), float(masses[1]))


class ResolverHandle:
    """Parameters and statistics of ringsim's C resolver in one simulation.

    Create it with :func:`install_resolver`.  The handle owns the C memory; it is freed
    by :meth:`close` or when the handle is garbage-collected.  A handle is attached to
    one simulation at a time.

    Parameters
    ----------
    restitution : mapping
        As in the scenario's ``restitution`` section, e.g.
        ``{"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}``.
    friction : mapping or None
        As in the scenario's ``friction`` section, ``{"model": "constant", "beta": 0.0}``
        or ``{"model": "coulomb", "mu": 0.5}`` (``physics.friction.FRICTION``); None:
        smooth spheres, no spins (the resolver's path without friction, bit for bit).
    inertia_factor : float
        k in I = k m R^2, in (0, 2/3] (``physics.friction.INERTIA_FACTOR``).
    log_capacity : int
        Number of sampled collisions kept (ring buffer); 0 disables the log.
    log_every : int
        Sampling stride: every ``log_every``-th resolved collision is logged.
    collision_detection : None, "tree" or "line"
        Collision search, the word of the scenario's ``integration.collision_detection``.
        None: REBOUND's own search, as set in ``sim.collision`` (``tree`` and ``direct``
        report overlaps at step ends, ``line`` and ``linetree`` swept paths).  "tree":
        the same, for a simulation whose ``sim.collision`` is REBOUND's ``tree`` (checked).
        "line": ringsim's swept-sphere sheet detector for shear-periodic (or periodic)
        boxes (``rs_sheet_detect.c``): :meth:`reinstall` sets ``sim.collision = "none"``
        and runs the search and the contact-time resolution as REBOUND's
        ``post_timestep_modifications``, once per step, before REBOUND wraps the particles.
    """

    def __init__(self, restitution: Mapping[str, Any],
                 friction: Mapping[str, Any] | None = None, inertia_factor: float = 0.4, *,
                 log_capacity: int = 0, log_every: int = 1,
                 collision_detection: str | None = None):
        if collision_detection not in COLLISION_DETECTIONS:
            raise ValueError(f"collision_detection: must be one of {COLLISION_DETECTIONS}, "
                             f"got {collision_detection!r}")
        model, params = _validated(restitution)
        friction_model, friction_params, k = _spins.checked_friction(friction, inertia_factor)
        log_capacity, log_every = _statistics.checked_log(log_capacity, log_every)
        code, values = _packed(model, params)
        address = _LIB.rs_resolver_create(code, *values, log_capacity, log_every)
        if not address:
            raise MemoryError(f"could not allocate the resolver (log_capacity={log_capacity})")
        self.model = model
        self.parameters = dict(params)
        self.log_capacity = log_capacity
        self.log_every = log_every
        self.collision_detection = collision_detection
        self._address: int | None = address
        self._struct: _Resolver | None = _Resolver.from_address(address)
        self._struct.measured[:] = measured_range(model)
        self._struct.measured_masses[:] = measured_masses(model)
        self.friction = (None if friction_model == "none"
                         else {"model": friction_model, **friction_params})
        self.inertia_factor = k
        _spins.install_friction(address, friction_model, friction_params, k)
        # Function pointers into the loaded library; kept here so they live with the handle.
        self._resolve_fp = COLRFF(_RESOLVE_ADDRESS)
        self._sheet_step_fp = _POST_TIMESTEP(_SHEET_STEP_ADDRESS)
        self._sim: rebound.Simulation | None = None
        self._finalizer = weakref.finalize(self, _free_resolver, address)

    # -- attachment -----------------------------------------------------------------------

    @property
    def address(self) -> int:
        """Address of the C struct (what ``sim.extras`` points to)."""
        if self._address is None:
            raise ValueError("the resolver handle is closed")
        return self._address

    @property
    def closed(self) -> bool:
        return self._address is None

    @property
    def simulation(self) -> rebound.Simulation | None:
        """The simulation the resolver is installed in (None once detached)."""
        return self._sim

    def reinstall(self, sim: rebound.Simulation) -> ResolverHandle:
        """Install this resolver, with its parameters and statistics, into ``sim``.

        Use it after loading a checkpoint (REBOUND does not save function pointers).  If
        the handle was installed in another simulation, it is removed from there; that
        simulation stops with an error if it meets a collision later.
        """
        address = self.address
        extras = sim.extras
        previous = getattr(sim, "_extras_ref", None)
        if extras not in (None, address) and not isinstance(previous, ResolverHandle):
            raise ValueError("sim.extras is already used by another library (REBOUNDx?); "
                             "ringsim's resolver needs it to find its parameters")
        if self.collision_detection == "tree" and sim.collision != "tree":
            raise ValueError(f"collision_detection 'tree' needs sim.collision = 'tree', "
                             f"the simulation has {sim.collision!r}")
        if self.collision_detection == "line":
            if sim.boundary not in ("shear", "periodic"):
                raise ValueError(f"collision_detection 'line' needs boundary 'shear' or "
                                 f"'periodic', the simulation has {sim.boundary!r}")
            post = _function_address(sim._post_timestep_modifications)
            if post not in (None, _SHEET_STEP_ADDRESS):
                raise ValueError("sim.post_timestep_modifications is already set; "
                                 "collision_detection 'line' runs its search there")
        if isinstance(previous, ResolverHandle) and previous is not self:
            previous._sim = None    # the old resolver's statistics stay readable
        if self._sim is not None and self._sim is not sim:
            _detach(self._sim, self)
        sim.extras = address
        sim._collision_resolve = self._resolve_fp
        if self.collision_detection == "line":
            sim.collision = "none"
            sim._post_timestep_modifications = self._sheet_step_fp
        sim._extras_ref = self
        self._sim = sim
        return self

    def close(self) -> None:
        """Remove the resolver from its simulation and free the C memory."""
        if self._address is None:
            return
        if self._sim is not None:
            _detach(self._sim, self)
            self._sim = None
        self._finalizer()
        self._address = None
        self._struct = None

    def __enter__(self) -> ResolverHandle:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else f"{self._open().stats.count} collisions"
        return f"<ResolverHandle {self.model} {self.parameters} ({state})>"

    # -- spins ----------------------------------------------------------------------------

    def spins(self) -> np.ndarray:
        """Spins of the simulation's particles at ``sim.t``, (N, 3) [rad/s], by index.

        Angular velocities about each centre relative to the rotating frame of the sheet,
        in its axes (``physics.friction``: w_z > 0 prograde; add Omega z for the inertial
        spin; between collisions w_x, w_y turn at -Omega).  Zero without friction.
        Detached: every particle the resolver has room for, in the axes at t = 0.
        """
        return _spins.read_spins(self.address, self._n_spins(), _spins.frame_angle(self._sim))

    def set_spins(self, spins: Any) -> None:
        """Set the spins, (N, 3) [rad/s] in the rotating frame's axes at ``sim.t``."""
        self._open()
        _spins.write_spins(self.address, spins, self._sim.N if self._sim is not None
                           else None, _spins.frame_angle(self._sim))

    def spin_state(self) -> np.ndarray:
        """The stored spins, (N, 3) [rad/s] (x, y in the frame's axes at t = 0), for
        checkpoints: :meth:`set_spin_state` restores them bit for bit."""
        return _spins.read_spin_state(self._open(), self._n_spins())

    def set_spin_state(self, spins: Any) -> None:
        """Restore :meth:`spin_state` (shape checked as for :meth:`set_spins`)."""
        _spins.write_spin_state(self.address, self._open(), spins,
                                self._sim.N if self._sim is not None else None)

    def _open(self) -> _Resolver:
        if self._struct is None:
            raise ValueError("the resolver handle is closed")
        return self._struct

    def _n_spins(self) -> int:
        return self._sim.N if self._sim is not None else int(self._open().spin_capacity)

    # -- statistics -----------------------------------------------------------------------

    def stats(self) -> dict[str, Any]:
        """Collision statistics accumulated in C since creation or the last reset.

        Returns
        -------
        dict with ``count``, ``n_floored``, ``mean_epsilon``, ``mean_vn`` [m/s],
        ``sum_epsilon``, ``sum_vn`` [m/s], ``histograms`` (``v_n`` and
        ``one_minus_epsilon``, each with ``edges``, ``counts``, ``underflow``,
        ``overflow``, ``units``), ``log`` (structured array, :data:`LOG_DTYPE`),
        ``log_written`` (entries ever logged) and ``log_every``.
        """
        s = self._open().stats
        log = _statistics.oldest_first(self._raw_log(), int(s.log_written))
        return _statistics.summary(s, log, self.log_every)

    # -- the sheet detector (collision_detection="line") --------------------------------

    def order_stats(self) -> dict[str, int]:
        """Counters of the sheet detector's time-ordered resolution since creation
        (``resolved``, ``rescheduled``, ...: `ringsim.engine.detector.order_counters`)."""
        return _detector.order_counters(self.address)

    def detector_stats(self) -> dict[str, Any]:
        """Counters of the sheet detector's search since creation (``steps``,
        ``candidates``, ...: `ringsim.engine.detector.search_counters`)."""
        return _detector.search_counters(self.address)

    def detect_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """Run the sheet detector's search on the simulation's current state, without
        resolving: (pairs, ghost-box offsets), for tests
        (`ringsim.engine.detector.detect_pairs`)."""
        if self._sim is None:
            raise ValueError("the resolver is not installed in a simulation")
        return _detector.detect_pairs(self._sim)

    def reset_stats(self) -> None:
        """Zero all counters, histograms and the log."""
        _LIB.rs_resolver_reset_stats(self.address)

    def stats_state(self) -> dict[str, np.ndarray]:
        """The raw statistics, exactly as held in C, to save with a checkpoint.

        Returns
        -------
        dict of numpy arrays: one per field of the C ``struct rs_stats`` (``count``,
        ``n_floored``, ``sum_epsilon`` [1], ``sum_vn`` [m/s], ``vn_underflow``,
        ``vn_overflow``, ``vn_hist``, ``eps_underflow``, ``eps_hist``, ``log_written``,
        ``multi_encounters``, ..., ``tangential_dissipation``, ``normal_dissipation`` [J]; scalars
        as 0-d arrays) and ``log``, the whole ring buffer
        (:data:`LOG_DTYPE`, ``log_capacity`` entries in memory order).  :meth:`set_stats`
        restores them bit for bit.
        """
        state = _statistics.saved(self._open().stats)
        state["log"] = self._raw_log().copy()
        return state

    def set_stats(self, state: Mapping[str, Any]) -> None:
        """Restore statistics saved by :meth:`stats_state` (e.g. on resuming a checkpoint).

        Every field must be present with its shape, and the log must have this handle's
        ``log_capacity``; ValueError naming the field otherwise (nothing is changed then).
        """
        values = _statistics.checked(self._open().stats, state)
        log = np.asarray(state.get("log", np.zeros(0, LOG_DTYPE)))
        if log.dtype != LOG_DTYPE or log.shape != (self.log_capacity,):
            raise ValueError(f"statistics: log must hold {self.log_capacity} entries of "
                             f"LOG_DTYPE, got {log.shape} {log.dtype}")
        _statistics.restore(self._open().stats, values)
        self._raw_log()[...] = log

    def _raw_log(self) -> np.ndarray:
        """The C ring buffer of the log as a writable numpy view (empty without a log)."""
        return _statistics.log_buffer(self._open().log, self.log_capacity)

    def resolve_batch(self, collisions: np.ndarray) -> int:
        """Resolve a list of collisions in the attached simulation with one C call.

        For benchmarks and tests: REBOUND normally calls the resolver itself.

        Parameters
        ----------
        collisions : structured array of :data:`COLLISION_DTYPE`
            From :func:`collision_records`, resolved in order.

        Returns
        -------
        int
            Number of collisions resolved (reports of receding pairs do nothing).
        """
        if self._sim is None:
            raise ValueError("the resolver is not installed in a simulation")
        if collisions.dtype != COLLISION_DTYPE or not collisions.flags.c_contiguous:
            raise ValueError("collisions: expected a contiguous COLLISION_DTYPE array")
        if np.any(collisions["p1"] >= self._sim.N) or np.any(collisions["p2"] >= self._sim.N):
            raise ValueError("collisions: particle index out of range")
        pointer = collisions.ctypes.data_as(ctypes.POINTER(CollisionS))
        return int(_LIB.rs_resolve_batch(ctypes.addressof(self._sim), pointer,
                                         collisions.size))

    def epsilon(self, v: Any, R_bar: Any, M_bar: Any) -> np.ndarray:
        """The law's coefficient of restitution as evaluated by the C code.

        Parameters
        ----------
        v : array [m/s]
            Normal impact speed (sign ignored).
        R_bar : array [m]
            Reduced radius of the pair.
        M_bar : array [kg]
            Reduced mass of the pair.
        """
        v_, r_, m_ = (np.ascontiguousarray(a, dtype=float)
                      for a in np.broadcast_arrays(v, R_bar, M_bar))
        out = np.empty(v_.shape)
        double_p = ctypes.POINTER(ctypes.c_double)
        _LIB.rs_epsilon_array(self.address, v_.size, v_.ctypes.data_as(double_p),
                              r_.ctypes.data_as(double_p), m_.ctypes.data_as(double_p),
                              out.ctypes.data_as(double_p))
        return out


def collision_records(pairs: Any, ghosts: Any = None) -> np.ndarray:
    """Collisions as REBOUND reports them, for :meth:`ResolverHandle.resolve_batch`.

    Parameters
    ----------
    pairs : int array (n, 2)
        Particle indices (p1, p2) of each reported collision.
    ghosts : array (n, 6) or (6,) [m, m, m, m/s, m/s, m/s], optional
        Ghost-box offset of p1 (x, y, z, vx, vy, vz); zero if omitted.
    """
    pairs = np.asarray(pairs).reshape(-1, 2)
    if np.any(pairs < 0):
        raise ValueError("pairs: particle indices must be >= 0")
    records = np.zeros(len(pairs), dtype=COLLISION_DTYPE)
    records["p1"] = pairs[:, 0]
    records["p2"] = pairs[:, 1]
    if ghosts is not None:
        records["gb"] = np.broadcast_to(np.asarray(ghosts, dtype=float), (len(pairs), 6))
    return records


def install_resolver(sim: rebound.Simulation, restitution: Mapping[str, Any],
                     friction: Mapping[str, Any] | None = None, inertia_factor: float = 0.4,
                     *, log_capacity: int = 0, log_every: int = 1,
                     collision_detection: str | None = None) -> ResolverHandle:
    """Put ringsim's C collision resolver with the given restitution law into ``sim``.

    Parameters
    ----------
    sim : rebound.Simulation
        Any REBOUND simulation with collision detection switched on.
    restitution : mapping
        ``{"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}``; models dilley
        {xi0, p, kappa}, bridges {v_c [m/s], exponent}, constant {epsilon},
        andrews {v_c [m/s]}, tabor {v_c [m/s], q}.  Missing optional parameters take
        their defaults; unknown models or keys raise ValueError naming the key.
    friction : mapping or None
        ``{"model": "constant", "beta": B}`` or ``{"model": "coulomb", "mu": M}``
        (optional ``beta0``); None: smooth spheres.  Spins: :meth:`ResolverHandle.spins`.
    inertia_factor : float
        k in I = k m R^2, in (0, 2/3]; 0.4 a solid sphere.
    log_capacity : int
        Number of sampled collisions kept in C (0: no log).
    log_every : int
        Log every ``log_every``-th collision.
    collision_detection : None, "tree" or "line"
        None keeps the simulation's REBOUND collision search (``tree``, ``direct``,
        ``line`` or ``linetree``, as set in ``sim.collision``); "tree" checks that it is
        REBOUND's tree search; "line" replaces it by ringsim's swept-sphere sheet detector
        for shearing sheets (see :class:`ResolverHandle`).

    Returns
    -------
    ResolverHandle
        Stored in the simulation as well (``sim._extras_ref``), so it lives as long as
        ``sim``; keep it to read the statistics.
    """
    handle = ResolverHandle(restitution, friction, inertia_factor,
                            log_capacity=log_capacity, log_every=log_every,
                            collision_detection=collision_detection)
    return handle.reinstall(sim)


def constant_epsilon_callback_address() -> int:
    """Address of a C ``coefficient_of_restitution`` returning the constant eps of the
    ringsim resolver installed in the same simulation (1 for other laws).

    For comparisons with REBOUND's built-in hard-sphere resolver::

        sim._coefficient_of_restitution = CORFF(constant_epsilon_callback_address())
    """
    return cast(int, _CONSTANT_COR_ADDRESS)   # a loaded function's address is never NULL
