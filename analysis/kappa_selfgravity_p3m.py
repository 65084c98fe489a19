"""The check of the slab solver by the full field (P3M) in ``analysis/kappa_selfgravity.py
--p3m``: ``write_p3m_check`` writes ``analysis/data/kappa_selfgravity_p3m_check.json`` (each
P3M run beside the slab run of the same seed, particles and box), and the report's section
on it and its flags under the headline are made from that file alone
(``p3m_check_lines``, ``slab_check_flags``), so they can be written where the report's
other runs are not.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from kappa_selfgravity import CASES, P3M_CHECK, SCENARIOS, last_orbit, p3m_output, slab_output
from kappa_selfgravity_report import HEADLINE, fmt_quotient, quotient

from ringsim.analysis.budget import replica_mean
from ringsim.analysis.equilibrium import equilibrium
from ringsim.store.runfile import open_run

#: The equilibrium quantities of each solver kept in ``P3M_CHECK``.
P3M_CHECK_KEYS = ("velocity_dispersion", "thickness", "toomre_Q", "toomre_Q_mass",
                  "gravitational_viscosity")
#: Header of the section ``p3m_check_lines`` writes.
P3M_SECTION = "## The slab against the full field (P3M)"


def write_p3m_check(cases: list[str], args, runs: Path) -> None:
    """``P3M_CHECK``: the P3M runs of ``cases`` (``run_p3m``) against the slab runs of the
    same seeds: per seed and kappa the equilibrium quantities ``P3M_CHECK_KEYS`` of each
    solver, each run's stationarity and length, and slab / P3M of c and H with errors;
    printed too.
    The entries of other cases already in the file are kept."""
    out = json.loads(P3M_CHECK.read_text()) if P3M_CHECK.exists() else {}
    for case in cases:
        for kappa in args.kappas:
            for seed in args.seeds:
                row = {}
                for name, path in (("p3m", p3m_output(runs, case, kappa, seed)),
                                   ("slab", slab_output(runs, case, kappa, seed))):
                    if not path.exists():
                        continue
                    run = open_run(path)
                    eq = equilibrium(run)
                    row[name] = {key: {"mean": eq[key]["mean"], "stderr": eq[key]["stderr"],
                                       "units": eq[key]["units"]}
                                 for key in P3M_CHECK_KEYS if isinstance(eq.get(key), dict)}
                    row[name].update({"in_equilibrium": bool(eq["in_equilibrium"]),
                                      "orbits": last_orbit(run)})
                if len(row) == 2:
                    for key in HEADLINE:
                        q = quotient(row["slab"][key], row["p3m"][key])
                        row[f"slab/p3m {key}"] = {"mean": q["mean"], "stderr": q["stderr"],
                                                  "units": "1"}
                out[f"{case} kappa {kappa:g} seed {seed}"] = row
                print(f"{case} kappa {kappa:g} seed {seed}: "
                      + json.dumps({k: v for k, v in row.items() if k.startswith("slab/")}))
    P3M_CHECK.write_text(json.dumps(out, indent=1))


def _check_value(row: dict, solver: str | None, key: str, scale: float,
                 digits: int = 4) -> str:
    """One cell of the check table: ``row[solver][key]`` (``row[key]`` for solver None)
    times ``scale``, ``digits`` significant digits."""
    value = (row if solver is None else row.get(solver, {})).get(key)
    if value is None or not math.isfinite(value["mean"]):
        return ""
    return f"{value['mean'] * scale:.{digits}g} ± {value['stderr'] * scale:.2g}"


def p3m_check_lines(check: dict) -> list[str]:
    """Markdown of ``P3M_CHECK`` (``write_p3m_check``): each P3M run beside its slab twin
    (same particles, box and seed), and for every case with stationary P3M runs of both
    kappa values the ratio kappa = 0.1 / kappa = 0 with the full field beside the slab's of
    the same seeds (seeds combined as in the headline: ``replica_mean``)."""
    entries = []
    for name, row in check.items():
        match = re.fullmatch(r"(.+) kappa (\S+) seed (\d+)", name)
        if match and "p3m" in row:
            entries.append((match[1], float(match[2]), int(match[3]), row))
    if not entries:
        return []
    entries.sort(key=lambda e: (e[0], e[1], e[2]))
    lines = [
        "Each P3M run (every mode the box holds, docs/gravity.md 4b) beside the slab run of "
        "the same seed, particles and box (`python analysis/kappa_selfgravity.py --p3m CASE "
        "--kappas K --seeds S`; analysis/data/kappa_selfgravity_p3m_check.json). Q (mass) is "
        "Toomre Q from the mass-weighted sigma_x; nu_g the gravitational viscosity. A "
        "stationary column reads P3M / slab.", "",
        "| case | kappa | seed | orbits | c, P3M [mm/s] | c, slab [mm/s] | slab / P3M, c | "
        "H, P3M [m] | H, slab [m] | slab / P3M, H | Q (mass), P3M | Q (mass), slab | "
        "nu_g, P3M [1e-4 m^2/s] | stationary |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for case, kappa, seed, row in entries:
        orbit_text = " / ".join(f"{row[s]['orbits']:.0f}" for s in ("p3m", "slab") if s in row)
        stationary = " / ".join(str(row[s]["in_equilibrium"]) for s in ("p3m", "slab")
                                if s in row)
        lines.append(
            f"| {case} | {kappa:g} | {seed} | {orbit_text} "
            f"| {_check_value(row, 'p3m', 'velocity_dispersion', 1e3)} "
            f"| {_check_value(row, 'slab', 'velocity_dispersion', 1e3)} "
            f"| {_check_value(row, None, 'slab/p3m velocity_dispersion', 1.0)} "
            f"| {_check_value(row, 'p3m', 'thickness', 1.0)} "
            f"| {_check_value(row, 'slab', 'thickness', 1.0)} "
            f"| {_check_value(row, None, 'slab/p3m thickness', 1.0)} "
            f"| {_check_value(row, 'p3m', 'toomre_Q_mass', 1.0, 3)} "
            f"| {_check_value(row, 'slab', 'toomre_Q_mass', 1.0, 3)} "
            f"| {_check_value(row, 'p3m', 'gravitational_viscosity', 1e4, 2)} "
            f"| {stationary} |")
    ratio_rows = []
    for case in dict.fromkeys(e[0] for e in entries):
        groups = {}
        for kappa in SCENARIOS:
            kept = [row for c, k, _, row in entries
                    if c == case and k == kappa and row["p3m"]["in_equilibrium"]]
            twins = [row for row in kept if row.get("slab", {}).get("in_equilibrium")]
            seeds = [s for c, k, s, row in entries
                     if c == case and k == kappa and row["p3m"]["in_equilibrium"]]
            groups[kappa] = (kept, twins, seeds)
        if not all(groups[k][0] for k in SCENARIOS):
            continue
        (kept0, twins0, seeds0), (kept1, twins1, seeds1) = (groups[k] for k in SCENARIOS)
        cells = []
        for key in HEADLINE:
            for solver, zero, one in (("p3m", kept0, kept1), ("slab", twins0, twins1)):
                q = (quotient(replica_mean([r[solver][key] for r in one]),
                              replica_mean([r[solver][key] for r in zero]))
                     if zero and one else None)
                cells.append(fmt_quotient(q))
        ratio_rows.append(f"| {case} | {' '.join(map(str, seeds0))} | "
                          f"{' '.join(map(str, seeds1))} | " + " | ".join(cells) + " |")
    if ratio_rows:
        lines += [
            "", "The ratio kappa = 0.1 / kappa = 0 with the full field (stationary P3M runs; "
            "statistical errors only), beside the slab's from the twins of the same seeds:",
            "", "| case | seeds, kappa 0 | seeds, kappa 0.1 | c: P3M | c: slab, same seeds | "
            "H: P3M | H: slab, same seeds |", "|---|---|---|---|---|---|---|", *ratio_rows]
    return lines


def slab_check_flags(check: dict, solver: dict) -> list[str]:
    """Lines for under the headline: each case whose kappa = 0 ring the slab misses, by
    ``P3M_CHECK``, by more than the slab's ``gravity_solver`` part (``solver_parts``) and
    more than three standard errors (stationary runs of both solvers, seeds combined)."""
    pairs: dict[str, list[dict]] = {}
    for name, row in check.items():
        match = re.fullmatch(r"(.+) kappa (\S+) seed (\d+)", name)
        if (match and float(match[2]) == 0.0 and row.get("p3m", {}).get("in_equilibrium")
                and row.get("slab", {}).get("in_equilibrium")):
            pairs.setdefault(match[1], []).append(row)
    with_ratio = {match[1] for name, row in check.items()
                  if (match := re.fullmatch(r"(.+) kappa (\S+) seed (\d+)", name))
                  and float(match[2]) != 0.0 and row.get("p3m", {}).get("in_equilibrium")}
    lines = []
    for case, rows in sorted(pairs.items()):
        parts, flagged, means = [], False, []
        for key, label in zip(HEADLINE, ("c", "H"), strict=True):
            q = replica_mean([row[f"slab/p3m {key}"] for row in rows])
            allowed = max(3.0 * q["stderr"], solver.get(CASES[case][0], {}).get(key, 0.0))
            flagged |= abs(q["mean"] - 1.0) > allowed
            parts.append(f"{q['mean']:.3f} ± {q['stderr']:.3f} in {label}")
            means.append(q["mean"])
        if flagged:
            way = ("too high" if max(means) < 1.0 else "too low" if min(means) > 1.0
                   else "off")
            lines.append(
                f"- **{case}: the slab's ratio is biased.** Against the full field (P3M, "
                f"{len(rows)} seed{'s' if len(rows) > 1 else ''}) the slab's kappa = 0 ring "
                f"has slab / P3M = {', '.join(parts)}, beyond the slab's `gravity_solver` "
                f"part of the budget: its ratios here are {way}, the full field's being about "
                "the slab's times this factor (for kappa = 0 alone). "
                + ("The ratio with the full field is in \"The slab against the full field "
                   "(P3M)\" below." if case in with_ratio
                   else "No kappa = 0.1 P3M run of this case yet."))
    return lines
