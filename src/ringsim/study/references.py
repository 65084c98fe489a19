"""A study's cases against their reference values (``references`` of the study file,
``ringsim.config.study_references``): the entries of ``report.json`` and the section of
``report.md``.

A case agrees with a reference when its seed-averaged mean (``report.case_entry``) lies in
the reference's interval (the value plus or minus its tolerance, or the range) widened by
three standard errors of that mean: the rule of the validation ladder (docs/validation.md,
"Reference cases").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from ringsim.analysis.equilibrium import TABLE_ROWS

#: Standard errors of the case's mean by which a reference's interval is widened.
N_SIGMA = 3.0
#: How the verdict is reached (report.json and report.md say it once).
RULE = ("a case agrees when its seed-averaged mean lies within the reference's interval "
        "(value ± tolerance, or the range) widened by 3 standard errors of that mean; "
        "distance: how far outside the interval, in those standard errors (0 inside)")


def reference_entry(reference, cases: Mapping[str, Mapping]) -> dict:
    """One reference with the case's mean, its distance from the interval [standard errors]
    and the verdict."""
    value = cases[reference.case]["equilibrium"][reference.quantity]
    mean, stderr = value["mean"], value["stderr"]
    outside = max(reference.low - mean, mean - reference.high, 0.0)
    if not (math.isfinite(mean) and math.isfinite(stderr)):
        distance, agrees = math.nan, False
    elif outside == 0.0:
        distance, agrees = 0.0, True
    else:
        distance = outside / stderr if stderr > 0 else math.inf
        agrees = outside <= N_SIGMA * stderr
    return {"case": reference.case, "quantity": reference.quantity, "mean": mean,
            "stderr": stderr, "units": value["units"], "value": reference.value,
            "low": reference.low, "high": reference.high, "source": reference.source,
            "distance": distance, "agrees": agrees}


def reference_entries(references: Sequence, cases: Mapping[str, Mapping]) -> list[dict]:
    """Every reference of a study, in file order."""
    return [reference_entry(r, cases) for r in references]


def _shown(x: float | None, scale: float) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x * scale:.4g}"


def references_section(entries: Sequence[Mapping]) -> list[str]:
    """``## Against the references``: every reference with the case's mean and verdict
    (empty without references)."""
    if not entries:
        return []
    lines = ["## Against the references", "", f"Rule: {RULE}.", "",
             "| case | quantity | this study | reference | distance | verdict | source |",
             "|---|---|---|---|---|---|---|"]
    for e in entries:
        label, unit, scale = TABLE_ROWS[e["quantity"]]
        ref = (f"{_shown(e['value'], scale)} ± {_shown(e['high'] - e['value'], scale)}"
               if e["value"] is not None else
               f"{_shown(e['low'], scale)} to {_shown(e['high'], scale)}")
        lines.append(f"| {e['case']} | {label}{f' [{unit}]' if unit else ''} | "
                     f"{_shown(e['mean'], scale)} ± {_shown(e['stderr'], scale)} | {ref} | "
                     f"{_shown(e['distance'], 1.0)} | "
                     f"{'agrees' if e['agrees'] else '**disagrees**'} | {e['source']} |")
    return lines + [""]
