"""Equilibria of runs, with error bars, and their comparison (``ringsim analyze`` / ``compare``).

The equilibrium window is found on the velocity dispersion and the thickness (MSER-5 on
each, the later start wins); every quantity is then averaged over that same window with a
standard error corrected for autocorrelation (``timeseries.stationary_mean``).  A run whose
window is too short or still drifts is reported as not in equilibrium, with the reason.
The keys of the result are part of the interface users rely on: docs/interface.md,
"Equilibrium JSON".
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.analysis import timeseries
from ringsim.physics import kinetic

#: Quantities of the equilibrium table: key -> (label, unit shown, scale from SI).
TABLE_ROWS = {
    "velocity_dispersion": ("velocity dispersion c", "mm/s", 1e3),
    "velocity_dispersion_rOmega": ("c / (<r> Omega)", "", 1.0),
    "thickness": ("thickness H (rms z)", "m", 1.0),
    "thickness_r": ("H / <r>", "", 1.0),
    "filling_factor": ("midplane filling factor", "", 1.0),
    "collision_frequency": ("collisions per particle per orbit", "", 1.0),
    "mean_epsilon": ("mean applied epsilon", "", 1.0),
    "translational_viscosity": ("translational viscosity", "m^2/s", 1.0),
    "collisional_viscosity": ("collisional viscosity", "m^2/s", 1.0),
}


def _value(mean: float, stderr: float) -> dict:
    return {"mean": float(mean), "stderr": float(stderr)}


def _window_stats(values: np.ndarray, start: int) -> dict:
    """Mean and autocorrelation-corrected stderr of values[start:] (no further truncation)."""
    mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(values[start:], dtype=float))
    return _value(mean, stderr)


def _scaled(value: dict, scale: float) -> dict:
    return _value(value["mean"] * scale, value["stderr"] * abs(scale))


def equilibrium(run) -> dict:
    """The equilibrium of a run: the numbers ``ringsim analyze --json`` writes.

    Parameters
    ----------
    run : ringsim Run (``ringsim.open_run``)

    Returns
    -------
    dict
        The keys of docs/interface.md "Equilibrium JSON" (each number ``{"mean",
        "stderr"}``, SI unless the name says otherwise) plus ``in_equilibrium``,
        ``reason``, ``orbits``, ``n_particles``,
        ``optical_depth``, ``translational_viscosity`` and ``collisional_viscosity``
        [m^2/s], and ``kinetic_estimate`` (the dilute-ring energy balance of the
        scenario's law, ``kinetic.kinetic_dispersion_estimate``).
    """
    ts = run.timeseries
    sc = run.scenario
    Omega = sc.orbital_frequency
    t = ts["t"]
    orbits = ts["orbits"]
    first = run.snapshot(0)
    radius, mass = first["radius"], first["mass"]
    n_particles = radius.size
    r_mean = float(radius.mean())
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])

    # rows 1.. (row 0 is the initial state, before any collision)
    c_fit = timeseries.stationary_mean(t[1:], ts["velocity_dispersion"][1:])
    h_fit = timeseries.stationary_mean(t[1:], ts["thickness"][1:])
    start = 1 + max(c_fit.start_index, h_fit.start_index)
    in_eq = bool(c_fit.in_equilibrium and h_fit.in_equilibrium)
    reasons = []
    for name, fit in (("velocity dispersion", c_fit), ("thickness", h_fit)):
        if not fit.in_equilibrium:
            reasons.append(f"{name}: {fit.reason}")
    reason = "; ".join(reasons) if reasons else c_fit.reason

    out: dict = {"name": sc.name}
    c = _window_stats(ts["velocity_dispersion"], start)
    h = _window_stats(ts["thickness"], start)
    out["velocity_dispersion"] = c
    out["velocity_dispersion_rOmega"] = _scaled(c, 1.0 / (r_mean * Omega))
    out["thickness"] = h
    out["thickness_r"] = _scaled(h, 1.0 / r_mean)
    out["filling_factor"] = _window_stats(ts["filling_factor"], start)

    interval_orbits = np.diff(orbits, prepend=orbits[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        frequency = np.where(interval_orbits > 0,
                             2.0 * ts["collisions"] / n_particles / interval_orbits, np.nan)
    frequency[0] = np.nan
    out["collision_frequency"] = _window_stats(frequency, start)
    out["mean_epsilon"] = _window_stats(ts["mean_epsilon"], start)
    out["equilibrium_from_orbit"] = _value(float(orbits[start]) if start < orbits.size
                                           else math.nan, 0.0)
    out["per_size_bin"] = _per_size_bin(ts, start)

    out["translational_viscosity"] = _window_stats(ts["translational_viscosity"], start)
    sigma = float(mass.sum()) / (Lx * Ly)
    dt = np.diff(t, prepend=t[0])
    dplog = np.diff(ts["collisions_plog"], prepend=ts["collisions_plog"][0])
    with np.errstate(invalid="ignore", divide="ignore"):
        nu_col = np.where(dt > 0, 2.0 * dplog / (3.0 * Omega * sigma * Lx * Ly * dt), np.nan)
    out["collisional_viscosity"] = _window_stats(nu_col, start)

    out["in_equilibrium"] = in_eq
    out["reason"] = reason
    out["orbits"] = float(orbits[-1])
    out["n_particles"] = int(n_particles)
    out["mean_radius"] = r_mean
    out["optical_depth"] = float(ts["optical_depth"][-1])
    out["restitution"] = sc.restitution_dict()
    out["kinetic_estimate"] = kinetic_estimate(sc.restitution_dict(), radius, mass,
                                               out["optical_depth"], Omega)
    return out


def _per_size_bin(ts: dict, start: int) -> list[dict]:
    edges = ts.get("size_bin_edges")
    if edges is None or "size_bin_velocity_dispersion" not in ts:
        return []
    rows = []
    for k in range(edges.size - 1):
        rows.append({
            "r_low": float(edges[k]),
            "r_high": float(edges[k + 1]),
            "velocity_dispersion": _window_stats(ts["size_bin_velocity_dispersion"][:, k], start),
            "thickness": _window_stats(ts["size_bin_thickness"][:, k], start),
            "n": int(round(float(np.mean(ts["size_bin_n"][start:, k])))),
        })
    return rows


def kinetic_estimate(restitution: dict, radius: np.ndarray, mass: np.ndarray,
                     optical_depth: float, Omega: float) -> dict:
    """The dilute-ring kinetic estimate, reduced to JSON-friendly numbers.

    Parameters
    ----------
    restitution : the scenario's restitution section
    radius : array [m]
    mass : array [kg]
    optical_depth : float
    Omega : float [1/s]
    """
    est = kinetic.kinetic_dispersion_estimate(restitution, radius, mass, optical_depth,
                                                  Omega)
    return {key: (float(est[key]) if isinstance(est[key], (float, np.floating)) else est[key])
            for key in ("status", "reason", "velocity_dispersion", "velocity_dispersion_rOmega",
                        "epsilon_critical", "effective_epsilon")}


# --- tables ------------------------------------------------------------------------------------

def _fmt(value: dict, scale: float = 1.0) -> str:
    mean, err = value["mean"] * scale, value["stderr"] * scale
    if not math.isfinite(mean):
        return "n/a"
    return f"{mean:.4g} ± {err:.2g}"


def equilibrium_table(eq: dict) -> str:
    """Plain-text table of one equilibrium."""
    lines = [f"run: {eq['name']}  ({eq['n_particles']} particles, {eq['orbits']:.4g} orbits, "
             f"tau = {eq['optical_depth']:.3g})"]
    status = "in equilibrium" if eq["in_equilibrium"] else "NOT IN EQUILIBRIUM"
    lines.append(f"equilibrium window from orbit {eq['equilibrium_from_orbit']['mean']:.3g}: "
                 f"{status} ({eq['reason']})")
    for key, (label, unit, scale) in TABLE_ROWS.items():
        lines.append(f"  {label + (f' [{unit}]' if unit else ''):<42} {_fmt(eq[key], scale)}")
    k = eq["kinetic_estimate"]
    if k["status"] == "equilibrium":
        lines.append(f"  {'dilute kinetic estimate c / (<r> Omega)':<42} "
                     f"{k['velocity_dispersion_rOmega']:.4g} (eps_crit = "
                     f"{k['epsilon_critical']:.3f})")
    else:
        lines.append(f"  {'dilute kinetic estimate':<42} {k['status']}: {k['reason']}")
    if eq["per_size_bin"]:
        lines.append("  per size bin:   r [m]            n     c [mm/s]            H [m]")
        for b in eq["per_size_bin"]:
            lines.append(f"    {b['r_low']:7.3g} - {b['r_high']:<7.3g} {b['n']:8d}   "
                         f"{_fmt(b['velocity_dispersion'], 1e3):<18} {_fmt(b['thickness'])}")
    return "\n".join(lines)

