"""The line detector with a grid per reach class against its one grid, on the benchmark
sheet of benchmarks/scale.py (power law 0.5-5 m, tau = 0.25, no gravity).

For each N, one sheet is built (``benchmarks/scale.yaml``), stepped twice, then stepped for
``--repeats`` rounds of ``--steps`` steps with the detector's grid per reach class
(rs_sheet_detect.c Method 2a, the default) and with its one grid in turn: the same sheet
in one process, so that the ratio is the figure least disturbed by other jobs (both
searches find the same pairs; the sheet evolves the same either way).  CPU time per
particle-step of the whole step (REBOUND's SEI, the search, the time-ordered resolution),
median of the rounds, on ``--threads`` threads (wall time with more than one).  With
``--write-doc`` the table replaces the section "## Reach classes of the line detector" of
docs/performance.md.

Usage: python benchmarks/detect_classes.py [--sizes 10000 100000] [--steps 20]
                                           [--repeats 5] [--threads 1] [--write-doc]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from datetime import datetime, timezone
from pathlib import Path

from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.engine import detector
from ringsim.engine.sheet import build_sheet
from ringsim.report import replace_section

SCENARIO = Path(__file__).with_name("scale.yaml")
HEADING = "## Reach classes of the line detector"
ONE_GRID = 1          # detector.set_classes: all particles in one grid


def measure(n: int, steps: int, repeats: int, threads: int) -> dict:
    """Seconds per particle-step with classes and with one grid (medians), the classes
    the search used, N."""
    sc = with_overrides(load_scenario(SCENARIO), {"sheet.n_particles": n,
                                                  "integration.threads": threads})
    built = build_sheet(sc)
    sim = built.sim
    sim.steps(2)
    clock = time.process_time if threads == 1 else time.perf_counter
    times: dict[int, list[float]] = {detector.MAX_CLASSES: [], ONE_GRID: []}
    used = 0
    for _ in range(repeats):
        for classes, found in times.items():
            detector.set_classes(built.resolver.address, classes)
            t0 = clock()
            sim.steps(steps)
            found.append((clock() - t0) / steps / sim.N)
            if classes != ONE_GRID:
                used = built.resolver.detector_stats()["classes"]
    return {"n": sim.N, "classes": statistics.median(times[detector.MAX_CLASSES]),
            "one_grid": statistics.median(times[ONE_GRID]), "used": used}


def table(sizes: list[int], steps: int, repeats: int, threads: int) -> str:
    rows = []
    for n in sizes:
        m = measure(n, steps, repeats, threads)
        rows.append(f"| {m['n']} | {m['used']} | {m['classes'] * 1e9:.0f} | "
                    f"{m['one_grid'] * 1e9:.0f} | {m['classes'] / m['one_grid']:.2f} |")
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    clock = "CPU time" if threads == 1 else "wall time"
    head = (f"{HEADING}\n\n`python benchmarks/detect_classes.py --steps {steps} --repeats "
            f"{repeats} --threads {threads} --write-doc`, {when}, {platform.machine()} "
            f"{platform.system()}, {threads} thread(s), {clock}, median of {repeats} rounds "
            f"(load average {os.getloadavg()[0]:.1f} at the end).  The benchmark sheet of "
            "`benchmarks/scale.py` (0.5-5 m, tau = 0.25, no gravity), the whole step, with "
            "the detector's grid per reach class and with its one grid in turn on the same "
            "sheet in one process.\n\n"
            "| particles | classes used | classes [ns per particle-step] | one grid [ns] "
            "| classes / one grid |\n|---|---|---|---|---|\n")
    return head + "\n".join(rows) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", nargs="+", type=int, default=[10_000, 100_000])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    text = table(args.sizes, args.steps, args.repeats, args.threads)
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", HEADING, text, "Performance")


if __name__ == "__main__":
    main()
