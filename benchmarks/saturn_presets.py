"""The Saturn presets' step: cost per particle-step with and without self-gravity, with the
line detector's reach classes and with its one grid.

Each preset of ``scenarios/saturn-*-ring.yaml`` (its own particles, friction, law and line
detection, one thread) is built and stepped from its initial state: two warm-up steps,
then ``--repeats`` rounds of ``--steps`` steps with the detector's grid per reach class
(rs_sheet_detect.c Method 2a, the default) and with its one grid in turn, on the same
sheet in the same process (the pair of figures least disturbed by other jobs; the two
searches find the same pairs, so the sheet evolves the same either way).  Once without
self-gravity (the baseline) and once as the preset runs (P3M with its field-only
particles).  CPU time per particle-step, median of the rounds; the ratios; what an orbit
costs at dt = 1e-3 orbit.  The initial state has the velocity dispersion of Toomre Q = 2
(``sheet.initial_toomre_q``), the order of an equilibrium's, but not its structure (no
wakes yet); the figures are the set-up's, not the equilibrium's.  With ``--write-doc`` the table
replaces the section "## The Saturn presets" of docs/performance.md.

With ``--states RUN.h5 ...`` it measures instead the last snapshot of each run file (a
preset's run in its equilibrium, e.g. a run of studies/kappa-saturn), as issue 39's target
asks: the whole step on 1 and on 2 threads (wall time, alternating rounds on the same
sheet), with and without self-gravity; ``--write-doc`` then replaces the section "## The
Saturn presets in their equilibrium".  ``--configs K[:R] ...`` (state mode) measures the
gravitating step once per configuration: the P3M mesh every K steps
(``sheet.p3m_mesh_interval``; 1: every step, the presets' default) and, with R, the mesh's
core set by the particles of radius at least R [m] (``sheet.p3m_core_min_radius``);
``--steps`` should be a multiple of every K, so that each round holds whole intervals.

Usage: python benchmarks/saturn_presets.py [--presets a b c] [--steps 5] [--repeats 3]
                                           [--states RUN.h5 ...] [--configs 1 5 5:0.25]
                                           [--write-doc]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time
from datetime import datetime, timezone

import h5py
import numpy as np

from ringsim import testing
from ringsim.config.scenario import load_scenario, scenario_from_text, with_overrides
from ringsim.config.study_start import Start, started
from ringsim.engine import detector
from ringsim.engine.native import set_detector_threads, use_threaded_sei
from ringsim.engine.sheet import build_sheet, particle_arrays, without_gravity
from ringsim.gravity import p3m
from ringsim.gravity.registry import set_gravity_threads
from ringsim.report import replace_section

STEPS_PER_ORBIT = 1000    # dt = 1e-3 orbit, the presets' dt: auto in line mode
ONE_GRID = 1              # detector.set_classes: all particles in one grid


def cost(path: str, gravity: bool, steps: int, repeats: int) -> tuple[float, float, int]:
    """CPU seconds per particle-step of the preset at ``path`` with the detector's reach
    classes and with its one grid (medians of ``repeats`` alternating rounds), and its
    particle count."""
    sc = load_scenario(path)
    if not gravity:
        sc = without_gravity(sc)
    sc = with_overrides(sc, {"integration.threads": 1})
    built = build_sheet(sc)
    sim = built.sim
    sim.steps(2)
    times: dict[int, list[float]] = {detector.MAX_CLASSES: [], ONE_GRID: []}
    for _ in range(repeats):
        for classes, found in times.items():
            detector.set_classes(built.resolver.address, classes)
            t0 = time.process_time()
            sim.steps(steps)
            found.append((time.process_time() - t0) / steps / sim.N)
    return (statistics.median(times[detector.MAX_CLASSES]), statistics.median(times[ONE_GRID]),
            sim.N)


def table(presets: list[str], steps: int, repeats: int) -> str:
    rows = []
    for name in presets:
        path = f"scenarios/saturn-{name}-ring.yaml"
        base, base_one, n = cost(path, False, steps, repeats)
        grav, grav_one, _ = cost(path, True, steps, repeats)
        rows.append(f"| {name.upper()} ring | {n} | {base * 1e9:.0f} | {base_one * 1e9:.0f} | "
                    f"{base / base_one:.2f} | {grav * 1e9:.0f} | {grav_one * 1e9:.0f} | "
                    f"{grav / grav_one:.2f} | {grav / base:.2f} | "
                    f"{grav * n * STEPS_PER_ORBIT / 60:.1f} |")
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0]
    head = (f"## The Saturn presets\n\n`python benchmarks/saturn_presets.py --steps {steps} "
            f"--repeats {repeats} --write-doc`, {when}, {platform.machine()} "
            f"{platform.system()}, one thread, CPU times, median of {repeats} rounds (the "
            f"machine shared: load average {load:.1f} at the end).  Each preset from its "
            "initial state (Toomre Q = 2, without an equilibrium's wakes), the same sheet in one "
            "process: the step without self-gravity (the baseline) and as the preset runs "
            "(P3M, field-only particles below `sheet.p3m_pair_min_radius`), each with the "
            "line detector's grid per reach class (the default) and with its one grid in "
            "turn.\n\n"
            "| preset | particles | no gravity [ns per particle-step] | one grid [ns] "
            "| classes / one grid | with gravity [ns] | one grid [ns] | classes / one grid "
            "| gravity / no gravity | CPU-minutes per orbit |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n")
    return head + "\n".join(rows) + "\n"


def last_state(path: str):
    """The scenario that starts from the last snapshot of the run file at ``path``, and
    that snapshot's time [orbits]."""
    with h5py.File(path, "r") as f:
        sc = scenario_from_text(f.attrs["scenario_yaml"], source=path)
        orbits = float(f.attrs["Omega"]) * float(list(f["snapshots"].values())[-1].attrs["t"]) \
            / (2.0 * math.pi)
    return started(sc, os.path.abspath(path), Start(case="", snapshot=-1)), orbits


def state_cost(path: str, gravity: bool, steps: int, repeats: int, interval: int = 1,
               core: float = 0.0) -> tuple[dict[int, float], int, float]:
    """Wall seconds per particle-step on 1 and 2 threads (medians of ``repeats``
    alternating rounds) of the sheet of the last snapshot of the run file at ``path``, with
    the P3M mesh every ``interval`` steps and its core of the particles of at least
    ``core`` [m], its particle count and the snapshot's time [orbits]."""
    sc, orbits = last_state(path)
    if not gravity:
        sc = without_gravity(sc)
    else:
        sc = with_overrides(sc, {"sheet.p3m_mesh_interval": interval,
                                 "sheet.p3m_core_min_radius": core})
    built = build_sheet(sc)
    sim = built.sim
    sim.steps(2 * interval)
    times: dict[int, list[float]] = {1: [], 2: []}
    for _ in range(repeats):
        for threads, found in times.items():
            use_threaded_sei(sim, threads)
            set_detector_threads(built.resolver.address, threads)
            set_gravity_threads(sim, threads)
            t0 = time.perf_counter()
            sim.steps(steps)
            found.append((time.perf_counter() - t0) / steps / sim.N)
    return {k: statistics.median(v) for k, v in times.items()}, sim.N, orbits


def state_force_errors(path: str, cores: list[float], n_targets: int) -> list[str]:
    """Rows of the rms per-particle relative force error of the last snapshot of ``path``
    against the converged shear-periodic image sum, on ``n_targets`` random field-only
    particles and as many pair-summed ones, with the mesh's core of each radius of
    ``cores`` [m], and the mesh's layers."""
    sc, orbits = last_state(path)
    built = build_sheet(sc)
    sim = built.sim
    arrays = particle_arrays(sim)
    radius = arrays["radius"]
    split_radius = float(sc.sheet.p3m_pair_min_radius or 0.0)
    rng = np.random.default_rng(0)
    groups = {"below": np.flatnonzero(radius < split_radius),
              "above": np.flatnonzero(radius >= split_radius)}
    targets = {k: np.sort(rng.choice(v, min(n_targets, v.size), replace=False))
               for k, v in groups.items() if v.size}
    ref = {k: testing.simulation_reference(sim, t) for k, t in targets.items()}
    solver = p3m.installed_solver(sim)
    rows = []
    for core in cores:
        solver.core_min_radius = core
        acc = testing.accelerations(sim)
        err = {k: 100.0 * testing.force_errors(acc[t], ref[k])["rms_relative"]
               for k, t in targets.items()}
        z = arrays["z"]
        rows.append(f"| `{os.path.basename(path)}` | {orbits:.1f} | {core:g} | "
                    f"{np.std(z):.1f} | {np.std(z[radius >= split_radius]):.1f} | "
                    f"{solver.params.nz} | {err.get('below', math.nan):.3f} % | "
                    f"{err.get('above', math.nan):.3f} % |")
    return rows


def parse_config(text: str) -> tuple[int, float]:
    """``K`` or ``K:R``: (mesh interval [steps], core radius [m], 0 if not given)."""
    k, _, r = text.partition(":")
    return int(k), float(r or 0.0)


def state_table(paths: list[str], steps: int, repeats: int, configs: list[str],
                force_targets: int = 0) -> str:
    rows = []
    cores = sorted({parse_config(c)[1] for c in configs})
    force_rows = [row for path in paths for row in state_force_errors(path, cores,
                                                                      force_targets)
                  ] if force_targets else []
    for path in paths:
        base, n, orbits = state_cost(path, False, steps, repeats)
        for config in configs:
            k, core = parse_config(config)
            grav, _, _ = state_cost(path, True, steps, repeats, k, core)
            rows.append(f"| `{os.path.basename(path)}` | {orbits:.1f} | {n} | {k} | "
                        f"{core:g} | "
                        f"{base[1] * 1e9:.0f} | {base[2] * 1e9:.0f} | {base[2] / base[1]:.2f} | "
                        f"{grav[1] * 1e9:.0f} | {grav[2] * 1e9:.0f} | {grav[2] / grav[1]:.2f} | "
                        f"{grav[1] / base[1]:.2f} | {grav[2] * n * STEPS_PER_ORBIT / 60:.1f} |")
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0]
    head = (f"## The Saturn presets in their equilibrium\n\n`python benchmarks/saturn_presets.py "
            f"--states RUN.h5 ... --steps {steps} --repeats {repeats} --configs "
            f"{' '.join(configs)} --write-doc`, {when}, "
            f"{platform.machine()} {platform.system()}, wall time, median of {repeats} "
            f"rounds alternating 1 and 2 threads on the same sheet (the machine shared: load "
            f"average {load:.1f} at the end).  Each run file's last snapshot, the sheet as "
            "its run left it (the particles, P3M with its field-only particles, friction, the "
            "law), stepped without self-gravity (the baseline) and as it runs, with the P3M "
            "mesh every k steps (`sheet.p3m_mesh_interval`; the preset's default 1) and its "
            "core set by the particles of at least the core radius "
            "(`sheet.p3m_core_min_radius`; 0, the preset's default: every particle).  Issue "
            "39's target: at most 1 us per particle-step with gravity on both cores.\n\n"
            "| run file | orbit | particles | mesh every k steps | core radius [m] "
            "| no gravity, 1 thread [ns per particle-step] "
            "| 2 threads [ns] | 2 / 1 | with gravity, 1 thread [ns] | 2 threads [ns] | 2 / 1 "
            "| gravity / no gravity (1 thread) | wall minutes per orbit (2 threads) |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    text = head + "\n".join(rows) + "\n"
    if force_rows:
        text += (f"\nThe force error of each core at the same states (`--force-targets "
                 f"{force_targets}`): rms per-particle relative error of the whole P3M force "
                 "against the converged shear-periodic image sum (`physics.selfgravity."
                 f"direct_accelerations`) on {force_targets} random particles below the "
                 "preset's field-only radius (`sheet.p3m_pair_min_radius`) and as many "
                 "above it; rms heights of all particles and of those above.\n\n"
                 "| run file | orbit | core radius [m] | rms z, all [m] | rms z, above [m] "
                 "| layers | error, below | error, above |\n"
                 "|---|---|---|---|---|---|---|---|\n" + "\n".join(force_rows) + "\n")
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--presets", nargs="+", default=["a", "b", "c"])
    parser.add_argument("--steps", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--states", nargs="+", default=None,
                        help="run files: measure their last snapshots on 1 and 2 threads")
    parser.add_argument("--configs", nargs="+", default=["1"],
                        help="state mode: K[:R], the P3M mesh every K steps (odd) and its "
                             "core of the particles of radius at least R [m]")
    parser.add_argument("--force-targets", type=int, default=0,
                        help="state mode: also the force error of each core radius on this "
                             "many particles below and above the field-only radius")
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    if args.states:
        text = state_table(args.states, args.steps, args.repeats, args.configs,
                           args.force_targets)
        section = "## The Saturn presets in their equilibrium"
    else:
        text = table(args.presets, args.steps, args.repeats)
        section = "## The Saturn presets"
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", section, text, "Performance")


if __name__ == "__main__":
    main()
