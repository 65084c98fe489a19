"""The cases of the self-gravity campaign (``analysis/kappa_selfgravity.py``), their run
lengths and the files their runs are written to.

A case is a size distribution, a distance from Saturn and an optical depth (``CASES``); its
patch (``patch``: Omega, Sigma, Toomre wavelength, particles, box) follows from them.  Each
run of a case is named by its kind (no gravity, tree, slab, P3M, a method variant of the
budget), kappa and seed (``output`` and the other ``*_output``), and runs for the fixed
number of orbits ``orbits`` gives it.  Everything here is plain numbers and paths: the
driver runs the jobs, the report and the P3M check read them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ringsim.physics.gravity import orbital_frequency, surface_density_from_tau, toomre_wavelength

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = {0.0: ROOT / "scenarios" / "kappa0-gravity.yaml",
             0.1: ROOT / "scenarios" / "kappa0.1-gravity.yaml"}
REPORT = ROOT / "analysis" / "kappa_selfgravity.md"
P3M_CHECK = ROOT / "analysis" / "data" / "kappa_selfgravity_p3m_check.json"
GM_SATURN = 3.7931e16       # [m^3/s^2], as the scenarios
DENSITY = 900.0             # [kg/m^3], as the scenarios
#: Smallest box side in Toomre wavelengths (wakes need 2), and fewest particles.
BOX_LAMBDA = 2.1
MIN_PARTICLES = 600
#: Cases run in boxes smaller than ``BOX_LAMBDA`` lambda_cr: case -> particles.  The slab
#: has no horizontal modes, so its field does not depend on the box's size in lambda_cr;
#: what a smaller box changes is measured by the budget's n_particles part.  Such a box is
#: below the 2 lambda_cr wakes need: tree runs of the case for the ratio need its entry
#: removed.  The tree kappa = 0 runs of mono-1.3e8-0.5 are in this box on purpose, a check
#: of the slab like for like where Q is lowest (why these cases, and what their full boxes
#: would cost: analysis/kappa_selfgravity.md, "Run lengths and boxes").
SLAB_PARTICLES = {"mono-1.3e8-0.5": 2400, "powerlaw-1.3e8-0.5": 2400}
#: Size distributions of the cases: overrides of ``particles.size_distribution``.
SIZES = {"mono": {"kind": "monodisperse", "radius": 1.0},
         "powerlaw": {"kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}}
#: Cases: name -> (size distribution, a [m], optical depth).
CASES = {f"{size}-{a_name}-{tau:g}": (size, a, tau)
         for size in SIZES for a_name, a in (("1e8", 1.0e8), ("1.3e8", 1.3e8))
         for tau in (0.25, 0.5)}

#: Orbits of every run, by case: entry -> orbits (``orbits`` reads them).
#: - Every run runs a fixed number of orbits from the scenario's initial state, and the
#:   equilibrium finder chooses its window afterwards: a run stopped as soon as the finder
#:   calls it stationary can stop inside a slow transient.
#: - All seeds of a group (case, solver, kappa) run alike, and a group with a run the finder
#:   leaves out is made longer, never shorter (``run_one`` refuses a run longer than asked).
#: - "nograv", "gravity" (the tree), "slab", "p3m" (P3M in the case's box), "p3m-box" (P3M
#:   in a box of ``--p3m-box`` lambda_cr) and "p3m-tiled" (P3M started tiled) name the
#:   kinds of run; "<kind>, kappa <k>" sets one kappa value's runs apart; a slab or P3M run
#:   without an entry of its own takes the "gravity" length.
#: - A case takes the lengths of its size distribution's case at tau = 0.25, with the
#:   no-gravity runs at tau = 0.5 half as long (their autocorrelation times scale with the
#:   collision rate, which is proportional to tau), and its own entries where its runs
#:   needed more.
#: Why each group has its length: analysis/kappa_selfgravity.md, "Run lengths and boxes".
MONO_LENGTHS = {"nograv": 320.0, "gravity": 140.0, "gravity, kappa 0.1": 280.0}
POWERLAW_LENGTHS = {"nograv": 480.0, "gravity": 70.0, "gravity, kappa 0.1": 140.0,
                    "slab": 140.0}
POWERLAW_05_LENGTHS = {**POWERLAW_LENGTHS, "nograv": 240.0, "nograv, kappa 0.1": 320.0,
                       "slab": 210.0}
ORBITS_FOR_CASE = {"mono-1e8-0.25": {**MONO_LENGTHS, "slab, kappa 0": 210.0},
                   "mono-1.3e8-0.25": {**MONO_LENGTHS, "gravity, kappa 0": 350.0,
                                       "slab, kappa 0": 280.0, "slab, kappa 0.1": 490.0},
                   "mono-1e8-0.5": {**MONO_LENGTHS, "nograv": 160.0,
                                    "gravity, kappa 0": 210.0, "slab, kappa 0": 140.0},
                   "mono-1.3e8-0.5": {**MONO_LENGTHS, "nograv": 160.0,
                                      "nograv, kappa 0": 200.0, "gravity, kappa 0": 210.0,
                                      "slab, kappa 0": 140.0},
                   "powerlaw-1e8-0.25": {**POWERLAW_LENGTHS, "slab": 210.0,
                                         "slab, kappa 0.1": 490.0},
                   "powerlaw-1e8-0.5": POWERLAW_05_LENGTHS,
                   "powerlaw-1.3e8-0.25": {**POWERLAW_LENGTHS, "slab, kappa 0": 210.0,
                                           "p3m, kappa 0": 140.0, "p3m, kappa 0.1": 210.0},
                   "powerlaw-1.3e8-0.5": {**POWERLAW_05_LENGTHS, "slab, kappa 0.1": 280.0,
                                          "p3m, kappa 0": 105.0, "p3m-box, kappa 0": 175.0,
                                          "p3m-tiled, kappa 0": 60.0}}

#: Method variants of the systematic budget (``--systematics CASE``): source -> overrides
#: of the runs ("n_particles": twice the case's particles, a box sqrt(2) times as wide;
#: "dt": the step halved).
SYSTEMATIC_VARIANTS = {"dt": {"integration.dt": 5e-4}, "n_particles": {}}
#: Kinds of run a variant repeats: "nograv" (no self-gravity) and "slab" (the slab solver,
#: 20-40 times cheaper than the tree); ``variant_output`` names the tree's ("gravity")
#: variant runs too (analysis/kappa_selfgravity.md, "Run lengths and boxes").
VARIANT_KINDS = ("nograv", "slab")


def orbits(case: str, gravity: bool, kappa: float, slab: bool = False,
           first: tuple[str, ...] = ()) -> float:
    """Orbits of the runs of ``case`` with or without self-gravity at ``kappa``; ``slab``:
    of its slab runs, whose own entries ("slab", "slab, kappa <k>") come first; ``first``:
    entries tried before those (``run_p3m``: "p3m", the P3M runs in the case's box)."""
    lengths = ORBITS_FOR_CASE[case]
    keys = [*first, "slab"] if slab else [*first]
    keys.append("gravity" if gravity or slab else "nograv")
    for key in keys:
        for name in (f"{key}, kappa {kappa:g}", key):
            if name in lengths:
                return lengths[name]
    raise KeyError(f"no length for {case}")


def p3m_orbits(case: str, kappa: float, box: float | None = None, tiled: bool = False) -> float:
    """Orbits of a P3M run of ``case`` at ``kappa`` (``run_p3m``): "p3m-tiled" when tiled,
    "p3m-box" in a box of ``box`` lambda_cr, else "p3m" (each else the "gravity" lengths)."""
    first = ("p3m-tiled",) if tiled else ("p3m-box",) if box else ("p3m",)
    return orbits(case, True, kappa, first=first)


def moments(size: str) -> tuple[float, float, float]:
    """<r>, <r^2>, <r^3> [m, m^2, m^3] of a size distribution of ``SIZES``."""
    d = SIZES[size]
    if d["kind"] == "monodisperse":
        r = d["radius"]
        return r, r * r, r ** 3
    r = np.geomspace(d["r_min"], d["r_max"], 200001)
    w = r ** -d["q"]
    norm = np.trapezoid(w, r)
    return tuple(float(np.trapezoid(w * r ** k, r) / norm) for k in (1, 2, 3))


def patch(case: str) -> dict:
    """Numbers of a case's patch: Omega [1/s], Sigma [kg/m^2], lambda_cr [m], particles
    (``SLAB_PARTICLES`` where set) and ``full_box_particles`` (those of a box of
    ``BOX_LAMBDA`` lambda_cr, ``particles_for_box``), the mean and mean-square radius
    [m, m^2] and the box's side [m]."""
    size, a, tau = CASES[case]
    r1, r2, r3 = moments(size)
    Omega = orbital_frequency(GM_SATURN, a)
    Sigma = surface_density_from_tau(tau, DENSITY, r2, r3)
    lam = toomre_wavelength(Sigma, Omega)
    full = particles_for_box(tau, r2, lam, BOX_LAMBDA)
    n = SLAB_PARTICLES.get(case, full)
    return {"Omega": Omega, "Sigma": Sigma, "lambda_cr": lam, "n_particles": n,
            "full_box_particles": full, "mean_radius": r1, "mean_square_radius": r2,
            "box": math.sqrt(n * math.pi * r2 / tau)}


def particles_for_box(tau: float, r2: float, lambda_cr: float, box_lambda: float) -> int:
    """Particles of a square box of ``box_lambda`` lambda_cr on a side, at least
    ``MIN_PARTICLES``: optical depth ``tau``, mean-square radius ``r2`` [m^2], ``lambda_cr``
    [m]."""
    return max(MIN_PARTICLES, math.ceil(tau * (box_lambda * lambda_cr) ** 2 / (math.pi * r2)))


def box_particles(case: str, box_lambda: float) -> int:
    """Particles of a square box of ``box_lambda`` lambda_cr on a side for ``case``."""
    p = patch(case)
    return particles_for_box(CASES[case][2], p["mean_square_radius"], p["lambda_cr"],
                             box_lambda)


def output(runs: Path, case: str, kappa: float, seed: int, gravity: bool) -> Path:
    """The file of a run of ``case`` at ``kappa`` and ``seed``, with self-gravity (the
    scenario's tree) or without."""
    return runs / f"{'gravity' if gravity else 'nograv'}_{case}_kappa{kappa:g}_seed{seed}.h5"


def slab_output(runs: Path, case: str, kappa: float, seed: int,
                box: float | None = None) -> Path:
    """The slab run's file; ``box``: the run in a box of that many lambda_cr."""
    tag = f"slab-box{box:g}" if box else "slab"
    return runs / f"{tag}_{case}_kappa{kappa:g}_seed{seed}.h5"


def p3m_output(runs: Path, case: str, kappa: float, seed: int,
               box: float | None = None) -> Path:
    """The P3M run's file; ``box``: the run in a box of that many lambda_cr."""
    tag = f"p3m-box{box:g}" if box else "p3m"
    return runs / f"{tag}_{case}_kappa{kappa:g}_seed{seed}.h5"


def tile_source(runs: Path, case: str, kappa: float, seed: int, box_from: float) -> Path:
    """The frozen copy of the P3M run in a box of ``box_from`` lambda_cr that a tiled run
    starts from (``tiled_p3m_job``): a copy, so that extending that run later does not
    change the state the tiled run's scenario names."""
    return runs / f"tile-source_{p3m_output(runs, case, kappa, seed, box_from).name}"


def tiled_output(runs: Path, case: str, kappa: float, seed: int, box: float) -> Path:
    """The file of the P3M run in a box of ``box`` lambda_cr started tiled
    (``tiled_p3m_job``)."""
    return runs / f"p3m-box{box:g}-tiled_{case}_kappa{kappa:g}_seed{seed}.h5"


def variant_output(runs: Path, source: str, case: str, kappa: float, seed: int,
                   kind: str = "gravity") -> Path:
    """The file of a run of the budget's variant ``source`` (``SYSTEMATIC_VARIANTS``) of
    kind ``kind`` (``VARIANT_KINDS``, or "gravity": the tree)."""
    tag = source if kind == "gravity" else f"{source}-{kind}"
    return runs / f"syst-{tag}_{case}_kappa{kappa:g}_seed{seed}.h5"


def last_orbit(run) -> float:
    """Orbits [orbits] a run has reached: its last time-series row."""
    return float(np.asarray(run.timeseries["orbits"])[-1])
