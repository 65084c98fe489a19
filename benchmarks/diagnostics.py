"""Benchmark: ``snapshot_summary`` of a synthetic 10^6-particle shearing-sheet snapshot.

Prints the wall-clock time (target: < 1 s on a 2-core machine) and appends one row to the
"Diagnostics" section of docs/performance.md, creating the section (or the file) if
needed.  Other sections of that file are left untouched.

    python benchmarks/diagnostics.py [--n 1000000] [--repeat 5] [--no-write]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time
from pathlib import Path

import numpy as np

from ringsim.analysis import snapshot
from ringsim.physics.sizes import PowerLaw

PERFORMANCE_MD = Path(__file__).resolve().parent.parent / "docs" / "performance.md"
SECTION = "## Diagnostics"
SECTION_INTRO = """\
`ringsim.diagnostics.snapshot_summary` on a synthetic snapshot (seeded; power-law radii
0.5-5 m, Gaussian layer, anisotropic Maxwellian on the shear flow, 8 log-spaced size bins),
timed by `benchmarks/diagnostics.py`: first call and best of the repeats.  Target: < 1 s for
10^6 particles on a 2-core machine.

| date (UTC) | particles | first call [s] | best [s] | CPUs | machine | numpy |
|---|---|---|---|---|---|---|
"""


def synthetic_snapshot(n: int, seed: int = 1) -> dict[str, object]:
    """A ring patch of n particles at optical depth ~0.5 (SI units)."""
    rng = np.random.default_rng(seed)
    Omega = 2.0e-4  # [1/s]
    r_min, r_max, q = 0.5, 5.0, 3.0  # [m], [m], dN/dR ~ R^-q
    radius = PowerLaw(q=q, r_min=r_min, r_max=r_max).draw_radii(n, rng)
    mass = 900.0 * 4.0 / 3.0 * np.pi * radius**3
    side = float(np.sqrt(np.pi * np.sum(radius**2) / 0.5))  # tau = 0.5 in a square box
    x = rng.uniform(-side / 2, side / 2, n)
    y = rng.uniform(-side / 2, side / 2, n)
    z = rng.normal(0.0, 3.0, n)
    vx = rng.normal(0.0, 2e-3, n)
    vy = -1.5 * Omega * x + rng.normal(0.0, 1e-3, n)
    vz = rng.normal(0.0, 1.4e-3, n)
    return dict(x=x, y=y, z=z, vx=vx, vy=vy, vz=vz, radius=radius, mass=mass, Omega=Omega,
                Lx=side, Ly=side, size_bins=snapshot.log_size_bins(r_min, r_max, 8))


def append_row(row: str, path: Path = PERFORMANCE_MD) -> None:
    """Append a table row to the Diagnostics section; create the section if missing."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = path.read_text() if path.exists() else "# Performance\n"
    lines = text.splitlines()
    if SECTION not in lines:
        if lines and lines[-1].strip():
            lines.append("")
        lines += [SECTION, ""] + SECTION_INTRO.splitlines() + [row]
    else:
        start = lines.index(SECTION)
        end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")),
                   len(lines))
        # Insert after the last non-blank line of our section.
        last = end - 1
        while last > start and not lines[last].strip():
            last -= 1
        lines.insert(last + 1, row)
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="number of particles")
    parser.add_argument("--repeat", type=int, default=5, help="timed repeats after the first")
    parser.add_argument("--no-write", action="store_true", help="do not touch performance.md")
    args = parser.parse_args()

    snap = synthetic_snapshot(args.n)
    t0 = time.perf_counter()
    summary = snapshot.snapshot_summary(**snap)
    first = time.perf_counter() - t0
    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        snapshot.snapshot_summary(**snap)
        times.append(time.perf_counter() - t0)
    best = min(times) if times else first
    print(f"snapshot_summary, {args.n} particles: first call {first:.3f} s, "
          f"best of {args.repeat} {best:.3f} s (target < 1 s)")
    print(f"  c = {summary['velocity_dispersion']:.4g} m/s, tau = {summary['optical_depth']:.3f}, "
          f"FF = {summary['filling_factor']:.3f}, H = {summary['thickness']:.3f} m")
    if not args.no_write:
        date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")
        row = (f"| {date} | {args.n} | {first:.3f} | {best:.3f} | {os.cpu_count()} | "
               f"{platform.machine()} {platform.processor() or platform.system()} | "
               f"{np.__version__} |")
        append_row(row)
        print(f"appended to {PERFORMANCE_MD}")


if __name__ == "__main__":
    main()
