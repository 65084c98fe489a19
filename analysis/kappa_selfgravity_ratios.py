"""The ratio kappa = 0.1 / kappa = 0 of the self-gravity campaign, and its error budget.

The runs' equilibria (``ringsim.analysis.equilibrium``) are grouped by case, kappa and
solver (``load_group``: only finished runs at their length, and only those the finder
calls stationary are kept), the seeds combined (``ringsim.analysis.compare``: replicas,
statistical error the larger of the propagated one and the seed scatter), and the ratio
formed with the systematic budget of ``analysis/data/kappa_selfgravity_budget_<size>.json``
(``write_budget`` measures it from the method variants of one case; ``solver_parts`` adds
the slab's difference from the tree).  The report (``kappa_selfgravity_report``) and the
P3M check (``kappa_selfgravity_p3m``) format what this module forms.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from kappa_comparison import relative_changes
from kappa_selfgravity_cases import (
    CASES,
    ROOT,
    SCENARIOS,
    SIZES,
    SYSTEMATIC_VARIANTS,
    VARIANT_KINDS,
    orbits,
    output,
    slab_output,
    variant_output,
)

from ringsim.analysis.budget import replica_mean
from ringsim.analysis.compare import comparison
from ringsim.analysis.compare import ratio as compare_ratio
from ringsim.analysis.equilibrium import TABLE_ROWS, equilibrium
from ringsim.analysis.timeseries import autocorrelated_mean
from ringsim.errors import InputError
from ringsim.physics.gravity import toomre_q
from ringsim.store.runfile import open_run

#: The quantities of the headline table: c and H.
HEADLINE = ("velocity_dispersion", "thickness")


def load_group(runs: Path, case: str, kappa: float, gravity: bool, seeds,
               slab: bool = False) -> dict:
    """Equilibria of one (case, kappa, gravity): ``kept`` (stationary), ``left_out`` (a line
    per run the finder did not call stationary), ``missing`` (seeds without a run).
    ``slab``: the gravity runs with the slab solver (``run_slab``) instead."""
    kept, left_out, missing = [], [], []
    for seed in seeds:
        path = (slab_output(runs, case, kappa, seed) if slab
                else output(runs, case, kappa, seed, gravity))
        if not path.exists():
            missing.append(seed)
            continue
        try:
            run = open_run(path)
        except (OSError, KeyError, InputError):   # being written, or damaged
            missing.append(seed)
            continue
        wanted = orbits(case, gravity, kappa, slab)
        if run.attrs.get("status") != "finished" or run.scenario.integration.orbits != wanted:
            missing.append(seed)     # still running, or not yet extended to its length
            continue
        eq = equilibrium(run)
        if not gravity:
            eq["toomre_Q"] = nograv_toomre_q(run, eq)
        (kept if eq["in_equilibrium"] else left_out).append(eq)
    return {"kept": kept, "left_out": [f"{e['name']} seed {e['scenario']['seed']}: "
                                       f"{e['reason']}" for e in left_out],
            "missing": missing}


def nograv_toomre_q(run, eq: dict) -> dict:
    """Toomre Q a run without self-gravity would have: Q = sigma_x Omega / (3.36 G Sigma)
    over its equilibrium window, Sigma [kg/m^2] from its first snapshot's masses."""
    snap = run.snapshot(0)
    sigma = float(np.sum(snap["mass"])) / (float(run.attrs["Lx"]) * float(run.attrs["Ly"]))
    ts = run.timeseries
    start = int(np.searchsorted(np.asarray(ts["orbits"]), eq["equilibrium_from_orbit"]["mean"]))
    q = toomre_q(np.sqrt(np.asarray(ts["sigma_xx"][start:])), sigma, float(run.attrs["Omega"]))
    mean, stderr, _ = autocorrelated_mean(q)
    return {"mean": float(mean), "stderr": float(stderr), "units": "dimensionless"}


def ratio(groups: list[dict], budget: dict | None) -> dict | None:
    """comparison() of [kappa 0, kappa 0.1] groups; None unless both have stationary runs."""
    if not all(g["kept"] for g in groups):
        return None
    return comparison(groups[0]["kept"] + groups[1]["kept"], budget)


def combined(group: dict, key: str) -> dict | None:
    """Seed mean of one quantity of a group (gravity rows are not in comparison())."""
    values = [e[key] for e in group["kept"] if key in e and math.isfinite(e[key]["mean"])]
    return replica_mean(values) if values else None


def quotient(a: dict | None, b: dict | None) -> dict | None:
    """a / b with first-order error (``ringsim.analysis.compare.ratio``); None without
    both."""
    return None if a is None or b is None else compare_ratio(a, b)


def fmt_quotient(q: dict | None) -> str:
    if q is None or not math.isfinite(q["mean"]):
        return ""
    return f"{q['mean']:.3g} ± {q['stderr']:.2g}"


def case_comps(groups: dict, slab: dict, budgets: dict) -> dict:
    """The comparisons kappa 0.1 / 0 of a case: no gravity (False), tree (True) and slab,
    each with its budget of ``budgets`` (None or missing: not measured)."""
    comps = {g: ratio([groups[(0.0, g)], groups[(0.1, g)]], budgets.get(g))
             for g in (False, True)}
    comps["slab"] = ratio([slab[0.0], slab[0.1]], budgets.get("slab"))
    return comps


def has_runs(group: dict) -> bool:
    """Whether a group has a finished run, stationary or not."""
    return bool(group["kept"] or group["left_out"])


def kappa0_values(group: dict) -> dict:
    """The table quantities of a group in the form ``relative_changes`` reads: key ->
    {"mean", "statistical"} (NaN where the group has none)."""
    out = {}
    for key in TABLE_ROWS:
        c = combined(group, key)
        out[key] = ({"mean": c["mean"], "statistical": c["stderr"]} if c
                    else {"mean": math.nan, "statistical": math.nan})
    return out


def solver_parts(loaded: dict) -> dict:
    """size distribution -> quantity -> the largest relative difference between slab and
    tree over the cases of that size distribution (or its statistical error if larger):
    of the ratio kappa 0.1 / 0 where both have it, else of the kappa = 0 ring where both
    have that (the ratio's denominator, and the ring gravity changes most).  The slab's
    systematic as a stand-in for the tree.  ``loaded``: case -> (groups, slab)."""
    parts: dict[str, dict[str, float]] = {}
    for case, (groups, slab) in loaded.items():
        comps = case_comps(groups, slab, {})
        if comps[True] is not None and comps["slab"] is not None:
            changes = relative_changes(comps[True]["ratios"][0], comps["slab"]["ratios"][0])
        elif groups[(0.0, True)]["kept"] and slab[0.0]["kept"]:
            changes = relative_changes(kappa0_values(groups[(0.0, True)]),
                                       kappa0_values(slab[0.0]))
        else:
            continue
        size = parts.setdefault(CASES[case][0], {})
        for key, value in changes.items():
            size[key] = max(size.get(key, 0.0), value)
    return parts


def case_budgets(case: str, budgets: dict, solver: dict) -> dict:
    """The budgets of a case's three ratios: no gravity, tree and slab (the slab's with the
    solver part added); None where not measured."""
    size = CASES[case][0]
    b = budgets.get(size)
    nograv = b["nograv"] if b else None
    gravity = b["slab"] if b else None
    relative = {key: dict(parts) for key, parts in
                (gravity["relative"] if gravity else {}).items()}
    for key, value in solver.get(size, {}).items():
        relative.setdefault(key, {})["gravity_solver"] = value
    return {False: nograv, True: gravity, "slab": {"relative": relative} if relative else None}


def budget_file(size: str) -> Path:
    """The systematic budget of the cases of size distribution ``size`` (``SIZES``)."""
    return ROOT / "analysis" / "data" / f"kappa_selfgravity_budget_{size}.json"


def load_budgets() -> dict:
    """size distribution -> its budget file's contents, for the files that exist."""
    return {size: json.loads(budget_file(size).read_text()) for size in SIZES
            if budget_file(size).exists()}


def write_budget(case: str, args, runs: Path) -> None:
    """The budget of ``case``'s size distribution from the variants of ``case``: for each
    kind of run (no gravity, slab), source and table quantity the relative change of the
    ratio kappa 0.1 / 0, or its statistical error if larger."""
    def group(paths):
        eqs = [equilibrium(open_run(p)) for p in paths if p.exists()]
        return {"kept": [e for e in eqs if e["in_equilibrium"]]}

    out, unmeasured = {}, []
    for kind in VARIANT_KINDS:
        base = ratio([load_group(runs, case, k, kind != "nograv", args.base_seeds,
                                 slab=kind == "slab") for k in SCENARIOS], None)
        relative: dict[str, dict[str, float]] = {key: {} for key in TABLE_ROWS}
        for source in SYSTEMATIC_VARIANTS:
            other = ratio([group([variant_output(runs, source, case, k, s, kind)
                                  for s in args.seeds]) for k in SCENARIOS], None)
            if base is None or other is None:
                unmeasured.append(f"{kind} {source}: no stationary "
                                  + ("base runs" if base is None else "variant runs")
                                  + " of both kappa values")
                continue
            for key, value in relative_changes(base["ratios"][0], other["ratios"][0]).items():
                relative[key][source] = value
        out[kind] = {"relative": {k: v for k, v in relative.items() if v}}
    path = budget_file(CASES[case][0])
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({
        "description": f"the no-gravity and slab runs of case {case} (seeds "
                       f"{list(args.base_seeds)}) again, seeds {list(args.seeds)}, with the "
                       "step halved (dt) and with twice the particles, a box sqrt(2) times as "
                       "wide (n_particles); each entry the relative change of the ratio "
                       "kappa 0.1 / 0, or its statistical error if larger",
        "measured_by": f"analysis/kappa_selfgravity.py --systematics {case}",
        "not_measured": unmeasured, **out},
        indent=1) + "\n")
