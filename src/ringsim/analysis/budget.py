"""Error budget of equilibrium ratios: statistical (seeds, autocorrelation) and systematic.

A ratio of two equilibria (``ringsim compare``) carries

* a **statistical** uncertainty: the autocorrelation-corrected standard errors of the two
  equilibria propagated to first order; when several runs differ only in their seed
  (replicas, `replica_groups`), each side is the mean over its replicas and its error is
  the larger of the propagated error and the scatter of the replicas about their mean
  (standard error of the mean over seeds), so that run-to-run variation the
  autocorrelation analysis misses is not hidden;
* a **systematic** uncertainty: how much the ratio moves when the method changes
  (collision detection line vs tree, time step, particle number, box size).  These are
  measured by dedicated runs (a study's ``variants``, ``ringsim study``) and stored in a
  budget file (JSON, format below); ``ringsim compare --systematics FILE`` adds them
  in quadrature.  Without a budget the systematic part is reported as "not measured"
  (NaN), never guessed.

Budget file::

    {"description": "...", "measured_by": "...",
     "relative": {"velocity_dispersion": {"collision_detection": 0.02, "dt": 0.005,
                                          "n_particles": 0.01, "box_size": 0.01}, ...}}

Each entry is the relative change of the RATIO [dimensionless] between the two variants of
that source (or its measured standard error, if larger), for the quantity named by its
``ringsim.equilibrium`` key.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ringsim.errors import InputError

#: Sources of systematic error a budget may name, with what each measures.
SOURCES = {
    "collision_detection": "ratio with line detection against tree detection (small dt)",
    "dt": "ratio with the time step halved",
    "n_particles": "ratio with a different particle number at the same optical depth",
    "box_size": "ratio with a different box aspect or size",
    "seeds": "ratio between independent replica sets",
    "gravity_solver": "ratio with the slab (mean vertical field) solver against the tree",
}


def load_budget(path: str | Path) -> dict:
    """Read and check a budget file; InputError naming the file and key if invalid."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise InputError(str(path), "--systematics", f"cannot read: {exc.strerror}") from None
    except json.JSONDecodeError as exc:
        raise InputError(str(path), "--systematics", f"not JSON ({exc.msg})") from None
    relative = data.get("relative") if isinstance(data, Mapping) else None
    if not isinstance(relative, Mapping):
        raise InputError(str(path), "relative", "missing: a mapping quantity -> source -> "
                         "relative systematic uncertainty of the ratio")
    for quantity, parts in relative.items():
        if not isinstance(parts, Mapping):
            raise InputError(str(path), f"relative.{quantity}", "not a mapping source -> value")
        for source, value in parts.items():
            if source not in SOURCES:
                raise InputError(str(path), f"relative.{quantity}.{source}",
                                 f"unknown source (one of {', '.join(SOURCES)})")
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value < 0:
                raise InputError(str(path), f"relative.{quantity}.{source}",
                                 f"{value!r} is not a finite number >= 0")
    return dict(data)


def systematic(budget: Mapping | None, quantity: str, value: float) -> tuple[float, dict]:
    """Systematic uncertainty of a ratio ``value`` of ``quantity`` [units of the ratio]:
    the budget's relative parts added in quadrature times |value|; NaN without a budget
    entry.  Returns (uncertainty, {source: relative part})."""
    parts = dict((budget or {}).get("relative", {}).get(quantity, {}))
    if not parts:
        return math.nan, {}
    relative = math.sqrt(sum(float(x) ** 2 for x in parts.values()))
    return abs(value) * relative, parts


def replica_key(eq: Mapping) -> str:
    """What replicas share: the scenario without its name, seed and output path."""
    scenario = json.loads(json.dumps(eq.get("scenario", {}), default=str))
    for key in ("name", "seed", "description"):
        scenario.pop(key, None)
    scenario.get("output", {}).pop("path", None)
    return json.dumps(scenario, sort_keys=True)


def replica_groups(equilibria: Sequence[Mapping]) -> list[list[int]]:
    """Indices of the equilibria grouped by `replica_key`, in order of first appearance."""
    groups: dict[str, list[int]] = {}
    for i, eq in enumerate(equilibria):
        groups.setdefault(replica_key(eq), []).append(i)
    return list(groups.values())


def replica_value(entry: Mapping) -> dict:
    """One replica's ``{"mean", "stderr", "units"}`` as `replica_mean` takes it, from a JSON
    entry whose non-finite numbers were written as null (read back as NaN)."""
    def number(x) -> float:
        return math.nan if x is None else float(x)

    return {"mean": number(entry.get("mean")), "stderr": number(entry.get("stderr")),
            "units": entry.get("units", "")}


def replica_mean(values: Sequence[Mapping]) -> dict:
    """Mean of replica values ``{"mean", "stderr", "units"}`` with the larger of the
    propagated error and the seed-to-seed standard error of the mean."""
    means = np.array([v["mean"] for v in values], dtype=float)
    errors = np.array([v["stderr"] for v in values], dtype=float)
    n = means.size
    propagated = float(np.sqrt(np.sum(errors**2)) / n)
    scatter = float(np.std(means, ddof=1) / math.sqrt(n)) if n > 1 else 0.0
    return {"mean": float(np.mean(means)), "stderr": max(propagated, scatter),
            "stderr_propagated": propagated, "stderr_seeds": scatter, "n_replicas": n,
            "units": values[0].get("units", "")}


def common_replicas(top: Sequence[int], bottom: Sequence[int]) -> list[int] | None:
    """The replicas (seeds) a ratio of two sets of replicas is taken over: None where both
    sets are the same (all of them), else those both have, sorted ([] where they share
    none: the ratio then compares different realisations, and says so).  A replica only
    one side has is another realisation, which would enter that side alone."""
    a, b = set(top), set(bottom)
    return None if a == b else sorted(a & b)


#: An error at most this fraction of its value is the round-off of equal values (the
#: replicas' scatter of a quantity they all have alike, such as the geometric optical
#: depth), which a table shows as 0 (`shown_error`).
ROUND_OFF = 1e-12


def shown_error(mean: float, error: float | None) -> float | None:
    """The error a table shows for ``mean`` [its units]: 0 where it is at most `ROUND_OFF`
    of the value, else as it is (None and NaN kept)."""
    if error is None or not (math.isfinite(error) and math.isfinite(mean)):
        return error
    return 0.0 if abs(error) <= ROUND_OFF * abs(mean) else error
