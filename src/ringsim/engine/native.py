"""The compiled library (``ringsim._resolver``): loaded once, checked against REBOUND.

Holds the ctypes mirror of the C structs, the integer codes and slot order of the
restitution laws, the histogram bins and record layouts shared with C, and the addresses
of the C functions REBOUND calls.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import os
from collections.abc import Iterator
from typing import Any, cast

import numpy as np
import rebound
from rebound.simulation import CollisionS

from ringsim.physics.friction import FRICTION
from ringsim.physics.restitution import RESTITUTION

#: Integer codes of the restitution laws in the C struct (enum RS_MODEL), from the declaration.
MODEL_CODES = {law.name: law.code for law in RESTITUTION}
#: Order in which each law's parameters fill the C struct's ``param[4]`` (their slots).
PARAMETER_ORDER = {law.name: tuple(p.name for p in sorted(law.parameters, key=lambda p: p.slot))
                   for law in RESTITUTION}

#: Integer codes of the friction models (RS_FRICTION_*); 0 is no friction (smooth spheres).
FRICTION_CODES = {"none": 0, **{law.name: law.code for law in FRICTION}}
#: Statistics fields of friction (after the others in the C struct): a checkpoint that
#: lacks them restores them as zero.
FRICTION_STATISTICS = ("tangential_dissipation", "n_sliding", "normal_dissipation")
#: Statistics fields of the law's measured range split below and above it, of the
#: critically damped collisions and of those inside every measured range at once (after
#: the friction fields): a checkpoint that lacks them restores them as zero.
RANGE_STATISTICS = ("speeds_below", "speeds_above", "sizes_below", "sizes_above",
                    "masses_below", "masses_above", "critically_damped", "inside_all")

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
        ("outside_speeds", ctypes.c_int64),
        ("outside_sizes", ctypes.c_int64),
        ("tangential_dissipation", ctypes.c_double),
        ("n_sliding", ctypes.c_int64),
        ("normal_dissipation", ctypes.c_double),
        *((name, ctypes.c_int64) for name in RANGE_STATISTICS),
    ]


class _Resolver(ctypes.Structure):
    _fields_ = [
        ("magic", ctypes.c_uint64),
        ("model", ctypes.c_int32),
        ("reserved", ctypes.c_int32),
        ("param", ctypes.c_double * 4),
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
        ("measured", ctypes.c_double * 4),
        ("friction_model", ctypes.c_int32),
        ("reserved2", ctypes.c_int32),
        ("friction", ctypes.c_double * 3),
        ("inertia_factor", ctypes.c_double),
        ("spin", ctypes.POINTER(ctypes.c_double)),
        ("spin_capacity", ctypes.c_int64),
        ("measured_masses", ctypes.c_double * 2),
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


def _declare_resolver(lib: ctypes.CDLL) -> None:
    """Prototypes of rs_resolver.c: the resolver's life, friction and spins, statistics, the
    layout checks, and the calls for tests and benchmarks."""
    size_t = ctypes.c_size_t
    for name in ("rs_simulation_struct_size", "rs_resolver_struct_size", "rs_log_entry_size"):
        getattr(lib, name).restype = size_t
        getattr(lib, name).argtypes = []
    lib.rs_histogram_bins.restype = ctypes.c_int
    lib.rs_histogram_bins.argtypes = [ctypes.c_int]
    lib.rs_resolver_create.restype = ctypes.c_void_p
    lib.rs_resolver_create.argtypes = [ctypes.c_int32, ctypes.c_double, ctypes.c_double,
                                       ctypes.c_double, ctypes.c_double, ctypes.c_int64,
                                       ctypes.c_int64]
    lib.rs_resolver_free.restype = None
    lib.rs_resolver_free.argtypes = [ctypes.c_void_p]
    lib.rs_resolver_set_friction.restype = ctypes.c_int
    lib.rs_resolver_set_friction.argtypes = [ctypes.c_void_p, ctypes.c_int32, ctypes.c_double,
                                             ctypes.c_double, ctypes.c_double, ctypes.c_double]
    lib.rs_spin_reserve.restype = ctypes.c_int
    lib.rs_spin_reserve.argtypes = [ctypes.c_void_p, ctypes.c_int64]
    lib.rs_spin_frame_angle.restype = ctypes.c_double
    lib.rs_spin_frame_angle.argtypes = [ctypes.c_void_p, ctypes.c_double]
    for name in ("rs_spins_read", "rs_spins_write"):
        getattr(lib, name).restype = None if name == "rs_spins_read" else ctypes.c_int
        getattr(lib, name).argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_int64,
                                       ctypes.c_void_p]
    lib.rs_resolver_reset_stats.restype = None
    lib.rs_resolver_reset_stats.argtypes = [ctypes.c_void_p]
    double_p = ctypes.POINTER(ctypes.c_double)
    lib.rs_resolve_batch.restype = ctypes.c_int64
    lib.rs_resolve_batch.argtypes = [ctypes.c_void_p, ctypes.POINTER(CollisionS),
                                     ctypes.c_int64]
    lib.rs_epsilon_array.restype = None
    lib.rs_epsilon_array.argtypes = [ctypes.c_void_p, ctypes.c_int64, double_p, double_p,
                                     double_p, double_p]


def _declare_setup(lib: ctypes.CDLL) -> None:
    """Prototypes of rs_setup.c: adding particles, the overlap grid, the overlap count."""
    double_p = ctypes.POINTER(ctypes.c_double)
    int64_p = ctypes.POINTER(ctypes.c_int64)
    lib.rs_add_particles.restype = ctypes.c_int64
    lib.rs_add_particles.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64,
                                     *[double_p] * 8]
    lib.rs_grid_create.restype = ctypes.c_void_p
    lib.rs_grid_create.argtypes = [ctypes.c_int64, ctypes.c_int32,
                                   ctypes.POINTER(ctypes.c_int32), double_p,
                                   *[ctypes.c_double] * 5, *[double_p] * 4]
    lib.rs_grid_free.restype = None
    lib.rs_grid_free.argtypes = [ctypes.c_void_p]
    lib.rs_grid_move.restype = None
    lib.rs_grid_move.argtypes = [ctypes.c_void_p, ctypes.c_int64, int64_p, *[double_p] * 3]
    lib.rs_grid_overlapping.restype = ctypes.c_int64
    lib.rs_grid_overlapping.argtypes = [ctypes.c_void_p, ctypes.c_int64, int64_p, int64_p]
    lib.rs_count_overlaps.restype = ctypes.c_int64
    lib.rs_count_overlaps.argtypes = [ctypes.c_int64, *[double_p] * 4, *[ctypes.c_double] * 4,
                                      ctypes.c_int]


#: OpenMP threads that wait for the next parallel region sleep instead of spinning, unless
#: the user chose otherwise: the detector's regions are short (one per step) and separated
#: by serial work (REBOUND's drift and kick, the time-ordered resolution), and spinning
#: threads take the core from that work on a shared machine (docs/performance.md,
#: "OpenMP wait policy").  Read by the OpenMP runtime when the library is loaded, so it is
#: set before.
OPENMP_WAIT_POLICY = "passive"


def _declare_detector(lib: ctypes.CDLL) -> None:
    """Prototypes of the line detector (rs_sheet_detect.c)."""
    double_p = ctypes.POINTER(ctypes.c_double)
    int64_p = ctypes.POINTER(ctypes.c_int64)
    lib.rs_sheet_max_shear_step.restype = ctypes.c_double
    lib.rs_sheet_max_shear_step.argtypes = []
    lib.rs_sheet_detect_pairs.restype = ctypes.c_int64
    lib.rs_sheet_detect_pairs.argtypes = [ctypes.c_void_p, ctypes.c_int64, int64_p,
                                          double_p]
    lib.rs_sheet_detector_counters.restype = ctypes.c_int
    lib.rs_sheet_detector_counters.argtypes = [ctypes.c_void_p, int64_p, double_p]
    lib.rs_sheet_order_counters.restype = ctypes.c_int
    lib.rs_sheet_order_counters.argtypes = [ctypes.c_void_p, int64_p]
    lib.rs_sheet_set_threads.restype = ctypes.c_int
    lib.rs_sheet_set_threads.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.rs_sheet_openmp.restype = ctypes.c_int
    lib.rs_sheet_openmp.argtypes = []
    lib.rs_sheet_set_classes.restype = ctypes.c_int
    lib.rs_sheet_set_classes.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.rs_sheet_set_lists.restype = ctypes.c_int
    lib.rs_sheet_set_lists.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.rs_sheet_list_counters.restype = ctypes.c_int
    lib.rs_sheet_list_counters.argtypes = [ctypes.c_void_p, int64_p]
    lib.rs_sheet_threads_used.restype = ctypes.c_int
    lib.rs_sheet_threads_used.argtypes = [ctypes.c_void_p]
    lib.rs_sheet_particles_per_thread.restype = ctypes.c_int64
    lib.rs_sheet_particles_per_thread.argtypes = []


#: One function of each C source.  setup.py compiles every source into the one library, so
#: a library without one of them is a broken build, refused when it is loaded.
_ONE_SYMBOL_PER_SOURCE = ("rs_resolve", "rs_sheet_step", "rs_add_particles", "rs_ghost_field",
                          "rs_p3m_short", "rs_sei_register", "rs_stop_arm",
                          "rs_sheet_classify")


def _load_library() -> ctypes.CDLL:
    """Load the compiled resolver and check it matches the running REBOUND."""
    os.environ.setdefault("OMP_WAIT_POLICY", OPENMP_WAIT_POLICY)
    spec = importlib.util.find_spec("ringsim._resolver")
    if spec is None or spec.origin is None:
        raise ImportError("ringsim._resolver is not built; run "
                          "`python setup.py build_ext --inplace` in the ringsim source tree")
    lib = ctypes.CDLL(spec.origin)
    missing = [name for name in _ONE_SYMBOL_PER_SOURCE if not hasattr(lib, name)]
    if missing:
        raise ImportError(f"ringsim._resolver is incomplete (no {', '.join(missing)}); rebuild "
                          "it from all of setup.py's sources (`pip install -e .`)")
    _declare_resolver(lib)
    _declare_setup(lib)
    _declare_detector(lib)

    librebound = rebound.clibrebound
    librebound.reb_simulation_struct_size.restype = ctypes.c_size_t
    check_simulation_struct_size(lib.rs_simulation_struct_size(),
                                 librebound.reb_simulation_struct_size())
    checks = [
        ("struct reb_collision", ctypes.sizeof(CollisionS), COLLISION_DTYPE.itemsize),
        ("struct rs_resolver", lib.rs_resolver_struct_size(), ctypes.sizeof(_Resolver)),
        ("struct rs_log_entry", lib.rs_log_entry_size(), LOG_DTYPE.itemsize),
        ("speed histogram bins", lib.rs_histogram_bins(0), _N_VN_BINS),
        ("dissipation histogram bins", lib.rs_histogram_bins(1), _N_EPS_BINS),
        ("restitution parameter slots", _Resolver.param.size // ctypes.sizeof(ctypes.c_double),
         RESTITUTION.n_slots),
        ("friction parameter slots",
         _Resolver.friction.size // ctypes.sizeof(ctypes.c_double), FRICTION.n_slots),
    ]
    for what, in_c, in_python in checks:
        if in_c != in_python:
            raise ImportError(f"ringsim._resolver is out of date: {what} is {in_c} in C but "
                              f"{in_python} in ringsim.engine.native; rebuild the extension")
    return lib


_LIB = _load_library()
_RESOLVE_ADDRESS = ctypes.cast(_LIB.rs_resolve, ctypes.c_void_p).value
_CONSTANT_COR_ADDRESS = ctypes.cast(_LIB.rs_constant_epsilon_cor, ctypes.c_void_p).value
#: The sheet detector's step function (a function's address, never NULL).
_SHEET_STEP_ADDRESS = cast(int, ctypes.cast(_LIB.rs_sheet_step, ctypes.c_void_p).value)
#: Type of REBOUND's post_timestep_modifications pointer.
_POST_TIMESTEP = ctypes.CFUNCTYPE(None, ctypes.POINTER(rebound.Simulation))
#: Values of ``collision_detection`` (the scenario's ``integration.collision_detection``):
#: None keeps the simulation's REBOUND search as set, "tree" is REBOUND's tree search,
#: "line" ringsim's swept-sphere sheet detector.
COLLISION_DETECTIONS = (None, "tree", "line")
#: Error codes of the sheet detector (RS_DETECT_* in rs_sheet_detect.c).
DETECTOR_ERRORS = {0: "none", 1: "out of memory",
                   2: "boundary is neither 'shear' nor 'periodic'",
                   3: "time step too long (1.5 Omega dt >= 0.5) or non-finite particle state"}


def max_shear_step() -> float:
    """Largest 1.5 Omega dt (exclusive) the sheet detector accepts (RS_MAX_SHEAR_STEP).

    Line detection refuses longer steps, so ``config.scenario`` validates a fixed
    ``integration.dt`` with it.
    """
    return float(_LIB.rs_sheet_max_shear_step())


def openmp_available() -> bool:
    """True if the sheet detector was compiled with OpenMP (more than one thread helps)."""
    return bool(_LIB.rs_sheet_openmp())


def checked_threads(threads) -> int:
    """``threads`` as an int >= 1 (``integration.threads`` of the detector and of P3M);
    ValueError otherwise."""
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads: must be an integer >= 1, got {threads!r}")
    return int(threads)


def set_detector_threads(resolver_address: int, threads: int) -> int:
    """Let the sheet detector of the resolver at ``resolver_address`` search with ``threads``
    OpenMP threads (``integration.threads``); returns the number it will ask for.

    The contacts found and resolved, hence every result, do not depend on the number
    (``rs_sheet_detect.c``, step 3a).  Without OpenMP in the build the search runs on one
    thread whatever the number; without the detector (tree mode) nothing changes.
    """
    threads = checked_threads(threads)
    done = int(_LIB.rs_sheet_set_threads(resolver_address, int(threads)))
    if done < 1:
        raise MemoryError("could not allocate the sheet detector")
    return done


def detector_threads_used(resolver_address: int) -> int:
    """Threads the last search of the sheet detector ran on (0 before the first search;
    fewer than asked where each would get fewer than `particles_per_thread`)."""
    return int(_LIB.rs_sheet_threads_used(resolver_address))


def particles_per_thread() -> int:
    """Particles per thread at least before the detector splits its search
    (RS_PARTICLES_PER_THREAD; below, starting the threads costs more than they save)."""
    return int(_LIB.rs_sheet_particles_per_thread())


def _free_resolver(address: int) -> None:
    _LIB.rs_resolver_free(address)


def _function_address(pointer: Any) -> int | None:
    """Address of a ctypes function pointer (None if NULL)."""
    return ctypes.cast(pointer, ctypes.c_void_p).value


# --- P3M self-gravity (ringsim/csrc/rs_p3m.c) ---------------------------------------------------

#: Nodes of the tabulated long-range pair force (RS_P3M_TABLE in rs_p3m.c).
P3M_TABLE = 4096


class P3MStruct(ctypes.Structure):
    """Mirror of ``struct rs_p3m`` (split, cutoff, softening, dz [m]; mesh; per-call
    layer geometry and shear offset; the smallest radius [m] in the pair sum)."""
    _fields_ = [
        ("split", ctypes.c_double),
        ("cutoff", ctypes.c_double),
        ("softening", ctypes.c_double),
        ("dz", ctypes.c_double),
        ("nx", ctypes.c_int),
        ("ny", ctypes.c_int),
        ("nz", ctypes.c_int),
        ("error", ctypes.c_int),
        ("threads", ctypes.c_int),
        ("two_pass", ctypes.c_int),
        ("zwindow", ctypes.c_int),
        ("zbins", ctypes.c_int),
        ("z0", ctypes.c_double),
        ("shift", ctypes.c_double),
        ("alpha", ctypes.c_double),
        ("pair_min_radius", ctypes.c_double),
        ("zlo", ctypes.c_double),
        ("zhi", ctypes.c_double),
        ("table", ctypes.c_double * (P3M_TABLE + 2)),
    ]


def _declare_p3m(lib: ctypes.CDLL) -> None:
    """Declare the P3M functions' prototypes (rs_p3m.c)."""
    sim_p, p3m_p = ctypes.c_void_p, ctypes.POINTER(P3MStruct)
    double_p = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    for name, args, res in (("rs_p3m_init", [p3m_p], None),
                            ("rs_p3m_prepare", [sim_p, p3m_p], ctypes.c_int),
                            ("rs_p3m_prepare_core", [sim_p, p3m_p, ctypes.c_double,
                                                     ctypes.c_double], ctypes.c_int),
                            ("rs_p3m_heights", [sim_p, double_p], None),
                            ("rs_p3m_heights_from", [sim_p, ctypes.c_double, double_p,
                                                     ctypes.POINTER(ctypes.c_double)],
                             ctypes.c_int),
                            ("rs_p3m_assign", [sim_p, p3m_p, double_p], None),
                            ("rs_p3m_interpolate", [sim_p, p3m_p, double_p, double_p, double_p],
                             None),
                            ("rs_p3m_short", [sim_p, p3m_p], None),
                            ("rs_p3m_mean_vertical", [sim_p, p3m_p], None),
                            ("rs_p3m_height_span", [sim_p, ctypes.POINTER(ctypes.c_int)],
                             ctypes.c_double)):
        getattr(lib, name).argtypes = args
        getattr(lib, name).restype = res


_declare_p3m(_LIB)
#: True: the library has the P3M solver, as it has every source (checked at load).
HAS_P3M = True

#: Name of ringsim's threaded SEI in REBOUND's registry of integrators (csrc/rs_sei.c): the
#: arithmetic of REBOUND's "sei", with its drift and kick loops on OpenMP threads.
THREADED_SEI = "ringsim_sei"
_THREADED_SEI_NAME = THREADED_SEI.encode("ascii")   # lives as long as the registry


def _register_threaded_sei(lib: ctypes.CDLL) -> None:
    """Register the threaded SEI with REBOUND, once per process (at import), through
    REBOUND's public ``reb_integrator_register``."""
    lib.rs_sei_register.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_char_p]
    lib.rs_sei_register.restype = None
    lib.rs_sei_set_threads.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.rs_sei_set_threads.restype = ctypes.c_int
    lib.rs_sei_particles_per_thread.restype = ctypes.c_int
    librebound = rebound.clibrebound
    lib.rs_sei_register(ctypes.cast(librebound.reb_integrator_register, ctypes.c_void_p),
                        ctypes.cast(librebound.reb_simulation_update_acceleration,
                                    ctypes.c_void_p),
                        _THREADED_SEI_NAME)


_register_threaded_sei(_LIB)


def use_threaded_sei(sim: rebound.Simulation, threads: int = 1) -> None:
    """Integrate ``sim`` (SEI) with ringsim's threaded SEI on ``threads`` OpenMP threads.

    The same bits as REBOUND's ``sei`` on any number of threads (tests/test_sei.py): a
    speed setting only.  A simulation with another integrator is left as it is.
    """
    threads = checked_threads(threads)
    if str(sim.integrator) not in ("sei", THREADED_SEI):
        return
    if str(sim.integrator) != THREADED_SEI:
        sim.integrator = THREADED_SEI
    _LIB.rs_sei_set_threads(ctypes.addressof(sim), threads)


def sei_particles_per_thread() -> int:
    """Particles a thread at least before the threaded SEI splits its loops."""
    return int(_LIB.rs_sei_particles_per_thread())


@contextlib.contextmanager
def rebound_sei(sim: rebound.Simulation) -> Iterator[None]:
    """Within the block ``sim`` integrates with REBOUND's own ``sei``, so that a file saved
    there loads in plain REBOUND; afterwards the threaded SEI is back with its threads."""
    if str(sim.integrator) != THREADED_SEI:
        yield
        return
    threads = int(sim.integrator.threads)
    sim.integrator = "sei"
    try:
        yield
    finally:
        use_threaded_sei(sim, threads)


#: glibc's mallopt parameters (malloc.h) and the largest mmap threshold it accepts on a
#: 64-bit system (DEFAULT_MMAP_THRESHOLD_MAX = 4 MiB x sizeof(long)).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_MMAP_THRESHOLD_MAX = 32 * 2**20
_KEPT: list[bool] = []


def keep_freed_memory() -> bool:
    """Let the C library's malloc keep freed memory for reuse, once per process: blocks up
    to 32 MiB come from the heap instead of a fresh mmap each, and the heap's top is not
    given back to the system.  P3M allocates a dozen mesh-sized numpy/scipy.fft temporaries
    per step; with glibc's defaults each large one is new memory whose pages the kernel
    zeroes on first touch, a share of the gravitating step worth saving (docs/performance.md,
    "Self-gravity").  Addresses do not enter any result.  Returns False where the C
    library has no ``mallopt`` (not glibc): nothing changes there."""
    if not _KEPT:
        try:
            mallopt = ctypes.CDLL(None).mallopt
        except AttributeError:
            _KEPT.append(False)
        else:
            mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
            _KEPT.append(bool(mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_MAX))
                         and bool(mallopt(_M_TRIM_THRESHOLD, 2**31 - 1)))
    return _KEPT[0]
