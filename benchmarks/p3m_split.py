"""Benchmark: P3M's split scale in thin and thick rings (``sheet.p3m_split``, issue 12).

Two measurements, each printed as a Markdown table for docs/performance.md ("P3M in
thick rings"):

* ``force``: one force evaluation of a random sheet (``testing.random_sheet``, 1 m
  ice at tau = 0.5, Omega = 1.95e-4 1/s) with the Gaussian scale height given, for fixed
  splits and for ``auto``: CPU milliseconds per evaluation (median of 5, after a warm-up
  that builds the kernel tables), rms and median relative error against the direct
  shear-periodic sum (300 targets, 4 rows of images), and the mesh.
* ``run``: integration steps of a scenario (default the hot kappa = 0.1 gravity scenario,
  scenarios/kappa0.1-gravity.yaml, 1200 particles with H ~ 120 m) with the tree, P3M at a
  fixed split and P3M with ``auto``, each in a fresh process: CPU milliseconds per step,
  the distinct layer counts and kernel tables the solver used, and the process's peak
  resident set.  The tree's row is the baseline: the ratio column is CPU per step over
  the tree's.

    python benchmarks/p3m_split.py force --n 1200 --height 120 --splits 3 4.5 6 auto
    python benchmarks/p3m_split.py run --steps 300
"""

from __future__ import annotations

import argparse
import ctypes
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "kappa0.1-gravity.yaml"
OMEGA = 1.95e-4             # [1/s] at 1e8 m from Saturn
T_SNAPSHOT = 0.37           # [orbits] a non-trivial shear offset
#: Solver settings of ``run``: label -> scenario overrides.
SETTINGS = {"tree": {"sheet.gravity_solver": "tree"},
            "p3m, split 3 m": {"sheet.gravity_solver": "p3m", "sheet.p3m_split": 3.0},
            "p3m, auto": {"sheet.gravity_solver": "p3m", "sheet.p3m_split": "auto"}}


def force_table(n: int, height: float, splits: list[str]) -> list[str]:
    """Markdown rows: cost and error of one force evaluation per split."""
    import rebound

    from ringsim import testing
    from ringsim.gravity import p3m
    from ringsim.physics import selfgravity as sg

    s = testing.random_sheet(n, optical_depth=0.5, Omega=OMEGA, dispersion=height * OMEGA, seed=11)
    rng = np.random.default_rng(0)
    targets = np.sort(rng.choice(n, min(n, 300), replace=False))
    t = T_SNAPSHOT * 2.0 * np.pi / OMEGA
    shift = sg.shear_offset(OMEGA, s["Lx"], s["Ly"], t)
    ref = sg.direct_accelerations(s["pos"], s["mass"], s["Lx"], s["Ly"], shift, 0.1,
                                  n_rows=4, targets=targets, chunk=16)
    rows = [f"N = {n}, box {s['Lx']:.1f} m, rms z {np.std(s['pos'][:, 2]):.1f} m, "
            f"z span {np.ptp(s['pos'][:, 2]):.0f} m", "",
            "| split [m] | CPU per evaluation [ms] | per particle [us] | rms error | "
            "median error | mesh nx x ny x nz |", "|---|---|---|---|---|---|"]
    for split in splits:
        auto = split == "auto"
        sim = testing.p3m_simulation(s, t=t, split=None if auto else float(split), auto=auto)

        def evaluate(sim=sim):
            rebound.clibrebound.reb_simulation_update_acceleration(ctypes.byref(sim))
        evaluate()
        times = []
        for _ in range(5):
            t0 = time.process_time()
            evaluate()
            times.append(time.process_time() - t0)
        err = testing.force_errors(testing.accelerations(sim)[targets], ref)
        par = p3m.installed_solver(sim).params
        label = f"auto ({par.split:.2f})" if auto else f"{float(split):g}"
        cost = float(np.median(times))
        rows.append(f"| {label} | {cost * 1e3:.2f} | {cost / n * 1e6:.2f} | "
                    f"{err['rms_relative']:.4f} | {err['median_relative']:.4f} | "
                    f"{par.nx} x {par.ny} x {par.nz} |")
    return rows


def one_run(label: str, steps: int, scenario: str) -> dict:
    """``steps`` steps of ``scenario`` with the solver setting ``label`` (this process)."""
    from ringsim.config.scenario import load_scenario, with_overrides
    from ringsim.engine.sheet import build_sheet
    from ringsim.gravity import p3m

    sc = with_overrides(load_scenario(scenario), {**SETTINGS[label],
                                                  "integration.until_equilibrium": False})
    sim = build_sheet(sc).sim
    solver = p3m.installed_solver(sim)
    layers, splits = set(), set()
    if solver is not None:
        apply = solver.apply

        def counted(address):
            apply(address)
            layers.add(solver.params.nz)
            splits.add(round(solver.params.split, 3))
        solver.apply = counted
    t0 = time.process_time()
    sim.steps(steps)
    cpu = time.process_time() - t0
    if solver is not None:
        p3m.raise_pending(sim)
    return {"label": label, "ms_per_step": cpu / steps * 1e3, "layers": sorted(layers),
            "splits": sorted(splits),
            "tables": (sum(len(m._tables) for _, m in solver._rungs.values())
                       if solver is not None else 0),
            "peak_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def run_table(steps: int, scenario: str) -> list[str]:
    """Markdown rows of ``one_run`` for every setting, each in a fresh process."""
    results = []
    for label in SETTINGS:
        out = subprocess.run([sys.executable, __file__, "one", label, "--steps", str(steps),
                              "--scenario", scenario], capture_output=True, text=True,
                             check=True)
        results.append(json.loads(out.stdout.strip().splitlines()[-1]))
    base = results[0]["ms_per_step"]
    rows = [f"{scenario}, {steps} steps from its initial state", "",
            "| solver | CPU per step [ms] | / tree | splits used [m] | layer counts used | "
            "kernel tables | peak memory [MB] |", "|---|---|---|---|---|---|---|"]
    for r in results:
        layers = (f"{len(r['layers'])} ({r['layers'][0]}-{r['layers'][-1]})" if r["layers"]
                  else "-")
        rows.append(f"| {r['label']} | {r['ms_per_step']:.1f} | {r['ms_per_step'] / base:.2f} "
                    f"| {', '.join(f'{s:g}' for s in r['splits']) or '-'} | {layers} | "
                    f"{r['tables']} | {r['peak_MB']:.0f} |")
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="what", required=True)
    force = sub.add_parser("force")
    force.add_argument("--n", type=int, default=1200)
    force.add_argument("--height", type=float, default=120.0, help="scale height [m]")
    force.add_argument("--splits", nargs="+", default=["3", "4.5", "6", "auto"])
    run = sub.add_parser("run")
    run.add_argument("--steps", type=int, default=300)
    run.add_argument("--scenario", default=str(SCENARIO))
    one = sub.add_parser("one")
    one.add_argument("label", choices=list(SETTINGS))
    one.add_argument("--steps", type=int, default=300)
    one.add_argument("--scenario", default=str(SCENARIO))
    args = parser.parse_args(argv)
    if args.what == "force":
        print("\n".join(force_table(args.n, args.height, args.splits)))
    elif args.what == "run":
        print("\n".join(run_table(args.steps, args.scenario)))
    else:
        print(json.dumps(one_run(args.label, args.steps, args.scenario)))


if __name__ == "__main__":
    main()
