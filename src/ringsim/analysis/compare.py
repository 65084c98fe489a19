"""Side-by-side equilibria of runs, with ratios and their uncertainties (``ringsim compare``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from ringsim import quantities
from ringsim.analysis import aggregation, budget
from ringsim.analysis.equilibrium import (
    NOT_IN_EQUILIBRIUM,
    TABLE_ROWS,
    _fmt,
    _ratio_of,
    law_range_lines,
    size_ratio_line,
)

#: a / b with first-order propagated standard error (independent a and b).
ratio = _ratio_of


def _combined(members: Sequence[dict]) -> dict:
    """One equilibrium from replicas (runs differing only in seed): every table quantity is
    the replica mean (``budget.replica_mean``); names joined; in equilibrium only if every
    replica is."""
    if len(members) == 1:
        return members[0]
    eq = dict(members[0])
    eq["name"] = "+".join(m["name"] for m in members)
    for key in TABLE_ROWS:
        eq[key] = budget.replica_mean([m[key] for m in members])
    eq["in_equilibrium"] = all(m["in_equilibrium"] for m in members)
    eq["aggregating"] = any(m.get("aggregating") for m in members)
    eq["reason"] = "; ".join(f"{m['name']}: {m['reason']}" for m in members
                             if not m["in_equilibrium"]) or members[0]["reason"]
    eq["replicas"] = [m["name"] for m in members]
    if all(_same_bins(m, members[0]) for m in members):
        eq["per_size_bin"] = [{**row, **{key: budget.replica_mean(
            [m["per_size_bin"][k][key] for m in members]) for key in PER_BIN if key in row}}
            for k, row in enumerate(members[0]["per_size_bin"])]
    return eq


#: The per-size-bin numbers `compare` divides between runs.
PER_BIN = ("velocity_dispersion", "thickness", "sigma_x", "sigma_y", "sigma_z")


def _same_bins(a: dict, b: dict) -> bool:
    """Whether two equilibria have size bins, the same ones (edges to 1e-9)."""
    x, y = a.get("per_size_bin") or [], b.get("per_size_bin") or []
    return bool(x) and len(x) == len(y) and all(
        math.isclose(p[k], q[k], rel_tol=1e-9) for p, q in zip(x, y, strict=True)
        for k in ("r_low", "r_high"))


def per_bin_ratios(eq: dict, base: dict) -> list[dict] | None:
    """Per size bin, the ratio eq / base of each `PER_BIN` number with its propagated
    standard error, with the bin edges [m]; None unless both runs have the same bins."""
    if not _same_bins(eq, base):
        return None
    return [{"r_low": a["r_low"], "r_high": a["r_high"],
             **{key: ratio(a[key], b[key]) for key in PER_BIN if key in a and key in b}}
            for a, b in zip(eq["per_size_bin"], base["per_size_bin"], strict=True)]


def comparison(equilibria: Sequence[dict], systematics: dict | None = None) -> dict:
    """Side-by-side equilibria with ratios to the first, each with its error budget.

    Runs that differ only in their seed are replicas and are first combined
    (``budget.replica_groups``); each later group is divided by the first.  If every run is
    a replica of one case, they are compared with each other instead.

    Parameters
    ----------
    equilibria : list of ``ringsim.equilibrium`` results
    systematics : a budget (``budget.load_budget``), or None

    Returns
    -------
    dict with ``runs`` (the combined equilibria), ``ratios`` (for each later group, each
    table quantity's ratio with the keys ``mean``, ``stderr``, ``units``, ``statistical``,
    ``systematic``, ``systematic_parts``, ``total`` and ``significance``: ``stderr`` =
    ``statistical``; the systematic part is NaN where the budget has no entry;
    ``significance`` is the difference in units of the combined statistical error),
    ``all_in_equilibrium`` and
    ``warnings`` (one per run the finder did not call stationary and one per aggregating
    run, whose collision statistics are NaN and so are their ratios).
    """
    indices = budget.replica_groups(equilibria)
    if len(indices) == 1:  # only replicas of one case: compare them with each other
        indices = [[i] for i in range(len(equilibria))]
    groups = [_combined([equilibria[i] for i in g]) for g in indices]
    base = groups[0]
    ratios = []
    for eq in groups[1:]:
        entry = {"name": eq["name"], "relative_to": base["name"],
                 "in_equilibrium": bool(eq["in_equilibrium"] and base["in_equilibrium"])}
        for key in TABLE_ROWS:
            r = ratio(eq[key], base[key])
            combined = math.hypot(eq[key]["stderr"], base[key]["stderr"])
            diff = eq[key]["mean"] - base[key]["mean"]
            r["significance"] = float(diff / combined) if combined > 0 else math.nan
            r["statistical"] = r["stderr"]
            r["systematic"], r["systematic_parts"] = budget.systematic(systematics, key,
                                                                       r["mean"])
            r["total"] = math.hypot(r["statistical"], r["systematic"])
            entry[key] = r
        entry["per_size_bin"] = per_bin_ratios(eq, base)
        ratios.append(entry)
    warnings = [NOT_IN_EQUILIBRIUM.format(name=eq["name"], reason=eq["reason"])
                for eq in equilibria if not eq["in_equilibrium"]]
    warnings += [aggregation.AGGREGATING_WARNING.format(
        name=eq["name"], share=100 * eq["aggregation"]["bound_fraction_max"])
        for eq in equilibria if eq.get("aggregating")]
    return {"runs": groups, "ratios": ratios, "warnings": warnings,
            "all_in_equilibrium": not warnings,
            "systematics": (systematics or {}).get("description", "not measured")}


def _ratio_text(r: dict) -> str:
    if not math.isfinite(r["mean"]):
        return "n/a"
    syst = (f" ± {r['systematic']:.2g} (syst)" if math.isfinite(r["systematic"])
            else " (syst. not measured)")
    return f"{r['mean']:.4g} ± {r['statistical']:.2g} (stat){syst}"


def comparison_table(comp: dict) -> str:
    """Plain-text side-by-side table with ratios to the first group, warnings first."""
    runs = comp["runs"]
    width = max(22, *(len(eq["name"]) + 2 for eq in runs))
    lines = list(comp.get("warnings", []))
    lines.append(f"{'quantity':<48}" + "".join(f"{eq['name']:>{width}}" for eq in runs))
    for key in TABLE_ROWS:
        q = quantities.QUANTITY[key]
        lines.append(f"{q.headline_label:<48}"
                     + "".join(f"{_fmt(eq[key], q.scale):>{width}}" for eq in runs))
    lines.append(f"{'in equilibrium':<48}"
                 + "".join(f"{str(eq['in_equilibrium']):>{width}}" for eq in runs))
    lines.append(f"{'aggregating (collisions withheld)':<48}"
                 + "".join(f"{str(bool(eq.get('aggregating'))):>{width}}" for eq in runs))
    for eq in runs:
        line = size_ratio_line(eq.get("size_ratio"))
        if line:
            lines.append(f"{eq['name']}: {line}")
        lines += [f"{eq['name']}: {text}" for text in law_range_lines(eq)]
    for entry in comp["ratios"]:
        lines.append("")
        caveat = "" if entry["in_equilibrium"] else "  [NOT IN EQUILIBRIUM: see the warning]"
        lines.append(f"ratio {entry['name']} / {entry['relative_to']} "
                     f"(difference in combined standard errors){caveat}")
        for key in TABLE_ROWS:
            r = entry[key]
            lines.append(f"  {quantities.QUANTITY[key].weighted_label:<46} "
                         f"{_ratio_text(r):>44}   "
                         f"({r['significance']:+.1f} sigma)")
        lines += _per_bin_lines(entry.get("per_size_bin"))
    lines.append(f"systematic budget: {comp.get('systematics', 'not measured')}")
    return "\n".join(lines)


def _per_bin_lines(rows: list[dict] | None) -> list[str]:
    """The per-size-bin ratios of one comparison (statistical errors only)."""
    if not rows:
        return []
    keys = [key for key in PER_BIN if key in rows[0]]
    names = {"velocity_dispersion": "c", "thickness": "H"}
    lines = ["  per size bin, ratio ± stat:",
             f"    {'r [m]':<17}" + "".join(f"{names.get(key, key):>18}" for key in keys)]
    for row in rows:
        cells = "".join(f"{_fmt(row[key]):>18}" for key in keys)
        lines.append(f"    {row['r_low']:7.3g} - {row['r_high']:<7.3g}{cells}")
    return lines
