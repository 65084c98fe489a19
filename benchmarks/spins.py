"""Cost per resolved collision of rough spheres, and of following the spins' precession.

Usage (from the repository root, a few seconds)::

    python benchmarks/spins.py [--pairs 100000 --repeats 15]

Times ``ResolverHandle.resolve_batch`` over fresh two-sphere collisions (those of
``benchmarks/resolver.py``, each reported twice as the tree search does) in four set-ups
interleaved, and prints the median cost per collision and the median of its ratio to the
smooth resolver in the same repeat: smooth spheres; beta = 0 in an inertial box
(REBOUND's OMEGA = 0: the frame angle is 0); beta = 0 in a rotating frame at t = 10
orbits (one cos and sin per collision turn the spins to the frame's axes and back);
Coulomb mu = 0.5 there.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from resolver import OMEGA, ORBIT, fresh_pairs

from ringsim.engine.resolver import collision_records, install_resolver

SETUPS = {
    "smooth": (None, 0.0),
    "beta = 0, OMEGA = 0": ({"model": "constant", "beta": 0.0}, 0.0),
    "beta = 0, rotating frame": ({"model": "constant", "beta": 0.0}, OMEGA),
    "mu = 0.5, rotating frame": ({"model": "coulomb", "mu": 0.5}, OMEGA),
}


def one_batch(friction, omega: float, n_pairs: int, seed: int) -> float:
    """CPU time [s] per resolved collision of one batch on a fresh copy of the pairs."""
    sim = fresh_pairs(n_pairs, seed=1)
    sim.OMEGA = omega
    sim.t = 10.0 * ORBIT
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5}, friction)
    if friction:
        handle.set_spins(np.random.default_rng(seed).normal(0.0, 1e-3, (sim.N, 3)))
    pairs = np.empty((2 * n_pairs, 2), dtype=np.int64)
    pairs[0::2] = np.column_stack([np.arange(0, 2 * n_pairs, 2),
                                   np.arange(1, 2 * n_pairs, 2)])
    pairs[1::2] = pairs[0::2, ::-1]
    records = collision_records(pairs)
    start = time.process_time()     # CPU time: the machine is shared
    resolved = handle.resolve_batch(records)
    return (time.process_time() - start) / resolved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=100000)
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    costs = {name: [] for name in SETUPS}
    for repeat in range(args.repeats):          # interleaved: the load changes slowly
        for name, (friction, omega) in SETUPS.items():
            costs[name].append(one_batch(friction, omega, args.pairs, repeat))
    print("| set-up | median per collision | median ratio to smooth (same repeat) |")
    print("|---|---|---|")
    for name, values in costs.items():
        ratios = [v / s for v, s in zip(values, costs["smooth"], strict=True)]
        print(f"| {name} | {statistics.median(values) * 1e9:.0f} ns | "
              f"{statistics.median(ratios):.2f} |")


if __name__ == "__main__":
    main()
