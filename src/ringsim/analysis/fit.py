"""`ringsim fit`: fit coefficient-of-restitution laws to measured epsilon(v, R, M).

Data (CSV, header names carry units; lines starting with ``#`` are comments):

==============================  =========================================================
column                          meaning
==============================  =========================================================
``v_m_s``                       normal impact speed [m/s], > 0
``R_bar_m``                     reduced radius of the pair [m], > 0; or
``R1_m``, ``R2_m``              the two radii [m] (``inf``: a flat wall), reduced by
                                ``restitution.reduced_radius``
``M_bar_kg``                    reduced mass [kg], > 0; or
``M1_kg``, ``M2_kg``            the two masses [kg] (``inf``: a massive brick)
``epsilon``                     measured coefficient of restitution, in [0, 1]
``sigma``                       optional 1-sigma error of epsilon, > 0
==============================  =========================================================

Radius and mass columns are needed by the Dilley law only.  Models and their parameters
(SI, as a scenario's ``restitution`` section names them): dilley {xi0, p, kappa}, bridges
{v_c [m/s], exponent}, constant {epsilon}, andrews {v_c [m/s]}, tabor {v_c [m/s], q}.

The fit is weighted least squares (``scipy.optimize.least_squares``, trust-region
reflective) within the declared ranges of ``restitution.RESTITUTION`` made finite by one
rule (`_search_parameter`), started from the declared typical values (the paper's) and
from a linearised fit of the data, and for the
critical-speed laws from a grid of v_c across the measured speeds; the best start wins.
Standard errors come from the covariance (J^T J)^-1 of the weighted residuals' Jacobian at
the optimum.  Without a ``sigma`` column every point has unit weight and the covariance is
scaled by the reduced chi^2 (the JSON says which in ``sigma_source``).

AIC (lower is better): chi^2 + 2k with measured sigmas; n ln(RSS/n) + 2k with unit
weights (Gaussian errors of unknown, common variance), k = number of free parameters.

The mass exponent kappa is only identifiable if the reduced mass varies: when every point
has the same M_bar (the experiments of Hatzes et al. 1988, a sphere on a pendulum against a
brick), (M_bar / 60 g)^-kappa is a constant absorbed by xi0, so kappa is fixed at 0 and
reported as fixed.
"""

from __future__ import annotations

import difflib
import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from ringsim.analysis.fit_data import RestitutionData, read_data
from ringsim.config.scenario import scenario_from_dict
from ringsim.config.schema import ScenarioError
from ringsim.errors import InputError
from ringsim.physics import restitution as rs
from ringsim.physics.laws import Parameter
from ringsim.physics.restitution import RESTITUTION
from ringsim.plots.fits import plot_fits

__all__ = [
    "FIT_MODELS",
    "RestitutionData",
    "fit_command",
    "fit_model",
    "fit_models",
    "fit_table",
    "read_data",
    "restitution_yaml",
]

#: The models `ringsim fit` knows, in the order ``--model all`` fits them (as declared).
FIT_MODELS = RESTITUTION.names

_TOLERANCE = 1e-13  # ftol, xtol and gtol of least_squares
_MAX_EVALUATIONS = 5000
#: Starts (of lowest initial cost) from which the optimizer runs.
_OPTIMIZED_STARTS = 3
#: A singular value of the Jacobian below this fraction of the largest marks parameters the
#: data cannot separate.
_RANK_TOLERANCE = 1e-10


# --- models -------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Parameter:
    """A fitted parameter: search bounds [unit of the parameter], unit, and whether it is
    fitted as its logarithm (all derived from the declaration by `_search_parameter`)."""

    name: str
    unit: str
    lower: float
    upper: float
    log: bool = False


#: The search rule's half-width around the typical value, in the fitted coordinate (ln x for
#: parameters fitted as logarithms: 20 e-folds, a factor 5e8 either way).
SEARCH_HALF_WIDTH = 20.0
#: The search rule's inward shift of an open end, as a fraction of the search interval.
OPEN_END_MARGIN = 1e-9


def _search_parameter(par: Parameter) -> _Parameter:
    """The fit's finite search interval of a declared parameter (THE SEARCH RULE).

    A parameter declared in (0, inf) is fitted as its logarithm, any other as itself.  In
    that coordinate the search interval is the declared range, with each infinite end
    replaced by the parameter's typical value (its default, or its example if it is
    required) -/+ `SEARCH_HALF_WIDTH`, and each open finite end moved inward by
    `OPEN_END_MARGIN` times the interval (the optimizer's bounds are closed, the law refuses
    an open end itself).
    """
    log = par.lower == 0.0 and not par.lower_closed and par.upper == math.inf
    centre = math.log(par.typical) if log else par.typical
    lo = -math.inf if log else par.lower
    hi = math.inf if log else par.upper
    lo = centre - SEARCH_HALF_WIDTH if math.isinf(lo) else lo
    hi = centre + SEARCH_HALF_WIDTH if math.isinf(hi) else hi
    margin = OPEN_END_MARGIN * (hi - lo)
    if not log:
        lo += margin if math.isfinite(par.lower) and not par.lower_closed else 0.0
        hi -= margin if math.isfinite(par.upper) and not par.upper_closed else 0.0
    if log:
        lo, hi = math.exp(lo), math.exp(hi)
    return _Parameter(par.name, par.unit, lo, hi, log=log)


def _fitted(model: str) -> tuple[Parameter, ...]:
    """The declared parameters a fit varies: all but those declared ``implicit_at_default``
    (a reference scale such as Dilley's M_ref, degenerate with the amplitude, stays at its
    default and is not reported)."""
    return tuple(par for par in RESTITUTION[model].parameters if not par.implicit_at_default)


def _fit_parameters(model: str) -> tuple[_Parameter, ...]:
    return tuple(_search_parameter(par) for par in _fitted(model))


def _typical(model: str) -> dict[str, float]:
    """The declared typical values (defaults, or examples of required parameters)."""
    return {par.name: par.typical for par in _fitted(model)}


def _evaluate(model: str, values: Mapping[str, float], data: RestitutionData) -> np.ndarray:
    """epsilon of the model with these parameter values at the data's points."""
    return data.law_epsilon({"model": model, **values})


def _weights(data: RestitutionData) -> np.ndarray:
    return 1.0 / data.sigma if data.sigma is not None else np.ones_like(data.v)


def _sizes(data: RestitutionData) -> tuple[np.ndarray, np.ndarray]:
    """R_bar [m] and M_bar [kg] of data that has them (checked by `fit_model` for the
    dilley model); ValueError otherwise."""
    if data.R_bar is None or data.M_bar is None:
        raise ValueError(f"{data.source}: no reduced radii and masses")
    return data.R_bar, data.M_bar


def _linearised_starts(model: str, data: RestitutionData, fixed: Mapping[str, float]
                       ) -> list[dict[str, float]]:
    """Starts from straight-line fits: ln xi (dilley) or ln epsilon (bridges) vs ln v."""
    inside = (data.epsilon > 0) & (data.epsilon < 1)
    if np.count_nonzero(inside) < 3:
        return []
    v = data.v[inside]
    if model == "dilley":
        R_bar, M_bar = _sizes(data)
        xi = np.asarray(rs.xi_from_epsilon(data.epsilon[inside]))
        target = np.log(xi) + rs.RADIUS_EXPONENT * np.log(R_bar[inside] / rs.R_REF)
        columns = [np.ones_like(v), np.log(v / rs.V_REF)]
        if "kappa" not in fixed:
            columns.append(-np.log(M_bar[inside] / rs.M_REF))
        coef, *_ = np.linalg.lstsq(np.column_stack(columns), target, rcond=None)
        start = {"xi0": float(np.exp(coef[0])), "p": float(coef[1])}
        start["kappa"] = float(coef[2]) if "kappa" not in fixed else fixed["kappa"]
        return [start]
    if model == "bridges":
        slope, intercept = np.polyfit(np.log(v), np.log(data.epsilon[inside]), 1)
        if slope >= 0:
            return []
        exponent = -slope
        return [{"v_c": float(np.exp(intercept / exponent)), "exponent": float(exponent)}]
    if model == "constant":
        w = _weights(data) ** 2
        return [{"epsilon": float(np.sum(w * data.epsilon) / np.sum(w))}]
    return []


def _starts(model: str, data: RestitutionData, fixed: Mapping[str, float]
            ) -> list[dict[str, float]]:
    """Start values: the paper's, linearised fits, and a grid of v_c over the speeds."""
    paper = {k: v for k, v in _typical(model).items() if k not in fixed}
    starts = [{**paper, **fixed}] + _linearised_starts(model, data, fixed)
    if "v_c" in RESTITUTION[model].names:
        v_grid = np.geomspace(data.v.min() / 3.0, data.v.max(), 8)
        others = {k: v for k, v in _typical(model).items() if k != "v_c"}
        shapes = [{**others, "q": q} for q in (0.2, others["q"], 0.45)] if "q" in others \
            else [others]
        starts += [{"v_c": float(v_c), **shape} for v_c in v_grid for shape in shapes]
    return starts


def _to_internal(params: Sequence[_Parameter], values: Mapping[str, float]) -> np.ndarray:
    x = []
    for par in params:
        value = min(max(values[par.name], par.lower), par.upper)
        lo, hi = (math.log(par.lower), math.log(par.upper)) if par.log else (par.lower,
                                                                           par.upper)
        internal = math.log(value) if par.log else value
        margin = 1e-9 * (hi - lo)  # least_squares starts strictly inside the bounds
        x.append(min(max(internal, lo + margin), hi - margin))
    return np.array(x)


def _to_values(params: Sequence[_Parameter], x: np.ndarray) -> dict[str, float]:
    return {par.name: float(math.exp(xi) if par.log else xi)
            for par, xi in zip(params, x, strict=True)}


def _covariance(jacobian: np.ndarray) -> np.ndarray | None:
    """(J^T J)^-1 by SVD; None if J is rank deficient (parameters not separable)."""
    if jacobian.size == 0:
        return np.zeros((0, 0))
    _, s, vt = np.linalg.svd(jacobian, full_matrices=False)
    if s[-1] <= _RANK_TOLERANCE * s[0] or not np.all(np.isfinite(s)):
        return None
    return (vt.T / s**2) @ vt


def _identifiability_notes(data: RestitutionData) -> tuple[dict[str, float], list[str]]:
    """Parameters fixed because the data cannot constrain them, and notes about the data."""
    fixed: dict[str, float] = {}
    notes: list[str] = []
    R_bar, M_bar = _sizes(data)
    if np.unique(M_bar).size == 1:
        fixed["kappa"] = 0.0
        notes.append(f"kappa fixed at 0: every point has the same reduced mass "
                     f"({M_bar[0]:.6g} kg), so (M_bar/60 g)^-kappa is a constant "
                     "absorbed by xi0")
    elif np.unique(R_bar).size > 1:
        ln_r, ln_m = np.log(R_bar), np.log(M_bar)
        slope, intercept = np.polyfit(ln_r, ln_m, 1)
        if np.max(np.abs(ln_m - (slope * ln_r + intercept))) < 1e-9:
            notes.append(f"M_bar varies only as R_bar^{slope:.3g}: kappa is separated from "
                         "the size dependence only through the fixed Hertz exponent "
                         "R_bar^-0.2")
    return fixed, notes


def _best_fit(residuals, starts: list[np.ndarray], lower: np.ndarray, upper: np.ndarray):
    """scipy's least_squares (trust-region reflective, bounded) from each start; the best
    successful result (lowest cost)."""
    from scipy.optimize import least_squares

    best = None
    for x0 in starts:
        result = least_squares(residuals, x0, jac="3-point",
                               bounds=(lower, upper), method="trf", x_scale="jac",
                               ftol=_TOLERANCE, xtol=_TOLERANCE, gtol=_TOLERANCE,
                               max_nfev=_MAX_EVALUATIONS)
        if best is None or (result.success, -result.cost) > (best.success, -best.cost):
            best = result
    return best


def _aic(chi2: float, n: int, k: int, measured_sigma: bool) -> dict:
    """AIC of a fit: chi2 + 2k with measured sigmas, n ln(RSS/n) + 2k with unit weights
    (Gaussian errors of unknown common variance); with its definition and the sigmas'
    source."""
    if measured_sigma:
        return {"aic": float(chi2 + 2.0 * k), "aic_definition": "chi2 + 2k",
                "sigma_source": "sigma column"}
    rss_per_point = max(chi2 / n, np.finfo(float).tiny)
    return {"aic": float(n * math.log(rss_per_point) + 2.0 * k),
            "aic_definition": "n ln(RSS/n) + 2k (unit weights)",
            "sigma_source": "none: unit weights, covariance scaled by the reduced chi2"}


def _parameter_entries(declared, free, values: dict, fixed: dict, covariance, x: np.ndarray,
                       bounds: tuple[np.ndarray, np.ndarray], notes: list[str]) -> dict:
    """{name: {"value", "stderr", "fixed"}} of a fit; a note for a parameter at a bound.

    ``x`` and ``bounds`` are in the fitted (internal) coordinates; d(value)/d(internal) =
    value for parameters fitted as logarithms."""
    scale = np.array([values[p.name] if p.log else 1.0 for p in free])
    parameters: dict[str, dict] = {}
    for par in declared:
        if par.name in fixed:
            parameters[par.name] = {"value": fixed[par.name], "stderr": None, "fixed": True}
            continue
        i = free.index(par)
        stderr = (None if covariance is None
                  else float(scale[i] * math.sqrt(max(covariance[i, i], 0.0))))
        parameters[par.name] = {"value": values[par.name], "stderr": stderr, "fixed": False}
        lo, hi = bounds[0][i], bounds[1][i]
        if min(x[i] - lo, hi - x[i]) <= 1e-8 * (hi - lo):
            notes.append(f"{par.name} is at a bound of its allowed range; its standard error "
                         "is not meaningful")
    return parameters


def fit_model(data: RestitutionData, model: str) -> dict:
    """Fit one restitution law by weighted least squares.

    Parameters
    ----------
    data : RestitutionData
    model : str
        dilley, bridges, constant, andrews or tabor.

    Returns
    -------
    dict
        ``{"model", "parameters": {name: {"value", "stderr", "fixed"}}, "chi2",
        "reduced_chi2", "aic", "n_points"}`` as in docs/interface.md, plus ``n_free_parameters``,
        ``sigma_source``, ``aic_definition``, ``units`` (of each parameter), ``note``,
        ``success`` and ``message`` of the optimizer.  Parameters are SI (v_c in m/s);
        stderr is None for a fixed parameter or when the data cannot separate the
        parameters.
    """
    if model not in FIT_MODELS:
        raise ValueError(f"unknown model {model!r} (one of {', '.join(FIT_MODELS)})")
    if model == "dilley" and not data.has_sizes:
        raise InputError(data.source, "R_bar_m", "the dilley model needs reduced radii and "
                         "masses (R_bar_m and M_bar_kg, or R1_m, R2_m, M1_kg, M2_kg)")
    fixed, notes = _identifiability_notes(data) if model == "dilley" else ({}, [])
    declared = _fit_parameters(model)
    free = tuple(p for p in declared if p.name not in fixed)
    n, k = len(data), len(free)
    if n <= k:
        raise InputError(data.source, "<rows>", f"{n} data rows; the {model} model needs "
                         f"more than its {k} free parameters")
    weights = _weights(data)

    def residuals(x: np.ndarray) -> np.ndarray:
        values = {**_to_values(free, x), **fixed}
        return (_evaluate(model, values, data) - data.epsilon) * weights

    lower = np.array([math.log(p.lower) if p.log else p.lower for p in free])
    upper = np.array([math.log(p.upper) if p.log else p.upper for p in free])
    # the optimizer runs from the few starts of lowest cost
    starts = [_to_internal(free, start) for start in _starts(model, data, fixed)]
    costs = [float(np.sum(residuals(x) ** 2)) for x in starts]
    order = np.argsort(costs, kind="stable")[:_OPTIMIZED_STARTS]
    best = _best_fit(residuals, [starts[i] for i in order], lower, upper)

    values = {**_to_values(free, best.x), **fixed}
    chi2 = float(np.sum(best.fun**2))
    dof = n - k
    reduced_chi2 = chi2 / dof
    covariance = _covariance(best.jac)
    if covariance is not None and data.sigma is None:
        covariance = covariance * reduced_chi2
    if covariance is None:
        notes.append("the data cannot separate the parameters (singular Jacobian): no "
                     "standard errors")
    parameters = _parameter_entries(declared, free, values, fixed, covariance, best.x,
                                    (lower, upper), notes)
    return {
        "model": model,
        "parameters": parameters,
        "chi2": chi2,
        "reduced_chi2": reduced_chi2,
        **_aic(chi2, n, k, data.sigma is not None),
        "n_points": n,
        "n_free_parameters": k,
        "units": {p.name: p.unit for p in declared},
        "note": "; ".join(notes),
        "success": bool(best.success),
        "message": str(best.message),
        "data": data.source,
    }


def fit_models(data: RestitutionData, models: Sequence[str] = FIT_MODELS) -> list[dict]:
    """`fit_model` for each model, sorted by AIC (best first)."""
    return sorted((fit_model(data, m) for m in models), key=lambda r: r["aic"])


# --- output -------------------------------------------------------------------------------------

def _format_parameter(name: str, entry: dict, unit: str) -> str:
    unit_text = "" if unit == "dimensionless" else f" {unit}"
    if entry.get("fixed"):
        return f"{name} = {entry['value']:.6g} (fixed)"
    if entry["stderr"] is None:
        return f"{name} = {entry['value']:.6g}{unit_text}"
    return f"{name} = {entry['value']:.6g} ± {entry['stderr']:.2g}{unit_text}"


def fit_table(results: Sequence[dict]) -> str:
    """A plain-text table of fits (as `fit_models` returns them, best first)."""
    first = results[0]
    lines = [f"fit of {first['data']}: {first['n_points']} points; errors: "
             f"{first['sigma_source']}; AIC = {first['aic_definition']}",
             f"{'model':<10}{'k':>3}{'chi2':>13}{'red. chi2':>12}{'AIC':>13}   parameters"]
    for r in results:
        params = ", ".join(_format_parameter(name, entry, r["units"][name])
                           for name, entry in r["parameters"].items())
        flag = "" if r["success"] else "  [optimizer did not converge]"
        lines.append(f"{r['model']:<10}{r['n_free_parameters']:>3}{r['chi2']:>13.5g}"
                     f"{r['reduced_chi2']:>12.4g}{r['aic']:>13.5g}   {params}{flag}")
    for r in results:
        if r["note"]:
            lines.append(f"note ({r['model']}): {r['note']}")
    return "\n".join(lines)


def _values(result: dict) -> dict[str, float]:
    return {name: entry["value"] for name, entry in result["parameters"].items()}


def restitution_yaml(result: dict) -> str:
    """A scenario's ``restitution:`` section (YAML text) with a fit's parameters (SI)."""
    section = {"model": result["model"], **_values(result)}
    header = (f"# Restitution law fitted by `ringsim fit` to {result['data']}: model "
              f"{result['model']}, AIC {result['aic']:.6g}, reduced chi2 "
              f"{result['reduced_chi2']:.4g}.\n# SI units (v_c in m/s); paste into a "
              "scenario file.\n")
    return header + yaml.safe_dump({"restitution": section}, sort_keys=False)


def _check_restitution_yaml(text: str, path: str) -> None:
    """The section must be accepted by a scenario (its validation is the scenario's)."""
    probe = {"name": "fit-check", "seed": 0, "planet": {"Omega": 2.0e-4},
             "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}},
             "restitution": yaml.safe_load(text)["restitution"]}
    try:
        scenario_from_dict(probe, source=path)
    except ScenarioError as exc:
        raise RuntimeError(f"the fitted restitution section is not a valid scenario "
                           f"section: {exc}") from None


# --- command line -------------------------------------------------------------------------------

def _requested_models(text: str, data: RestitutionData | None = None
                      ) -> tuple[tuple[str, ...], dict[str, str]]:
    """The models ``--model`` asks for that ``data`` can be fitted with, and the skipped ones
    with the reason: ``--model all`` on data without radii and masses fits the laws that
    need none (only dilley needs them).  Without ``data`` only the name is checked."""
    if text != "all" and text not in FIT_MODELS:
        close = difflib.get_close_matches(text, FIT_MODELS + ("all",), n=1, cutoff=0.6)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise InputError("<command line>", "--model", f"unknown model {text!r} ({hint}one of "
                         f"{', '.join(FIT_MODELS)} or all)")
    models = FIT_MODELS if text == "all" else (text,)
    skipped: dict[str, str] = {}
    if text == "all" and data is not None and not data.has_sizes:
        skipped["dilley"] = ("the file has no radius and mass columns (R_bar_m or R1_m and "
                             "R2_m; M_bar_kg or M1_kg and M2_kg)")
    return tuple(m for m in models if m not in skipped), skipped


def fit_command(args) -> int:
    """``ringsim fit DATA.csv [--model M] [--json OUT.json] [--plot PNG]
    [--write-restitution OUT.yaml]``: fit, print a table, write the requested files.

    Returns 0 on success, 1 if an optimizer did not converge (InputError for bad input
    propagates: exit status 2, nothing written).
    """
    models, _ = _requested_models(args.model)
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise InputError(args.plot, "--plot", "the figure must be a .png file")
    data = read_data(args.data, need_sizes=args.model == "dilley")
    models, skipped = _requested_models(args.model, data)
    results = fit_models(data, models)
    print(fit_table(results))
    for model, reason in skipped.items():
        print(f"skipped {model}: {reason}")
    best = results[0]
    yaml_text = restitution_yaml(best) if args.write_restitution else None
    if yaml_text is not None:
        _check_restitution_yaml(yaml_text, args.write_restitution)
    if args.json:
        payload = results if args.model == "all" else best
        out = Path(args.json)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(payload, indent=2) + "\n")
        print(f"wrote {out}")
    if args.plot:
        print(f"wrote {plot_fits(data, results, args.plot)}")
    if yaml_text is not None:
        out = Path(args.write_restitution)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(yaml_text)
        print(f"wrote {out} (restitution: {best['model']})")
    failed = [r["model"] for r in results if not r["success"]]
    if failed:
        print(f"ringsim fit: the optimizer did not converge for {', '.join(failed)}",
              file=sys.stderr)
        return 1
    return 0
