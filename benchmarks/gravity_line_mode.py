"""Benchmark: line-mode collision detection in a self-gravitating sheet (issue 12).

Line mode resolves contacts on straight paths through the end-of-step positions with the
end-of-step velocities; SEI applies gravity as a kick between two drifts, so within a step
the true relative path bends by the kick (and by Hill's terms, without gravity too).  This
runs one small wake-forming sheet (1000 identical 1 m ice particles, tau = 0.5, a = 1e8 m
from Saturn, r_h = 0.82, Bridges law) for ``--orbits`` orbits from the same initial state:

* ``tree-ref``: tree detection (overlaps at step ends) at a small fixed step ``--dt-ref``;
* ``line``: line detection at 1e-3 orbit (its ``dt: auto`` limit);
* ``tree``: tree detection at 1e-3 orbit;

each with and without self-gravity, and compares the collision frequency, the deep
overlaps, the impact speeds and the velocity dispersion over the last orbit.  The
difference line - tree-ref with gravity, beside the same difference without gravity, is
what the gravity kick does to line mode.

    python benchmarks/gravity_line_mode.py [--orbits 2] [--dt-ref 2e-4] [--json OUT]
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


def scenario(gravity: bool, detection: str, dt_orbits: float, orbits: float):
    return scenario_from_dict({
        "name": f"line-grav-{detection}",
        "seed": 4,
        "planet": {"GM": 3.7931e16, "a": 1.0e8},
        "particles": {"density": 900.0,
                      "size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "sheet": {"optical_depth": 0.5, "n_particles": 1000, "gravity": gravity},
        "restitution": {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234},
        "integration": {"orbits": orbits, "dt": dt_orbits, "collision_detection": detection},
        "output": {"path": "runs/x.h5", "timeseries_every": 0.1, "snapshot_every": orbits},
    }, source="<benchmark>")


def measure(sc, directory: Path) -> dict:
    start = time.process_time()
    path = ringsim.run(sc, output=directory / f"{sc.name}.h5", force=True, progress=False)
    cpu = time.process_time() - start
    ts = ringsim.open_run(path).timeseries
    last = ts["orbits"] >= ts["orbits"][-1] - 1.0 + 1e-9
    n = 1000
    collisions = float(np.sum(ts["collisions"][last]))
    span = float(ts["orbits"][last][-1] - ts["orbits"][last][0] + 0.1)
    return {"cpu_s": cpu,
            "collision_frequency": collisions / n / span,
            "mean_impact_speed_mm_s": 1e3 * float(np.nanmean(ts["mean_impact_speed"][last])),
            "mean_epsilon": float(np.nanmean(ts["mean_epsilon"][last])),
            "velocity_dispersion_mm_s": 1e3 * float(np.mean(ts["velocity_dispersion"][last])),
            "thickness_m": float(np.mean(ts["thickness"][last])),
            "overlapping_pairs": float(np.mean(ts["overlapping_pairs"][last])),
            "multi_encounter_share": float(np.sum(ts["multi_encounters"][last])) / collisions}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbits", type=float, default=2.0)
    parser.add_argument("--dt-ref", type=float, default=2e-4)
    parser.add_argument("--json")
    args = parser.parse_args()
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for gravity in (False, True):
            for label, detection, dt in (("tree-ref", "tree", args.dt_ref),
                                         ("line", "line", 1e-3), ("tree", "tree", 1e-3)):
                key = f"{label}{' gravity' if gravity else ''}"
                results[key] = measure(scenario(gravity, detection, dt, args.orbits),
                                       Path(tmp))
                print(key, json.dumps(results[key]), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
