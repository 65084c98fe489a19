"""Benchmark: one (B, phi) view of ``ringsim observe`` at a 1 % statistical error.

A synthetic snapshot (seeded): n identical 1 m spheres at uniform random positions in a square
box of optical depth 0.5 and a Gaussian layer of 2 m rms thickness, sheared images offset by
a third of the box.  For each n and opening angle B one view (phi = 30 deg) is traced at a
relative standard error of 1 % in tau_n (``analysis.occultation.trace_view``: a 2000-ray pilot,
then as many rays as ``rays_for`` asks, at most 200 000); the CPU time covers the cell list
and the rays.  Prints a Markdown table for docs/performance.md ("Synthetic occultations") and
writes the figure docs/figures/observe/speed.png.

    python benchmarks/observe.py [--n 10000 30000 100000 300000] [--no-figure]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from ringsim.analysis import occultation
from ringsim.plots.common import pyplot, save_figure, set_readable_axis

FIGURE = Path(__file__).resolve().parent.parent / "docs" / "figures" / "observe" / "speed.png"
ELEVATIONS = (3.45, 10.0, 30.0, 90.0)


def snapshot(n: int, tau: float = 0.5, seed: int = 1) -> tuple[dict, float]:
    """n spheres of 1 m at optical depth ``tau`` in a square box: (arrays [m], side [m])."""
    rng = np.random.default_rng(seed)
    L = math.sqrt(n * math.pi / tau)
    return {"x": (rng.random(n) - 0.5) * L, "y": (rng.random(n) - 0.5) * L,
            "z": rng.normal(0.0, 2.0, n), "radius": np.ones(n)}, L


def time_view(n: int, elevation: float) -> dict:
    """CPU time [s] of one view of an n-particle snapshot at 1 % in tau_n."""
    snap, L = snapshot(n)
    rng = np.random.default_rng(0)
    start = time.process_time()
    view = occultation.trace_view(snap, L, L, L / 3.0, elevation, 30.0, rng)
    seconds = time.process_time() - start
    rel = view["normal_optical_depth_stderr"] / view["normal_optical_depth"]
    return {"n": n, "elevation": elevation, "seconds": seconds, "rays": view["rays"],
            "relative_error": rel, "transmission": view["transmission"]}


def figure(rows: list[dict]):
    """CPU time per view against n, one line per B."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8.0, 4.8))
    for i, b in enumerate(ELEVATIONS):
        sel = [r for r in rows if r["elevation"] == b]
        worst = max(r["relative_error"] for r in sel)
        capped = f" (ray cap: up to {100 * worst:.1f} %)" if worst > 0.0105 else ""
        ax.plot([r["n"] for r in sel], [r["seconds"] for r in sel], "o-", color=f"C{i}",
                label=f"B = {b:g}°{capped}")
    set_readable_axis(ax, "x", [r["n"] for r in rows], log=True)
    set_readable_axis(ax, "y", [r["seconds"] for r in rows], log=True)
    ax.set_xlabel("particles in the snapshot")
    ax.set_ylabel("CPU time of one view at 1 % error in τ_n [s]")
    ax.set_title("ringsim observe: one (B, φ) view, cell list in the ray's frame")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[10000, 30000, 100000, 300000])
    parser.add_argument("--no-figure", action="store_true")
    args = parser.parse_args()
    rows = [time_view(n, b) for n in args.n for b in ELEVATIONS]
    print("| particles | B [deg] | T | rays | relative error of tau_n | CPU time [s] |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['n']} | {r['elevation']:g} | {r['transmission']:.3g} | {r['rays']} | "
              f"{100 * r['relative_error']:.2f} % | {r['seconds']:.2f} |")
    if not args.no_figure:
        print(f"wrote {save_figure(figure(rows), FIGURE)}")


if __name__ == "__main__":
    main()
