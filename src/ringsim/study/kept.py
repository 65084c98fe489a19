"""What a study's run summaries keep beyond the equilibrium quantities when the study
asks for it (``keep``, ``config.study_references.KEPT_QUANTITIES``), and their seed means
per case.

* ``energy_budget``: the shear heating (9/4) Omega^2 Sigma nu_trans + (3/2) Omega
  (collisional momentum flux) against the dissipation the resolver counted, normal and
  tangential [W/m^2], their ratio (1 in a steady state) and the tangential share, each a
  window mean with its standard error (``analysis.spins.energy_budget``); null for a run
  file without the dissipation (REBOUND's resolver, ``integration.resolver``).
* ``aggregation``: the largest and the last share of the mass in bound Hill-sphere groups
  over the window's snapshots, the last share in contact groups, the multi-encounters per
  collision and the overlap guard's rows (``analysis.aggregation.run_aggregation``), each
  as ``{mean, stderr: 0, units}`` (one run's number: the seeds give the scatter), and the
  verdict ``aggregating``.

A summary keeps only what its study names, so that the summaries of every other study are
unchanged, byte for byte.  A case's entry in ``report.json`` holds the seed means
(``budget.replica_mean``) of each kept entry every run of the case has; references name
them ``NAME.KEY`` (NaN, never agreeing, where the case has none).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

from ringsim.analysis import budget
from ringsim.config.study_references import KEPT_QUANTITIES


def _number(value: object, units: str) -> dict:
    """One run's number as ``{mean, stderr: 0, units}`` (NaN when it has none)."""
    mean = float(value) if isinstance(value, (int, float)) else math.nan
    return {"mean": mean, "stderr": 0.0, "units": units}


def kept_summary(eq: Mapping, names: Iterable[str]) -> dict:
    """The kept entries ``names`` of a run's equilibrium (``ringsim.equilibrium``)."""
    out: dict = {}
    for name in names:
        keys = KEPT_QUANTITIES[name]
        if name == "energy_budget":
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
    """Whether a summary lacks an entry its study keeps (it is then remade from its run
    file, when that is there)."""
    return any(name not in summary for name in names)


def case_kept(summaries: Sequence[Mapping], names: Iterable[str]) -> dict:
    """The seed means of each kept entry that every run of a case has (a name whose entry
    some run lacks or holds null is left out)."""
    out: dict = {}
    for name in names:
        entries: list[Mapping] = [s[name] for s in summaries if s.get(name)]
        if not entries or len(entries) < len(summaries):
            continue
        out[name] = {key: budget.replica_mean([budget.replica_value(e[key])
                                               for e in entries])
                     for key in KEPT_QUANTITIES[name]}
        if name == "aggregation":
            out[name]["aggregating_runs"] = sum(bool(e.get("aggregating")) for e in entries)
    return out


def kept_value(case: Mapping, quantity: str) -> dict:
    """The case's seed mean of the kept ``NAME.KEY`` (NaN when the case has none)."""
    name, key = quantity.split(".", 1)
    entry = (case.get("kept") or {}).get(name) or {}
    return dict(entry.get(key, {"mean": math.nan, "stderr": math.nan,
                                "units": "dimensionless"}))
