"""Shear-periodic P3M self-gravity installed in REBOUND (``sheet.gravity_solver: p3m``).

The solver (docs/gravity.md, section "P3M"): Gaussian force split of scale r_s; the long-
range part on a mesh of horizontal cells and layers in sheared coordinates, solved with
scipy.fft (:class:`ringsim.physics.p3m_mesh.P3MMesh`); mass assignment, interpolation and
the short-range pair sum within r_c in C (``ringsim/csrc/rs_p3m.c``).  REBOUND's own gravity
is off (``sim.gravity = "none"``); one Python ``additional_forces`` callback per force
evaluation (SEI: once per step, at the half-step positions, time ``sim.t`` of mid-step) does
prepare -> assign -> FFT solve -> interpolate -> pair sum (with ``sheet.p3m_mesh_interval``
k > 1 the mesh stages run on one step in k, their force times k: `P3MSolver`).  ctypes
swallows exceptions raised in a callback, so the callback stores the first one and
:func:`raise_pending` re-raises it after the step (the run loop calls it after every chunk
of steps).  `SOLVER` is the solver
behind ``ringsim.gravity.base.GravitySolver``: its keyword ``p3m_setting`` is (split [m],
auto).
"""

from __future__ import annotations

import ctypes
import math
import time
import weakref

import numpy as np
import rebound
import scipy.fft

from ringsim.engine.native import (
    _LIB,
    _POST_TIMESTEP,
    HAS_P3M,
    P3MStruct,
    checked_threads,
    keep_freed_memory,
)
from ringsim.gravity.base import GravitySolver
from ringsim.physics.constants import G_SI
from ringsim.physics.gravity_solvers import P3M
from ringsim.physics.p3m_mesh import P3MMesh, core_heights
from ringsim.physics.p3m_scales import (
    P3M_CELL_SPLITS,
    P3M_CORE_MIN_COUNT,
    P3M_CORE_MIN_MASS_SHARE,
    P3M_CUTOFF_SPLITS,
    P3M_LAYER_SPLITS,
    P3M_TAIL_MARGIN_SCALES,
    P3M_TAIL_MARGIN_SPLITS,
    layer_bucket,
    p3m_auto_split,
)

#: Interquartile range of a unit Gaussian: (q3 - q1) / GAUSSIAN_IQR is a robust sigma.
GAUSSIAN_IQR = 1.349

#: Installed solvers by the address of their callback (REBOUND keeps the callback object in
#: ``sim._afp``, and the callback keeps its solver alive).
_SOLVERS: weakref.WeakValueDictionary = weakref.WeakValueDictionary()


def _even_cells(length, cell):
    """An even number of cells of at most ``cell`` [m] with only small prime factors."""
    n = max(4, int(math.ceil(length / cell)))
    while True:
        n = scipy.fft.next_fast_len(n, real=True)
        if n % 2 == 0:
            return n
        n += 1


def p3m_parameters(Lx, Ly, split, cutoff=None, cell=None, dz=None) -> dict:
    """The P3M solver's parameters for a box: ``split``, ``cutoff``, ``cell``, ``dz`` [m]
    (defaults: the P3M_*_SPLITS multiples of ``split``) and the mesh ``nx``, ``ny``.

    Parameters
    ----------
    Lx, Ly, split : float [m]
    cutoff, cell, dz : float [m], optional
    """
    cutoff = P3M_CUTOFF_SPLITS * split if cutoff is None else cutoff
    cell = P3M_CELL_SPLITS * split if cell is None else cell
    dz = P3M_LAYER_SPLITS * split if dz is None else dz
    return {"split": float(split), "cutoff": float(cutoff), "dz": float(dz),
            "nx": _even_cells(Lx, cell), "ny": _even_cells(Ly, cell)}


def describe(Lx, Ly, softening, split, auto=False, pair_min_radius=0.0,
             tail_fraction=0.0, mesh_interval=1, core_min_radius=0.0) -> dict:
    """Root attributes of a run file for the P3M solver at its defaults, each with
    ``units_<name>`` beside it; with ``auto`` the split, cutoff, mesh and layers given are
    those of the first rung, and ``p3m_split_auto`` says that the split follows the height
    span (the largest it may take is ``p3m_split_largest``).

    Parameters
    ----------
    Lx, Ly, softening, split : float [m]
    auto : bool
    pair_min_radius : float [m]
        Particles below it are field-only (0: none).
    tail_fraction : float [-]
        Fraction of the particles the mesh may leave beyond its layers (0: none).
    mesh_interval : int [steps]
        Steps per mesh evaluation (1: every step; recorded only when above 1).
    core_min_radius : float [m]
        The particles whose heights set the mesh's core are those of at least this radius
        (0: all; recorded only when above 0).
    """
    p = p3m_parameters(Lx, Ly, split)
    largest = p3m_auto_split(split, math.inf, 1, Lx, Ly) if auto else p["split"]
    optional = {} if mesh_interval == 1 else {
        "p3m_mesh_interval": int(mesh_interval), "units_p3m_mesh_interval":
            "steps (the mesh force acts as an impulse of this many steps on the middle "
            "step of every group of this many; 1: every step)"}
    if core_min_radius > 0.0:
        optional.update({"p3m_core_min_radius": float(core_min_radius),
                         "units_p3m_core_min_radius":
                             "m (the heights of the particles of at least this radius set "
                             "the mesh's core; 0: every particle's)"})
    return {"gravity_solver": P3M.name, **optional,
            "p3m_split": p["split"], "units_p3m_split": "m",
            "p3m_split_auto": int(bool(auto)),
            "units_p3m_split_auto": "1: the split follows the height span, 0: fixed",
            "p3m_split_largest": largest, "units_p3m_split_largest": "m",
            "p3m_cutoff": p["cutoff"], "units_p3m_cutoff": "m",
            "p3m_mesh": np.array([p["nx"], p["ny"]], dtype=np.int64),
            "units_p3m_mesh": "cells (x, y)",
            "p3m_cell": np.array([Lx / p["nx"], Ly / p["ny"]]), "units_p3m_cell": "m",
            "p3m_layer_spacing": p["dz"], "units_p3m_layer_spacing": "m",
            "p3m_pair_min_radius": float(pair_min_radius), "units_p3m_pair_min_radius":
                "m (smaller particles are field-only: mesh, no pair sum; 0: none)",
            "p3m_tail_fraction": float(tail_fraction), "units_p3m_tail_fraction":
                "1 (fraction of the particles the mesh's layers may leave beyond them, "
                "half above, half below; 0: the layers span every particle)",
            "softening": float(softening), "units_softening": "m"}


class _Laps:
    """Adds the CPU time since the last lap to ``profile[name]`` (nothing if ``profile`` is
    None)."""

    def __init__(self, profile: dict[str, float] | None):
        self.profile = profile
        self.t = time.process_time() if profile is not None else 0.0

    def __call__(self, name: str) -> None:
        if self.profile is not None:
            now = time.process_time()
            self.profile[name] = self.profile.get(name, 0.0) + now - self.t
            self.t = now


class P3MSolver:
    """P3M gravity of one shear-periodic box (the callback REBOUND calls).

    Parameters
    ----------
    Lx, Ly : float [m]
    softening : float [m]
        Plummer softening b (as REBOUND's ``softening``).
    split : float [m]
        r_s of the Gaussian split; with ``auto``, the smallest split (the first rung).
    cutoff : float [m]
        r_c of the pair sum (default P3M_CUTOFF_SPLITS r_s); must be < min(Lx, Ly).
    cell : float [m]
        Target horizontal mesh cell (rounded to an even number of cells; default
        P3M_CELL_SPLITS r_s).
    dz : float [m]
        Layer spacing (default P3M_LAYER_SPLITS r_s).
    workers : int
        scipy.fft threads.
    auto : bool
        ``sheet.p3m_split: auto``: at every force evaluation the split is chosen from the
        particles' height span (``physics.p3m_scales.p3m_auto_split``, rungs from
        ``split`` up; cutoff, cell and layers at their default multiples of it).  Each
        rung keeps its own parameters and mesh, made when first used.
    pair_min_radius : float [m]
        Particles smaller than this are field-only (``sheet.p3m_pair_min_radius``): on the
        mesh, not in the pair sum; 0: every particle in the pair sum.
    tail_fraction : float [-]
        ``sheet.p3m_tail_fraction``: the mesh's layers span only the heights that hold all
        but this fraction of the particles (``physics.p3m_mesh.core_heights``), widened by
        a margin (`_prepare`); a particle beyond them is on the mesh at the nearer limit
        with damped weights, its pair forces within r_c and its mean vertical field are
        exact.  The split of ``auto`` still follows the whole height span.  0: the layers
        span every particle.
    mesh_interval : int [steps]
        ``sheet.p3m_mesh_interval`` k (odd): in REBOUND's steps the mesh (assignment, FFTs,
        interpolation) runs only on the middle step of every k, index floor(t / dt) =
        (k - 1) / 2 modulo k, its force multiplied by k (an impulse of k steps, centred on
        the steps it stands for; the RESPA scheme of Tuckerman et al. 1992), and is left
        out on the others; the pair sum and the mean vertical field act every step.  The
        schedule is a function of t and dt alone, so a resumed run takes the same steps.
        :meth:`apply` called directly gives the whole force.  1: the mesh every step.
    core_min_radius : float [m]
        ``sheet.p3m_core_min_radius``: with ``tail_fraction``, the core's order statistics
        and robust scale are those of the heights of the particles of at least this radius
        where they hold enough of the mass and are enough in number (`_core`), else of
        every particle's; the layers never reach beyond the particles.  0: every
        particle's height.
    """

    def __init__(self, Lx: float, Ly: float, softening: float, split: float,
                 cutoff: float | None = None, cell: float | None = None,
                 dz: float | None = None, G: float = G_SI, workers: int = 1,
                 auto: bool = False, pair_min_radius: float = 0.0,
                 tail_fraction: float = 0.0, mesh_interval: int = 1,
                 core_min_radius: float = 0.0) -> None:
        if not HAS_P3M:
            raise ImportError("ringsim._resolver was built without rs_p3m.c; rebuild the "
                              "extension (`python setup.py build_ext --inplace`)")
        if auto and (cutoff, cell, dz) != (None, None, None):
            raise ValueError("auto P3M split: cutoff, cell and dz follow the split")
        keep_freed_memory()     # the mesh temporaries of every step reuse memory
        self.Lx, self.Ly, self.G = float(Lx), float(Ly), float(G)
        self.softening, self.workers, self.threads = float(softening), workers, 1
        self.first_split, self.auto = float(split), bool(auto)
        self.pair_min_radius = float(pair_min_radius)
        if not 0.0 <= tail_fraction < 1.0:
            raise ValueError(f"P3M tail fraction {tail_fraction} must be in [0, 1)")
        self.tail_fraction = float(tail_fraction)
        if not core_min_radius >= 0.0:
            raise ValueError(f"P3M core radius {core_min_radius} m must be at least 0")
        self.core_min_radius = float(core_min_radius)
        if (mesh_interval != int(mesh_interval) or int(mesh_interval) % 2 == 0
                or not 1 <= mesh_interval <= 99):
            raise ValueError(f"P3M mesh interval {mesh_interval} must be an odd whole number "
                             "of steps in [1, 99]")
        self.mesh_interval = int(mesh_interval)
        self._explicit = (cutoff, cell, dz)
        self.height_index = True
        self._rungs: dict[float, tuple[P3MStruct, P3MMesh]] = {}
        self.error: BaseException | None = None
        #: CPU seconds [s] per stage of :meth:`apply` (summed over calls) while it is a
        #: dict (a benchmark sets ``{}``); None: not timed
        self.profile: dict[str, float] | None = None
        self._use(self.first_split)
        self._callback = _POST_TIMESTEP(self._additional_forces)

    def _use(self, split: float) -> None:
        """Make the rung of ``split`` [m] current (``params``, ``mesh``)."""
        if split not in self._rungs:
            par = p3m_parameters(self.Lx, self.Ly, split, *self._explicit)
            if not 0.0 < par["cutoff"] < min(self.Lx, self.Ly):
                raise ValueError(f"P3M cutoff {par['cutoff']:.3g} m must be below the box's "
                                 f"width ({min(self.Lx, self.Ly):.3g} m)")
            params = P3MStruct(split=split, cutoff=par["cutoff"], softening=self.softening,
                               dz=par["dz"], nx=par["nx"], ny=par["ny"], threads=self.threads,
                               pair_min_radius=self.pair_min_radius)
            _LIB.rs_p3m_init(ctypes.byref(params))
            params.zwindow = int(self.height_index)
            mesh = P3MMesh(self.Lx, self.Ly, params.nx, params.ny, par["dz"], split,
                           G=self.G, workers=self.threads)
            self._rungs[split] = (params, mesh)
        self.params, self.mesh = self._rungs[split]

    @property
    def setting(self) -> tuple[float, bool]:
        """(split [m], auto) as given: enough to make the same solver again."""
        return self.first_split, self.auto

    def set_height_index(self, on: bool) -> None:
        """The pair sum through its height index where the ring is thick (``True``, the
        default: ``rs_p3m_window``) or by whole columns (the reference of tests and
        benchmarks); the same bits either way."""
        self.height_index = bool(on)
        for params, _mesh in self._rungs.values():
            params.zwindow = int(self.height_index)

    def set_threads(self, threads: int) -> None:
        """Interpolation, pair sum (OpenMP) and FFTs (scipy.fft workers) on ``threads``
        threads; every result is the same on any number (each particle's sums keep their
        order, and scipy's FFTs split independent transforms)."""
        self.threads = checked_threads(threads)
        for params, mesh in self._rungs.values():
            params.threads = self.threads
            mesh.workers = self.threads

    def _prepare(self, sim_address: int) -> P3MStruct:
        """Choose the split (``auto``: from the particles' whole height span) and the
        layers (all particles, or with ``tail_fraction`` the core of `core_heights` of the
        heights `_core` chooses (with ``core_min_radius``, the large particles'), widened
        on each side by the larger of P3M_TAIL_MARGIN_SPLITS r_s and
        P3M_TAIL_MARGIN_SCALES robust scales of those heights, within every particle's
        heights) for the state at ``sim_address``; returns the parameters made current."""
        count = ctypes.c_int(0)
        span = _LIB.rs_p3m_height_span(sim_address, ctypes.byref(count))
        if self.auto:
            self._use(p3m_auto_split(self.first_split, span, count.value, self.Lx, self.Ly))
        p = self.params
        if self.tail_fraction > 0.0 and count.value > 0:
            heights = np.empty(count.value)
            _LIB.rs_p3m_heights(sim_address, heights)
            core = self._core(sim_address, heights)
            zlo, zhi = core_heights(core, self.tail_fraction)
            q1, q3 = core_heights(core, 0.5)      # the quartiles: a robust scale
            margin = max(P3M_TAIL_MARGIN_SPLITS * p.split,
                         P3M_TAIL_MARGIN_SCALES * (q3 - q1) / GAUSSIAN_IQR)
            nz = _LIB.rs_p3m_prepare_core(sim_address, ctypes.byref(p),
                                          max(zlo - margin, float(heights.min())),
                                          min(zhi + margin, float(heights.max())))
        else:
            nz = _LIB.rs_p3m_prepare(sim_address, ctypes.byref(p))
        # padded to a fixed ladder of layer counts: a few kernel tables serve the whole run
        p.nz = layer_bucket(nz)
        return p

    def _core(self, sim_address: int, heights: np.ndarray) -> np.ndarray:
        """The heights [m] whose order statistics and quartiles set the mesh's core: those
        of the particles of at least ``core_min_radius`` where they hold at least
        P3M_CORE_MIN_MASS_SHARE of the mass and number at least P3M_CORE_MIN_COUNT and 2 /
        ``tail_fraction``, else ``heights`` (every particle's)."""
        if self.core_min_radius <= 0.0:
            return heights
        core = np.empty(heights.size)
        share = ctypes.c_double(0.0)
        large = _LIB.rs_p3m_heights_from(sim_address, self.core_min_radius, core,
                                         ctypes.byref(share))
        enough = max(P3M_CORE_MIN_COUNT, 2.0 / self.tail_fraction)
        if large < enough or share.value < P3M_CORE_MIN_MASS_SHARE:
            return heights
        return core[:large]

    def apply(self, sim_address: int, mesh_steps: int = 1) -> None:
        """Add the P3M accelerations [m/s^2] to the simulation at ``sim_address``, the mesh
        force ``mesh_steps`` times (an impulse of that many steps; 0: none)."""
        lap = _Laps(self.profile)
        p = self._prepare(sim_address)
        lap("split and layers")
        if mesh_steps > 0:
            mass = np.empty((p.nz, p.nx, p.ny))
            _LIB.rs_p3m_assign(sim_address, ctypes.byref(p), mass)
            lap("mass assignment")
            gx, gy, gz = self.mesh.fields(mass, p.alpha)
            if mesh_steps != 1:
                for g in (gx, gy, gz):
                    g *= float(mesh_steps)
            lap("mesh fields (FFT)")
            _LIB.rs_p3m_interpolate(sim_address, ctypes.byref(p), gx, gy, gz)
            lap("interpolation")
        _LIB.rs_p3m_mean_vertical(sim_address, ctypes.byref(p))
        lap("mean vertical field")
        _LIB.rs_p3m_short(sim_address, ctypes.byref(p))
        lap("pair sum")
        if p.error:
            raise MemoryError("rs_p3m: out of memory (cell list or fine vertical layers)")

    def _mesh_steps(self, sim_pointer) -> int:
        """Steps of mesh force in this force evaluation: k = ``mesh_interval`` on the
        steps whose index n = floor(t / dt) is (k - 1) / 2 modulo k, the middle of the k
        steps n - (k - 1) / 2 ... n + (k - 1) / 2 it stands for (SEI evaluates at mid-step,
        t = (n + 1/2) dt from t = 0), 0 on the others; 1 when k = 1."""
        k = self.mesh_interval
        if k == 1:
            return 1
        sim = sim_pointer.contents
        return k if (math.floor(sim.t / sim.dt) - k // 2) % k == 0 else 0

    def _additional_forces(self, sim_pointer) -> None:
        if self.error is not None:
            return
        try:
            address = ctypes.cast(sim_pointer, ctypes.c_void_p).value
            if address is None:
                raise ValueError("REBOUND called the P3M solver with a NULL simulation")
            self.apply(address, self._mesh_steps(sim_pointer))
        except Exception as exc:  # noqa: BLE001 - ctypes would swallow it; re-raised later
            self.error = exc


def install_p3m(sim: rebound.Simulation, solver: P3MSolver) -> None:
    """Make ``solver`` the self-gravity of ``sim``: REBOUND's gravity off, the solver as
    ``additional_forces``.  REBOUND does not save function pointers: install again after
    loading a simulation from a file."""
    sim.gravity = "none"
    sim.softening = solver.params.softening
    sim._additional_forces = solver._callback
    sim._afp = solver._callback     # REBOUND's slot that keeps the ctypes object alive
    _SOLVERS[ctypes.cast(solver._callback, ctypes.c_void_p).value] = solver


def installed_solver(sim: rebound.Simulation) -> P3MSolver | None:
    """The P3M solver installed in ``sim`` (None if none)."""
    address = ctypes.cast(sim._additional_forces, ctypes.c_void_p).value
    return None if address is None else _SOLVERS.get(address)


def raise_pending(sim: rebound.Simulation) -> None:
    """Re-raise an exception the P3M callback caught during the last steps (ctypes cannot
    propagate it through REBOUND)."""
    solver = installed_solver(sim)
    if solver is not None and solver.error is not None:
        exc, solver.error = solver.error, None
        raise RuntimeError(f"P3M self-gravity failed during a step: {exc}") from exc


def set_threads(sim: rebound.Simulation, threads: int) -> None:
    """The installed P3M solver's threads (`P3MSolver.set_threads`; nothing without P3M)."""
    solver = installed_solver(sim)
    if solver is not None:
        solver.set_threads(threads)


def install(sim: rebound.Simulation, *, p3m_setting: tuple[float, bool],
            p3m_pair_min_radius: float = 0.0, p3m_tail_fraction: float = 0.0,
            p3m_mesh_interval: int = 1, p3m_core_min_radius: float = 0.0) -> None:
    """A `P3MSolver` of ``sim``'s box and softening with ``p3m_setting`` = (split scale
    [m], auto: the split follows the height span from there up), the field-only radius
    ``p3m_pair_min_radius`` [m], the tail fraction ``p3m_tail_fraction`` [-], the steps
    per mesh evaluation ``p3m_mesh_interval`` and the core's radius ``p3m_core_min_radius``
    [m], the other parameters at their defaults (``physics.p3m_scales.P3M_*``)."""
    split, auto = p3m_setting
    Lx = sim.root_size * sim.N_root_x
    Ly = sim.root_size * sim.N_root_y
    install_p3m(sim, P3MSolver(Lx, Ly, sim.softening, split, G=G_SI, auto=auto,
                               pair_min_radius=p3m_pair_min_radius,
                               tail_fraction=p3m_tail_fraction,
                               mesh_interval=p3m_mesh_interval,
                               core_min_radius=p3m_core_min_radius))


def _optional(mesh_interval: int, core_min_radius: float = 0.0) -> dict:
    """``p3m_mesh_interval`` where it is not 1 and ``p3m_core_min_radius`` where it is not
    0, as keywords (the defaults leave the keywords of earlier runs as they were)."""
    return ({} if mesh_interval == 1 else {"p3m_mesh_interval": int(mesh_interval)}) | (
        {} if core_min_radius == 0.0 else {"p3m_core_min_radius": float(core_min_radius)})


def arguments(scenario) -> dict:
    """``p3m_setting`` (split [m], auto), ``p3m_pair_min_radius`` [m],
    ``p3m_tail_fraction`` [-] and, where not at their defaults, ``p3m_mesh_interval``
    [steps] and ``p3m_core_min_radius`` [m] of a scenario's P3M solver."""
    tail = scenario.sheet.p3m_tail_fraction
    return {"p3m_setting": scenario.p3m_setting,
            "p3m_pair_min_radius": float(scenario.sheet.p3m_pair_min_radius or 0.0),
            "p3m_tail_fraction": 0.0 if tail is None else float(tail),
            **_optional(int(scenario.sheet.p3m_mesh_interval or 1),
                        float(scenario.sheet.p3m_core_min_radius or 0.0))}


def recognise(sim: rebound.Simulation) -> dict | None:
    """`arguments` of the P3M solver installed in ``sim`` (None: none)."""
    solver = installed_solver(sim)
    return None if solver is None else {"p3m_setting": solver.setting,
                                        "p3m_pair_min_radius": solver.pair_min_radius,
                                        "p3m_tail_fraction": solver.tail_fraction,
                                        **_optional(solver.mesh_interval,
                                                    solver.core_min_radius)}


def attributes(keywords: dict, geometry) -> dict:
    """`describe` of the solver in ``geometry``'s box (Lx, Ly [m])."""
    split, auto = keywords["p3m_setting"]
    return describe(geometry.Lx, geometry.Ly, keywords["softening"], split, auto,
                    pair_min_radius=keywords.get("p3m_pair_min_radius", 0.0),
                    tail_fraction=keywords.get("p3m_tail_fraction", 0.0),
                    mesh_interval=keywords.get("p3m_mesh_interval", 1),
                    core_min_radius=keywords.get("p3m_core_min_radius", 0.0))


SOLVER = GravitySolver(P3M, install=install, arguments=arguments, recognise=recognise,
                       attributes=attributes, set_threads=set_threads,
                       raise_pending=raise_pending)
