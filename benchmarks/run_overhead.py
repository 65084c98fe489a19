"""Benchmark: the run loop's overhead over a bare REBOUND integration.

Times ``ringsim.run`` (diagnostics, guards, HDF5 time series, snapshots and checkpoints at
the default output cadence) against building the very same simulation with
``ringsim.sheet.build_sheet`` (same native resolver) and integrating it straight to the end
with ``sim.integrate``.  Both use a fixed dt so they take the same steps.  The two are run
alternately in one process; the median of the per-pair ratios is printed (target: <= 1.05).

    python benchmarks/run_overhead.py [--particles 1000] [--orbits 2] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine.runner import run as ringsim_run
from ringsim.engine.sheet import build_sheet


def scenario(n_particles: int, orbits: float, collision_detection: str = "tree",
             dt="1.0e-3"):
    return scenario_from_dict({
        "name": "overhead", "seed": 1, "planet": {"Omega": 2.0e-4},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 1.0, "r_max": 3.0}},
        "sheet": {"optical_depth": 0.25, "n_particles": n_particles},
        "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1},
        "integration": {"orbits": orbits, "dt": dt if dt == "auto" else float(dt),
                        "collision_detection": collision_detection},
    }, source="<benchmark>")


def time_bare(sc) -> float:
    """Build the sheet (as ringsim run does) and integrate it to the end, nothing else."""
    t0 = time.perf_counter()
    built = build_sheet(sc)
    built.sim.integrate(sc.integration.orbits * sc.orbital_period, exact_finish_time=0)
    return time.perf_counter() - t0


def time_ringsim(sc, directory: Path) -> float:
    t0 = time.perf_counter()
    ringsim_run(sc, output=directory / "overhead.h5", force=True, progress=False)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=1000)
    parser.add_argument("--orbits", type=float, default=2.0)
    parser.add_argument("--repeat", type=int, default=3)
    # --detection: the spelling of the measurements recorded in docs/performance.md
    parser.add_argument("--collision-detection", "--detection", choices=["tree", "line"],
                        default="tree")
    parser.add_argument("--dt", default="1.0e-3", help="step in orbits, or auto")
    args = parser.parse_args()
    sc = scenario(args.particles, args.orbits, args.collision_detection, args.dt)
    ratios, bare_times, run_times = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            bare = time_bare(sc)
            full = time_ringsim(sc, Path(tmp))
            bare_times.append(bare)
            run_times.append(full)
            ratios.append(full / bare)
    print(f"scenario: {args.particles} particles, {args.orbits:g} orbits, dt = {args.dt}, "
          f"collision_detection {args.collision_detection}, "
          f"Dilley kappa = 0.1, default output cadence (time series every "
          f"{sc.output.timeseries_every:g} orbit, snapshot+checkpoint every "
          f"{sc.output.snapshot_every:g} orbits)")
    print(f"bare REBOUND + resolver: median {statistics.median(bare_times):.3f} s")
    print(f"ringsim run:             median {statistics.median(run_times):.3f} s")
    print(f"ratio ringsim run / bare (median of {args.repeat} pairs): "
          f"{statistics.median(ratios):.3f}  (target <= 1.05)")


if __name__ == "__main__":
    main()
