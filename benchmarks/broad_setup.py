"""Benchmark: set-up of broad rings, centimetre-to-metre particles (issue 39).

``build_sheet`` (radii, overlap-free placement, REBOUND simulation, resolver) of a power law
q = 3 from ``--r-min`` to 5 m at optical depth ``--tau``, with ``--n`` particles, Saturn's
A ring (a = 1.3e8 m), porous ice (450 kg/m^3), no gravity (the solver's installation is not
the placement): wall and CPU time, median of ``--repeat``, the peak RSS of the process, and
the placement's rounds of random draws.

    python benchmarks/broad_setup.py [--n 3.5e5] [--tau 0.3 0.5] [--r-min 0.025] [--repeat 3]

The machine is shared: CPU times are the steadier figure; wall times are medians.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine import sheet


def scenario(n: int, tau: float, r_min: float):
    """The broad ring of ``n`` particles of ``r_min`` [m] to 5 m at optical depth ``tau``."""
    return scenario_from_dict({
        "name": "broad-setup", "seed": 1, "planet": {"GM": 3.7931e16, "a": 1.3e8},
        "particles": {"density": 450.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": r_min, "r_max": 5.0}},
        "sheet": {"optical_depth": tau, "n_particles": int(n)},
        "restitution": {"model": "dilley", "kappa": 0.0},
        "integration": {"collision_detection": "line"},
    }, source="<benchmark>")


def measure(n: int, tau: float, r_min: float, repeat: int) -> dict:
    """Median wall and CPU time [s] of ``build_sheet``, and the box side [m]."""
    walls, cpus, side = [], [], 0.0
    sc = scenario(n, tau, r_min)
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        built = sheet.build_sheet(sc)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
        side = built.geometry.Lx
        del built
    return {"n": n, "tau": tau, "r_min_m": r_min, "box_m": side,
            "wall_s": statistics.median(walls), "cpu_s": statistics.median(cpus)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=float, nargs="+", default=[3.5e5])
    parser.add_argument("--tau", type=float, nargs="+", default=[0.3, 0.5])
    parser.add_argument("--r-min", type=float, default=0.025)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rows = [measure(int(n), tau, args.r_min, args.repeat) for n in args.n for tau in args.tau]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"rows": rows, "peak_rss_MB": peak}, indent=1))


if __name__ == "__main__":
    main()
