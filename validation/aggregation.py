"""Where ringsim's rings start to aggregate: a scan in r_h with small, cheap runs.

Identical 1 m ice spheres at tau = 0.25 with the Bridges law and P3M self-gravity, r_h set
by the orbital radius about Saturn, dt fixed at 5e-4 orbit; each run's last snapshots are
read with ``ringsim.analysis.aggregation`` (bound Hill-sphere groups, contact groups,
overlap-guard events).  Run from the repository root:

    python -m validation.aggregation OUT_DIR [--n 400] [--orbits 2] [--seeds 1 2]
                                             [--r-h 0.9 1.0 1.1 1.2 1.3]

It prints one Markdown row per run, the table of docs/validation.md ("Where the rings
start to aggregate"); the run files stay in OUT_DIR (about 10 CPU-seconds each).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import ringsim
from ringsim.analysis.aggregation import run_aggregation
from ringsim.config.scenario import scenario_from_dict
from ringsim.physics import gravity as patch

#: Saturn's GM [m^3/s^2].
GM_SATURN = 3.7931e16
#: Internal density of the particles [kg/m^3] (solid ice).
DENSITY = 900.0


def scenario(r_h: float, n: int, orbits: float, seed: int):
    """The scan's scenario at Hill parameter r_h (1 m ice, tau = 0.25, Bridges law)."""
    a = 1.0e8 * r_h / float(patch.hill_parameter(1.0, 1.0, DENSITY, GM_SATURN, 1.0e8))
    return scenario_from_dict({
        "name": f"aggregation-rh{r_h:g}", "seed": seed, "planet": {"GM": GM_SATURN, "a": a},
        "particles": {"density": DENSITY, "size_distribution": {"kind": "monodisperse",
                                                                "radius": 1.0}},
        "sheet": {"optical_depth": 0.25, "n_particles": n, "gravity": True},
        "restitution": {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234},
        "integration": {"orbits": orbits, "dt": 5e-4, "dt_safety": 0.2},
        "output": {"timeseries_every": 0.05, "snapshot_every": 0.25}}, source="<scan>")


def table_row(run, r_h: float, seed: int, orbits: float) -> str:
    """One Markdown row: the aggregation of the second half of a scan run."""
    agg = run_aggregation(run, from_orbit=0.5 * orbits)
    shares = [s["bound_fraction"] for s in agg["snapshots"]]
    last = agg["snapshots"][-1]
    return (f"| {r_h:g} | {seed} | {100 * min(shares):.0f}-{100 * max(shares):.0f} % "
            f"| {last['largest_bound_group']} | {100 * last['contact_fraction']:.0f} % "
            f"| {agg['overlap_rows']} of {agg['rows']} "
            f"| {100 * agg['multi_encounter_share']:.1f} % | {agg['aggregating']} |")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("--n", type=int, default=400)
    p.add_argument("--orbits", type=float, default=2.0)
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    p.add_argument("--r-h", type=float, nargs="+", default=[0.9, 1.0, 1.1, 1.2, 1.3])
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"{args.n} particles, {args.orbits:g} orbits; window: the second half "
          f"({len(args.seeds)} seeds)\n")
    print("| r_h | seed | mass bound in Hill groups (window snapshots) | largest bound group, "
          "last | in contact groups >= 10, last | rows with pairs overlapping > 10 % | "
          "multi-encounters per collision | aggregating |")
    print("|---|---|---|---|---|---|---|---|")
    for r_h in args.r_h:
        for seed in args.seeds:
            path = args.out / f"rh{r_h:g}-seed{seed}.h5"
            if not path.exists():
                ringsim.run(scenario(r_h, args.n, args.orbits, seed), output=path,
                            progress=False)
            print(table_row(ringsim.open_run(path), r_h, seed, args.orbits))


if __name__ == "__main__":
    main()
