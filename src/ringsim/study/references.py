"""A study's cases against their reference values (``references`` of the study file,
``ringsim.config.study_references``): the entries of ``report.json`` and the section of
``report.md``.

A case agrees with a reference when its seed-averaged mean (``report.case_entry``) lies in
the reference's interval (the value plus or minus its tolerance, or the range) widened by
three standard errors of that mean: the rule of the validation ladder (docs/validation.md,
"Reference cases").  A reference with its own uncertainty ``sigma`` widens the interval by
three combined standard uncertainties, the mean's and the reference's in quadrature.  A
per-size-bin reference reads the report's ``by_size`` seed means (a ratio of two bins with
``analysis.compare.ratio``); a reference on a ratio of two cases reads the report's
``ratios`` entry, with its statistical and systematic errors in quadrature.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from ringsim.analysis import compare
from ringsim.analysis.equilibrium import TABLE_ROWS
from ringsim.config.study_references import (
    BY_SIZE_QUANTITIES,
    KEPT_REFERENCES,
    SPIN_REFERENCES,
)
from ringsim.quantities import QUANTITY
from ringsim.study.kept import kept_value
from ringsim.study.spin import SPIN_LABELS, spin_value

#: Standard errors of the case's mean by which a reference's interval is widened.
N_SIGMA = 3.0
#: How the verdict is reached (report.json and report.md say it once).
RULE = ("a case agrees when its seed-averaged mean lies within the reference's interval "
        "(value ± tolerance, or the range) widened by 3 standard errors of that mean; "
        "distance: how far outside the interval, in those standard errors (0 inside)")
#: Added to `RULE` when a reference has its own uncertainty.
RULE_SIGMA = ("; a reference with its own standard uncertainty sigma: widened by 3 combined "
              "standard uncertainties, sqrt(stderr^2 + sigma^2), and the distance in those")
#: Added to `RULE` when a reference is on a ratio of two cases.
RULE_RATIO = ("; a ratio of two cases: its mean and its error, statistical and systematic "
              "in quadrature (report.json ratios)")


def _ratio_value(reference, ratios: Sequence[Mapping]) -> dict:
    num, den = reference.ratio
    for r in ratios:
        if (r["numerator"], r["denominator"], r["quantity"]) == (num, den, reference.quantity):
            syst = r["syst"]
            error = (math.hypot(r["stat"], syst) if syst is not None and math.isfinite(syst)
                     else r["stat"])
            return {"mean": r["mean"], "stderr": error, "units": r["units"]}
    return {"mean": math.nan, "stderr": math.nan, "units": "dimensionless"}


def _bin_value(reference, by_size: Mapping | None) -> tuple[dict, dict]:
    """The per-size-bin value of a case (a ratio of two bins with ``over_bin``) and the
    entry's keys naming the bins."""
    missing = {"mean": math.nan, "stderr": math.nan, "units": ""}
    case = ((by_size or {}).get("cases") or {}).get(reference.case)
    key = BY_SIZE_QUANTITIES[reference.quantity]
    extra: dict = {"bin": reference.bin, "over_bin": reference.over_bin}
    if case is None:
        return missing, extra
    bins = case["bins"]

    def pick(k: int | None) -> Mapping | None:
        return bins[k] if k is not None and -len(bins) <= k < len(bins) else None

    top, bottom = pick(reference.bin), pick(reference.over_bin)
    if top is None or top[key] is None:
        return missing, extra
    extra["bin_radii"] = [top["r_low"], top["r_high"]]
    if reference.over_bin is None:
        return dict(top[key]), extra
    if bottom is None or bottom[key] is None:
        return missing, extra
    extra["over_bin_radii"] = [bottom["r_low"], bottom["r_high"]]
    r = compare.ratio(dict(top[key]), dict(bottom[key]))
    return {"mean": r["mean"], "stderr": r["stderr"], "units": r["units"]}, extra


def reference_entry(reference, cases: Mapping[str, Mapping], by_size: Mapping | None = None,
                    ratios: Sequence[Mapping] = ()) -> dict:
    """One reference with the case's mean, its distance from the interval [combined
    standard uncertainties] and the verdict."""
    extra: dict = {}
    if reference.ratio is not None:
        value = _ratio_value(reference, ratios)
        extra["ratio"] = list(reference.ratio)
    elif reference.quantity in BY_SIZE_QUANTITIES:
        value, extra = _bin_value(reference, by_size)
    elif reference.quantity in SPIN_REFERENCES:
        value = spin_value(cases[reference.case], reference.quantity)
    elif reference.quantity in KEPT_REFERENCES:
        value = kept_value(cases[reference.case], reference.quantity)
    else:
        value = cases[reference.case]["equilibrium"][reference.quantity]
    if reference.sigma:
        extra["sigma"] = reference.sigma
    mean, stderr = value["mean"], value["stderr"]
    error = math.hypot(stderr, reference.sigma)
    outside = max(reference.low - mean, mean - reference.high, 0.0)
    if not (math.isfinite(mean) and math.isfinite(stderr)):
        distance, agrees = math.nan, False
    elif outside == 0.0:
        distance, agrees = 0.0, True
    else:
        distance = outside / error if error > 0 else math.inf
        agrees = outside <= N_SIGMA * error
    return {"case": reference.case, "quantity": reference.quantity, "mean": mean,
            "stderr": stderr, "units": value["units"], "value": reference.value,
            "low": reference.low, "high": reference.high, "source": reference.source,
            "distance": distance, "agrees": agrees, **extra}


def reference_entries(references: Sequence, report: Mapping) -> list[dict]:
    """Every reference of a study, in file order, from the report's ``cases``, ``by_size``
    and ``ratios``."""
    return [reference_entry(r, report["cases"], report.get("by_size"),
                            report.get("ratios", ())) for r in references]


def rule(references: Sequence) -> str:
    """`RULE`, with what the study's references add to it."""
    return (RULE + (RULE_SIGMA if any(r.sigma for r in references) else "")
            + (RULE_RATIO if any(r.ratio for r in references) else ""))


def _shown(x: float | None, scale: float) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x * scale:.4g}"


def _label(e: Mapping) -> tuple[str, float]:
    """What a reference's row calls its quantity, and the scale of its numbers."""
    if e["quantity"] in BY_SIZE_QUANTITIES:
        label, unit, scale = TABLE_ROWS[BY_SIZE_QUANTITIES[e["quantity"]]]
        radii = e.get("bin_radii")
        text = label + (f", size bin {e['bin']}" if radii is None else
                        f", {radii[0]:.3g}-{radii[1]:.3g} m bin")
        if e.get("over_bin") is None:
            return text + (f" [{unit}]" if unit else ""), scale
        under = e.get("over_bin_radii")
        return text + (f" / bin {e['over_bin']}" if under is None else
                       f" / {under[0]:.3g}-{under[1]:.3g} m bin"), 1.0
    if e["quantity"] in SPIN_LABELS:
        return SPIN_LABELS[e["quantity"]], 1.0
    if e["quantity"] in KEPT_REFERENCES:
        kept = QUANTITY[e["quantity"]]
        return f"{kept.label} [{kept.shown}]" if kept.shown else kept.label, kept.scale
    label, unit, scale = TABLE_ROWS[e["quantity"]]
    if "ratio" in e:
        return f"{label}, ratio", 1.0
    return label + (f" [{unit}]" if unit else ""), scale


def _reference_text(e: Mapping, scale: float) -> str:
    if e["value"] is not None:
        tolerance = e["high"] - e["value"]
        text = _shown(e["value"], scale) + (f" ± {_shown(tolerance, scale)}"
                                            if tolerance or "sigma" not in e else "")
        return text + (f" (σ {_shown(e['sigma'], scale)})" if "sigma" in e else "")
    low, high = e["low"], e["high"]
    if low is None or not math.isfinite(low):
        return f"below {_shown(high, scale)}"
    if high is None or not math.isfinite(high):
        return f"above {_shown(low, scale)}"
    return f"{_shown(low, scale)} to {_shown(high, scale)}"


def references_section(entries: Sequence[Mapping], rule_text: str) -> list[str]:
    """``## Against the references``: every reference with the case's mean and verdict
    (empty without references)."""
    if not entries:
        return []
    lines = ["## Against the references", "", f"Rule: {rule_text}.", "",
             "| case | quantity | this study | reference | distance | verdict | source |",
             "|---|---|---|---|---|---|---|"]
    for e in entries:
        label, scale = _label(e)
        lines.append(f"| {e['case']} | {label} | "
                     f"{_shown(e['mean'], scale)} ± {_shown(e['stderr'], scale)} | "
                     f"{_reference_text(e, scale)} | {_shown(e['distance'], 1.0)} | "
                     f"{'agrees' if e['agrees'] else '**disagrees**'} | {e['source']} |")
    return lines + [""]
