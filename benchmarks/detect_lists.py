"""The line detector with its neighbour list against its cells alone, on the benchmark
sheet of benchmarks/scale.py (power law 0.5-5 m, tau = 0.25, no gravity).

For each N, one sheet is built (``benchmarks/scale.yaml``), stepped twice, then stepped for
``--repeats`` rounds of ``--steps`` steps with the detector's neighbour list
(rs_sheet_detect.c Method 9, the default) and with its cells alone in turn, on 1 and on 2
threads: the same sheet in one process, so that the ratio is the figure least disturbed
by other jobs (both find the same pairs; the sheet evolves the same either way).  Time per
particle-step of the whole step (SEI, the search, the time-ordered resolution): CPU time on
one thread, wall time on two; medians of the rounds.  Each round with the list starts by
building it.  With ``--write-doc`` the table replaces the section "## Neighbour lists of
the line detector" of docs/performance.md.

Usage: python benchmarks/detect_lists.py [--sizes 10000 100000] [--steps 40]
                                         [--repeats 7] [--write-doc]
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
from ringsim.engine import detector, native
from ringsim.engine.resolver import ResolverHandle
from ringsim.engine.sheet import build_sheet
from ringsim.report import KEPT_MARKER, replace_section

SCENARIO = Path(__file__).with_name("scale.yaml")
HEADING = "## Neighbour lists of the line detector"
MARKER = f"{KEPT_MARKER}benchmarks/detect_lists.py writes; the text below is kept -->"
CELLS = 0             # detector.set_lists: the cells at every step
THREADS = (1, 2)


def measure(n: int, steps: int, repeats: int) -> dict:
    """Seconds per particle-step with the list and with the cells alone (medians) on 1
    and 2 threads, the lists built per 100 steps and the listed pairs per particle."""
    sc = with_overrides(load_scenario(SCENARIO), {"sheet.n_particles": n})
    built = build_sheet(sc)
    sim = built.sim
    assert isinstance(built.resolver, ResolverHandle), "line detection has ringsim's resolver"
    address = built.resolver.address
    sim.steps(2)
    times: dict[tuple[int, int], list[float]] = {
        (threads, lists): [] for threads in THREADS for lists in (detector.LIST_STEPS, CELLS)}
    before = detector.list_counters(address)
    for _ in range(repeats):
        for (threads, lists), found in times.items():
            native.use_threaded_sei(sim, threads)
            native.set_detector_threads(address, threads)
            detector.set_lists(address, lists)
            clock = time.process_time if threads == 1 else time.perf_counter
            t0 = clock()
            sim.steps(steps)
            found.append((clock() - t0) / steps / sim.N)
    after = detector.list_counters(address)
    listed_steps = max(after["steps"] - before["steps"], 1)
    return {"n": sim.N, "times": {key: statistics.median(v) for key, v in times.items()},
            "builds": 100.0 * (after["builds"] - before["builds"]) / listed_steps,
            "pairs": after["pairs"] / sim.N}


def table(sizes: list[int], steps: int, repeats: int) -> str:
    rows = []
    for n in sizes:
        m = measure(n, steps, repeats)
        for threads in THREADS:
            lists = m["times"][(threads, detector.LIST_STEPS)]
            cells = m["times"][(threads, CELLS)]
            rows.append(f"| {m['n']} | {threads} | {lists * 1e9:.0f} | {cells * 1e9:.0f} | "
                        f"{lists / cells:.2f} | {m['builds']:.0f} | {m['pairs']:.2f} |")
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = (f"{HEADING}\n\n`python benchmarks/detect_lists.py --sizes "
            f"{' '.join(str(n) for n in sizes)} --steps {steps} --repeats {repeats} "
            f"--write-doc`, {when}, {platform.machine()} {platform.system()}, CPU time on "
            "one thread, wall time on two, medians of the rounds (load average "
            f"{os.getloadavg()[0]:.1f} at the end).  The benchmark sheet of "
            "`benchmarks/scale.py` (0.5-5 m, tau = 0.25, no gravity), the whole step, with "
            f"the detector's neighbour list (built to last {detector.LIST_STEPS} steps) and "
            "with its cells alone in turn on the same sheet in one process.\n\n"
            "| particles | threads | list [ns per particle-step] | cells alone [ns] "
            "| list / cells | lists built per 100 steps | listed pairs per particle |\n"
            "|---|---|---|---|---|---|---|\n")
    return head + "\n".join(rows) + "\n\n" + MARKER + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", nargs="+", type=int, default=[10_000, 100_000])
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    text = table(args.sizes, args.steps, args.repeats)
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", HEADING, text, "Performance")


if __name__ == "__main__":
    main()
