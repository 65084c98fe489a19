"""Benchmark: line-mode collision detection in a self-gravitating sheet (issue 12).

SEI applies gravity as a kick between two drifts, so within a step a particle's path is two
straight pieces (Hill's curvature aside).  Line mode follows both pieces (``rs_sheet_detect.c``,
Method 1a: "kicked paths"); before, it traced one straight path through the end-of-step
positions with the end-of-step velocities ("straight paths", kept as a switch for this
measurement only).  This runs one small wake-forming sheet (1000 identical 1 m ice
particles, tau = 0.5, a = 1e8 m from Saturn, r_h = 0.82, Bridges law, REBOUND's tree for
gravity as in the first measurement) for ``--orbits`` orbits from the same initial state:

* ``tree-ref``: tree detection (overlaps at step ends) at small fixed steps ``--dt-ref``;
* ``line``: line detection with kicked paths at 1e-3 orbit (its ``dt: auto`` limit) and at
  the smaller ``--dt-line`` steps;
* ``line-straight``: line detection with straight paths at 1e-3 orbit;
* ``tree``: tree detection at 1e-3 orbit;

each with self-gravity (and the first three without), for every seed of ``--seeds``, and
compares the collision frequency, the dissipation rate, the deep overlaps, the impact
speeds and the velocity dispersion and thickness over the last orbit.

    python benchmarks/gravity_line_mode.py [--orbits 2] [--seeds 4 5] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

import ringsim
from ringsim.config.scenario import scenario_from_dict
from ringsim.engine.native import set_straight_paths
from ringsim.engine.runner import Runner
from ringsim.engine.sheet import build_sheet

N_PARTICLES = 1000


def scenario(gravity: bool, detection: str, dt_orbits: float, orbits: float, seed: int):
    return scenario_from_dict({
        "name": f"line-grav-{detection}",
        "seed": seed,
        "planet": {"GM": 3.7931e16, "a": 1.0e8},
        "particles": {"density": 900.0,
                      "size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "sheet": {"optical_depth": 0.5, "n_particles": N_PARTICLES, "gravity": gravity,
                  **({"gravity_solver": "tree"} if gravity else {})},
        "restitution": {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234},
        "integration": {"orbits": orbits, "dt": dt_orbits, "collision_detection": detection,
                        "threads": 1},
        "output": {"path": "runs/x.h5", "timeseries_every": 0.1, "snapshot_every": orbits},
    }, source="<benchmark>")


def measure(sc, directory: Path, straight: bool = False) -> dict:
    """One run of ``sc`` (line detection with straight paths if ``straight``); the means
    over its last orbit."""
    path = directory / f"{sc.name}.h5"
    start = time.process_time()
    runner = Runner(sc, path, progress=False)
    built = build_sheet(sc)
    if straight:
        set_straight_paths(built.resolver.address, True)
    runner.start_new(built)
    runner.loop()
    cpu = time.process_time() - start
    ts = ringsim.open_run(path).timeseries
    last = ts["orbits"] >= ts["orbits"][-1] - 1.0 + 1e-9
    n = N_PARTICLES
    collisions = float(np.sum(ts["collisions"][last]))
    span = float(ts["orbits"][last][-1] - ts["orbits"][last][0] + 0.1)
    mass = n * 900.0 * 4.0 / 3.0 * np.pi
    return {"cpu_s": cpu,
            "collision_frequency": collisions / n / span,
            "dissipation_W_per_kg": float(np.sum(ts["normal_dissipation"][last]))
            / (span * sc.orbital_period) / mass,
            "mean_impact_speed_mm_s": 1e3 * float(np.nanmean(ts["mean_impact_speed"][last])),
            "mean_epsilon": float(np.nanmean(ts["mean_epsilon"][last])),
            "velocity_dispersion_mm_s": 1e3 * float(np.mean(ts["velocity_dispersion"][last])),
            "thickness_m": float(np.mean(ts["thickness"][last])),
            "overlapping_pairs": float(np.mean(ts["overlapping_pairs"][last])),
            "multi_encounter_share": float(np.sum(ts["multi_encounters"][last])) / collisions}


def variants(args) -> list[tuple[str, bool, str, float, bool]]:
    """(label, gravity, detection, dt [orbits], straight paths) of every run."""
    out = []
    for gravity in (False, True):
        out += [(f"tree-ref {dt:g}", gravity, "tree", dt, False) for dt in args.dt_ref]
        out += [(f"line {dt:g}", gravity, "line", dt, False) for dt in [1e-3] + args.dt_line]
        if gravity:
            out += [("line-straight 0.001", True, "line", 1e-3, True),
                    ("tree 0.001", True, "tree", 1e-3, False)]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbits", type=float, default=2.0)
    parser.add_argument("--dt-ref", type=float, nargs="+", default=[2e-4, 1e-4])
    parser.add_argument("--dt-line", type=float, nargs="*", default=[2.5e-4])
    parser.add_argument("--seeds", type=int, nargs="+", default=[4])
    parser.add_argument("--only", help="run only the variants whose label contains this")
    parser.add_argument("--json")
    args = parser.parse_args()
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            for label, gravity, detection, dt, straight in variants(args):
                if args.only and args.only not in label:
                    continue
                key = f"{label}{' gravity' if gravity else ''} seed {seed}"
                sc = scenario(gravity, detection, dt, args.orbits, seed)
                results[key] = measure(sc, Path(tmp), straight)
                print(key, json.dumps(results[key]), flush=True)
                if args.json:
                    Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
