"""What a study's run summaries keep beyond the equilibrium quantities when the study
asks for it (``keep``, ``config.study_references.KEPT_QUANTITIES``), and their seed means
per case.

* ``energy_budget``: the shear heating (9/4) Omega^2 Sigma nu_trans + (3/2) Omega
  (collisional momentum flux) against the dissipation the resolver counted, normal and
  tangential [W/m^2], their ratio (1 in a steady state) and the tangential share, each a
  window mean with its standard error (``analysis.spins.energy_budget``); null for a run
  file without the dissipation (REBOUND's resolver, ``integration.resolver``).
* ``aggregation``: the mean (the verdict's), the largest and the last share of the mass in
  bound Hill-sphere groups over the window's snapshots, the last share in contact groups,
  the multi-encounters per collision and the overlap guard's rows
  (``analysis.aggregation.run_aggregation``), each as ``{mean, stderr: 0, units}`` (one
  run's number: the seeds give the scatter), and the verdict ``aggregating``.
* ``thermal_balance``: the growth rate of ln c^2 [1/orbit] and the stress ratios
  sigma_xy / sigma_xx, sigma_yy / sigma_xx, sigma_zz / sigma_xx over the rows after the
  start's relaxation, with batch-means errors (``analysis.thermal``): whether a ring
  heats or cools where it has no stationary window.

A summary keeps only what its study names, so that the summaries of every other study are
unchanged, byte for byte.  A case's entry in ``report.json`` holds the seed means
(``budget.replica_mean``) of each kept entry every run of the case has; references name
them ``NAME.KEY`` (NaN, never agreeing, where the case has none).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

from ringsim.analysis import budget
from ringsim.analysis.thermal import thermal_balance
from ringsim.config.study_references import KEPT_QUANTITIES
from ringsim.quantities import QUANTITY


def _number(value: object, units: str) -> dict:
    """One run's number as ``{mean, stderr: 0, units}`` (NaN when it has none)."""
    mean = float(value) if isinstance(value, (int, float)) else math.nan
    return {"mean": mean, "stderr": 0.0, "units": units}


def kept_summary(eq: Mapping, names: Iterable[str], run=None) -> dict:
    """The kept entries ``names`` of a run's equilibrium (``ringsim.equilibrium``); ``run``
    (``ringsim.open_run``) for those read from its time series (``thermal_balance``)."""
    out: dict = {}
    for name in names:
        keys = KEPT_QUANTITIES[name]
        if name == "thermal_balance":
            out[name] = thermal_balance(run)
        elif name == "energy_budget":
            b = eq.get("energy_budget")
            out[name] = None if not b else {key: dict(b[key]) for key in keys}
        else:
            agg = eq.get("aggregation") or {}
            units = agg.get("units", {})
            out[name] = {key: _number(agg.get(key), units.get(key, "dimensionless"))
                         for key in keys}
            out[name]["aggregating"] = bool(agg.get("aggregating"))
    return out


def lacks_kept(summary: Mapping, names: Iterable[str]) -> bool:
    """Whether a summary lacks an entry its study keeps, or a key of one (it is then remade
    from its run file, when that is there)."""
    return any(name not in summary
               or (summary[name] and not set(KEPT_QUANTITIES[name]) <= set(summary[name]))
               for name in names)


def case_kept(summaries: Sequence[Mapping], names: Iterable[str]) -> dict:
    """The seed means of each kept entry that every run of a case has (a name whose entry
    some run lacks or holds null is left out, and so is a key some run's entry lacks: a
    summary kept by an older ringsim whose run file is gone)."""
    out: dict = {}
    for name in names:
        entries: list[Mapping] = [s[name] for s in summaries if s.get(name)]
        if not entries or len(entries) < len(summaries):
            continue
        out[name] = {key: budget.replica_mean([budget.replica_value(e[key])
                                               for e in entries])
                     for key in KEPT_QUANTITIES[name] if all(key in e for e in entries)}
        if name == "aggregation":
            out[name]["aggregating_runs"] = sum(bool(e.get("aggregating")) for e in entries)
    return out


def kept_value(case: Mapping, quantity: str) -> dict:
    """The case's seed mean of the kept ``NAME.KEY`` (NaN when the case has none)."""
    name, key = quantity.split(".", 1)
    entry = (case.get("kept") or {}).get(name) or {}
    return dict(entry.get(key, {"mean": math.nan, "stderr": math.nan,
                                "units": "dimensionless"}))


def kept_section(report: Mapping) -> list[str]:
    """The report's section "Kept": each kept entry's seed means per case (none without
    ``kept`` in the cases, so the reports of other studies are unchanged)."""
    cases = {case: entry["kept"] for case, entry in report["cases"].items()
             if "kept" in entry}
    if not cases:
        return []
    lines = ["## Kept", "", "What the summaries keep beyond the equilibrium (the study's "
             "`keep`): each case's mean over its seeds, with the larger of the propagated "
             "error and the seed-to-seed standard error of the mean; – where a run of the "
             "case lacks the entry.", ""]
    for name in KEPT_QUANTITIES:
        if not any(name in kept for kept in cases.values()):
            continue
        rows = []
        for key in KEPT_QUANTITIES[name]:
            q = QUANTITY[f"{name}.{key}"]
            rows.append([q.label + (f" [{q.shown}]" if q.shown else "")]
                        + [_shown(kept.get(name, {}).get(key), q.scale)
                           for kept in cases.values()])
        if name == "aggregation":
            rows.append(["aggregating runs"] + [str(kept[name]["aggregating_runs"])
                                                if name in kept else "–"
                                                for kept in cases.values()])
        lines += [f"`{name}`:", "", "| quantity | " + " | ".join(cases) + " |",
                  "|" + "---|" * (len(cases) + 1)]
        lines += ["| " + " | ".join(row) + " |" for row in rows] + [""]
    return lines


def _shown(value: Mapping | None, scale: float) -> str:
    """``mean ± stderr`` in the shown unit, or – without a value."""
    if not value or value.get("mean") is None or not math.isfinite(value["mean"]):
        return "–"
    err = budget.shown_error(value["mean"], value.get("stderr"))
    return (f"{value['mean'] * scale:.4g} ± "
            + ("n/a" if err is None or not math.isfinite(err) else f"{err * scale:.2g}"))
