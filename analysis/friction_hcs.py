"""Homogeneous cooling of rough spheres: T_rot/T_tr against the closed form.

Runs ringsim.validation.cooling.cool_rough_gas for the parameter sets of
tests/test_friction.py (same seeds, so the same numbers), prints the table of
docs/friction.md and writes docs/figures/friction/hcs_ratio.png.

    python analysis/friction_hcs.py [--quick]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ringsim.physics import friction as fr
from ringsim.plots import save_figure
from ringsim.validation.cooling import cool_rough_gas

FIGURE = Path(__file__).resolve().parent.parent / "docs" / "figures" / "friction" / "hcs_ratio.png"

#: (n_particles, eps_n, beta, T_rot/T_tr at the start, collisions per particle, seed,
#:  average from this many collisions per particle): the default tests' three runs, then
#:  the slow test's (average from five relaxation lengths, then 80 more collisions).
CASES = [
    (300, 0.9, 0.5, 0.0, 40.0, 1, 15.0),
    (300, 0.9, 0.5, 3.0, 40.0, 2, 15.0),
    (300, 1.0, 1.0, 0.0, 30.0, 3, 10.0),
] + [
    (1000, eps_n, beta, 0.0, settle + 80.0, 11, settle)
    for eps_n, beta in [(0.9, 0.0), (0.9, 0.5), (0.9, -0.5), (0.7, 0.5), (1.0, 1.0)]
    for settle in [max(20.0, 5.0 * fr.hcs_relaxation_collisions(eps_n, beta))]
]
VOLUME_FRACTION = 0.01


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the default tests' cases only")
    args = parser.parse_args()
    cases = CASES[:3] if args.quick else CASES
    print("| N | eps_n | beta | start | collisions/particle | averaged from | closed form "
          "| measured | difference | multi-contacts | run time |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    runs = []
    for n, eps_n, beta, start, length, seed, after in cases:
        clock = time.perf_counter()
        run = cool_rough_gas(n, VOLUME_FRACTION, eps_n, {"model": "constant", "beta": beta},
                             start, length, seed=seed)
        mean, stderr = run.converged_ratio(after)
        target = fr.hcs_temperature_ratio(eps_n, beta)
        collisions = run.collisions_per_particle[-1] * n / 2.0
        print(f"| {n} | {eps_n} | {beta} | {start} | {length:.0f} | {after:.0f} | {target:.4f} "
              f"| {mean:.4f} ± {stderr:.4f} | {100.0 * (mean / target - 1.0):+.1f}% "
              f"| {run.multi_contacts / collisions:.2%} "
              f"| {time.perf_counter() - clock:.0f} s |", flush=True)
        runs.append((run, target, f"N={n}, eps_n={eps_n}, beta={beta}, start {start}"))
    plot(runs)


def plot(runs) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 5.5))
    for run, target, label in runs:
        c = run.collisions_per_particle
        r = run.temperature_ratio
        # Running mean over about one collision per particle, to show the trend.
        width = max(1, int(np.searchsorted(c, 1.0)))
        smooth = np.convolve(r, np.ones(width) / width, mode="valid")
        (line,) = ax.plot(c[width - 1:], smooth / target, linewidth=1.0, label=label)
    ax.axhline(1.0, color="black", linewidth=0.8)
    ax.axhspan(0.94, 1.06, color="grey", alpha=0.15, label="closed form ± 6%")
    ax.set_xlabel("collisions per particle  [-]")
    ax.set_ylabel("(T_rot / T_tr) / closed form  [-]")
    ax.set_ylim(0.0, 1.6)
    ax.set_title("Homogeneous cooling of rough spheres, volume fraction "
                 f"{VOLUME_FRACTION}, k = 2/5")
    ax.legend(fontsize=8, loc="lower right")
    save_figure(fig, FIGURE)
    print(f"wrote {FIGURE}")


if __name__ == "__main__":
    main()
