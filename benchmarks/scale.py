"""Benchmark: one sheet from 1e3 to 1e6 particles: cost, memory, set-up, snapshots.

For each N (one fresh process per N, so that its peak memory is its own):

* **set-up** [s]: ``ringsim.engine.sheet.build_sheet`` of benchmarks/scale.yaml (line
  mode, no gravity, power law 0.5-5 m, tau = 0.25, Bridges et al. 1984);
* **snapshot write** [s]: one snapshot of the N particles through
  ``ringsim.store.runfile.RunFileWriter.commit`` into a new run file, and the file's size;
* **whole run loop** [ns per particle-step]: ``runner.Runner.loop`` (integration, time-series
  outputs every 0.1 orbit with their diagnostics, invariants, guards and HDF5 rows, the
  final checkpoint) from the built sheet, with ``integration.threads`` 1 and 2 alternately
  on copies of the same state, ``--repeat`` times; wall and CPU time; the ratio 2 threads /
  1 thread per pair (same process, same state: the figure least disturbed by other jobs);
* **REBOUND's own step** [ns per particle-step], N <= 1e5: its tree collision search and
  its SEI step without collisions, on the same sheet in the same process (the baseline);
* **memory** [bytes per particle]: the process's peak resident set after all of the above,
  less its resident set before the set-up (after a warm-up run of 200 particles has
  imported and allocated what any run needs), over N.

Medians of the repeats; with ``--passes K`` the sizes are measured K times in turn and
pooled, and the flatness and the 1e5 cost are also given per pass.  Targets:
<= 300 ns per particle-step at 1e5 on one thread, flat within 1.5x from 1e3 to 1e6;
2 threads <= 0.6x of one; <= 1 kB per particle; set-up of 1e6 <= 10 s.

    python benchmarks/scale.py [--quick] [--sizes 1000 ...] [--repeat 3] [--passes 1]
                               [--write-doc]

``--quick``: N = 1e3, 1e4, 1e5.  ``--write-doc`` replaces the section "Scale" of
docs/performance.md and draws docs/figures/scale.png.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = Path(__file__).with_name("scale.yaml")
DOC = ROOT / "docs" / "performance.md"
FIGURE = ROOT / "docs" / "figures" / "scale.png"
RESULTS = ROOT / "docs" / "figures" / "scale.json"     # what the figure shows
HEADING = "## Scale"
#: Ends the part of the section this script writes; the hand-written text after it (what
#: the figures show, the subsections) is kept by ``--write-doc``.
MARKER = "<!-- end of the part benchmarks/scale.py writes; the text below is kept -->"
SIZES = (1_000, 10_000, 100_000, 1_000_000)
QUICK_SIZES = (1_000, 10_000, 100_000)
#: Targets of the run loop at scale [ns per particle-step; ratios; bytes per particle].
TARGET_NS = 300.0
TARGET_FLATNESS = 1.5
TARGET_THREAD_RATIO = 0.6
TARGET_BYTES = 1000.0
#: Particles of the warm-up run before the memory baseline is taken.
WARM_UP_PARTICLES = 200
#: Baseline drawn in the figure [ns per particle-step]: the whole run loop on one thread
#: before it was made to scale (docs/performance.md, "Scale").
BEFORE_NS = {1_000: 540.0, 10_000: 600.0, 100_000: 1000.0}


def steps_for(n: int) -> int:
    """Steps of one timed loop: about 1e7 particle-steps (a few seconds), at least one
    output interval (100 steps of 1e-3 orbit) and at most 30 of them."""
    return int(min(3000, max(100, round(1e7 / n / 100) * 100)))


def _rss_bytes() -> int:
    """Current resident set [bytes] (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _peak_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024   # kB on Linux


def _copy_of(built, scenario):
    """A sheet with a copy of ``built``'s simulation and a resolver of its own."""
    from ringsim.engine.resolver import install_resolver
    from ringsim.engine.sheet import BuiltSheet

    sim = built.sim.copy()
    handle = install_resolver(sim, scenario.restitution_dict(), scenario.friction_dict(),
                              scenario.particles.inertia_factor,
                              log_capacity=scenario.output.log_collisions,
                              collision_detection="line")
    return BuiltSheet(sim, built.geometry, built.radii, built.masses, built.size_bin_edges,
                      handle)


def _snapshot_write(built, scenario, directory: Path) -> tuple[float, int]:
    """Wall time [s] of one snapshot commit of all particles, and the size [bytes] of the
    file and its part files."""
    from ringsim.engine.sheet import particle_arrays
    from ringsim.store.bulk import parts_folder
    from ringsim.store.runfile import RunFileWriter

    path = directory / "snapshot.h5"
    writer = RunFileWriter(path)
    writer.create(scenario_yaml=scenario.yaml_text, seed=scenario.seed, attributes={},
                  size_bin_edges=None, histogram_edges={})
    arrays = particle_arrays(built.sim)
    start = time.perf_counter()
    writer.commit(snapshot=(0, built.sim.t, arrays))
    seconds = time.perf_counter() - start
    parts = parts_folder(path)   # a large snapshot is in a part file beside the run file
    size = path.stat().st_size + (sum(f.stat().st_size for f in parts.iterdir())
                                  if parts.is_dir() else 0)
    return seconds, size


def _timed_loop(built, scenario, threads: int, steps: int, directory: Path) -> dict:
    """Wall and CPU time per particle-step [ns] of Runner.loop over ``steps`` steps."""
    from ringsim.config.scenario import with_overrides
    from ringsim.engine.runner import Runner

    sc = with_overrides(scenario, {"integration.threads": threads,
                                   "integration.orbits": steps * 1e-3})
    copy = _copy_of(built, sc)
    runner = Runner(sc, directory / f"loop{threads}.h5", progress=False)
    runner.start_new(copy)
    steps_before = copy.sim.steps_done
    wall, cpu = time.perf_counter(), time.process_time()
    status = runner.loop()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    done = copy.sim.steps_done - steps_before
    if status != "finished" or done < steps:
        raise RuntimeError(f"the timed run ended {status} after {done} of {steps} steps")
    per = 1e9 / (done * copy.sim.N)
    return {"wall_ns": wall * per, "cpu_ns": cpu * per}


#: Largest N at which REBOUND's tree baseline is timed (it costs ~1 s per step at 1e5).
TREE_MAX_N = 100_000


def _rebound_baseline(scenario, repeat: int) -> dict:
    """Wall time per particle-step [ns] of REBOUND's own step on the same sheet (the same
    seed, so the same particles), median of ``repeat`` timings: with its tree collision
    search (ringsim's C resolver on the overlaps it reports, as ``collision_detection:
    tree`` runs) and without collisions (its SEI step with the shear boundary: the floor
    of any collision search)."""
    from ringsim.config.scenario import with_overrides
    from ringsim.engine.sheet import build_sheet

    sc = with_overrides(scenario, {"integration.collision_detection": "tree",
                                   "integration.threads": 1})
    built = build_sheet(sc)
    sim = built.sim
    steps = max(2, int(2e6 // sim.N))
    out: dict = {}
    for label, collision in (("tree", "tree"), ("none", "none")):
        sim.collision = collision
        sim.steps(1)
        times = []
        for _ in range(repeat):
            wall = time.perf_counter()
            sim.steps(steps)
            times.append((time.perf_counter() - wall) * 1e9 / (steps * sim.N))
        out[label] = statistics.median(times)
    return out


def measure_one(n: int, repeat: int) -> dict:
    """All measurements at N = n, in this process."""
    from ringsim.config.scenario import load_scenario, with_overrides
    from ringsim.engine.sheet import build_sheet

    scenario = with_overrides(load_scenario(SCENARIO), {"sheet.n_particles": n})
    # everything imported and allocated once on a small sheet, so that the memory counted
    # below is what the N particles need
    warm = with_overrides(scenario, {"sheet.n_particles": WARM_UP_PARTICLES})
    with tempfile.TemporaryDirectory() as tmp:
        _timed_loop(build_sheet(warm), warm, 1, 100, Path(tmp))
    rss_before = _rss_bytes()
    load_before = os.getloadavg()[0]
    wall, cpu = time.perf_counter(), time.process_time()
    built = build_sheet(scenario)
    setup_wall, setup_cpu = time.perf_counter() - wall, time.process_time() - cpu
    steps = steps_for(n)
    loops = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as tmp:
        snapshot_s, snapshot_bytes = _snapshot_write(built, scenario, Path(tmp))
        for _ in range(repeat):
            for threads in (1, 2):
                loops[threads].append(_timed_loop(built, scenario, threads, steps, Path(tmp)))
    ratios = [two["wall_ns"] / one["wall_ns"] for one, two in zip(loops[1], loops[2],
                                                                   strict=True)]
    # the memory is taken before the baseline builds a second sheet
    bytes_per_particle = (_peak_rss_bytes() - rss_before) / n
    rebound_ns = _rebound_baseline(scenario, repeat) if n <= TREE_MAX_N else None
    return {
        "rebound_ns": rebound_ns,
        "n": n, "steps": steps, "repeat": repeat,
        "setup_wall_s": setup_wall, "setup_cpu_s": setup_cpu,
        "snapshot_write_s": snapshot_s, "snapshot_bytes": snapshot_bytes,
        "loops": {str(k): v for k, v in loops.items()},
        "wall_ns": {str(k): statistics.median(x["wall_ns"] for x in v)
                    for k, v in loops.items()},
        "cpu_ns": {str(k): statistics.median(x["cpu_ns"] for x in v)
                   for k, v in loops.items()},
        "thread_ratio": statistics.median(ratios), "thread_ratios": ratios,
        "bytes_per_particle": bytes_per_particle,
        "load_average": [load_before, os.getloadavg()[0]],
    }


def measure(sizes, repeat: int, passes: int = 1) -> list[dict]:
    """measure_one for each size, each in a fresh process (its own peak memory), in
    ``passes`` passes over all sizes: the host's speed drifts by 20 % within an hour, and
    passes spread that drift over every size alike instead of loading it onto the last.
    Returns one pooled result per size (``pooled``)."""
    by_size: dict[int, list[dict]] = {n: [] for n in sizes}
    for _ in range(passes):
        for n in sizes:
            proc = subprocess.run([sys.executable, __file__, "--one", str(n), "--repeat",
                                   str(repeat)], capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                raise RuntimeError(f"N = {n}: {proc.stderr.strip()}")
            by_size[n].append(json.loads(proc.stdout.splitlines()[-1]))
            print(_row(by_size[n][-1]), flush=True)
    return [pooled(by_size[n]) for n in sizes]


def pooled(runs: list[dict]) -> dict:
    """One size's passes as one result: medians over all their timed loops and per-pair
    thread ratios, the median set-up and snapshot times, the largest memory, the load
    range, and each pass's own 1-thread median (``pass_wall_ns``) for the per-pass
    flatness."""
    loops = {k: [x for r in runs for x in r["loops"][k]] for k in ("1", "2")}
    ratios = [x for r in runs for x in r["thread_ratios"]]
    return {
        **runs[0], "passes": len(runs), "loops": loops,
        "wall_ns": {k: statistics.median(x["wall_ns"] for x in v) for k, v in loops.items()},
        "cpu_ns": {k: statistics.median(x["cpu_ns"] for x in v) for k, v in loops.items()},
        "thread_ratio": statistics.median(ratios), "thread_ratios": ratios,
        "setup_wall_s": statistics.median(r["setup_wall_s"] for r in runs),
        "snapshot_write_s": statistics.median(r["snapshot_write_s"] for r in runs),
        "bytes_per_particle": max(r["bytes_per_particle"] for r in runs),
        "load_average": [min(r["load_average"][0] for r in runs),
                         max(r["load_average"][1] for r in runs)],
        "pass_wall_ns": [r["wall_ns"]["1"] for r in runs],
    }


def pass_flatness(results: list[dict]) -> list[float]:
    """Largest / smallest 1-thread cost over the sizes, in each pass (one value for
    results stored before passes existed)."""
    per_pass = [r.get("pass_wall_ns", [r["wall_ns"]["1"]]) for r in results]
    return [max(costs) / min(costs) for costs in zip(*per_pass, strict=True)]


def _row(r: dict) -> str:
    return (f"| {r['n']:.0e} | {r['steps']} | {r['wall_ns']['1']:.0f} | {r['cpu_ns']['1']:.0f} "
            f"| {r['wall_ns']['2']:.0f} | {r['thread_ratio']:.2f} "
            f"({min(r['thread_ratios']):.2f}-{max(r['thread_ratios']):.2f}) "
            f"| {r['bytes_per_particle']:.0f} | {r['setup_wall_s']:.2f} "
            f"| {r['snapshot_write_s']:.3f} ({r['snapshot_bytes'] / r['n']:.0f} B/particle) "
            f"| {r['load_average'][0]:.1f}-{r['load_average'][1]:.1f} |")


TABLE_HEAD = ("| N | steps | 1 thread wall [ns] | 1 thread CPU [ns] | 2 threads wall [ns] | "
              "2 / 1 threads (range) | memory [B/particle] | set-up [s] | "
              "snapshot write [s] (file) | load average |\n"
              "|---|---|---|---|---|---|---|---|---|---|")


def plot(results: list[dict], path: Path) -> None:
    """Log-log cost per particle-step against N, 1 and 2 threads, with the targets."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = np.array([r["n"] for r in results], float)
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    for threads, marker in (("1", "o"), ("2", "s")):
        median = np.array([r["wall_ns"][threads] for r in results])
        low = np.array([min(x["wall_ns"] for x in r["loops"][threads]) for r in results])
        high = np.array([max(x["wall_ns"] for x in r["loops"][threads]) for r in results])
        ax.errorbar(n, median, yerr=[median - low, high - median], marker=marker,
                    capsize=3, label=f"{threads} thread{'s' if threads == '2' else ''}, "
                    "wall (median, range)")
    ax.plot(n, [r["cpu_ns"]["1"] for r in results], "o-", color="C2", mfc="none",
            label="1 thread, CPU time (less disturbed by other jobs)")
    before = sorted(BEFORE_NS.items())
    ax.plot([k for k, _ in before], [v for _, v in before], "x:", color="grey",
            label="before scaling (1 thread)")
    ax.axhline(TARGET_NS, color="k", ls="--", lw=1, label=f"target {TARGET_NS:.0f} ns")
    smallest = min(r["wall_ns"]["1"] for r in results)
    ax.axhline(TARGET_FLATNESS * smallest, color="k", ls=":", lw=1,
               label=f"flat: {TARGET_FLATNESS}x the smallest 1-thread cost")
    one = np.array([r["wall_ns"]["1"] for r in results])
    ax.plot(n, TARGET_THREAD_RATIO * one, color="C1", ls="--", lw=1,
            label=f"2-thread target: {TARGET_THREAD_RATIO} x 1 thread")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("particles N")
    ax.set_ylabel("time per particle-step [ns]")
    ax.set_title("Whole run loop, line mode, tau = 0.25, 0.5-5 m")
    ticks = [100, 150, 200, 300, 500, 700, 1000]
    ax.set_yticks(ticks)
    ax.set_yticklabels([str(t) for t in ticks])
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2,
              frameon=False)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _spread(values: list[float], digits: int = 2) -> str:
    """"median (min-max) of n" of a list of values, or the value alone."""
    if len(values) == 1:
        return f"{values[0]:.{digits}f} (one pass)"
    return (f"median {statistics.median(values):.{digits}f} ({min(values):.{digits}f}-"
            f"{max(values):.{digits}f}) of {len(values)}")


def section(results: list[dict], command: str, note: str, when: str) -> str:
    """The "Scale" section of docs/performance.md (``note``: a paragraph after the table;
    ``when``: the time of the measurement)."""
    import rebound

    from ringsim.engine.native import openmp_available

    rows = "\n".join(_row(r) for r in results)
    costs = [r["wall_ns"]["1"] for r in results]
    flats = pass_flatness(results)
    at_1e5 = next((r for r in results if r["n"] == 100_000), None)
    verdict = [f"flatness (largest / smallest 1-thread cost over N = {results[0]['n']:.0e}-"
               f"{results[-1]['n']:.0e}): {max(costs) / min(costs):.2f} of the medians; "
               f"per pass {_spread(flats)} (target <= {TARGET_FLATNESS})"]
    if at_1e5 is not None:
        verdict.append(f"1 thread at N = 1e5: {at_1e5['wall_ns']['1']:.0f} ns wall, "
                       f"{at_1e5['cpu_ns']['1']:.0f} ns CPU; pass medians "
                       f"{_spread(at_1e5.get('pass_wall_ns', [at_1e5['wall_ns']['1']]), 0)}"
                       f" ns (target <= {TARGET_NS:.0f})")
        verdict.append(f"2 threads / 1 thread at N = 1e5: {at_1e5['thread_ratio']:.2f} "
                       f"(target <= {TARGET_THREAD_RATIO})")
    note = f"\n{note}\n" if note else ""
    baseline = _baseline_table(results)
    verdict.append("memory: " + ", ".join(f"{r['bytes_per_particle']:.0f} B at "
                                          f"{r['n']:.0e}" for r in results)
                   + f" per particle (target <= {TARGET_BYTES:.0f})")
    return f"""{HEADING}

`benchmarks/scale.py` ({command}), run on {when}, {platform.machine()} {platform.system()},
{os.cpu_count()} cores shared with other engineers' jobs (load averages in the table: the
machine was busy, so wall times are noisy and 2 threads rarely got 2 free cores), REBOUND
{rebound.__version__}, numpy {np.__version__}, ringsim built {"with" if openmp_available()
else "without"} OpenMP.  Sheet: benchmarks/scale.yaml (line mode, no gravity, power law
0.5-5 m, q = 3, tau = 0.25, Bridges et al. 1984), from `build_sheet`'s initial state.
Whole run loop: `runner.Runner.loop` (integration, a time-series output every 0.1 orbit with
its diagnostics, invariants, guards and HDF5 rows, the final checkpoint), ns per
particle-step, median of the repeats of all passes ({results[0].get("passes", 1)} over all
sizes in turn, so that the host's drift falls on every size alike; the table's rows are the
pooled passes, the per-pass figures below it); threads 1 and 2 alternate on copies of the
same state in one process, and "2 / 1 threads" is the median of the per-pair wall-time
ratios.  Memory:
peak resident set of the process (set-up, snapshot, loops) less its resident set before
the set-up, per particle.  Set-up and snapshot write are part A's (`build_sheet`,
`RunFileWriter`), timed here through their public calls.

{TABLE_HEAD}
{rows}
{note}
{chr(10).join("- " + v for v in verdict)}
{baseline}
![cost per particle-step against N](figures/scale.png)

{MARKER}
"""


def _baseline_table(results: list[dict]) -> str:
    """The side-by-side table of ringsim's whole loop against REBOUND's own step on the same
    sheet in the same process (empty for results without the baseline)."""
    rows = [r for r in results if r.get("rebound_ns")]
    if not rows:
        return ""
    lines = [f"| {r['n']:.0e} | {r['wall_ns']['1']:.0f} | {r['rebound_ns']['tree']:.0f} | "
             f"{r['rebound_ns']['none']:.0f} | "
             f"{r['wall_ns']['1'] / r['rebound_ns']['tree']:.3f} | "
             f"{r['wall_ns']['1'] / r['rebound_ns']['none']:.1f} | "
             f"{r['thread_ratio']:.2f} |" for r in rows]
    return ("\n**Against REBOUND, same sheet, same process** (1 thread, wall time, median of "
            "the repeats; REBOUND's figures are its step alone, ringsim's the whole run loop "
            "with its outputs): REBOUND's tree collision search with ringsim's resolver on "
            "the overlaps it reports (`collision_detection: tree`), and REBOUND's SEI step "
            "with the shear boundary and no collisions, the floor of any collision search."
            "\n\n| N | ringsim line, whole loop [ns] | REBOUND tree step [ns] | REBOUND "
            "no-collision step [ns] | ringsim / REBOUND tree | ringsim / no-collision floor | "
            "ringsim 2 / 1 threads |\n|---|---|---|---|---|---|---|\n"
            + "\n".join(lines) + "\n")


def write_doc(results: list[dict], command: str, note: str = "", when: str = "") -> None:
    """Replace (or append) the "Scale" section of docs/performance.md; draw the figure.
    ``when``: the time of the measurement (a redraw keeps the stored one)."""
    from ringsim.report import replace_section  # ends the part at MARKER, keeps the rest

    when = when or datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    replace_section(DOC, HEADING, section(results, command, note, when), "Performance")
    RESULTS.write_text(json.dumps({"command": command, "note": note, "when": when,
                                   "results": results},
                                  indent=1))
    plot(results, FIGURE)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+")
    parser.add_argument("--quick", action="store_true", help="N = 1e3, 1e4, 1e5")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--passes", type=int, default=1,
                        help="passes over all sizes in turn (pooled; per-pass flatness)")
    parser.add_argument("--write-doc", action="store_true")
    parser.add_argument("--replot", action="store_true",
                        help="redraw the figure and the section from docs/figures/scale.json")
    parser.add_argument("--one", type=float, help=argparse.SUPPRESS)  # worker: one size
    args = parser.parse_args()
    if args.replot:
        stored = json.loads(RESULTS.read_text())
        write_doc(stored["results"], stored["command"], stored.get("note", ""),
                  stored.get("when", "(time not recorded)"))
        return
    if args.one is not None:
        print(json.dumps(measure_one(int(args.one), args.repeat)))
        return
    sizes = ([int(n) for n in args.sizes] if args.sizes
             else list(QUICK_SIZES if args.quick else SIZES))
    print(TABLE_HEAD)
    results = measure(sizes, args.repeat, args.passes)
    print(_baseline_table(results))
    if args.write_doc:
        flags = " ".join(a for a in sys.argv[1:])
        write_doc(results, f"`python benchmarks/scale.py {flags}`".replace("  ", " "))
        print(f"wrote {DOC} and {FIGURE}")
    if not math.isfinite(results[-1]["wall_ns"]["1"]):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
