"""Side-by-side equilibria of runs, with ratios and their uncertainties (``ringsim compare``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from ringsim.analysis.equilibrium import TABLE_ROWS, _fmt, _value


def ratio(a: dict, b: dict) -> dict:
    """a / b with first-order propagated standard error (independent a and b)."""
    if not (b["mean"] and math.isfinite(b["mean"]) and math.isfinite(a["mean"])):
        return _value(math.nan, math.nan)
    r = a["mean"] / b["mean"]
    rel = math.hypot(a["stderr"] / a["mean"] if a["mean"] else 0.0, b["stderr"] / b["mean"])
    return _value(r, abs(r) * rel)


def comparison(equilibria: Sequence[dict]) -> dict:
    """Side-by-side equilibria with ratios to the first run.

    Returns
    -------
    dict with ``runs`` (the equilibria) and ``ratios``: for each later run, each table
    quantity divided by the first run's, ``{"mean", "stderr"}``, and the difference in
    units of the combined standard error (``significance``).
    """
    base = equilibria[0]
    ratios = []
    for eq in equilibria[1:]:
        entry = {"name": eq["name"], "relative_to": base["name"]}
        for key in TABLE_ROWS:
            r = ratio(eq[key], base[key])
            combined = math.hypot(eq[key]["stderr"], base[key]["stderr"])
            diff = eq[key]["mean"] - base[key]["mean"]
            r["significance"] = float(diff / combined) if combined > 0 else math.nan
            entry[key] = r
        ratios.append(entry)
    return {"runs": list(equilibria), "ratios": ratios}


def comparison_table(comp: dict) -> str:
    """Plain-text side-by-side table with ratios to the first run."""
    runs = comp["runs"]
    width = max(22, *(len(eq["name"]) + 2 for eq in runs))
    head = f"{'quantity':<40}" + "".join(f"{eq['name']:>{width}}" for eq in runs)
    lines = [head]
    for key, (label, unit, scale) in TABLE_ROWS.items():
        lines.append(f"{label + (f' [{unit}]' if unit else ''):<40}"
                     + "".join(f"{_fmt(eq[key], scale):>{width}}" for eq in runs))
    lines.append(f"{'in equilibrium':<40}"
                 + "".join(f"{str(eq['in_equilibrium']):>{width}}" for eq in runs))
    for entry in comp["ratios"]:
        lines.append("")
        lines.append(f"ratio {entry['name']} / {entry['relative_to']} "
                     "(difference in combined standard errors)")
        for key, (label, _unit, _scale) in TABLE_ROWS.items():
            r = entry[key]
            lines.append(f"  {label:<38} {_fmt(r):>20}   ({r['significance']:+.1f} sigma)")
    return "\n".join(lines)
