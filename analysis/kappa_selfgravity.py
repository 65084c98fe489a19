"""Ring equilibria with kappa = 0 and kappa = 0.1 WITH self-gravity: the campaign's driver.

For every case (size distribution x distance from Saturn x optical depth,
``kappa_selfgravity_cases``) and seed, runs (or reuses finished runs of)
``scenarios/kappa0-gravity.yaml`` and ``scenarios/kappa0.1-gravity.yaml`` with the case's
overrides, with self-gravity (REBOUND's tree, line detection with kicked paths) and without
it (the baseline: same particles, same Omega, same box, same initial state), every run for
a fixed number of orbits (``kappa_selfgravity_cases.ORBITS_FOR_CASE``) after which the
equilibrium finder chooses the stationary window.  Writes ``analysis/kappa_selfgravity.md``
(``kappa_selfgravity_report``): the equilibria, the ratio kappa = 0.1 / kappa = 0 with and
without gravity with the error budget, gravity / no gravity for each kappa, Toomre Q, wakes
and viscosities, and the measured cost of every run; ``analysis/data/kappa_selfgravity.json``
keeps the costs.

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
import shutil
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from kappa_comparison import run_one
from kappa_selfgravity_cases import (
    BOX_LAMBDA,
    CASES,
    REPORT,
    ROOT,
    SCENARIOS,
    SIZES,
    SYSTEMATIC_VARIANTS,
    VARIANT_KINDS,
    box_particles,
    last_orbit,
    orbits,
    output,
    p3m_orbits,
    p3m_output,
    patch,
    slab_output,
    tile_source,
    tiled_output,
    variant_output,
)
from kappa_selfgravity_p3m import write_p3m_check
from kappa_selfgravity_ratios import write_budget
from kappa_selfgravity_report import write_report

from ringsim.config.scenario import load_scenario
from ringsim.store.lock import lock_path
from ringsim.store.runfile import open_run

#: The recorded CPU of every run (``run_jobs``).
DATA = ROOT / "analysis" / "data" / "kappa_selfgravity.json"


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


def gravity_jobs(case: str, seeds, extra: dict, path_of, slab: bool = False,
                 kappas=tuple(SCENARIOS)) -> list:
    """Jobs of the gravity runs of ``case`` (``kappas``, ``seeds``; ``slab``: with the slab
    solver) with the scenario overrides ``extra`` on top, written to
    ``path_of(kappa, seed)``."""
    return [(str(SCENARIOS[k]), {**overrides(case, k, s, True, slab), **extra},
             str(path_of(k, s))) for k in kappas for s in seeds]


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


def run_systematics(case: str, args, runs: Path, costs: dict) -> None:
    """The no-gravity and slab runs of ``case`` again with each method variant (seeds
    ``args.seeds``), and the budget file of the case's size distribution: the relative
    change of each ratio per source, or its statistical error if larger (as
    analysis/kappa_comparison.py)."""
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


#: CPU per particle-orbit of a run with each solver over the slab's, measured in the
#: campaign's runs of the same particles and box (analysis/kappa_selfgravity.md, "Run lengths
#: and boxes"); a no-gravity run counts as a slab run (the slab adds one vertical field per
#: step).
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
    write_report(args, runs, costs)


if __name__ == "__main__":
    main()
