"""Where a run's impacts lie against the ranges its restitution law was measured over.

Each law declares the impact speeds [m/s], reduced radii [m] and reduced masses [kg] its
parameters were measured at (``physics.restitution.RESTITUTION``, ``MeasuredRange``).  The
C resolver counts, per output interval, the impacts below and above each range, those
inside all three at once, and those whose law gives eps = 0 because its damping ratio
xi >= 1 (critical damping, Dilley 1993 eq. 5.9); the run file holds them as the
``law_*`` time series.  This module turns the counts of an equilibrium window into shares
of the window's impacts (``analyze``).
"""

from __future__ import annotations

import math

import numpy as np

from ringsim import quantities
from ringsim.physics.restitution import RESTITUTION

#: Share of impacts outside the speeds (or sizes, or masses) a law was measured over above
#: which ``analyze`` and ``compare`` warn that the result extrapolates the law.
LAW_RANGE_WARNING = 0.10

#: The measured dimensions: name, the label of the printed line.
DIMENSIONS = (("speeds", "impact speeds"), ("sizes", "reduced radii"),
              ("masses", "reduced masses"))


def law_range(ts: dict, start: int, model: str) -> dict | None:
    """Share of the equilibrium window's impacts (rows ``start:``) outside the impact speeds,
    reduced radii and reduced masses the restitution law's parameters were measured over,
    each split below and above the range, and the share the law gives eps = 0 (xi >= 1).
    None for run files without the counts.

    Returns
    -------
    dict with ``outside_X``, ``X_below``, ``X_above`` for X in speeds, sizes, masses
    [fraction of impacts; NaN without impacts, where the law states no range or where the
    run file lacks the count], ``critically_damped`` [fraction of impacts] and
    ``critically_damped_count`` [count] (NaN / -1 without the count), ``inside_all``
    [fraction of impacts] inside every measured range at once (`_inside_all`), the measured
    ranges ``speeds`` [m/s], ``sizes`` [m], ``masses`` [kg] (None where not stated),
    ``source`` and ``units``.
    """
    if "law_outside_speeds" not in ts:
        return None
    measured = RESTITUTION[model].measured
    impacts = float(np.sum(ts["collisions"][start:]))

    def share(key: str, declared) -> float:
        if declared is None or not impacts or key not in ts:
            return math.nan
        return float(np.sum(ts[key][start:])) / impacts

    out: dict = {}
    for what, _ in DIMENSIONS:
        declared = getattr(measured, what)
        below = share(f"law_{what}_below", declared)
        above = share(f"law_{what}_above", declared)
        outside = share(f"law_outside_{what}", declared)
        out[f"outside_{what}"] = outside if what != "masses" else below + above
        out[f"{what}_below"], out[f"{what}_above"] = below, above
        out[what] = list(declared) if declared else None
    critical = "law_critically_damped" in ts
    out["critically_damped"] = share("law_critically_damped", True)
    out["critically_damped_count"] = (int(np.sum(ts["law_critically_damped"][start:]))
                                      if critical else -1)
    out["inside_all"] = _inside_all(ts, start, measured)
    out["source"] = measured.source
    out["units"] = {key: quantities.unit(f"law_range.{key}") for key in out
                    if key != "source"}
    return out


def _inside_all(ts: dict, start: int, measured) -> float:
    """Share of the window's impacts inside every measured range at once [fraction]: NaN
    where the law states no range in one of the dimensions, or no row of the window holds
    the counter (rows written before it existed hold -1, and the row of an interval
    resumed from a checkpoint without it a large negative number: both are left out, with
    their impacts)."""
    if "law_inside_all" not in ts or any(getattr(measured, what) is None
                                         for what, _ in DIMENSIONS):
        return math.nan
    counts = np.asarray(ts["law_inside_all"][start:])
    kept = counts >= 0
    impacts = float(np.sum(np.asarray(ts["collisions"][start:])[kept]))
    return float(np.sum(counts[kept])) / impacts if impacts else math.nan


def law_range_lines(eq: dict) -> list[str]:
    """Lines saying how much of a run's equilibrium extrapolates its restitution law, below
    and above each measured range, with a WARNING above `LAW_RANGE_WARNING`, and the share
    of critically damped impacts."""
    rng = eq.get("law_range")
    if not rng:
        return []
    lines = []
    model = eq["restitution"]["model"]
    for what, _ in DIMENSIONS:
        share = rng.get(f"outside_{what}", math.nan)
        if rng.get(what) is None or not math.isfinite(share):
            continue
        shown = quantities.QUANTITY[f"law_range.{what}"]
        lo, hi = (x * shown.scale for x in rng[what])
        text = (f"{100 * share:.1f} % of impacts outside the {shown.label} the {model} law "
                f"was measured over ({lo:g}-{hi:g} {shown.shown})")
        below, above = rng.get(f"{what}_below", math.nan), rng.get(f"{what}_above", math.nan)
        if math.isfinite(below) and math.isfinite(above):
            text += f": {100 * below:.1f} % below, {100 * above:.1f} % above"
        warn = share > LAW_RANGE_WARNING
        lines.append(("WARNING: " if warn else "") + text
                     + ("; the result extrapolates the law" if warn else ""))
    inside = rng.get("inside_all", math.nan)
    if math.isfinite(inside):
        lines.append(f"{100 * inside:.1f} % of impacts inside all three measured ranges "
                     "at once (speeds, reduced radii and reduced masses)")
    if model == "dilley" and rng.get("critically_damped_count", -1) >= 0:
        lines.append(f"{100 * rng['critically_damped']:.2f} % of impacts critically damped "
                     f"(xi >= 1, eps = 0): {rng['critically_damped_count']} impacts")
    return lines
