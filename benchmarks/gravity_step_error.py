"""Benchmark: the error of one step's collisions in a self-gravitating sheet (issue 12).

A wake-forming sheet (1000 identical 1 m ice particles, tau = 0.5, a = 1e8 m from Saturn,
r_h = 0.82, Bridges law, REBOUND's tree for gravity) is integrated for ``--warm`` orbits
with line detection; then ``--states`` states ``--every`` steps apart are saved.  From each
saved state one step of dt = 1e-3 orbit is taken again with every method, whole or in k
sub-steps of dt / k:

* ``line``: line detection with kicked paths (the path of a step is two straight pieces,
  kinked by the gravity kick at mid-step; rs_sheet_detect.c, Method 1a);
* ``straight``: line detection with one straight path through the end-of-step velocities
  (before the kicked paths; kept as a switch for this measurement);
* ``tree``: REBOUND's tree search, overlaps at the ends of (sub-)steps.

Summed over the states: the energy the normal impulses dissipated [J], the collisions, and
the collisions faster than the law's v_c.  Both line and tree converge as k grows; the
difference of a whole step to the converged value is the method's error per step, free of
the chaos that makes long runs of one sheet differ by ~20 % from seed to seed.

    python benchmarks/gravity_step_error.py [--warm 1] [--states 20] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np
import rebound

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine.native import set_straight_paths
from ringsim.engine.resolver import install_resolver
from ringsim.engine.sheet import build_sheet
from ringsim.gravity.registry import install_scenario_gravity

LAW = {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234}
DT_ORBITS = 1e-3
METHODS = [("line", 1), ("straight", 1), ("tree", 1), ("line", 4), ("tree", 4),
           ("line", 16), ("tree", 16), ("line", 64), ("tree", 64)]


def scenario(seed: int, solver: str):
    return scenario_from_dict({
        "name": "step-error", "seed": seed, "planet": {"GM": 3.7931e16, "a": 1.0e8},
        "particles": {"density": 900.0,
                      "size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "sheet": {"optical_depth": 0.5, "n_particles": 1000, "gravity": True,
                  "gravity_solver": solver},
        "restitution": LAW,
        "integration": {"orbits": 3, "dt": DT_ORBITS, "collision_detection": "line"},
        "output": {"path": "unused.h5"}}, source="<benchmark>")


def saved_states(sc, warm: float, n: int, every: int, directory: Path) -> list[Path]:
    sim = build_sheet(sc).sim
    sim.integrate(warm * sc.orbital_period, exact_finish_time=0)
    paths = []
    for k in range(n):
        sim.steps(every)
        path = directory / f"state{k}.bin"
        sim.save_to_file(str(path))
        paths.append(path)
    return paths


def one_step(path: Path, sc, method: str, substeps: int) -> np.ndarray:
    """(dissipation [J], collisions, collisions above v_c) of one step from ``path``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # REBOUND: function pointers not restored
        sim = rebound.Simulation(str(path))
    install_scenario_gravity(sim, sc)
    if method == "tree":
        sim.collision = "tree"
        handle = install_resolver(sim, LAW, collision_detection="tree")
    else:
        handle = install_resolver(sim, LAW, collision_detection="line")
        set_straight_paths(handle.address, method == "straight")
    sim.dt = DT_ORBITS * sc.orbital_period / substeps
    sim.steps(substeps)
    stats = handle.stats()
    hist = stats["histograms"]["v_n"]
    fast = int(hist["counts"][hist["edges"][:-1] >= LAW["v_c"]].sum())
    return np.array([float(handle.stats_state()["normal_dissipation"]), stats["count"], fast])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--warm", type=float, default=1.0, help="orbits before the states")
    parser.add_argument("--states", type=int, default=20)
    parser.add_argument("--every", type=int, default=7, help="steps between the states")
    parser.add_argument("--seed", type=int, default=4)
    parser.add_argument("--solver", default="tree", choices=["tree", "p3m"])
    parser.add_argument("--json")
    args = parser.parse_args()
    sc = scenario(args.seed, args.solver)
    with tempfile.TemporaryDirectory() as tmp:
        states = saved_states(sc, args.warm, args.states, args.every, Path(tmp))
        totals = {f"{m} dt/{k}": sum(one_step(p, sc, m, k) for p in states) for m, k in METHODS}
    reference = totals["line dt/64"]
    results = {}
    for key, (diss, count, fast) in totals.items():
        results[key] = {"dissipation_J": float(diss), "collisions": int(count),
                        "collisions_above_v_c": int(fast),
                        "dissipation_vs_line_dt64": float(diss / reference[0] - 1.0)}
        print(f"{key:16s} dissipation {diss:.5e} J ({diss / reference[0] - 1:+.2e})  "
              f"collisions {count:.0f}  above v_c {fast:.0f}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"arguments": vars(args), "results": results},
                                              indent=1))


if __name__ == "__main__":
    main()
