"""Side-by-side equilibria of runs, with ratios and their uncertainties (``ringsim compare``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

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
from ringsim.analysis.size_bins import _fmt as _layer_fmt  # a layer may have no error
from ringsim.analysis.size_bins import pooled_pair_means

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
            [m["per_size_bin"][k][key] for m in members]) for key in PER_BIN
            if all(key in m["per_size_bin"][k] for m in members)}}
            for k, row in enumerate(members[0]["per_size_bin"])]
    eq["vertical_segregation"] = _combined_layers(members)
    eq["pair_epsilon"] = _combined_pairs(members)
    return eq


def _combined_layers(members: Sequence[dict]) -> dict | None:
    """The replicas' small- and large-particle layers (``analysis.size_bins``): each
    thickness and their ratio as the replica mean; None unless every replica has them."""
    found = [m.get("vertical_segregation") for m in members]
    layers = [g for g in found if g]
    if len(layers) < len(found):
        return None
    out: dict[str, object] = {name: {**layers[0][name], "thickness": _replica_layer(
        [g[name]["thickness"] for g in layers])} for name in ("small", "large")}
    out["ratio"] = _replica_layer([g["ratio"] for g in layers])
    out["definition"] = (f"{layers[0]['definition'].split('; mean over')[0]}; the mean over "
                         f"{len(layers)} replicas")
    out["in_window"] = all(g.get("in_window", True) for g in layers)
    out["units"] = layers[0].get("units", {})
    return out


def _replica_layer(values: Sequence[dict]) -> dict:
    """`budget.replica_mean` of layer values whose errors may be NaN (a layer from one
    snapshot has none): the propagated part from the finite errors, so that the replicas'
    scatter still gives an error; NaN only for one replica without an error."""
    finite = [v if math.isfinite(v["stderr"]) else {**v, "stderr": 0.0} for v in values]
    out = budget.replica_mean(finite)
    if len(values) == 1 and not math.isfinite(values[0]["stderr"]):
        out["stderr"] = out["stderr_propagated"] = math.nan
    return out


def _combined_pairs(members: Sequence[dict]) -> dict:
    """The replicas' eps per pair of size bins: their sampled collisions pooled (counts
    added, mean eps weighted by count); ``status`` off unless every replica has the same
    table."""
    tables = [m.get("pair_epsilon") or {} for m in members]
    if not all(t.get("status") == "on" and t["edges"] == tables[0]["edges"] for t in tables):
        return {"status": "off", "reason": "not every replica sampled collisions over the "
                "same size bins"}
    counts, mean = pooled_pair_means([t["counts"] for t in tables],
                                     [t["mean_epsilon"] for t in tables])
    return {**tables[0], "counts": counts, "mean_epsilon": mean}


#: The per-size-bin numbers `compare` divides between runs.
PER_BIN = ("velocity_dispersion", "thickness", "sigma_x", "sigma_y", "sigma_z",
           "rotational_energy_ratio")


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


def layer_ratios(eq: dict, base: dict) -> dict | None:
    """The ratios eq / base of the small- and the large-particle layers' thickness and of
    their ratio H_small / H_large, with propagated standard errors; None unless both runs
    have layers."""
    a, b = eq.get("vertical_segregation"), base.get("vertical_segregation")
    if not (a and b):
        return None
    return {"small": ratio(a["small"]["thickness"], b["small"]["thickness"]),
            "large": ratio(a["large"]["thickness"], b["large"]["thickness"]),
            "small_over_large": ratio(a["ratio"], b["ratio"])}


def pair_epsilon_difference(eq: dict, base: dict) -> dict | None:
    """eps(eq) - eps(base) of the law per pair of size bins, from the sampled collisions
    (NaN where either run sampled none of that pair), with both runs' counts; None unless
    both runs have the table over the same bins.  No error is given: the run file keeps
    the sums of eps per pair, not their spread."""
    a, b = eq.get("pair_epsilon") or {}, base.get("pair_epsilon") or {}
    if not (a.get("status") == b.get("status") == "on" and a["edges"] == b["edges"]):
        return None
    diff = np.asarray(a["mean_epsilon"], float) - np.asarray(b["mean_epsilon"], float)
    return {"edges": a["edges"], "difference": diff.tolist(), "counts": a["counts"],
            "counts_base": b["counts"], "layout": a["layout"],
            "units": {"edges": "m", "difference": "dimensionless", "counts": "count",
                      "counts_base": "count"}}


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
    ``significance`` is the difference in units of the combined statistical error; with
    size bins also ``per_size_bin``, ``layers`` (`layer_ratios`) and
    ``pair_epsilon_difference`` (`pair_epsilon_difference`), each None where a run lacks
    it),
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
        entry["layers"] = layer_ratios(eq, base)
        entry["pair_epsilon_difference"] = pair_epsilon_difference(eq, base)
        ratios.append(entry)
    warnings = [NOT_IN_EQUILIBRIUM.format(name=eq["name"], reason=eq["reason"])
                for eq in equilibria if not eq["in_equilibrium"]]
    warnings += [aggregation.AGGREGATING_WARNING.format(
        name=eq["name"], share=100 * eq["aggregation"]["bound_fraction_mean"])
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
        seg = eq.get("vertical_segregation")
        if seg:
            lines.append(f"{eq['name']}: layers (rms z, number-weighted within each) "
                         f"H_small {_layer_fmt(seg['small']['thickness'])} m, "
                         f"H_large {_layer_fmt(seg['large']['thickness'])} m, "
                         f"H_small / H_large {_layer_fmt(seg['ratio'])}")
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
        lines += _layer_lines(entry.get("layers"))
        lines += _pair_difference_lines(entry.get("pair_epsilon_difference"))
    lines.append(f"systematic budget: {comp.get('systematics', 'not measured')}")
    return "\n".join(lines)


def _per_bin_lines(rows: list[dict] | None) -> list[str]:
    """The per-size-bin ratios of one comparison (statistical errors only)."""
    if not rows:
        return []
    keys = [key for key in PER_BIN if key in rows[0]]
    names = {"velocity_dispersion": "c", "thickness": "H",
             "rotational_energy_ratio": "E_rot/E_tr"}
    lines = ["  per size bin, ratio ± stat:",
             f"    {'r [m]':<17}" + "".join(f"{names.get(key, key):>18}" for key in keys)]
    for row in rows:
        cells = "".join(f"{_fmt(row[key]):>18}" for key in keys)
        lines.append(f"    {row['r_low']:7.3g} - {row['r_high']:<7.3g}{cells}")
    return lines


def _layer_lines(layers: dict | None) -> list[str]:
    """The ratios of the small- and large-particle layers of one comparison."""
    if not layers:
        return []
    return ["  layers, ratio ± stat: " + ", ".join(
        f"{label} {_layer_fmt(layers[key])}" for key, label in
        (("small", "H_small"), ("large", "H_large"), ("small_over_large",
                                                     "H_small / H_large")))]


def _pair_difference_lines(diff: dict | None) -> list[str]:
    """The table of eps differences per pair of size bins of one comparison."""
    if not diff:
        return []
    edges = diff["edges"]
    names = [f"{lo:.3g}-{hi:.3g}" for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    lines = [f"  eps difference per pair of size bins (sampled collisions; {diff['layout']}; "
             "no error: the run files keep sums, not spreads):",
             "    r [m]            " + " ".join(f"{name:>12}" for name in names)]
    for i, name in enumerate(names):
        cells = [f"{d:+.3f}" if math.isfinite(d) else "-" for d in diff["difference"][i]]
        lines.append(f"    {name:<16} " + " ".join(f"{c:>12}" for c in cells))
    return lines
