"""ringsim's native collision resolver for REBOUND, and its pure-Python twin.

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
``install_resolver(..., detector="sheet")`` replaces REBOUND's search by ringsim's own
swept-sphere search for shearing sheets (``ringsim/csrc/rs_sheet_detect.c``): cells in
the shear frame, searches widened by the speeds relative to the shear flow only, contacts
resolved as in ``linetree`` mode.  Its cost per particle-step does not grow with the box.

Lifetime: the handle owns the C memory of parameters and statistics and frees it when
closed or garbage-collected.  ``install_resolver`` stores the handle in the simulation
(``sim._extras_ref``, the slot REBOUND reserves for this) and the handle keeps the
simulation, so neither is collected while the other is in use.  The C struct is found
from the simulation through ``sim.extras``, so the resolver cannot be combined with
REBOUNDx, which uses the same pointer.

REBOUND does not save function pointers in its binary files: after loading a checkpoint
call ``handle.reinstall(new_sim)``, which keeps the parameters and the statistics.

Statistics (``ResolverHandle.stats``):

* ``count``, ``n_floored`` (collisions whose impulse ``minimum_collision_velocity``
  raised), ``mean_epsilon`` and ``mean_vn`` [m/s] (NaN before the first collision);
* ``histograms["v_n"]``: normal impact speed [m/s] in 90 logarithmic bins from 1e-7 to
  1e2 m/s (10 per decade), with ``underflow``/``overflow`` counts;
* ``histograms["one_minus_epsilon"]``: the dissipation 1 - eps in 40 logarithmic bins
  from 1e-4 to 1 (10 per decade); collisions with 1 - eps < 1e-4 (eps = 1 included) are
  the ``underflow``, eps = 0 falls in the last bin.  Bin edges hold up to round-off of
  ``log10`` in C;
* ``log``: a structured array (fields ``t`` [s], ``v_n`` [m/s], ``R_bar`` [m],
  ``M_bar`` [kg], ``epsilon``) of every ``log_every``-th collision, the most recent
  ``log_capacity`` of them, oldest first.  ``epsilon`` is the law's value, also when
  the minimum collision velocity raised the impulse.
* ``multi_encounters``: resolved collisions in which one of the two particles had already
  been deflected earlier in the same step (by a partner carrying at least 10% of that
  pair's mass, ``MULTI_ENCOUNTER_MASS_SHARE``: a boulder struck by a few grains keeps its
  path).  With swept-path detection each contact is resolved on the straight path of the
  velocities at the end of the step, so this count divided by ``count`` measures how often
  that approximation is stretched; ``dt: auto`` keeps it near or below 1%.
"""

from __future__ import annotations

import ctypes
import importlib.util
import math
import weakref
from collections.abc import Mapping
from typing import Any

import numpy as np
import rebound
from rebound.simulation import COLRFF, CollisionS

from ringsim import restitution as rs

__all__ = [
    "COLLISION_DTYPE",
    "LOG_DTYPE",
    "ONE_MINUS_EPSILON_BIN_EDGES",
    "VN_BIN_EDGES",
    "PythonReferenceResolver",
    "ResolverHandle",
    "check_simulation_struct_size",
    "collision_records",
    "constant_epsilon_callback_address",
    "install_resolver",
    "multi_encounter_fraction",
    "multi_encounter_rate",
    "predicted_contacts",
]

#: Integer codes of the restitution laws in the C struct (enum RS_MODEL).
MODEL_CODES = {"dilley": 0, "bridges": 1, "constant": 2, "andrews": 3, "tabor": 4}
#: Order in which each law's parameters fill the C struct's ``param[3]``.
PARAMETER_ORDER = {
    "dilley": ("xi0", "p", "kappa"),
    "bridges": ("v_c", "exponent"),
    "constant": ("epsilon",),
    "andrews": ("v_c",),
    "tabor": ("v_c", "q"),
}

#: Bin edges of the normal-impact-speed histogram [m/s].
VN_BIN_EDGES = np.logspace(-7.0, 2.0, 91)
#: Bin edges of the dissipation (1 - eps) histogram [dimensionless].
ONE_MINUS_EPSILON_BIN_EDGES = np.logspace(-4.0, 0.0, 41)
#: One sampled collision: t [s], v_n [m/s], R_bar [m], M_bar [kg], epsilon [-].
LOG_DTYPE = np.dtype([("t", "f8"), ("v_n", "f8"), ("R_bar", "f8"), ("M_bar", "f8"),
                      ("epsilon", "f8")])

#: Memory layout of REBOUND's struct reb_collision: p1, p2, ghost-box offset gb of p1
#: (x, y, z [m], vx, vy, vz [m/s]), root cell ri.
COLLISION_DTYPE = np.dtype([("p1", "u8"), ("p2", "u8"), ("gb", "f8", (6,)), ("ri", "u8")])

# Normal speeds below this many round-off units of the summed |velocity components| are
# treated as not approaching (as in the C; keeps eps = 0 pairs from resolving twice).
_ROUNDOFF_SPEED = 64.0 * np.finfo(float).eps
# REBOUND's collision search modes that report swept-path contacts (line, linetree).
_SWEPT_PATH_MODES = (rebound.simulation.COLLISIONS["line"],
                     rebound.simulation.COLLISIONS["linetree"])
_N_VN_BINS = VN_BIN_EDGES.size - 1
_N_EPS_BINS = ONE_MINUS_EPSILON_BIN_EDGES.size - 1


class _Stats(ctypes.Structure):
    _fields_ = [
        ("count", ctypes.c_int64),
        ("n_floored", ctypes.c_int64),
        ("sum_epsilon", ctypes.c_double),
        ("sum_vn", ctypes.c_double),
        ("vn_underflow", ctypes.c_int64),
        ("vn_overflow", ctypes.c_int64),
        ("vn_hist", ctypes.c_int64 * _N_VN_BINS),
        ("eps_underflow", ctypes.c_int64),
        ("eps_hist", ctypes.c_int64 * _N_EPS_BINS),
        ("log_written", ctypes.c_int64),
        ("multi_encounters", ctypes.c_int64),
    ]


class _Resolver(ctypes.Structure):
    _fields_ = [
        ("magic", ctypes.c_uint64),
        ("model", ctypes.c_int32),
        ("reserved", ctypes.c_int32),
        ("param", ctypes.c_double * 3),
        ("log_capacity", ctypes.c_int64),
        ("log_every", ctypes.c_int64),
        ("log", ctypes.c_void_p),
        ("stats", _Stats),
        ("memory_sim", ctypes.c_void_p),
        ("memory_step", ctypes.c_uint64),
        ("memory_n", ctypes.c_int64),
        ("memory_capacity", ctypes.c_int64),
        ("memory_keys", ctypes.c_void_p),
        ("memory_n_stamps", ctypes.c_int64),
        ("memory_last_step", ctypes.c_void_p),
        ("detector", ctypes.c_void_p),
        ("detector_free", ctypes.c_void_p),
    ]


def check_simulation_struct_size(compiled_size: int, loaded_size: int) -> None:
    """Raise ImportError unless the resolver and the loaded librebound agree on the size
    of ``struct reb_simulation`` (the resolver reads its fields by offset).

    Parameters
    ----------
    compiled_size : int [bytes]
        ``sizeof(struct reb_simulation)`` as ringsim._resolver was compiled.
    loaded_size : int [bytes]
        ``reb_simulation_struct_size()`` of the librebound REBOUND's Python package loaded.
    """
    if compiled_size != loaded_size:
        raise ImportError(
            f"ringsim._resolver was compiled against a rebound.h whose struct reb_simulation "
            f"has {compiled_size} bytes, but the loaded REBOUND {rebound.__version__} has "
            f"{loaded_size}: the resolver would read the wrong fields. Rebuild ringsim "
            f"(`python setup.py build_ext --inplace`) against the installed REBOUND.")


def _load_library() -> ctypes.CDLL:
    """Load the compiled resolver and check it matches the running REBOUND."""
    spec = importlib.util.find_spec("ringsim._resolver")
    if spec is None or spec.origin is None:
        raise ImportError("ringsim._resolver is not built; run "
                          "`python setup.py build_ext --inplace` in the ringsim source tree")
    lib = ctypes.CDLL(spec.origin)
    size_t = ctypes.c_size_t
    for name in ("rs_simulation_struct_size", "rs_resolver_struct_size", "rs_log_entry_size"):
        getattr(lib, name).restype = size_t
        getattr(lib, name).argtypes = []
    lib.rs_histogram_bins.restype = ctypes.c_int
    lib.rs_histogram_bins.argtypes = [ctypes.c_int]
    lib.rs_resolver_create.restype = ctypes.c_void_p
    lib.rs_resolver_create.argtypes = [ctypes.c_int32, ctypes.c_double, ctypes.c_double,
                                       ctypes.c_double, ctypes.c_int64, ctypes.c_int64]
    lib.rs_resolver_free.restype = None
    lib.rs_resolver_free.argtypes = [ctypes.c_void_p]
    lib.rs_resolver_reset_stats.restype = None
    lib.rs_resolver_reset_stats.argtypes = [ctypes.c_void_p]
    double_p = ctypes.POINTER(ctypes.c_double)
    lib.rs_resolve_batch.restype = ctypes.c_int64
    lib.rs_resolve_batch.argtypes = [ctypes.c_void_p, ctypes.POINTER(CollisionS),
                                     ctypes.c_int64]
    lib.rs_epsilon_array.restype = None
    lib.rs_epsilon_array.argtypes = [ctypes.c_void_p, ctypes.c_int64, double_p, double_p,
                                     double_p, double_p]
    if hasattr(lib, "rs_sheet_step"):     # rs_sheet_detect.c compiled in
        int64_p = ctypes.POINTER(ctypes.c_int64)
        lib.rs_sheet_detect_pairs.restype = ctypes.c_int64
        lib.rs_sheet_detect_pairs.argtypes = [ctypes.c_void_p, ctypes.c_int64, int64_p,
                                              double_p]
        lib.rs_sheet_detector_counters.restype = ctypes.c_int
        lib.rs_sheet_detector_counters.argtypes = [ctypes.c_void_p, int64_p, double_p]

    librebound = rebound.clibrebound
    librebound.reb_simulation_struct_size.restype = size_t
    check_simulation_struct_size(lib.rs_simulation_struct_size(),
                                 librebound.reb_simulation_struct_size())
    checks = [
        ("struct reb_collision", ctypes.sizeof(CollisionS), COLLISION_DTYPE.itemsize),
        ("struct rs_resolver", lib.rs_resolver_struct_size(), ctypes.sizeof(_Resolver)),
        ("struct rs_log_entry", lib.rs_log_entry_size(), LOG_DTYPE.itemsize),
        ("speed histogram bins", lib.rs_histogram_bins(0), _N_VN_BINS),
        ("dissipation histogram bins", lib.rs_histogram_bins(1), _N_EPS_BINS),
    ]
    for what, in_c, in_python in checks:
        if in_c != in_python:
            raise ImportError(f"ringsim._resolver is out of date: {what} is {in_c} in C but "
                              f"{in_python} in ringsim/resolver.py; rebuild the extension")
    return lib


_LIB = _load_library()
_RESOLVE_ADDRESS = ctypes.cast(_LIB.rs_resolve, ctypes.c_void_p).value
_CONSTANT_COR_ADDRESS = ctypes.cast(_LIB.rs_constant_epsilon_cor, ctypes.c_void_p).value
#: The sheet detector's step function (None if ringsim._resolver was built without
#: rs_sheet_detect.c).
_SHEET_STEP_ADDRESS = (ctypes.cast(_LIB.rs_sheet_step, ctypes.c_void_p).value
                       if hasattr(_LIB, "rs_sheet_step") else None)
#: Type of REBOUND's post_timestep_modifications pointer.
_POST_TIMESTEP = ctypes.CFUNCTYPE(None, ctypes.POINTER(rebound.Simulation))
#: Collision searches: REBOUND's own (sim.collision as set) or ringsim's sheet detector.
DETECTORS = ("rebound", "sheet")
#: Error codes of the sheet detector (RS_DETECT_* in rs_sheet_detect.c).
DETECTOR_ERRORS = {0: "none", 1: "out of memory",
                   2: "boundary is neither 'shear' nor 'periodic'",
                   3: "time step too long (1.5 Omega dt >= 0.5) or non-finite particle state"}


def _validated(restitution: Mapping[str, Any]) -> tuple[str, dict[str, float]]:
    """Model name and complete parameters; ValueError naming the key if invalid."""
    if not isinstance(restitution, Mapping):
        raise ValueError(f"restitution: expected a mapping, got {type(restitution).__name__}")
    model, params = rs.model_parameters(restitution)
    # The law itself checks the ranges (v_c > 0, 0 < q < 1/2, ...), naming the key.
    rs.epsilon_for_pair({"model": model, **params}, 1e-3, 1.0, 1.0)
    return model, params


def _free_resolver(address: int) -> None:
    _LIB.rs_resolver_free(address)


def _function_address(pointer: Any) -> int | None:
    """Address of a ctypes function pointer (None if NULL)."""
    return ctypes.cast(pointer, ctypes.c_void_p).value


def _detach(sim: rebound.Simulation, handle: ResolverHandle) -> None:
    """Remove ``handle``'s resolver from ``sim`` if it is still installed there."""
    if sim.extras == handle._address:
        sim.extras = None
        if _function_address(sim._post_timestep_modifications) == _SHEET_STEP_ADDRESS:
            sim._post_timestep_modifications = _POST_TIMESTEP()
    if getattr(sim, "_extras_ref", None) is handle:
        sim._extras_ref = None


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
    log_capacity : int
        Number of sampled collisions kept (ring buffer); 0 disables the log.
    log_every : int
        Sampling stride: every ``log_every``-th resolved collision is logged.
    detector : "rebound" or "sheet"
        Collision search.  "rebound": REBOUND's own, as set in ``sim.collision`` (``tree``
        and ``direct`` report overlaps at step ends, ``line`` and ``linetree`` swept paths).
        "sheet": ringsim's swept-sphere search for shear-periodic (or periodic) boxes
        (``rs_sheet_detect.c``): :meth:`reinstall` sets ``sim.collision = "none"`` and
        runs the search and the contact-time resolution as REBOUND's
        ``post_timestep_modifications``, once per step, before REBOUND wraps the particles.
    """

    def __init__(self, restitution: Mapping[str, Any], *, log_capacity: int = 0,
                 log_every: int = 1, detector: str = "rebound"):
        if detector not in DETECTORS:
            raise ValueError(f"detector: must be one of {DETECTORS}, got {detector!r}")
        if detector == "sheet" and _SHEET_STEP_ADDRESS is None:
            raise ImportError("ringsim._resolver was built without rs_sheet_detect.c; add it "
                              "to setup.py's sources and rebuild "
                              "(`python setup.py build_ext --inplace`)")
        model, params = _validated(restitution)
        if isinstance(log_capacity, bool) or not isinstance(log_capacity, (int, np.integer)) \
                or log_capacity < 0:
            raise ValueError(f"log_capacity: must be an integer >= 0, got {log_capacity!r}")
        if isinstance(log_every, bool) or not isinstance(log_every, (int, np.integer)) \
                or log_every < 1:
            raise ValueError(f"log_every: must be an integer >= 1, got {log_every!r}")
        values = [params[name] for name in PARAMETER_ORDER[model]]
        values += [0.0] * (3 - len(values))
        address = _LIB.rs_resolver_create(MODEL_CODES[model], *values, int(log_capacity),
                                          int(log_every))
        if not address:
            raise MemoryError(f"could not allocate the resolver (log_capacity={log_capacity})")
        self.model = model
        self.parameters = dict(params)
        self.log_capacity = int(log_capacity)
        self.log_every = int(log_every)
        self.detector = detector
        self._address: int | None = address
        self._struct = _Resolver.from_address(address)
        # Function pointers into the loaded library; kept here so they live with the handle.
        self._resolve_fp = COLRFF(_RESOLVE_ADDRESS)
        self._sheet_step_fp = (_POST_TIMESTEP(_SHEET_STEP_ADDRESS) if _SHEET_STEP_ADDRESS
                               else _POST_TIMESTEP())
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
        if self.detector == "sheet":
            if sim.boundary not in ("shear", "periodic"):
                raise ValueError(f"detector 'sheet' needs boundary 'shear' or 'periodic', "
                                 f"the simulation has {sim.boundary!r}")
            post = _function_address(sim._post_timestep_modifications)
            if post not in (None, _SHEET_STEP_ADDRESS):
                raise ValueError("sim.post_timestep_modifications is already set; detector "
                                 "'sheet' runs there")
        if isinstance(previous, ResolverHandle) and previous is not self:
            previous._sim = None    # the old resolver's statistics stay readable
        if self._sim is not None and self._sim is not sim:
            _detach(self._sim, self)
        sim.extras = address
        sim._collision_resolve = self._resolve_fp
        if self.detector == "sheet":
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
        state = "closed" if self.closed else f"{self._struct.stats.count} collisions"
        return f"<ResolverHandle {self.model} {self.parameters} ({state})>"

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
        if self._struct is None:
            raise ValueError("the resolver handle is closed")
        s = self._struct.stats
        count = int(s.count)
        mean_eps = s.sum_epsilon / count if count else math.nan
        mean_vn = s.sum_vn / count if count else math.nan
        histograms = {
            "v_n": {
                "edges": VN_BIN_EDGES.copy(),
                "counts": np.ctypeslib.as_array(s.vn_hist).copy(),
                "underflow": int(s.vn_underflow),
                "overflow": int(s.vn_overflow),
                "units": "m/s",
            },
            "one_minus_epsilon": {
                "edges": ONE_MINUS_EPSILON_BIN_EDGES.copy(),
                "counts": np.ctypeslib.as_array(s.eps_hist).copy(),
                "underflow": int(s.eps_underflow),
                "overflow": 0,
                "units": "1",
            },
        }
        return {
            "count": count,
            "n_floored": int(s.n_floored),
            "mean_epsilon": mean_eps,
            "mean_vn": mean_vn,
            "sum_epsilon": float(s.sum_epsilon),
            "sum_vn": float(s.sum_vn),
            "histograms": histograms,
            "log": self._read_log(int(s.log_written)),
            "log_written": int(s.log_written),
            "log_every": self.log_every,
            "multi_encounters": int(s.multi_encounters),
        }

    def detector_stats(self) -> dict[str, Any]:
        """Counters of the sheet detector since the handle was created.

        Returns
        -------
        dict with ``steps`` (searches run), ``candidates`` (pairs whose straight paths
        were tested), ``reports`` (pairs passed to the resolver), ``cells`` and
        ``cell_size`` [m] of the last search's grid, and ``error`` (text; "none" if the
        last search succeeded).  All zero before the first search or for
        ``detector="rebound"``.
        """
        counters = (ctypes.c_int64 * 5)()
        cell_size = ctypes.c_double()
        if _SHEET_STEP_ADDRESS is None:
            return {"steps": 0, "candidates": 0, "reports": 0, "cells": 0, "cell_size": 0.0,
                    "error": "none"}
        _LIB.rs_sheet_detector_counters(self.address, counters, ctypes.byref(cell_size))
        return {"steps": int(counters[0]), "candidates": int(counters[1]),
                "reports": int(counters[2]), "cells": int(counters[3]),
                "cell_size": float(cell_size.value),
                "error": DETECTOR_ERRORS.get(int(counters[4]), f"code {int(counters[4])}")}

    def detect_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """Run the sheet detector's search on the simulation's current state (no resolution).

        For tests: the pairs whose straight paths over the last step (``dt_last_done``,
        current velocities) came within the sum of their radii.

        Returns
        -------
        pairs : int array (n, 2)
            Particle indices (p1 < p2).
        offsets : array (n, 6) [m, m, m, m/s, m/s, m/s]
            Ghost-box offset of p1 (x, y, z, vx, vy, vz), as in ``struct reb_collision``.
        """
        if self._sim is None:
            raise ValueError("the resolver is not installed in a simulation")
        if _SHEET_STEP_ADDRESS is None:
            raise ImportError("ringsim._resolver was built without rs_sheet_detect.c")
        sim_address = ctypes.addressof(self._sim)
        capacity = 0
        while True:
            pairs = np.zeros((max(capacity, 1), 2), dtype=np.int64)
            offsets = np.zeros((max(capacity, 1), 6))
            found = _LIB.rs_sheet_detect_pairs(
                sim_address, capacity, pairs.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)),
                offsets.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
            if found < 0:
                raise ValueError("sheet detector: " + DETECTOR_ERRORS.get(-found - 1, "error"))
            if found <= capacity:
                return pairs[:found].copy(), offsets[:found].copy()
            capacity = int(found)

    def _read_log(self, written: int) -> np.ndarray:
        capacity = self.log_capacity
        if capacity == 0 or written == 0:
            return np.zeros(0, dtype=LOG_DTYPE)
        raw = (ctypes.c_char * (capacity * LOG_DTYPE.itemsize)).from_address(self._struct.log)
        entries = np.frombuffer(raw, dtype=LOG_DTYPE)
        if written <= capacity:
            return entries[:written].copy()
        return np.roll(entries, -(written % capacity)).copy()   # oldest first

    def reset_stats(self) -> None:
        """Zero all counters, histograms and the log."""
        _LIB.rs_resolver_reset_stats(self.address)

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


def install_resolver(sim: rebound.Simulation, restitution: Mapping[str, Any], *,
                     log_capacity: int = 0, log_every: int = 1,
                     detector: str = "rebound") -> ResolverHandle:
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
    log_capacity : int
        Number of sampled collisions kept in C (0: no log).
    log_every : int
        Log every ``log_every``-th collision.
    detector : "rebound" or "sheet"
        "rebound" keeps the simulation's REBOUND collision search; "sheet" replaces it by
        ringsim's swept-sphere search for shearing sheets (see :class:`ResolverHandle`).

    Returns
    -------
    ResolverHandle
        Stored in the simulation as well (``sim._extras_ref``), so it lives as long as
        ``sim``; keep it to read the statistics.
    """
    handle = ResolverHandle(restitution, log_capacity=log_capacity, log_every=log_every,
                            detector=detector)
    return handle.reinstall(sim)


#: Largest fraction of collisions in which a partner has a second contact in the same step
#: that ``dt: auto`` accepts in line mode (``ringsim.sheet.auto_dt``).
MULTI_ENCOUNTER_TARGET = 0.01
#: Window of the contact prediction of ``dt: auto`` in line mode [steps of 1e-3 orbit].
MULTI_ENCOUNTER_WINDOW_STEPS = 16
#: A collision deflects a particle when its partner carries at least this share of the
#: pair's mass (its velocity then changes by at least this share of the relative-velocity
#: change); RS_DEFLECTING_MASS_SHARE in rs_resolver.c.
MULTI_ENCOUNTER_MASS_SHARE = 0.1


def predicted_contacts(x: Any, y: Any, z: Any, vx: Any, vy: Any, vz: Any, radius: Any,
                       mass: Any, Omega: float,
                       window: float) -> tuple[np.ndarray, np.ndarray]:
    """Contacts each particle would make within ``window`` on straight paths.

    Every pair that does not overlap now, approaches, and whose straight relative path
    reaches contact within ``window`` counts once for each of its two particles; it also
    counts as a deflection of a particle whose partner carries at least
    :data:`MULTI_ENCOUNTER_MASS_SHARE` of the pair's mass.  Positions are taken as they
    are (no periodic images: pairs straddling the box edges are missed, a fraction of
    about the search radius over the box size).

    Parameters
    ----------
    x, y, z : arrays [m]
    vx, vy, vz : arrays [m/s]
        Velocities in the frame of the sheet (shear flow vy = -1.5 Omega x included).
    radius : array [m]
    mass : array [kg]
    Omega : float [1/s]
        Orbital frequency; the search is widened by speeds relative to the shear flow.
    window : float [s]

    Returns
    -------
    contacts, deflections : int arrays [count per particle]
    """
    from scipy.spatial import cKDTree

    pos = np.column_stack([x, y, z]).astype(float)
    vel = np.column_stack([vx, vy, vz]).astype(float)
    radius = np.asarray(radius, dtype=float)
    mass = np.asarray(mass, dtype=float)
    contacts = np.zeros(radius.size, dtype=np.int64)
    deflections = np.zeros(radius.size, dtype=np.int64)
    if radius.size < 2:
        return contacts, deflections
    random_speed = np.sqrt(vel[:, 0] ** 2 + (vel[:, 1] + 1.5 * Omega * pos[:, 0]) ** 2
                           + vel[:, 2] ** 2)
    shear_drift = 1.5 * abs(Omega) * window
    if not shear_drift < 0.5:
        raise ValueError(f"window: 1.5 Omega window = {shear_drift:.3g} must be < 0.5")
    search = 2.0 * float(np.max(radius + window * random_speed)) / (1.0 - shear_drift)
    pairs = cKDTree(pos).query_pairs(search, output_type="ndarray")
    if pairs.size == 0:
        return contacts, deflections
    i, j = pairs[:, 0], pairs[:, 1]
    d = pos[j] - pos[i]
    u = vel[j] - vel[i]
    a = np.einsum("ij,ij->i", u, u)
    b = np.einsum("ij,ij->i", d, u)
    c = np.einsum("ij,ij->i", d, d) - (radius[i] + radius[j]) ** 2
    discriminant = b * b - a * c
    hit = (c > 0.0) & (b < 0.0) & (discriminant >= 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        t_contact = np.where(hit, (-b - np.sqrt(np.where(hit, discriminant, 0.0))) / a, np.inf)
    hit &= t_contact <= window
    i, j = i[hit], j[hit]
    np.add.at(contacts, i, 1)
    np.add.at(contacts, j, 1)
    total = mass[i] + mass[j]
    np.add.at(deflections, i[mass[j] >= MULTI_ENCOUNTER_MASS_SHARE * total], 1)
    np.add.at(deflections, j[mass[i] >= MULTI_ENCOUNTER_MASS_SHARE * total], 1)
    return contacts, deflections


def multi_encounter_fraction(contacts: Any, deflections: Any, radius: Any = None) -> float:
    """Predicted fraction of collisions in which a partner was deflected earlier in the step.

    A particle of contact rate lambda, lambda_s of them deflecting (Poisson), collides in a
    window W with probability ~ lambda W and has then on average lambda_s W other
    deflections in the same window, half of them before.  Summed over both partners of a
    collision, the fraction of collisions preceded within the window by a deflection of a
    partner is sum(lambda_s lambda) W / sum(lambda): the resolver's statistic
    ``multi_encounters / count`` for steps of length W.  The rates are pooled over
    particles of similar size (bins of 0.1 in log10 radius) - the mean counts of a bin
    estimate its rates - so that the estimate rests on all contacts of a snapshot, not on
    the few coincidences of one window.  0 without contacts.

    Parameters
    ----------
    contacts, deflections : int arrays [count per particle in one window]
        From :func:`predicted_contacts`.
    radius : array [m], optional
        Radii for pooling; all particles in one pool if omitted.
    """
    k = np.asarray(contacts, dtype=float)
    s = np.asarray(deflections, dtype=float)
    total = float(k.sum())
    if not total > 0:
        return 0.0
    if radius is None:
        groups = np.zeros(k.size, dtype=np.int64)
    else:
        log_r = np.log10(np.asarray(radius, dtype=float))
        groups = np.floor((log_r - log_r.min()) / 0.1).astype(np.int64)
    n = np.bincount(groups).astype(float)
    used = n > 0
    k_mean = np.bincount(groups, weights=k)[used] / n[used]
    s_mean = np.bincount(groups, weights=s)[used] / n[used]
    return float(np.sum(n[used] * s_mean * k_mean) / total)


def multi_encounter_rate(arrays: Mapping[str, Any], Omega: float, max_window: float) -> float:
    """Predicted ``multi_encounters / count`` per unit step length [1/s].

    The fraction for a step dt is about this rate times dt (for fractions << 1).  Contacts
    are predicted on straight paths over a window W and pooled by size
    (:func:`multi_encounter_fraction`); the rate is that fraction over W.  W is
    ``max_window`` unless the fastest particle (speed w_max relative to the shear flow)
    would then reach beyond max(3 r_max, 1/8 of the smaller horizontal extent of the
    particles), which bounds the search.  The estimate is lowered to its 2-sigma lower
    bound, (1 - 2 / sqrt(S)) for S predicted deflections (0 for S <= 4): a shorter step
    needs evidence, not the chance coincidences of a snapshot of a dilute ring.

    Parameters
    ----------
    arrays : mapping of particle arrays x, y, z [m], vx, vy, vz [m/s], radius [m], mass [kg]
    Omega : float [1/s]
    max_window : float [s]
    """
    x, y, z = (np.asarray(arrays[k], dtype=float) for k in ("x", "y", "z"))
    vx, vy, vz = (np.asarray(arrays[k], dtype=float) for k in ("vx", "vy", "vz"))
    radius = np.asarray(arrays["radius"], dtype=float)
    if radius.size < 2:
        return 0.0
    w_max = float(np.sqrt(np.max(vx**2 + (vy + 1.5 * Omega * x) ** 2 + vz**2)))
    r_max = float(radius.max())
    reach = max(3.0 * r_max, 0.125 * min(float(np.ptp(x)), float(np.ptp(y))))
    window = max_window if w_max <= 0 else min(max_window, (reach - r_max) / w_max)
    contacts, deflections = predicted_contacts(x, y, z, vx, vy, vz, radius, arrays["mass"],
                                               Omega, window)
    evidence = float(np.sum(deflections))
    if evidence <= 4.0:
        return 0.0
    fraction = multi_encounter_fraction(contacts, deflections, radius)
    return fraction * (1.0 - 2.0 / math.sqrt(evidence)) / window


def constant_epsilon_callback_address() -> int:
    """Address of a C ``coefficient_of_restitution`` returning the constant eps of the
    ringsim resolver installed in the same simulation (1 for other laws).

    For comparisons with REBOUND's built-in hard-sphere resolver::

        sim._coefficient_of_restitution = CORFF(constant_epsilon_callback_address())
    """
    return _CONSTANT_COR_ADDRESS


# --- the pure-Python twin ----------------------------------------------------------------

def _dilley_epsilon(v: float, R_bar: float, M_bar: float, xi0: float, p: float,
                    kappa: float) -> float:
    xi = (xi0 * math.pow(R_bar / rs.R_REF, -rs.RADIUS_EXPONENT)
          * math.pow(M_bar / rs.M_REF, -kappa) * math.pow(v / rs.V_REF, p))
    if not xi < 1.0:
        return 0.0
    return math.exp(-math.pi * xi / math.sqrt(1.0 - xi * xi))


def _bridges_epsilon(v: float, v_c: float, exponent: float) -> float:
    u = v / v_c
    return math.pow(u, -exponent) if u > 1.0 else 1.0


def _andrews_epsilon(v: float, v_c: float) -> float:
    u = v / v_c
    if not u > 1.0:
        return 1.0
    u2 = u * u
    return math.sqrt((-2.0 + math.sqrt(30.0 * u2 - 5.0)) / (3.0 * u2))


def _tabor_epsilon(v: float, v_c: float, q: float) -> float:
    u = v / v_c
    if not u > 1.0:
        return 1.0
    amplitude = math.pow(u, -(1.0 - 2.0 * q))
    log_amplitude = math.log(amplitude)
    lo = amplitude
    hi = amplitude * math.pow(1.0 - q, -q)
    if hi > 1.0:
        hi = 1.0
    eps = 0.5 * (lo + hi)
    for _ in range(200):
        g = math.log(eps) - log_amplitude - q * math.log((1.0 - q * eps * eps) / (1.0 - q))
        if g < 0.0:
            lo = eps
        elif g > 0.0:
            hi = eps
        else:
            break
        dg = 1.0 / eps + 2.0 * q * q * eps / (1.0 - q * eps * eps)
        newton = eps - g / dg
        nxt = newton if lo < newton < hi else 0.5 * (lo + hi)
        step = abs(nxt - eps)
        eps = nxt
        if step <= 1e-15 * eps or not hi - lo > 1e-15 * eps:
            break
    return eps


class PythonReferenceResolver:
    """Pure-Python twin of the C resolver, for testing: ``sim.collision_resolve = ref``.

    Same physics and the same floating-point operations in the same order as
    ``rs_resolver.c`` (Python floats and ``math`` call the same libm), so a simulation
    resolved by either evolves identically to round-off.  It records every collision in
    :attr:`log` (tuples t [s], v_n [m/s], R_bar [m], M_bar [kg], eps).  An exception
    inside a call is appended to :attr:`errors` and the collision is left unresolved
    (returns 0; particles are never removed).

    Parameters
    ----------
    restitution : mapping
        As for :func:`install_resolver`.
    """

    def __init__(self, restitution: Mapping[str, Any]):
        self.model, self.parameters = _validated(restitution)
        self.count = 0
        self.n_floored = 0
        self.sum_epsilon = 0.0
        self.sum_vn = 0.0
        self.log: list[tuple[float, float, float, float, float]] = []
        self.errors: list[Exception] = []
        self._memory: set[tuple[int, int]] = set()     # pairs resolved in this step
        self._memory_step: tuple[int, int] | None = None

    def epsilon(self, v: float, R_bar: float, M_bar: float) -> float:
        """The law's eps for one pair, scalar arithmetic as in C.

        Parameters
        ----------
        v : float [m/s]
            Normal impact speed, >= 0.
        R_bar : float [m]
        M_bar : float [kg]
        """
        prm = self.parameters
        if self.model == "dilley":
            return _dilley_epsilon(v, R_bar, M_bar, prm["xi0"], prm["p"], prm["kappa"])
        if self.model == "bridges":
            return _bridges_epsilon(v, prm["v_c"], prm["exponent"])
        if self.model == "constant":
            return prm["epsilon"]
        if self.model == "andrews":
            return _andrews_epsilon(v, prm["v_c"])
        return _tabor_epsilon(v, prm["v_c"], prm["q"])

    def __call__(self, sim_pointer: Any, collision: Any) -> int:
        try:
            self._resolve(sim_pointer.contents, collision)
        except Exception as exc:    # recorded: an exception cannot cross the C callback
            self.errors.append(exc)
        return 0

    def _resolve(self, sim: rebound.Simulation, c: Any) -> None:
        particles = sim.particles
        p1 = particles[c.p1]
        p2 = particles[c.p2]
        gb = c.gb
        dx = p1.x + gb.x - p2.x
        dy = p1.y + gb.y - p2.y
        dz = p1.z + gb.z - p2.z
        sum_radii = p1.r + p2.r
        distance2 = dx * dx + dy * dy + dz * dz
        dvx = p1.vx + gb.vx - p2.vx
        dvy = p1.vy + gb.vy - p2.vy
        dvz = p1.vz + gb.vz - p2.vz
        overlapping = distance2 < sum_radii * sum_radii

        if sim._collision not in _SWEPT_PATH_MODES:
            if overlapping:
                self._apply_impulse(sim, p1, p2, gb, dx, dy, dz, math.sqrt(distance2), dvx,
                                    dvy, dvz, 0.0)
            return

        step = (ctypes.addressof(sim), sim.steps_done)   # as the C: per simulation and step
        if self._memory_step != step:
            self._memory_step = step
            self._memory.clear()
        key = (min(c.p1, c.p2), max(c.p1, c.p2))
        if key in self._memory:
            return
        a = dvx * dvx + dvy * dvy + dvz * dvz
        b = dx * dvx + dy * dvy + dz * dvz
        gap = distance2 - sum_radii * sum_radii
        discriminant = b * b - a * gap
        back_time = 0.0
        if a > 0.0 and discriminant >= 0.0:
            back_time = (b + math.sqrt(discriminant)) / a
        if 0.0 < back_time <= sim.dt_last_done:
            cx = dx - back_time * dvx
            cy = dy - back_time * dvy
            cz = dz - back_time * dvz
            contact = math.sqrt(cx * cx + cy * cy + cz * cz)
            resolved = self._apply_impulse(sim, p1, p2, gb, cx, cy, cz, contact, dvx, dvy,
                                           dvz, back_time)
        elif overlapping:
            resolved = self._apply_impulse(sim, p1, p2, gb, dx, dy, dz, math.sqrt(distance2),
                                           dvx, dvy, dvz, 0.0)
        else:
            return
        if resolved:
            self._memory.add(key)

    def _apply_impulse(self, sim: rebound.Simulation, p1: Any, p2: Any, gb: Any, dx: float,
                       dy: float, dz: float, distance: float, dvx: float, dvy: float,
                       dvz: float, back_time: float) -> bool:
        v_n = (dvx * dx + dvy * dy + dvz * dz) / distance
        speed_scale = (abs(p1.vx) + abs(p1.vy) + abs(p1.vz) + abs(gb.vx) + abs(gb.vy)
                       + abs(gb.vz) + abs(p2.vx) + abs(p2.vy) + abs(p2.vz))
        if not -v_n > _ROUNDOFF_SPEED * speed_scale:
            return False
        m1 = p1.m
        m2 = p2.m
        total_mass = m1 + m2
        if not total_mass > 0.0:
            return False
        R_bar = p1.r * p2.r / (p1.r + p2.r)
        M_bar = m1 * m2 / total_mass
        impact_speed = -v_n
        eps = self.epsilon(impact_speed, R_bar, M_bar)

        separation_change = (1.0 + eps) * impact_speed
        r_min = p2.r if p1.r > p2.r else p1.r
        r_max = p2.r if p1.r < p2.r else p1.r
        w = sim.minimum_collision_velocity
        v_floor = r_min * w
        v_floor *= 1.0 - (distance - r_max) / r_min
        if v_floor > r_max * w:
            v_floor = r_max * w
        floored = separation_change < v_floor
        if floored:
            separation_change = v_floor

        old_vy_outer = p1.vy if dx > 0.0 else p2.vy
        jx = separation_change * (dx / distance)
        jy = separation_change * (dy / distance)
        jz = separation_change * (dz / distance)
        share2 = m1 / total_mass
        share1 = m2 / total_mass
        p2.vx = p2.vx - share2 * jx
        p2.vy = p2.vy - share2 * jy
        p2.vz = p2.vz - share2 * jz
        p1.vx = p1.vx + share1 * jx
        p1.vy = p1.vy + share1 * jy
        p1.vz = p1.vz + share1 * jz
        if back_time > 0.0:
            p2.x = p2.x - back_time * (share2 * jx)
            p2.y = p2.y - back_time * (share2 * jy)
            p2.z = p2.z - back_time * (share2 * jz)
            p1.x = p1.x + back_time * (share1 * jx)
            p1.y = p1.y + back_time * (share1 * jy)
            p1.z = p1.z + back_time * (share1 * jz)
        if dx > 0.0:
            sim.collisions_plog += -abs(dx) * (old_vy_outer - p1.vy) * m1
        else:
            sim.collisions_plog += -abs(dx) * (old_vy_outer - p2.vy) * m2
        sim.collisions_log_n += 1

        self.count += 1
        self.n_floored += int(floored)
        self.sum_epsilon += eps
        self.sum_vn += impact_speed
        self.log.append((sim.t, impact_speed, R_bar, M_bar, eps))
        return True

    def stats(self) -> dict[str, Any]:
        """count, n_floored, mean_epsilon, mean_vn [m/s] and the full log (LOG_DTYPE)."""
        count = self.count
        return {
            "count": count,
            "n_floored": self.n_floored,
            "mean_epsilon": self.sum_epsilon / count if count else math.nan,
            "mean_vn": self.sum_vn / count if count else math.nan,
            "log": np.array(self.log, dtype=LOG_DTYPE),
        }
