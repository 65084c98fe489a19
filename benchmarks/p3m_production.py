"""Benchmark: where the CPU of a production P3M run goes (issue 12).

The runs of analysis/kappa_selfgravity.md cost 6-7 CPU us per particle-step, against
2.5 us for the whole gravitating step of benchmarks/gravity.py at N = 1e5 (docs/
performance.md, "P3M in the production runs").  This script splits the cost of a real run's
step from its checkpoint: it copies the run file to a temporary folder, resumes it there
(``Runner.start_resume``, the run's own scenario, threads and gravity), and in that one
process measures

* after ``warmup`` steps (which make the rungs and kernel tables the state needs; a
  table costs about a second, so one made among the timed steps would dominate them; the
  number made is reported), ``steps`` whole steps with P3M, with the CPU of each stage of
  the solver's force evaluation (``P3MSolver.profile``: split and layers, mass assignment,
  the FFT mesh fields, interpolation, the fine-layer mean vertical field, the short-range
  pair sum) and the splits, meshes and layer counts it used;
* the same number of steps from the same checkpoint without gravity (the callback
  removed): REBOUND's SEI, ringsim's line detection and resolver, the baseline run;
* one time-series output (``Runner._output``: particle copies, invariants, diagnostics,
  guards; the commit is made by a writer thread and is timed apart, wall clock), per
  particle-step at the run's output cadence.  An overestimate: the output sampled may fall
  on a checkpoint or snapshot, and the CPU of the writer thread is counted;

and the benchmark's own whole step (benchmarks/gravity.py's sheet: 1 m ice, tau = 0.5,
cold thin layer, Bridges law) at the same N as the reference.  CPU times are
``time.process_time`` (one thread: the runs use ``integration.threads: 1``).

    python benchmarks/p3m_production.py RUN.h5 [RUN.h5 ...] [--steps 100] [--warmup 20]
"""

from __future__ import annotations

import argparse
import ctypes
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from ringsim.engine.runner import Runner
from ringsim.engine.sheet import particle_arrays
from ringsim.gravity import p3m
from ringsim.store.runfile import open_run

#: Stages of P3MSolver.apply, in order.
STAGES = ("split and layers", "mass assignment", "mesh fields (FFT)", "interpolation",
          "mean vertical field", "pair sum")


def resumed(path: Path, folder: Path, tag: str) -> Runner:
    """A Runner resumed from a copy of the run file ``path`` made in ``folder``."""
    copy = folder / f"{tag}_{path.name}"
    shutil.copyfile(path, copy)
    runner = Runner(open_run(copy).scenario, copy, progress=False)
    runner.start_resume()
    return runner


def cpu_of_steps(sim, steps: int) -> float:
    """CPU time [s] of ``steps`` steps of ``sim`` (an error in the P3M callback raised)."""
    t0 = time.process_time()
    sim.steps(steps)
    cost = time.process_time() - t0
    p3m.raise_pending(sim)
    return cost


def table_count(solver) -> int:
    """Kernel tables made so far by all the rungs of ``solver`` (one when a layer count is
    first used on a rung, or again after the least recently used was dropped; a build
    costs about a second)."""
    return sum(mesh.tables_built for _, mesh in solver._rungs.values())


def profile_run(path: Path, steps: int, warmup: int) -> dict:
    """The split of one run's step (module docstring), per particle-step [s]."""
    from gravity import step_cost  # benchmarks/gravity.py, beside this script

    with tempfile.TemporaryDirectory() as folder:
        runner = resumed(path, Path(folder), "gravity")
        sim = runner.sim
        n = sim.N
        solver = p3m.installed_solver(sim)
        if solver is None:
            raise SystemExit(f"{path}: not a P3M run")
        meshes: list[tuple] = []    # (split, nx, ny, nz) of each timed step
        sim.steps(warmup)       # warm-up: the rungs and kernel tables the state needs
        built = table_count(solver)
        solver.profile = {}
        t0 = time.process_time()
        for _ in range(steps):
            sim.steps(1)
            par = solver.params
            meshes.append((par.split, par.nx, par.ny, int(par.nz)))
        whole = time.process_time() - t0
        p3m.raise_pending(sim)
        stages = dict(solver.profile)
        solver.profile = None
        out = {"file": path.name, "n": n, "steps": steps, "dt_orbit": sim.dt / runner.orbit,
               "tables_built": table_count(solver) - built,
               "whole": whole / (steps * n),
               "stages": {k: stages.get(k, 0.0) / (steps * n) for k in STAGES},
               "meshes": sorted(set(meshes)),
               "z_rms": float(np.std(particle_arrays(sim)["z"])),
               "steps_per_output": runner.ts_every / sim.dt}
        t0 = time.process_time()
        runner._output()
        out["output"] = (time.process_time() - t0) / (out["steps_per_output"] * n)
        runner._writes.join()
        out["commit_wall"] = runner._writes.last_cost   # this output's commit
        runner.handle.close()

        bare = resumed(path, Path(folder), "nogravity")
        bare.sim._additional_forces = ctypes.cast(None, type(bare.sim._additional_forces))
        bare.sim.steps(warmup)
        out["no_gravity"] = cpu_of_steps(bare.sim, steps) / (steps * n)
        bare.handle.close()
    out["benchmark_step"] = step_cost(n, True, "p3m") / n
    return out


def table(results: list[dict]) -> list[str]:
    """Markdown rows, CPU microseconds per particle-step."""
    head = ["run", "N", "rms z [m]", "split [m]: mesh nx x ny x layers", "tables built",
            "whole step", *STAGES, "P3M total", "no gravity (same state)", "rest", "output",
            "benchmark step, same N"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        p3m_total = sum(r["stages"].values())
        rest = r["whole"] - p3m_total - r["no_gravity"]
        meshes = ", ".join(f"{s:.2f}: {nx} x {ny} x {nz}" for s, nx, ny, nz in r["meshes"])
        cells = [r["file"], str(r["n"]), f"{r['z_rms']:.1f}", meshes, str(r["tables_built"]),
                 *(f"{1e6 * v:.2f}" for v in (r["whole"], *r["stages"].values(), p3m_total,
                                              r["no_gravity"], rest, r["output"],
                                              r["benchmark_step"]))]
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--warmup", type=int, default=20,
                        help="steps before the timed ones (rungs and kernel tables)")
    args = parser.parse_args(argv)
    results = []
    for path in args.runs:
        r = profile_run(path, args.steps, args.warmup)
        print(r, flush=True)
        results.append(r)
    print("\n".join(table(results)))


if __name__ == "__main__":
    main()
