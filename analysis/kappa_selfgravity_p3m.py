"""The check of the slab solver by the full field (P3M) in ``analysis/kappa_selfgravity.py
--p3m``: ``write_p3m_check`` writes ``analysis/data/kappa_selfgravity_p3m_check.json`` (each
P3M run beside the slab run of the same seed, particles and box), and the report's section
on it and its flags under the headline are made from that file alone
(``p3m_check_lines``, ``slab_check_flags``), so they can be written where the report's
other runs are not.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from pathlib import Path

from kappa_selfgravity_cases import (
    CASES,
    P3M_CHECK,
    SCENARIOS,
    last_orbit,
    orbits,
    p3m_orbits,
    p3m_output,
    slab_output,
    tiled_output,
)
from kappa_selfgravity_ratios import HEADLINE, fmt_quotient, quotient

from ringsim.analysis import tiling
from ringsim.analysis.budget import replica_mean
from ringsim.analysis.equilibrium import equilibrium
from ringsim.store.runfile import open_run

#: The equilibrium quantities of each solver kept in ``P3M_CHECK`` (those with errors as
#: {"mean", "stderr", "units"}; ``wake_significant_fraction``, the fraction of snapshots
#: with a significant wake, as a number).
P3M_CHECK_KEYS = ("velocity_dispersion", "thickness", "toomre_Q", "toomre_Q_mass",
                  "gravitational_viscosity", "lambda_cr", "wake_wavelength", "wake_pitch_angle",
                  "wake_amplitude", "wake_significant_fraction")
#: Header of the section ``p3m_check_lines`` writes.
P3M_SECTION = "## The slab against the full field (P3M)"
#: Keys of ``P3M_CHECK``: "<case> kappa <k> seed <s>" for the case's own box, "<case> box
#: <b> kappa <k> seed <s>" for a box of b lambda_cr (``--p3m-box b``).
CHECK_KEY = re.compile(r"(\S+)(?: box (\S+))? kappa (\S+) seed (\d+)")


def check_key(case: str, kappa: float, seed: int, box: float | None = None) -> str:
    """The ``P3M_CHECK`` key of one seed (``CHECK_KEY``)."""
    return f"{case}{f' box {box:g}' if box else ''} kappa {kappa:g} seed {seed}"


def parse_key(name: str) -> tuple[str, str, float, int] | None:
    """(case, label, kappa, seed) of a ``P3M_CHECK`` key; the label names the box when it is
    not the case's own."""
    match = CHECK_KEY.fullmatch(name)
    if not match:
        return None
    label = match[1] if match[2] is None else f"{match[1]}, {match[2]} lambda_cr box"
    return match[1], label, float(match[3]), int(match[4])


def write_p3m_check(cases: list[str], args, runs: Path) -> None:
    """``P3M_CHECK``: the P3M runs of ``cases`` (``run_p3m``) against the slab runs of the
    same seeds: per seed and kappa the equilibrium quantities ``P3M_CHECK_KEYS`` of each
    solver, each run's stationarity and length, and slab / P3M of c and H with errors;
    printed too.  ``args.p3m_box``: the runs in a box of that many lambda_cr.
    The entries of other cases already in the file are kept."""
    box = getattr(args, "p3m_box", None)
    box_from = getattr(args, "tile_from", None)
    out = json.loads(P3M_CHECK.read_text()) if P3M_CHECK.exists() else {}
    for case in cases:
        for kappa in args.kappas:
            for seed in args.seeds:
                # a solver's entry whose run file is not here (made on another machine)
                # is kept as written
                row = {name: entry for name, entry in
                       out.get(check_key(case, kappa, seed, box), {}).items()
                       if name in ("p3m", "slab")}
                p3m = (tiled_output(runs, case, kappa, seed, box) if box_from
                       else p3m_output(runs, case, kappa, seed, box))
                lengths = {"p3m": p3m_orbits(case, kappa, box, tiled=bool(box_from)),
                           "slab": orbits(case, True, kappa, slab=True)}
                for name, path in (("p3m", p3m),
                                   ("slab", slab_output(runs, case, kappa, seed, box))):
                    if not path.exists():
                        continue
                    run = open_run(path)
                    eq = equilibrium(run)
                    row[name] = {key: {"mean": eq[key]["mean"], "stderr": eq[key]["stderr"],
                                       "units": eq[key]["units"]}
                                 for key in P3M_CHECK_KEYS if isinstance(eq.get(key), dict)}
                    row[name].update({key: float(eq[key]) for key in P3M_CHECK_KEYS
                                      if isinstance(eq.get(key), (int, float))})
                    # a run not yet at its length is never averaged, whatever the
                    # finder says of it so far: the lengths are fixed before the runs.
                    # The driver's length, not the file's own: a run finished at a shorter
                    # length than the driver's is not finished until it is extended.
                    reached = last_orbit(run)
                    finished = (run.attrs.get("status") == "finished"
                                and reached >= lengths[name] - 1e-9)
                    row[name].update({"in_equilibrium": bool(eq["in_equilibrium"]) and finished,
                                      "finder_stationary": bool(eq["in_equilibrium"]),
                                      "finished": finished,
                                      "length_orbits": float(lengths[name]),
                                      "orbits": reached,
                                      "box_lambda_cr": float(run.attrs["box_lambda_cr"])})
                    if name == "p3m" and box_from:
                        row[name].update(tiled_from_box_lambda_cr=box_from,
                                         copy_correlation=copy_correlation(run, eq))
                if len(row) == 2:
                    for key in HEADLINE:
                        q = quotient(row["slab"][key], row["p3m"][key])
                        row[f"slab/p3m {key}"] = {"mean": q["mean"], "stderr": q["stderr"],
                                                  "units": "1"}
                if not row:
                    continue
                out[check_key(case, kappa, seed, box)] = row
                print(f"{check_key(case, kappa, seed, box)}: "
                      + json.dumps({k: v for k, v in row.items() if k.startswith("slab/")}))
    P3M_CHECK.write_text(json.dumps(out, indent=1))


def copy_correlation(run, eq: dict, snapshots: int = 4) -> dict:
    """How far the copies of a tiled run have gone apart over its first ``snapshots``
    snapshots (``ringsim.analysis.tiling.copy_correlations``): orbits, and the largest
    correlation of a copy with copy 0 in the particles' velocities and in surface density
    (the largest over the copies; 1 identical, about 0 independent), and the orbit from
    which the equilibrium window may start (the run's equilibrium ``eq`` has it)."""
    out: dict = {"orbits": [], "velocity": [], "surface_density": []}
    for orbit, corr in itertools.islice(tiling.copy_correlations(run), snapshots):
        out["orbits"].append(orbit)
        for key in ("velocity", "surface_density"):
            out[key].append(max(corr[key]))
    out["independent_from_orbit"] = eq["tiled_copies_independent_from_orbit"]["mean"]
    return {**out, "units": "orbits; correlations dimensionless"}


def _check_value(row: dict, solver: str | None, key: str, scale: float,
                 digits: int = 4) -> str:
    """One cell of the check table: ``row[solver][key]`` (``row[key]`` for solver None)
    times ``scale``, ``digits`` significant digits."""
    value = (row if solver is None else row.get(solver, {})).get(key)
    if value is None or not math.isfinite(value["mean"]):
        return ""
    return f"{value['mean'] * scale:.{digits}g} ± {value['stderr'] * scale:.2g}"


def _stationary_text(entry: dict) -> str:
    """The stationary column of one run: the finder's verdict, or for a run not yet at its
    length (``finished`` False; a row without that key is of a finished run) how far it
    is and what the finder says so far."""
    if entry.get("finished", True):
        return str(entry["in_equilibrium"])
    return (f"not finished ({entry['orbits']:.0f} of {entry['length_orbits']:.0f} orbits; "
            f"so far {'stationary' if entry['finder_stationary'] else 'not stationary'})")


def p3m_check_lines(check: dict) -> list[str]:
    """Markdown of ``P3M_CHECK`` (``write_p3m_check``): each P3M run beside its slab twin
    (same particles, box and seed, ``_seed_rows``), and for every case with stationary P3M
    runs of both kappa values the ratio kappa = 0.1 / kappa = 0 with the full field beside
    the slab's of the same seeds (``_ratio_rows``), then the box convergence
    (``box_lines``)."""
    entries = []
    for name, row in check.items():
        parsed = parse_key(name)
        if parsed and "p3m" in row:
            entries.append((parsed[1], parsed[2], parsed[3], row))
    if not entries:
        return []
    entries.sort(key=lambda e: (e[0], e[1], e[2]))
    lines = [
        "Each P3M run (every mode the box holds, docs/gravity.md 4b) beside the slab run of "
        "the same seed, particles and box (`python analysis/kappa_selfgravity.py --p3m CASE "
        "--kappas K --seeds S`; analysis/data/kappa_selfgravity_p3m_check.json). Q (mass) is "
        "Toomre Q from the mass-weighted sigma_x; nu_g the gravitational viscosity; box the "
        "smaller side over lambda_cr (a case named with its box was run again in a larger "
        "box, `--p3m-box LAMBDA_CR`). The orbits and stationary columns read "
        "P3M / slab.", "",
        "| case | kappa | seed | box [lambda_cr] | orbits | c, P3M [mm/s] | c, slab [mm/s] | "
        "slab / P3M, c | H, P3M [m] | H, slab [m] | slab / P3M, H | Q (mass), P3M | "
        "Q (mass), slab | nu_g, P3M [1e-4 m^2/s] | stationary |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        *_seed_rows(entries)]
    ratio_rows = _ratio_rows(entries)
    if ratio_rows:
        lines += [
            "", "The ratio kappa = 0.1 / kappa = 0 with the full field (stationary P3M runs; "
            "statistical errors only), beside the slab's from the twins of the same seeds:",
            "", "| case | seeds, kappa 0 | seeds, kappa 0.1 | c: P3M | c: slab, same seeds | "
            "H: P3M | H: slab, same seeds |", "|---|---|---|---|---|---|---|", *ratio_rows]
    boxes = box_lines(check)
    return lines + (["", *boxes] if boxes else [])


def _seed_rows(entries: list[tuple]) -> list[str]:
    """The rows of the per-seed table of ``p3m_check_lines``: ``entries`` (label, kappa,
    seed, ``P3M_CHECK`` row)."""
    lines = []
    for case, kappa, seed, row in entries:
        orbit_text = " / ".join(f"{row[s]['orbits']:.0f}" for s in ("p3m", "slab") if s in row)
        stationary = " / ".join(_stationary_text(row[s]) for s in ("p3m", "slab")
                                if s in row)
        box = row["p3m"].get("box_lambda_cr")
        lines.append(
            f"| {case} | {kappa:g} | {seed} | {'' if box is None else f'{box:.2f}'} "
            f"| {orbit_text} "
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
    return lines


def _ratio_rows(entries: list[tuple]) -> list[str]:
    """The rows of the full field's ratio kappa = 0.1 / kappa = 0 (``p3m_check_lines``): per
    case with stationary P3M runs of both kappa values, c and H with P3M (those runs, seeds
    combined by ``replica_mean``) and with the slab (their stationary slab twins)."""
    rows = []
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
        rows.append(f"| {case} | {' '.join(map(str, seeds0))} | "
                    f"{' '.join(map(str, seeds1))} | " + " | ".join(cells) + " |")
    return rows


#: Columns of ``box_lines``: equilibrium key, header, scale, significant digits.
BOX_COLUMNS = (("velocity_dispersion", "c [mm/s]", 1e3, 4), ("thickness", "H [m]", 1.0, 4),
               ("toomre_Q_mass", "Q (mass)", 1.0, 3),
               ("gravitational_viscosity", "nu_g [1e-4 m^2/s]", 1e4, 2))


#: Share of snapshots with a significant wake above which ``box_lines`` gives the wake
#: wavelength (below it the ring forms no lasting wakes and the wavelength is noise).
WAKE_SHARE = 0.5


def box_groups(check: dict) -> dict:
    """case -> box [lambda_cr, the runs' mean] -> kappa -> the P3M entries of its stationary
    runs (``P3M_CHECK`` rows' "p3m" parts), for the cases with such runs in more than one
    box (the case's own and those of ``--p3m-box``)."""
    grouped: dict[str, dict[str | None, dict[float, list[dict]]]] = {}
    for name, row in check.items():
        match = CHECK_KEY.fullmatch(name)
        if match and row.get("p3m", {}).get("in_equilibrium"):
            (grouped.setdefault(match[1], {}).setdefault(match[2], {})
             .setdefault(float(match[3]), []).append(row["p3m"]))
    out = {}
    for case, by_label in grouped.items():
        if len(by_label) < 2:
            continue
        boxes = {}
        for by_kappa in by_label.values():
            rows = [r for runs in by_kappa.values() for r in runs]
            boxes[sum(r["box_lambda_cr"] for r in rows) / len(rows)] = by_kappa
        out[case] = dict(sorted(boxes.items()))
    return out


def box_lines(check: dict) -> list[str]:
    """Markdown: the box convergence of the full field, for every case run with P3M in more
    than one box (``box_groups``): per box and kappa the seeds-combined equilibrium
    (``replica_mean``), the wake wavelength over lambda_cr with the fraction of snapshots
    holding a significant wake, and the ratio kappa = 0.1 / kappa = 0 (statistical errors
    only).  A box with no stationary kappa = 0.1 run takes, for its ratio, those of the
    largest smaller box that has them, and says so: the kappa = 0.1 ring is hot enough
    (mass-weighted Q ~ 8) to form no wakes, so it should not depend on the box, which the
    row of the kappa = 0.1 runs in a larger box tests where they exist."""
    rows = []
    for case, boxes in box_groups(check).items():
        hot_box = None
        for box, by_kappa in boxes.items():
            combined = {k: {key: replica_mean([r[key] for r in runs]) for key, *_ in
                            BOX_COLUMNS if all(key in r for r in runs)}
                        for k, runs in by_kappa.items()}
            for kappa, runs in sorted(by_kappa.items()):
                wakes = [r["wake_wavelength"]["mean"] / r["lambda_cr"]["mean"] for r in runs
                         if r.get("wake_wavelength", {}).get("mean") is not None
                         and math.isfinite(r["wake_wavelength"]["mean"])]
                seen = sum(r.get("wake_significant_fraction", 0.0) for r in runs) / len(runs)
                cells = [_check_value(combined[kappa], None, key, scale, digits)
                         for key, _, scale, digits in BOX_COLUMNS]
                rows.append((case, box, kappa, len(runs), cells,
                             f"{sum(wakes) / len(wakes):.2f}"
                             if wakes and seen >= WAKE_SHARE else "-",
                             f"{100 * seen:.0f} %"))
            if 0.1 in combined:
                hot_box = box
            ratio = ""
            if 0.0 in combined and hot_box is not None:
                hot = boxes[hot_box]
                hot_mean = {key: replica_mean([r[key] for r in hot[0.1]])
                            for key in HEADLINE}
                ratio = ", ".join(
                    f"{label} {fmt_quotient(quotient(hot_mean[key], combined[0.0][key]))}"
                    for key, label in zip(HEADLINE, ("c", "H"), strict=True))
                if hot_box != box:
                    ratio += f" (kappa = 0.1 from the {hot_box:.2f} lambda_cr box)"
            rows[-1] = (*rows[-1], ratio)
    if not rows:
        return []
    lines = [
        "Box convergence of the full field: the P3M runs of each case in each box it was run "
        "in, seeds combined (statistical errors only); the share of snapshots with a "
        "significant wake, and the wake wavelength over lambda_cr where that share is at "
        f"least {100 * WAKE_SHARE:.0f} % (else -); the ratio kappa = 0.1 / kappa = 0 on the "
        "last row of each box.",
        "", "| case | box [lambda_cr] | kappa | seeds | "
        + " | ".join(head for _, head, *_ in BOX_COLUMNS)
        + " | wake wavelength [lambda_cr] | snapshots with wakes | ratio 0.1 / 0 |",
        "|" + "---|" * (7 + len(BOX_COLUMNS))]
    for case, box, kappa, n, cells, wake, seen, *ratio in rows:
        lines.append(f"| {case} | {box:.2f} | {kappa:g} | {n} | " + " | ".join(cells)
                     + f" | {wake} | {seen} | {ratio[0] if ratio else ''} |")
    return lines


def slab_check_flags(check: dict, solver: dict) -> list[str]:
    """Lines for under the headline: each case whose kappa = 0 ring the slab misses, by
    ``P3M_CHECK``, by more than the slab's ``gravity_solver`` part (``solver_parts``) and
    more than three standard errors (stationary runs of both solvers, seeds combined)."""
    pairs: dict[str, list[dict]] = {}
    size_of: dict[str, str] = {}
    with_ratio = set()
    for name, row in check.items():
        parsed = parse_key(name)
        if not parsed or not row.get("p3m", {}).get("in_equilibrium"):
            continue
        case, label, kappa, _ = parsed
        size_of[label] = CASES[case][0]
        if kappa != 0.0:
            with_ratio.add(label)
        elif row.get("slab", {}).get("in_equilibrium"):
            pairs.setdefault(label, []).append(row)
    lines = []
    for case, rows in sorted(pairs.items()):
        parts, flagged, means = [], False, []
        for key, label in zip(HEADLINE, ("c", "H"), strict=True):
            q = replica_mean([row[f"slab/p3m {key}"] for row in rows])
            allowed = max(3.0 * q["stderr"], solver.get(size_of[case], {}).get(key, 0.0))
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
                   else "No kappa = 0.1 P3M run of this case has finished stationary yet."
                   if case in CASES
                   else "No kappa = 0.1 P3M run in this box has finished stationary yet."))
    return lines
