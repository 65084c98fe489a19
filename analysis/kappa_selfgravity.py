"""Ring equilibria with kappa = 0 and kappa = 0.1 WITH self-gravity (issue 12, item 6).

For every case (size distribution x distance from Saturn x optical depth) and seed, runs
(or reuses finished runs of) ``scenarios/kappa0-gravity.yaml`` and
``scenarios/kappa0.1-gravity.yaml`` with the case's overrides, with self-gravity (REBOUND's
tree, line detection with kicked paths) and without it (the baseline: same particles, same
Omega, same box, same initial state), every run for a fixed number of orbits (``ORBITS_FOR_CASE``)
after which the equilibrium finder chooses the stationary window.  Writes
``analysis/kappa_selfgravity.md``: the equilibria, the ratio
kappa = 0.1 / kappa = 0 with and without gravity with the error budget, gravity / no
gravity for each kappa, Toomre Q, wakes and viscosities, and the measured cost of every
run; ``analysis/data/kappa_selfgravity.json`` keeps the costs.

    python analysis/kappa_selfgravity.py --cases mono-1e8-0.5 mono-1e8-0.25 --seeds 1 2 3
    python analysis/kappa_selfgravity.py --report-only
    python analysis/kappa_selfgravity.py --slab mono-1e8-0.25 --seeds 1 2 3
    python analysis/kappa_selfgravity.py --p3m powerlaw-1.3e8-0.5 --kappas 0 0.1 --seeds 1 2 3
    python analysis/kappa_selfgravity.py --p3m powerlaw-1.3e8-0.5 --kappas 0 --seeds 1 --p3m-box 4.2
    python analysis/kappa_selfgravity.py --p3m powerlaw-1.3e8-0.5 --kappas 0 --seeds 3 \
        --p3m-box 4.2 --tile-from 2.1

Box: at least ``BOX_LAMBDA`` Toomre wavelengths on a side and ``MIN_PARTICLES`` particles.
A run the finder does not call stationary is never averaged: it is listed and left out.
Functions of ``analysis/kappa_comparison.py`` are imported, not copied.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np
from kappa_comparison import run_one

from ringsim.config.scenario import load_scenario
from ringsim.physics.gravity import orbital_frequency, surface_density_from_tau, toomre_wavelength
from ringsim.store.lock import lock_path
from ringsim.store.runfile import open_run

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = {0.0: ROOT / "scenarios" / "kappa0-gravity.yaml",
             0.1: ROOT / "scenarios" / "kappa0.1-gravity.yaml"}
REPORT = ROOT / "analysis" / "kappa_selfgravity.md"
DATA = ROOT / "analysis" / "data" / "kappa_selfgravity.json"
LINE_MODE = ROOT / "analysis" / "data" / "gravity_line_mode.json"
P3M_CHECK = ROOT / "analysis" / "data" / "kappa_selfgravity_p3m_check.json"
GM_SATURN = 3.7931e16       # [m^3/s^2], as the scenarios
DENSITY = 900.0             # [kg/m^3], as the scenarios
#: Smallest box side in Toomre wavelengths (wakes need 2), and fewest particles.
BOX_LAMBDA = 2.1
MIN_PARTICLES = 600
#: Cases run with the slab solver only, in smaller boxes: case -> particles.  Their boxes
#: of 2.1 lambda_cr would hold 5886 and 19329 particles (tree: about 60 and 150 CPU-hours
#: at the lengths below).  The slab has no horizontal modes, so its field does not depend
#: on the box's size in lambda_cr; what a smaller box changes is measured by the budget's
#: n_particles part.  Such a case's box is below the 2 lambda_cr wakes need: its tree runs
#: for the ratio, if ever made, need this entry removed.  The tree kappa = 0 runs of
#: mono-1.3e8-0.5 (seeds 1 and 2, 2026-11-23) are made in the slab's box on purpose: they
#: check the solver where Q is lowest, like for like (same particles, box and length), and
#: say what the modes that fit in 1.34 lambda_cr add to the mean field.
SLAB_PARTICLES = {"mono-1.3e8-0.5": 2400, "powerlaw-1.3e8-0.5": 2400}
#: Size distributions of item 6: overrides of ``particles.size_distribution``.
SIZES = {"mono": {"kind": "monodisperse", "radius": 1.0},
         "powerlaw": {"kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}}
#: Cases: name -> (size distribution, a [m], optical depth).
CASES = {f"{size}-{a_name}-{tau:g}": (size, a, tau)
         for size in SIZES for a_name, a in (("1e8", 1.0e8), ("1.3e8", 1.3e8))
         for tau in (0.25, 0.5)}
#: Orbits of every run (fixed: the equilibrium finder chooses the window afterwards).  The
#: finder can call a run stationary inside a slow transient: the no-gravity power-law
#: kappa = 0.1 ring started isotropic at its equilibrium c (43 mm/s) overshoots to 80 mm/s
#: within 4 orbits, looks flat over orbits 2-5, and is back at 40 mm/s only after ~25
#: orbits (measured 2026-11-22); runs stopped by ``until_equilibrium`` after 3-5 orbits
#: were caught there.  So no run here stops early, and all start from the scenario's
#: initial state (gravity and no-gravity twins alike).
#: The kappa = 0.1 rings have autocorrelation times of orbits: after 30 orbits with gravity
#: (80 without) most runs had fewer than the finder's 20 effective samples, so the runs
#: were extended (--resume, bit-identical to running them whole) to 70 and 160 orbits.
#: Then longer, case by case (``ORBITS_FOR_CASE``): after 70 / 160 orbits the finder found
#: 10-20 effective samples in most runs of the monodisperse cases (autocorrelation times
#: of a few orbits in boxes of 600-740 particles), so they were extended.  A "<gravity or
#: nograv>, kappa <k>" entry sets one kappa value's runs apart: after 140 orbits 4 of the
#: 6 kappa = 0.1 gravity runs of the monodisperse cases, and after 70 all 3 of the power
#: law's, had 10-18 of the 20 effective samples (the hot ring relaxes over several
#: orbits), while the kappa = 0 runs were stationary; the power law's no-gravity runs had
#: 9-20 after 160 orbits.
#: The cases run later take the lengths of the case of their size distribution at
#: tau = 0.25, except that the no-gravity runs at tau = 0.5 are half as long: the
#: autocorrelation times are set by the collision rate (proportional to tau), not by the
#: box, and mono-1e8-0.5's no-gravity runs were stationary after 160 orbits.  Its one
#: tree run (kappa = 0, seed 1, the check of the slab in the densest ring) had 17.8 of 20
#: effective samples after 140 orbits, so it runs to 210.
#: The power law's slab runs were 140 orbits for both kappa values: after 70, 2 of 3 kappa
#: = 0 slab runs were stationary, and slab runs cost 1/20-1/40 of the tree's.
#: Every run must be stationary, so on 2026-11-23 each group (case, solver, kappa) with a
#: run the finder left out was made longer, all its seeds alike; the other groups kept
#: their lengths.  Left out were: 6 slab runs with 13-18 of the 20 effective samples (one
#: power-law run still drifting) at 140 orbits, and one at 18.4 at 280 (mono-1.3e8-0.25,
#: kappa 0.1), so those groups run 210 and 350; mono-1.3e8-0.25's tree kappa = 0 seed 3
#: (drifting, 9 samples at 140), so its group runs 280; a no-gravity run at tau = 0.5 with
#: 18.9 samples at 160 (mono-1.3e8-0.5, kappa 0) and one with 15.9 at 240
#: (powerlaw-1e8-0.5, kappa 0.1), so those run 200 and 320.  powerlaw-1.3e8-0.5, run
#: last, takes the lengths of powerlaw-1e8-0.5.  That left 4 of 103 runs out, so their
#: groups were raised again (the finder's effective samples of a run fluctuate by 10-20 %
#: between lengths): mono-1.3e8-0.25's tree kappa = 0 (18.7 at 280) to 350, its slab
#: kappa = 0 (19.9 at 210) to 280 and kappa = 0.1 (17.1 at 350) to 490, and
#: powerlaw-1e8-0.25's slab kappa = 0.1 (15.7 at 210) to 350.  A length is only ever
#: raised: ``run_one`` refuses a run longer than asked.  After that, 2 of 115 runs were
#: left out, both power-law slab kappa = 0.1: powerlaw-1e8-0.25 seed 2 (13.1 at 350) and
#: powerlaw-1.3e8-0.5 seed 2 (15.5 at 210); their groups run 490 and 280.  The tree
#: check of mono-1.3e8-0.5 (kappa = 0, seeds 1 and 2) had 17.6 effective samples in
#: seed 1 at 140 orbits, so that group runs 210, like mono-1e8-0.5's.  Its slab kappa = 0
#: runs keep the 140 orbits they were made with ("slab, kappa 0"): without that entry the
#: slab's length falls through to the "gravity, kappa 0" entry above.
#: The P3M checks of the slab (``run_p3m``) take the "gravity" lengths unless a "p3m"
#: entry is set; the P3M runs in a larger box (``--p3m-box``) take the "gravity" lengths
#: always (eight or more times the particles: a smaller error per snapshot, the same
#: autocorrelation times).  In powerlaw-1.3e8-0.5 the kappa = 0 P3M seed 3 had
#: 15.9 of the 20 effective samples after 70 orbits (2026-11-25), so that group runs 105.
#: In powerlaw-1.3e8-0.25 the kappa = 0 P3M seed 2 had 13.3 (c) and 11.0 (H) after 70
#: orbits (seeds 1 and 3: 29 and 30; 2026-11-25), so that group runs 140; its kappa = 0.1
#: P3M seed 1 had 17.0 and 17.1 after 140 (2026-11-26), so that group runs 210.  "p3m-box": the
#: P3M runs in a box of ``--p3m-box`` lambda_cr; in powerlaw-1.3e8-0.5 the kappa = 0 seed 3
#: in the 2.1 lambda_cr box had 16.5 of the 20 effective samples in H after 70 orbits
#: (2026-11-26), so that group runs 105 (seeds 1 and 2, 49 and 24 samples at 70, were run
#: to 70 on a machine since retired); at 105 seed 3 had 15.4 in c, still short, so that
#: group runs 175 (2026-11-26: 87 CPU-s per orbit on this machine).
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

#: Gravity quantities shown beside the table rows: key -> (label, unit shown).
GRAVITY_ROWS = {"toomre_Q": ("Toomre Q (from sigma_x)", ""),
                "wake_wavelength": ("wake wavelength", "m"),
                "wake_amplitude": ("wake amplitude (peak contrast)", ""),
                "gravitational_viscosity": ("gravitational viscosity", "m^2/s")}


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


def plain_sheet(kappa: float) -> dict:
    """The scenario's ``sheet`` section without self-gravity and its keys."""
    sheet = load_scenario(SCENARIOS[kappa]).to_dict()["sheet"]
    for key in ("gravity_solver", "softening", "opening_angle"):
        sheet.pop(key, None)
    sheet["gravity"] = False
    return sheet


def overrides(case: str, kappa: float, seed: int, gravity: bool, slab: bool = False,
              solver: str | None = None) -> dict:
    """Scenario overrides of one run (``slab``: a gravity run with the slab solver;
    ``solver``: a gravity run with that solver instead of the scenario's tree, at the slab's
    lengths when it is "p3m": a check of the slab like the tree's)."""
    size, a, tau = CASES[case]
    p = patch(case)
    out = {} if gravity else {"sheet": plain_sheet(kappa)}
    out.update({"seed": seed, "planet.a": a, "sheet.optical_depth": tau,
           "sheet.n_particles": p["n_particles"],
           "particles.size_distribution": SIZES[size],
           "integration.until_equilibrium": False,
           "integration.orbits": orbits(case, gravity, kappa, slab),
           "name": f"{case}-kappa{kappa:g}-{'gravity' if gravity else 'nogravity'}"})
    if slab:
        solver = "slab"
    if solver is not None:
        out.update({"sheet.gravity_solver": solver, "name": f"{case}-kappa{kappa:g}-{solver}"})
    return out


def output(runs: Path, case: str, kappa: float, seed: int, gravity: bool) -> Path:
    return runs / f"{'gravity' if gravity else 'nograv'}_{case}_kappa{kappa:g}_seed{seed}.h5"


def last_orbit(run) -> float:
    """Orbits [orbits] a run has reached: its last time-series row."""
    return float(np.asarray(run.timeseries["orbits"])[-1])


def orbits_done(path: str) -> float:
    """Orbits [orbits] a run file has reached (0 without one)."""
    return last_orbit(open_run(path)) if Path(path).exists() else 0.0


def timed(job: tuple) -> tuple[str, float, float]:
    """run_one in a worker (which also extends a finished shorter run); returns (path, CPU
    seconds of the worker, orbits the file had before)."""
    before = orbits_done(job[2])
    t0 = time.process_time()
    path, _ = run_one(job)
    return path, time.process_time() - t0, before


def run_jobs(jobs: list[tuple], workers: int, costs: dict, threads: int = 1) -> None:
    """Run ``jobs``, each on ``threads`` threads (``integration.threads``: line detection
    and P3M; no result depends on it, and a run is continued on any), and add each one's
    CPU to ``costs[file name]``: "cpu_s" and "orbits",
    the orbits that CPU covers (fewer than the run's when a part ran in a process whose
    record was lost, or before records were kept).  A job's cost is saved when it ends,
    whatever the order, so a cut-off loses only the jobs still running; it is merged into
    the file as it is then (``DATA``), so drivers running side by side keep each other's
    records."""
    jobs = [(scenario, {**changes, "integration.threads": threads}, out)
            for scenario, changes, out in jobs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for future in as_completed([pool.submit(timed, job) for job in jobs]):
            path, cpu, before = future.result()
            run = open_run(path)
            now = last_orbit(run)
            costs.update(load_costs())
            old = costs.get(Path(path).name, {})
            if now < before or before == 0.0:
                # rewritten from the start (the job asked for fewer orbits), or made anew
                # where an entry is kept for the same file made before (another machine):
                # the entry is this run's cost, not the sum of both
                old, before = {}, 0.0
            if now > before:    # else nothing ran here (a run made elsewhere keeps no entry)
                costs[Path(path).name] = {
                    "cpu_s": old.get("cpu_s", 0.0) + cpu,
                    "stop_reason": str(run.attrs.get("stop_reason", "")),
                    "orbits": old.get("orbits", 0.0) + now - before}
            save_costs(costs)


def load_costs() -> dict:
    return json.loads(DATA.read_text())["costs"] if DATA.exists() else {}


def save_costs(costs: dict) -> None:
    DATA.parent.mkdir(parents=True, exist_ok=True)
    units = {"cpu_s": "s (CPU)", "orbits": "orbits the CPU covers"}
    DATA.write_text(json.dumps({"costs": costs, "units": units}, indent=1))


def nograv_jobs(case: str, seeds, extra: dict, path_of) -> list:
    """Jobs of the no-gravity runs of ``case`` (both kappa values, ``seeds``) with the
    scenario overrides ``extra`` on top, written to ``path_of(kappa, seed)``."""
    return [(str(SCENARIOS[k]), {**overrides(case, k, s, False), **extra}, str(path_of(k, s)))
            for k in SCENARIOS for s in seeds]


def run_case(case: str, args, runs: Path, costs: dict) -> None:
    """No-gravity runs of both kappa values and every seed, then the gravity runs, all
    from the scenario's initial state (the same particles for a seed)."""
    run_jobs(nograv_jobs(case, args.seeds, {}, lambda k, s: output(runs, case, k, s, False)),
             args.workers, costs, args.threads)
    grav = gravity_jobs(case, args.seeds, {}, lambda k, s: output(runs, case, k, s, True),
                        kappas=args.kappas)
    run_jobs(grav, args.workers, costs, args.threads)


def slab_output(runs: Path, case: str, kappa: float, seed: int,
                box: float | None = None) -> Path:
    """The slab run's file; ``box``: the run in a box of that many lambda_cr."""
    tag = f"slab-box{box:g}" if box else "slab"
    return runs / f"{tag}_{case}_kappa{kappa:g}_seed{seed}.h5"


def gravity_jobs(case: str, seeds, extra: dict, path_of, slab: bool = False,
                 kappas=tuple(SCENARIOS)) -> list:
    """Jobs of the gravity runs of ``case`` (``kappas``, ``seeds``; ``slab``: with the slab
    solver) with the scenario overrides ``extra`` on top, written to
    ``path_of(kappa, seed)``."""
    return [(str(SCENARIOS[k]), {**overrides(case, k, s, True, slab), **extra},
             str(path_of(k, s))) for k in kappas for s in seeds]


def p3m_output(runs: Path, case: str, kappa: float, seed: int,
               box: float | None = None) -> Path:
    """The P3M run's file; ``box``: the run in a box of that many lambda_cr."""
    tag = f"p3m-box{box:g}" if box else "p3m"
    return runs / f"{tag}_{case}_kappa{kappa:g}_seed{seed}.h5"


def box_overrides(case: str, box: float) -> dict:
    """Overrides that put a run of ``case`` in a box of ``box`` lambda_cr (``box_particles``)
    instead of its own (``SLAB_PARTICLES``, ``patch``)."""
    return {"sheet.n_particles": box_particles(case, box)}


def p3m_jobs(case: str, kappas, seeds, runs: Path, box: float | None = None) -> list:
    """Jobs of ``run_p3m`` for one case: for each kappa and seed the P3M run and its slab
    twin (same particles, box and seed); ``box``: both in a box of that many lambda_cr
    (``box_overrides``), else in the case's own box; the P3M run at its "p3m-box" or "p3m"
    length where one is set, else at the "gravity" lengths; the slab twin at the case's slab
    lengths (``overrides``)."""
    extra = box_overrides(case, box) if box else {}
    tag = f"-box{box:g}" if box else ""
    jobs = []
    for k in kappas:
        for s in seeds:
            p3m = overrides(case, k, s, True, solver="p3m")
            p3m.update(extra, name=p3m["name"] + tag,
                       **{"integration.orbits": p3m_orbits(case, k, box)})
            slab = overrides(case, k, s, True, slab=True)
            slab.update(extra, name=slab["name"] + tag)
            jobs += [(str(SCENARIOS[k]), p3m, str(p3m_output(runs, case, k, s, box))),
                     (str(SCENARIOS[k]), slab, str(slab_output(runs, case, k, s, box)))]
    return jobs


def tile_source(runs: Path, case: str, kappa: float, seed: int, box_from: float) -> Path:
    """The frozen copy of the P3M run in a box of ``box_from`` lambda_cr that a tiled run
    starts from (``tiled_p3m_job``): a copy, so that extending that run later does not
    change the state the tiled run's scenario names."""
    return runs / f"tile-source_{p3m_output(runs, case, kappa, seed, box_from).name}"


def tiled_output(runs: Path, case: str, kappa: float, seed: int, box: float) -> Path:
    """The file of the P3M run in a box of ``box`` lambda_cr started tiled
    (``tiled_p3m_job``)."""
    return runs / f"p3m-box{box:g}-tiled_{case}_kappa{kappa:g}_seed{seed}.h5"


def tiled_p3m_job(case: str, kappa: float, seed: int, runs: Path, box: float,
                  box_from: float) -> tuple:
    """The P3M run of ``case`` in a box of ``box`` lambda_cr that starts from the last
    snapshot of its run (same kappa and seed) in a box of ``box_from`` lambda_cr, repeated
    box / box_from times in x and in y (``sheet.initial_state.tile``, the sheet's own
    shear-periodic images): a box too dear to run through its transient starts from the
    smaller box's equilibrium, and the equilibrium finder says when the larger box's own
    has set in.  Length: the case's "p3m-tiled" entry.  No slab twin (the slab's field does
    not depend on the box's size, docs/gravity.md 4c).  The smaller run is copied once
    (``tile_source``), when it is not running."""
    import shutil

    tile = box / box_from
    if abs(tile - round(tile)) > 1e-9 or round(tile) < 2:
        raise SystemExit(f"--p3m-box {box:g} is not a multiple (2 or more) of --tile-from "
                         f"{box_from:g}")
    source = tile_source(runs, case, kappa, seed, box_from)
    if not source.exists():
        original = p3m_output(runs, case, kappa, seed, box_from)
        if not original.exists() or lock_path(original).exists():
            raise SystemExit(f"{original} is missing or running: the tiled run needs it "
                             "finished or stopped")
        shutil.copyfile(original, source)
    # the P3M run's overrides, the sheet's keys replaced by a sheet from the file (which
    # gives the particles and the box)
    p3m = {key: value for key, value in overrides(case, kappa, seed, True, solver="p3m").items()
           if not key.startswith("sheet.")}
    p3m.update({"sheet": {"gravity": True, "gravity_solver": "p3m", "softening": "auto",
                          "p3m_split": "auto", "z_box": "auto",
                          "initial_state": {"file": str(source), "snapshot": -1,
                                            "tile": [round(tile), round(tile)]}},
                "integration.orbits": p3m_orbits(case, kappa, box, tiled=True),
                "name": f"{p3m['name']}-box{box:g}-tiled"})
    return (str(SCENARIOS[kappa]), p3m, str(tiled_output(runs, case, kappa, seed, box)))


def run_p3m(cases: list[str], args, runs: Path, costs: dict) -> None:
    """The check of the slab by a solver of the full field where the tree is too dear: the
    gravity runs of ``cases`` (``args.kappas``, ``args.seeds``) with P3M (every mode the box
    holds, docs/gravity.md 4b), and the slab runs of the same seeds: same particles, box
    and lengths (the "gravity" lengths of the case).  Writes ``P3M_CHECK`` (per seed and
    mean: c and H with each solver and slab / P3M) instead of the report, whose other
    runs this does not touch.
    ``args.p3m_box``: both runs in a box of that many lambda_cr instead of the case's own
    (``SLAB_PARTICLES``), which can be too small for wakes (``p3m_jobs``)."""
    from kappa_selfgravity_p3m import write_p3m_check

    box = getattr(args, "p3m_box", None)
    box_from = getattr(args, "tile_from", None)
    if box_from:
        jobs = [tiled_p3m_job(case, k, s, runs, box, box_from)
                for case in cases for k in args.kappas for s in args.seeds]
        run_jobs(jobs, args.workers, costs, args.threads)
        write_p3m_check(cases, args, runs)
        return
    jobs = [job for case in cases for job in p3m_jobs(case, args.kappas, args.seeds, runs, box)]
    jobs.sort(key=job_cost, reverse=True)
    run_jobs(jobs, args.workers, costs, args.threads)
    write_p3m_check(cases, args, runs)


def run_slab(cases: list[str], args, runs: Path, costs: dict) -> None:
    """The gravity runs of ``cases`` with ``sheet.gravity_solver: slab`` (the averaged
    layer's vertical field only, docs/gravity.md 4c), and their no-gravity twins: same
    particles, box and lengths as the tree runs, so the report can say how much of
    gravity's effect the mean field alone gives, and give the ratio with the mean field
    where the tree is too dear.  All jobs share one pool, the dearest first."""
    jobs = []
    for case in cases:
        jobs += nograv_jobs(case, args.seeds, {},
                            lambda k, s, case=case: output(runs, case, k, s, False))
        jobs += gravity_jobs(case, args.seeds, {},
                             lambda k, s, case=case: slab_output(runs, case, k, s), slab=True)
    jobs.sort(key=job_cost, reverse=True)
    run_jobs(jobs, args.workers, costs, args.threads)


#: Method variants of the systematic budget (``--systematics CASE``): source -> overrides
#: of the runs ("n_particles": twice the case's particles, a box sqrt(2) times as wide;
#: "dt": the step halved).
SYSTEMATIC_VARIANTS = {"dt": {"integration.dt": 5e-4}, "n_particles": {}}
#: Kinds of run a variant repeats: "nograv" (no self-gravity), "slab" (the slab solver)
#: and "gravity" (the tree: its dt variant of mono-1e8-0.25, seed 1, 70 orbits, was run
#: before the budget moved to the slab, which costs 20-40 times less).
VARIANT_KINDS = ("nograv", "slab")


def variant_output(runs: Path, source: str, case: str, kappa: float, seed: int,
                   kind: str = "gravity") -> Path:
    tag = source if kind == "gravity" else f"{source}-{kind}"
    return runs / f"syst-{tag}_{case}_kappa{kappa:g}_seed{seed}.h5"


def run_systematics(case: str, args, runs: Path, costs: dict) -> None:
    """The no-gravity and slab runs of ``case`` again with each method variant (seeds
    ``args.seeds``), and the budget file of the case's size distribution: the relative
    change of each ratio per source, or its statistical error if larger (as
    analysis/kappa_comparison.py)."""
    from kappa_selfgravity_report import write_budget

    jobs = []
    for source, extra in SYSTEMATIC_VARIANTS.items():
        if source not in args.variants:
            continue
        if source == "n_particles":
            extra = {**extra, "sheet.n_particles": 2 * patch(case)["n_particles"]}
        for kind in VARIANT_KINDS:
            def path_of(k, s, source=source, kind=kind):
                return variant_output(runs, source, case, k, s, kind)
            jobs += (nograv_jobs(case, args.seeds, extra, path_of) if kind == "nograv"
                     else gravity_jobs(case, args.seeds, extra, path_of, slab=True))
    jobs.sort(key=job_cost, reverse=True)
    run_jobs(jobs, args.workers, costs, args.threads)
    write_budget(case, args, runs)


#: CPU per particle-orbit of a run with each solver over the slab's, from the records of
#: analysis/data/kappa_selfgravity.json (powerlaw-1.3e8-0.5, kappa = 0, same particles and
#: box): P3M 15 (13.9 / 0.9 CPU-s per orbit with 2400 particles, 130 / 9.1 with 19329),
#: the tree 57 (51.4 / 0.9).  A no-gravity run is counted as a slab run (the slab adds
#: one vertical field per step).
SOLVER_COST = {"slab": 1.0, "p3m": 15.0, "tree": 57.0}


def job_solver(job: tuple) -> str:
    """The solver of a job's run: "slab" for a no-gravity run (see ``SOLVER_COST``), else
    its ``sheet.gravity_solver``, the scenario's tree where the job sets none."""
    o = job[1]
    return "slab" if "sheet" in o else o.get("sheet.gravity_solver", "tree")


def job_cost(job: tuple) -> float:
    """Relative cost of a job, to start the dearest first: particles x orbits x the
    solver's ``SOLVER_COST``, kappa = 0.1 counted twice (its hot ring collides more
    often)."""
    return (job[1]["sheet.n_particles"] * job[1]["integration.orbits"]
            * SOLVER_COST[job_solver(job)]
            * (2.0 if job[0] == str(SCENARIOS[0.1]) else 1.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1,
                        help="threads of each run (line detection, P3M; results do not "
                        "depend on it): 1 when --workers fill the cores, more for one run "
                        "on an idle machine")
    parser.add_argument("--kappas", type=float, nargs="+", default=list(SCENARIOS),
                        choices=list(SCENARIOS),
                        help="the kappa values of the (tree) gravity runs of --cases")
    parser.add_argument("--runs", default=str(ROOT / "runs" / "kappa_selfgravity"))
    parser.add_argument("--report-only", action="store_true",
                        help="only rewrite the report from the runs that exist")
    parser.add_argument("--report", default=str(REPORT))
    parser.add_argument("--systematics", choices=list(CASES),
                        help="run the method variants of this case (seeds --seeds) and write "
                        "the budget against its runs of --base-seeds")
    parser.add_argument("--slab", nargs="+", choices=list(CASES), default=[],
                        help="run the gravity runs of these cases with the slab solver, and "
                        "their no-gravity twins (seeds --seeds)")
    parser.add_argument("--p3m", nargs="+", choices=list(CASES), default=[],
                        help="check the slab runs of these cases against P3M (seeds "
                        "--seeds, kappa values --kappas); writes P3M_CHECK, not the report")
    parser.add_argument("--p3m-box", type=float, nargs="?", const=BOX_LAMBDA, default=None,
                        metavar="LAMBDA_CR",
                        help=f"with --p3m: both solvers' runs in a square box of LAMBDA_CR "
                        f"(default {BOX_LAMBDA:g}) Toomre wavelengths, one that can hold "
                        "wakes, instead of the case's own")
    parser.add_argument("--tile-from", type=float, default=None, metavar="LAMBDA_CR",
                        help="with --p3m and --p3m-box: start the P3M runs from their runs "
                        "in a box of LAMBDA_CR, repeated to fill the --p3m-box box "
                        "(tiled_p3m_job); no slab twins; the check file's row is the "
                        "--p3m-box one")
    parser.add_argument("--base-seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--variants", nargs="+", default=list(SYSTEMATIC_VARIANTS),
                        choices=list(SYSTEMATIC_VARIANTS), help="sources of --systematics")
    args = parser.parse_args()
    if args.tile_from and not (args.p3m and args.p3m_box):
        parser.error("--tile-from needs --p3m and --p3m-box")
    runs = Path(args.runs)
    runs.mkdir(parents=True, exist_ok=True)
    costs = load_costs()
    if args.systematics:
        run_systematics(args.systematics, args, runs, costs)
    elif args.slab:
        run_slab(args.slab, args, runs, costs)
    elif args.p3m:
        run_p3m(args.p3m, args, runs, costs)
        return
    elif not args.report_only:
        for case in args.cases:
            run_case(case, args, runs, costs)
    from kappa_selfgravity_report import write_report

    write_report(args, runs, costs)


if __name__ == "__main__":
    main()
