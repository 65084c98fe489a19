"""The SEI step on threads: REBOUND's own ``sei`` against ringsim's threaded ``ringsim_sei``.

One sheet (line detection, no gravity, power law 0.5-5 m, q = 3, tau = 0.25, Bridges law,
dt = 1e-3 orbit) of ``--n`` particles is stepped in one process with each integrator on 1
and 2 threads in turn (the detector's threads set alike), ``--steps`` steps a repeat; wall
time per particle-step, median of the repeats.  Both integrators give the same bits
(tests/test_sei.py); the difference is the drift and kick loops and, with REBOUND's gravity
off, the loop that sets every acceleration to zero, all serial in REBOUND's pip wheel.
With ``--write-doc`` the table replaces the section "## The SEI step on threads" of
docs/performance.md.

Usage: python benchmarks/sei_threads.py [--n 100000] [--steps 20] [--repeats 5] [--write-doc]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from datetime import datetime, timezone

import numpy as np

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine import native
from ringsim.engine.sheet import build_sheet
from ringsim.report import replace_section

CASES = (("REBOUND sei", "sei", 1), ("REBOUND sei", "sei", 2),
         ("ringsim_sei", native.THREADED_SEI, 1), ("ringsim_sei", native.THREADED_SEI, 2))


def measure(n: int, steps: int, repeats: int) -> dict[tuple[str, int], float]:
    """Median wall time [s] per particle-step of each (integrator, threads)."""
    sc = scenario_from_dict({
        "name": "sei-threads", "seed": 1, "planet": {"Omega": 2e-4},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}},
        "sheet": {"optical_depth": 0.25, "n_particles": n},
        "restitution": {"model": "bridges"},
        "integration": {"dt": 1e-3, "collision_detection": "line"}},
        source="benchmarks/sei_threads.py")
    built = build_sheet(sc)
    sim = built.sim
    sim.steps(5)
    times: dict[tuple[str, int], list[float]] = {}
    for _ in range(repeats):
        for label, integrator, threads in CASES:
            if integrator == "sei":
                sim.integrator = "sei"
            else:
                native.use_threaded_sei(sim, threads)
            native.set_detector_threads(built.resolver.address, threads)
            t0 = time.perf_counter()
            sim.steps(steps)
            times.setdefault((label, threads), []).append(
                (time.perf_counter() - t0) / steps / n)
    return {key: float(np.median(values)) for key, values in times.items()}


#: Core counts at which the serial fraction's speed-up is stated.
CORES = (16, 64)


def serial_fraction(ratio: float) -> float:
    """Amdahl's serial fraction s from the time on 2 threads over the time on 1:
    ratio = s + (1 - s) / 2, so s = 2 ratio - 1 (an upper bound: thread overheads and the
    memory bandwidth two threads share count as serial)."""
    return 2.0 * ratio - 1.0


def speedup(s: float, cores: int) -> float:
    """Amdahl's speed-up on ``cores`` of a step whose serial fraction is ``s``."""
    return 1.0 / (s + (1.0 - s) / cores)


def table(n: int, steps: int, repeats: int) -> str:
    t = measure(n, steps, repeats)
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    rows = []
    for label in ("REBOUND sei", "ringsim_sei"):
        ratio = t[(label, 2)] / t[(label, 1)]
        s = serial_fraction(ratio)
        rows.append(f"| {label} | {t[(label, 1)] * 1e9:.0f} | {t[(label, 2)] * 1e9:.0f} | "
                    f"{ratio:.2f} | {s:.2f} | "
                    + " / ".join(f"{speedup(s, c):.1f}" for c in CORES) + " |")
    return (f"## The SEI step on threads\n\n`python benchmarks/sei_threads.py --n {n} "
            f"--steps {steps} --repeats {repeats} --write-doc`, {when}, {platform.machine()} "
            f"{platform.system()}, {os.cpu_count()} cores, load average "
            f"{os.getloadavg()[0]:.1f}: the same sheet in one process, each integrator on "
            "1 and 2 threads in turn (the line detector's threads alike), wall time, median "
            "of the repeats.  The serial fraction s is Amdahl's, from the two: 2 / 1 threads "
            "= s + (1 - s) / 2 (an upper bound: thread overheads and the memory bandwidth the "
            "threads share count as serial), and the speed-up it implies on "
            + " and ".join(str(c) for c in CORES) + " cores is 1 / (s + (1 - s) / cores).  "
            "ringsim_sei threads the drift, the kick and, with REBOUND's gravity off (ringsim's "
            "solvers are additional forces), the zeroing of the accelerations; serial in both "
            "stay REBOUND's boundary check (a pass over every particle) and the detector's "
            "time-ordered resolution of the contacts."
            "\n\n| integrator | 1 thread [ns per particle-step] | 2 threads [ns] | 2 / 1 "
            "threads | serial fraction s | speed-up on " + " / ".join(str(c) for c in CORES)
            + " cores |\n|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=100000)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    text = table(args.n, args.steps, args.repeats)
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", "## The SEI step on threads", text,
                        "Performance")


if __name__ == "__main__":
    main()
