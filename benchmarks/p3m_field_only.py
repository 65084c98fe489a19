"""P3M with field-only pairs (``sheet.p3m_pair_min_radius``): force error and cost.

A cool power-law sheet (0.25-5 m, q = 3, tau = 0.5, solid ice, placed as ``ringsim run``
places it) is given P3M with no field-only particles (the full solver, the baseline in the
same process) and with each radius of ``--radii``: pairs of two particles below it act
through the mesh only.  The split follows the scenario's rule (3 x the larger of the mean
radius and the field-only radius).  Errors: per-particle relative error, rms, against the
converged direct image sum (``physics.selfgravity``) on random targets, apart for the
particles of the pair sum and the field-only ones; cost: CPU time of one force evaluation
(median of the repeats, one thread).  With ``--write-doc`` the table replaces the section
"## P3M: field-only pairs" of docs/performance.md.

Usage: python benchmarks/p3m_field_only.py [--n 4000] [--radii 0.35 0.5 1.0] [--write-doc]
"""

from __future__ import annotations

import argparse
import platform
import time
from datetime import datetime, timezone

import numpy as np

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine.sheet import build_sheet, particle_arrays
from ringsim.physics.p3m_scales import P3M_SPLIT_RADII
from ringsim.physics.selfgravity import direct_accelerations, shear_offset
from ringsim.report import replace_section
from ringsim.testing import gravity as tg

T = 1234.5    # [s] a time with a non-zero shear offset


def sheet_of(n: int, seed: int) -> dict:
    sc = scenario_from_dict({
        "name": "field-only", "seed": seed, "planet": {"GM": 3.7931e16, "a": 1.3e8},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.25, "r_max": 5.0}},
        "sheet": {"optical_depth": 0.5, "n_particles": n, "initial_dispersion": 8.0}},
        source="benchmarks/p3m_field_only.py")
    built = build_sheet(sc)
    a = particle_arrays(built.sim)
    return {"pos": np.column_stack([a["x"], a["y"], a["z"]]),
            "vel": np.column_stack([a["vx"], a["vy"], a["vz"]]), "mass": a["mass"],
            "radius": a["radius"], "Lx": built.geometry.Lx, "Ly": built.geometry.Ly,
            "geometry": built.geometry}


def measure(sheet: dict, r_pair: float, split: float, repeats: int) -> tuple[np.ndarray, float]:
    """Accelerations [m/s^2] and the median CPU time [s] of one force evaluation."""
    sim = tg.p3m_simulation(sheet, t=T, split=split, softening=0.025,
                            pair_min_radius=r_pair)
    acc = tg.accelerations(sim)
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        tg.accelerations(sim)
        times.append(time.process_time() - t0)
    return acc, float(np.median(times))


def table(n: int, radii: list[float], repeats: int, seed: int) -> str:
    sheet = sheet_of(n, seed)
    mean_radius = float(np.mean(sheet["radius"]))
    targets = np.random.default_rng(0).choice(n, min(n, 400), replace=False)
    shift = shear_offset(sheet["geometry"].Omega, sheet["Lx"], sheet["Ly"], T)
    reference = direct_accelerations(sheet["pos"], sheet["mass"], sheet["Lx"], sheet["Ly"],
                                     shift, 0.025, targets=targets)
    rows = []
    full_cpu = None
    for r_pair in [0.0, *radii]:
        split = P3M_SPLIT_RADII * max(mean_radius, r_pair)   # the scenario's rule
        acc, cpu = measure(sheet, r_pair, split, repeats)
        full_cpu = cpu if full_cpu is None else full_cpu
        small = sheet["radius"] < r_pair
        small_t = small[targets]
        err = {name: (tg.force_errors(acc[targets][sel], reference[sel])["rms_relative"]
                      if sel.any() else float("nan"))
               for name, sel in (("pair", ~small_t), ("field", small_t))}
        rows.append(f"| {r_pair:g} | {split:.3f} | {small.mean():.3f} | "
                    f"{sheet['mass'][small].sum() / sheet['mass'].sum():.4f} | "
                    f"{err['pair']:.4f} | {err['field']:.4f} | {cpu * 1e3:.1f} | "
                    f"{cpu / full_cpu:.2f} |")
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = (f"## P3M: field-only pairs\n\n`python benchmarks/p3m_field_only.py --n {n} "
            f"--radii {' '.join(f'{r:g}' for r in radii)} --write-doc`, {when}, "
            f"{platform.machine()} {platform.system()}, one thread (the machine shared: CPU "
            f"times).  Sheet: {n} particles of 0.25-5 m (q = 3, solid ice), tau = 0.5, box "
            f"{sheet['Lx']:.1f} m, rms height {np.std(sheet['pos'][:, 2]):.2f} m, mean radius "
            f"{mean_radius:.3f} m; P3M's split as a scenario sets it, 3 x the larger of the "
            "mean radius and the field-only radius; errors against the direct image "
            f"sum on {len(targets)} random targets (per-particle relative error, rms).  Row "
            "0 is the full solver, the baseline in the same process.\n\n"
            "| field-only below [m] | split [m] | field-only by number | field-only by mass "
            "| rms error, pair-summed particles | rms error, field-only particles "
            "| CPU per evaluation [ms] | / full |\n|---|---|---|---|---|---|---|---|\n")
    return head + "\n".join(rows) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=4000)
    parser.add_argument("--radii", type=float, nargs="+", default=[0.35, 0.5, 1.0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    text = table(args.n, args.radii, args.repeats, args.seed)
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", "## P3M: field-only pairs", text, "Performance")


if __name__ == "__main__":
    main()
