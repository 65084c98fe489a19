"""Benchmark: ringsim's line-mode detector and step against an earlier build of it.

On a shared machine the absolute cost of a step drifts by 20 % or more within minutes, so a
change is measured against the build before it, in two ways.  The earlier build is a source
tree with its extension built in place (``git worktree add --detach ../before <commit> &&
(cd ../before && python setup.py build_ext --inplace)``), given as ``--before``; the
current build is the ``ringsim`` this script imports.  Sheet: benchmarks/scale.yaml (line
mode, no gravity, power law 0.5-5 m, q = 3, tau = 0.25, Bridges et al. 1984) from
``build_sheet``, after 20 steps.

1. **Search, same process** (the baseline run in the same process): the earlier build's
   library is loaded beside the current one, and its detector search
   (``rs_sheet_detect_pairs``: wrap, grid and sort, candidate search; no resolution) runs
   on a copy of the sheet with a resolver of its own, alternately with the current build's
   on the sheet, ``--rounds`` pairs of 10 searches each; both must report the same pairs
   with the same ghost offsets (checked with ``==``).
2. **Whole step, same process**: the earlier build's ``rs_sheet_step`` (detection and
   time-ordered resolution) is installed as REBOUND's post-timestep function of the copy,
   and ``--steps`` steps of ``sim.integrate`` (REBOUND's SEI step, the same code for both,
   the detector, the resolution; no outputs) alternate between the two, ``--rounds``
   pairs; both states must be the same bits at the end.
3. With ``--processes``, the whole integration in interleaved fresh processes: each round
   runs every build once per thread count, and all final states must be the same bits.

Reports medians over the rounds and the median of the per-round ratios current / before.

    python benchmarks/compare_builds.py --before ../before --sizes 1e4 1e5 --rounds 5
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

SCENARIO = Path(__file__).with_name("scale.yaml")

CHILD = """
import hashlib, json, sys, time
import numpy as np
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.engine import native, sheet
n, threads, steps, path = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
sc = with_overrides(load_scenario(path), {"sheet.n_particles": n})
built = sheet.build_sheet(sc)
sim = built.sim
native.set_detector_threads(built.resolver.address, threads)
sim.integrate(sim.t + 10 * sim.dt, exact_finish_time=0)
wall, cpu = time.perf_counter(), time.process_time()
sim.integrate(sim.t + steps * sim.dt, exact_finish_time=0)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
a = sheet.particle_arrays(sim)
state = b"".join(np.ascontiguousarray(a[k]).tobytes() for k in ("x", "y", "z", "vx", "vy", "vz"))
per = 1e9 / (n * steps)
print(json.dumps({"wall_ns": wall * per, "cpu_ns": cpu * per,
                  "state": hashlib.sha1(state).hexdigest()}))
"""


def one(tree: Path, n: int, threads: int, steps: int) -> dict:
    """One timed integration with ``tree``'s build, in a fresh process."""
    env = dict(os.environ, PYTHONPATH=str(tree.resolve()))
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), str(threads), str(steps),
                          str(SCENARIO)], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def _detect(lib, sim, capacity: int) -> tuple[np.ndarray, np.ndarray]:
    """Pairs and ghost offsets of one search of ``lib``'s detector (sorted by pair)."""
    pairs = np.zeros((max(capacity, 1), 2), np.int64)
    offsets = np.zeros((max(capacity, 1), 6))
    found = lib.rs_sheet_detect_pairs(ctypes.addressof(sim), capacity,
                                      pairs.ctypes.data, offsets.ctypes.data)
    if found < 0:
        raise RuntimeError(f"detector error {-found - 1}")
    found = min(found, capacity)   # the timed searches keep no pairs
    order = np.lexsort((pairs[:found, 1], pairs[:found, 0]))
    return pairs[:found][order], offsets[:found][order]


def _two_sheets(before: Path, n: int, threads: int):
    """The earlier build's library (loaded from ``before``), the current build's sheet of
    ``n`` particles after 20 steps, and a copy of it with a resolver of its own whose
    detector only the earlier build will make; both searching on ``threads`` threads."""
    import scale

    from ringsim.config.scenario import load_scenario, with_overrides
    from ringsim.engine import native, sheet

    old = ctypes.CDLL(str(next(before.resolve().glob("ringsim/_resolver*.so"))))
    for lib in (old, native._LIB):
        lib.rs_sheet_detect_pairs.restype = ctypes.c_int64
        lib.rs_sheet_detect_pairs.argtypes = [ctypes.c_void_p, ctypes.c_int64,
                                              ctypes.c_void_p, ctypes.c_void_p]
    old.rs_sheet_set_threads.argtypes = [ctypes.c_void_p, ctypes.c_int]
    sc = with_overrides(load_scenario(SCENARIO), {"sheet.n_particles": n})
    current = sheet.build_sheet(sc)
    current.sim.integrate(current.sim.t + 20 * current.sim.dt, exact_finish_time=0)
    earlier = scale._copy_of(current, sc)
    old.rs_sheet_set_threads(earlier.resolver.address, threads)
    native.set_detector_threads(current.resolver.address, threads)
    return old, current, earlier


def _paired(pairs: list[tuple[float, float]]) -> dict:
    """Medians of (before, now) timings and the median of their per-pair ratios."""
    return {"before": statistics.median(p[0] for p in pairs),
            "now": statistics.median(p[1] for p in pairs),
            "ratio": statistics.median(p[1] / p[0] for p in pairs)}


def _state(sim) -> bytes:
    """Positions and velocities of all particles, as bytes (for ``==``)."""
    from ringsim.engine.sheet import particle_arrays

    a = particle_arrays(sim)
    return b"".join(np.ascontiguousarray(a[k]).tobytes() for k in ("x", "y", "z", "vx", "vy",
                                                                   "vz"))


def search_same_process(before: Path, n: int, threads: int, rounds: int) -> dict:
    """Search cost [ns per particle] of the earlier build (loaded from ``before``) and of
    the current one, alternating in this process on the same state."""
    from ringsim.engine import native

    old, current, earlier = _two_sheets(before, n, threads)
    a, b = _detect(old, earlier.sim, 4 * n), _detect(native._LIB, current.sim, 4 * n)
    same = bool(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]))

    def timed(lib, sim) -> float:
        start = time.perf_counter()
        for _ in range(10):
            _detect(lib, sim, 0)
        return (time.perf_counter() - start) * 1e9 / (10 * n)

    pairs = [(timed(old, earlier.sim), timed(native._LIB, current.sim))
             for _ in range(rounds)]
    return {**_paired(pairs), "same_pairs": same}


def step_same_process(before: Path, n: int, threads: int, rounds: int, steps: int) -> dict:
    """Whole-step cost [ns per particle-step] of the earlier build's detector and
    resolution (its ``rs_sheet_step`` installed as REBOUND's post-timestep function on a
    copy of the sheet with a resolver of its own) and of the current build's, alternating
    in this process: REBOUND's SEI step is the same code in both."""
    from ringsim.engine.resolver import _POST_TIMESTEP

    old, current, earlier = _two_sheets(before, n, threads)
    step = _POST_TIMESTEP(ctypes.cast(old.rs_sheet_step, ctypes.c_void_p).value)
    earlier.sim._post_timestep_modifications = step   # kept alive by `step` below

    def timed(sim) -> float:
        start = time.perf_counter()
        sim.integrate(sim.t + steps * sim.dt, exact_finish_time=0)
        return (time.perf_counter() - start) * 1e9 / (steps * n)

    pairs = [(timed(earlier.sim), timed(current.sim)) for _ in range(rounds)]
    same = _state(earlier.sim) == _state(current.sim)
    del step
    return {**_paired(pairs), "same_bits": same}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True,
                        help="source tree of the earlier build, extension built in place")
    parser.add_argument("--sizes", type=float, nargs="+", default=[1e5])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--processes", action="store_true",
                        help="also the interleaved fresh processes (3.)")
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).parent))   # scale.py's sheet copy
    trees = [Path(args.before), Path(__file__).resolve().parent.parent]
    for size in args.sizes:
        n = int(size)
        print(f"N = {n:.0e}, search (wrap, grid, candidates), same process, {args.rounds} "
              "pairs of 10 searches")
        print("| threads | before [ns] | now [ns] | now / before | same pairs |")
        print("|---|---|---|---|---|")
        for k in args.threads:
            r = search_same_process(Path(args.before), n, k, args.rounds)
            print(f"| {k} | {r['before']:.0f} | {r['now']:.0f} | {r['ratio']:.2f} | "
                  f"{'yes' if r['same_pairs'] else 'NO'} |")
        print(f"N = {n:.0e}, whole step (REBOUND's SEI, detector, resolution), same "
              f"process, {args.rounds} pairs of {args.steps} steps")
        print("| threads | before [ns] | now [ns] | now / before | same bits after |")
        print("|---|---|---|---|---|")
        for k in args.threads:
            r = step_same_process(Path(args.before), n, k, args.rounds, args.steps)
            print(f"| {k} | {r['before']:.0f} | {r['now']:.0f} | {r['ratio']:.2f} | "
                  f"{'yes' if r['same_bits'] else 'NO'} |")
        if not args.processes:
            continue
        runs = {(t, k): [] for t in range(len(trees)) for k in args.threads}
        for _ in range(args.rounds):
            for t, tree in enumerate(trees):
                for k in args.threads:
                    runs[t, k].append(one(tree, n, k, args.steps))
        states = {r["state"] for rs in runs.values() for r in rs}
        print(f"N = {n:.0e}, whole integration, {args.steps} steps, {args.rounds} rounds "
              "of fresh processes; final states "
              f"{'the same bits in every run' if len(states) == 1 else 'DIFFER'}")
        print("| build | threads | wall [ns] (median) | CPU [ns] (median) | wall / before "
              "(median of rounds) | wall, threads / 1 thread |")
        print("|---|---|---|---|---|---|")
        for t, name in enumerate(("before", "now")):
            for k in args.threads:
                wall = [r["wall_ns"] for r in runs[t, k]]
                cpu = [r["cpu_ns"] for r in runs[t, k]]
                base = [r["wall_ns"] for r in runs[0, k]]
                ratio = statistics.median(w / b for w, b in zip(wall, base, strict=True))
                one_thread = [r["wall_ns"] for r in runs[t, args.threads[0]]]
                speedup = statistics.median(w / b for w, b in zip(wall, one_thread, strict=True))
                print(f"| {name} | {k} | {statistics.median(wall):.0f} | "
                      f"{statistics.median(cpu):.0f} | {ratio:.2f} | {speedup:.2f} |")


if __name__ == "__main__":
    main()
