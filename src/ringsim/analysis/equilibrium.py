"""Equilibria of runs, with error bars, and their comparison (``ringsim analyze`` / ``compare``).

The equilibrium window is found on the velocity dispersion and the thickness, number- and
mass-weighted (MSER-5 on each, the latest start wins); every quantity is then averaged over
that same window with a standard error corrected for autocorrelation
(``timeseries.stationary_mean``).  A run whose
window is too short or still drifts is reported as not in equilibrium, with the reason.
The keys of the result are part of the interface users rely on: docs/interface.md,
"Equilibrium JSON".
"""

from __future__ import annotations

import math

import numpy as np

from ringsim import quantities
from ringsim.analysis import (
    aggregation,
    collisions,
    motions,
    size_bins,
    spins,
    tiling,
    timeseries,
)
from ringsim.analysis import window as snapshot_window
from ringsim.analysis.gravitating import gravity_equilibrium, gravity_table_lines
from ringsim.analysis.law_range import LAW_RANGE_WARNING as LAW_RANGE_WARNING
from ringsim.analysis.law_range import law_range, law_range_lines
from ringsim.physics import kinetic

#: The equilibrium quantities (declared in ``ringsim.quantities``): key -> (label, unit of
#: the JSON number (SI unless the key says otherwise), unit shown in tables, scale from the
#: JSON unit to it).
QUANTITIES = quantities.table_rows(quantities.EQUILIBRIUM)
#: Rows of the plain-text tables: key -> (label, unit shown, scale from the JSON unit).
TABLE_ROWS = {key: (label, shown, scale) for key, (label, _unit, shown, scale)
              in QUANTITIES.items()}
#: Units of the plain numbers of an equilibrium (the JSON's ``units`` entry).
PLAIN_UNITS = quantities.units(quantities.PLAIN)


def _value(mean: float, stderr: float, units: str) -> dict:
    """A JSON number: ``{"mean", "stderr", "units"}``."""
    return {"mean": float(mean), "stderr": float(stderr), "units": units}


def _window_stats(values: np.ndarray, start: int, units: str) -> dict:
    """Mean and autocorrelation-corrected stderr of values[start:] (no further truncation)."""
    mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(values[start:], dtype=float))
    return _value(mean, stderr, units)


def _scaled(value: dict, scale: float, units: str) -> dict:
    return _value(value["mean"] * scale, value["stderr"] * abs(scale), units)


def _interval_rates(ts: dict, n_particles: int, Omega: float, Lx: float, Ly: float,
                    surface_density: float) -> tuple[np.ndarray, np.ndarray]:
    """Collision frequency [1/orbit] and collisional viscosity [m^2/s] of every output
    interval, from the tested functions of ``analysis.collisions`` (NaN for row 0, before
    any collision, and for empty intervals)."""
    t, plog = ts["t"], ts["collisions_plog"]
    frequency = np.full(t.size, np.nan)
    nu_col = np.full(t.size, np.nan)
    for i in range(1, t.size):
        elapsed = float(t[i] - t[i - 1])
        if elapsed > 0:
            frequency[i] = collisions.collision_frequency(float(ts["collisions"][i]),
                                                          n_particles, elapsed, Omega)
            nu_col[i] = collisions.collisional_viscosity(float(plog[i] - plog[i - 1]),
                                                         elapsed, Lx, Ly, surface_density,
                                                         Omega)
    return frequency, nu_col


def _table_quantities(ts: dict, start: int, radius: np.ndarray, mass: np.ndarray,
                      Omega: float, Lx: float, Ly: float) -> dict:
    """The `QUANTITIES` of an equilibrium window from row ``start``, in their order.

    Parameters
    ----------
    ts : the run's time series
    radius : array [m]
    mass : array [kg]
    Omega : float [1/s]
    Lx, Ly : float [m]
    """
    r_mean = float(radius.mean())
    c = _window_stats(ts["velocity_dispersion"], start, QUANTITIES["velocity_dispersion"][1])
    h = _window_stats(ts["thickness"], start, QUANTITIES["thickness"][1])
    out = {"velocity_dispersion": c,
           "velocity_dispersion_rOmega": _scaled(c, 1.0 / (r_mean * Omega),
                                                 QUANTITIES["velocity_dispersion_rOmega"][1]),
           "thickness": h,
           "thickness_r": _scaled(h, 1.0 / r_mean, QUANTITIES["thickness_r"][1])}
    frequency, nu_col = _interval_rates(ts, radius.size, Omega, Lx, Ly,
                                        float(mass.sum()) / (Lx * Ly))
    for key, series in (("filling_factor", ts["filling_factor"]),
                        ("collision_frequency", frequency), ("mean_epsilon", ts["mean_epsilon"]),
                        ("translational_viscosity", ts["translational_viscosity"]),
                        ("collisional_viscosity", nu_col)):
        out[key] = _window_stats(series, start, QUANTITIES[key][1])
    return out


def stationary_window(orbits: np.ndarray, velocity_dispersion: np.ndarray,
                      thickness: np.ndarray, first_orbit: float = 0.0,
                      mass_weighted: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """Where a run's equilibrium window starts and whether c and H are stationary there.

    The one verdict of ringsim: ``analyze`` reports it and ``integration.until_equilibrium``
    stops a run on it.  Row 0 (the initial state, before any collision) is skipped; the
    finder (``timeseries.stationary_mean``) runs on c and on H, number-weighted, and, where
    given, mass-weighted (a few large particles can hold much of the mass and relax more
    slowly); the latest start wins, and the run is in equilibrium only if every series is
    stationary with enough independent samples.  Drift slopes are quoted in mm/s per orbit
    for c and m per orbit for H.

    Parameters
    ----------
    orbits : array [orbits]
        Output times.
    velocity_dispersion : array [m/s]
        Number-weighted.
    thickness : array [m]
        Number-weighted.
    first_orbit : float [orbits]
        Rows before it are skipped too (a tiled start's copies not yet independent,
        ``tiling.independent_from_orbit``); inf: no row is, and there is no window.
    mass_weighted : (array [m/s], array [m]) or None
        The mass-weighted c and H, judged as well.

    Returns
    -------
    dict with ``start`` (row index of the window), ``in_equilibrium`` (bool) and
    ``reason`` (text).
    """
    orbits = np.asarray(orbits)
    first = (max(1, int(np.searchsorted(orbits, first_orbit))) if math.isfinite(first_orbit)
             else orbits.size)
    if first >= orbits.size:
        return {"start": orbits.size - 1, "in_equilibrium": False,
                "reason": "the copies of the tiled start are not independent yet: no window"}
    series = [("velocity dispersion", velocity_dispersion, 1e3, "mm/s"),
              ("thickness", thickness, 1.0, "m")]
    for (name, number, scale, shown), values in zip(series[:2], mass_weighted or (),
                                                    strict=False):
        if not np.allclose(values, number, rtol=1e-9, atol=0.0, equal_nan=True):
            # (identical particles give the same series to rounding: judged once)
            series.append((f"mass-weighted {name}", values, scale, shown))
    fits = {name: timeseries.stationary_mean(orbits[first:],
                                             scale * np.asarray(values, float)[first:],
                                             time_unit="orbit", value_unit=shown)
            for name, values, scale, shown in series}
    problems = [f"{name}: {fit.reason}" for name, fit in fits.items() if not fit.in_equilibrium]
    return {"start": first + max(fit.start_index for fit in fits.values()),
            "in_equilibrium": not problems,
            "reason": "; ".join(problems) if problems else fits["velocity dispersion"].reason}


def _mass_weighted(ts) -> tuple[np.ndarray, np.ndarray] | None:
    """The mass-weighted c [m/s] and H [m] of a time series, None if it lacks them."""
    keys = ("velocity_dispersion_mass_weighted", "thickness_mass_weighted")
    return (ts[keys[0]], ts[keys[1]]) if all(key in ts for key in keys) else None


def _window(run, ts) -> tuple[dict, float | None]:
    """The equilibrium window of a run (``stationary_window``), starting no earlier than the
    orbit from which the copies of a tiled start are independent, and that orbit (None for
    a run not started from a tiled snapshot; ``tiling.independent_from_orbit``)."""
    independent = tiling.independent_from_orbit(run)
    return (stationary_window(ts["orbits"], ts["velocity_dispersion"], ts["thickness"],
                              independent or 0.0, _mass_weighted(ts)), independent)


def equilibrium(run) -> dict:
    """The equilibrium of a run: the numbers ``ringsim analyze --json`` writes.

    The window is found on the velocity dispersion and the thickness (the later start
    wins); the drift test works in orbits, so its slope reads "per orbit".

    Parameters
    ----------
    run : ringsim Run (``ringsim.open_run``)

    Returns
    -------
    dict
        docs/interface.md keys: each number ``{"mean", "stderr", "units"}`` (SI unless the
        key says otherwise, see `QUANTITIES`), plus ``in_equilibrium``, ``reason``,
        ``status`` (the run file's: finished, stopped, running), ``orbits``,
        ``n_particles``, ``mean_radius`` [m], ``optical_depth``, ``units`` (the units of
        these plain numbers and of the per-size-bin edges), ``size_ratio`` (small / large
        velocity dispersion with its bins and the equipartition value for the same bins,
        `size_dispersion_ratio`) and ``kinetic_estimate`` (the dilute-ring energy balance
        of the scenario's law, ``kinetic.kinetic_dispersion_estimate``), ``energy_budget``
        and, with friction, ``spin`` and ``rotational_energy_fraction``
        (``analysis.spins``); weighted and local c and H, ``weightings``
        (``analysis.motions``); ``aggregation``, ``aggregating``
        (`_aggregation_and_gravity`); after a tiled start
        ``tiled_copies_independent_from_orbit``.
    """
    ts = run.timeseries
    sc = run.scenario
    Omega = sc.orbital_frequency
    orbits = ts["orbits"]
    first = run.snapshot(0)
    radius, mass = first["radius"], first["mass"]
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])

    window, independent = _window(run, ts)
    start = window["start"]

    out: dict = {"name": sc.name}
    out.update(_table_quantities(ts, start, radius, mass, Omega, Lx, Ly))
    out.update(motions.motion_equilibrium(run, start))
    out["equilibrium_from_orbit"] = _value(float(orbits[start]) if start < orbits.size
                                           else math.nan, 0.0,
                                           quantities.unit("equilibrium_from_orbit"))
    _add_size_sections(out, run, start, radius, mass)
    _aggregation_and_gravity(run, start, out)
    if independent is not None:
        out["tiled_copies_independent_from_orbit"] = _value(
            independent, 0.0, quantities.unit("tiled_copies_independent_from_orbit"))
    out.update(in_equilibrium=window["in_equilibrium"], reason=window["reason"],
               window_snapshots=snapshot_window.count_in_window(run, start),
               status=str(run.attrs.get("status", "unknown")), orbits=float(orbits[-1]),
               n_particles=int(radius.size), mean_radius=float(radius.mean()),
               optical_depth=float(ts["optical_depth"][-1]), units=dict(PLAIN_UNITS))
    out["restitution"] = sc.restitution_dict()
    out["scenario"] = sc.to_dict()
    out["kinetic_estimate"] = kinetic_estimate(sc.restitution_dict(), radius, mass,
                                               out["optical_depth"], Omega)
    motions.name_weightings(out)
    return out


def _add_size_sections(out: dict, run, start: int, radius: np.ndarray, mass: np.ndarray
                       ) -> None:
    """The per-size-bin rows, the size ratio, the law's range, the energy budget and the
    spins of an equilibrium (radius [m] and mass [kg] of the first snapshot)."""
    ts = run.timeseries
    out["per_size_bin"] = _per_size_bin(ts, start, radius, mass)
    size_bins.add_ellipsoid(out["per_size_bin"], ts, start)
    out["vertical_segregation"] = size_bins.vertical_segregation(run, start)
    out["pair_epsilon"] = size_bins.pair_epsilon(run, start)
    out["size_ratio"] = size_dispersion_ratio(out["per_size_bin"])
    out["law_range"] = law_range(ts, start, run.scenario.restitution.model)
    out["energy_budget"] = spins.energy_budget(run, start)
    out["spin"] = spins.spin_equilibrium(run, start, ts.get("size_bin_edges"))
    if out["spin"]:
        out["rotational_energy_fraction"] = out["spin"]["rotational_energy_fraction"]


def _aggregation_and_gravity(run, start: int, out: dict) -> None:
    """Add to the equilibrium ``out`` the run's ``aggregation`` and ``aggregating``
    (``analysis.aggregation``: an aggregating run's collision statistics become NaN, their
    fluid averages kept in ``aggregation["as_fluid"]``) and, for a gravitating run, the
    gravity entries (``gravity_equilibrium``, from row ``start``)."""
    aggregation.withhold_collision_statistics(out, aggregation.run_aggregation(run, start))
    if run.scenario.sheet.gravity:
        out.update(gravity_equilibrium(run, start, out))


def _per_size_bin(ts: dict, start: int, radius: np.ndarray, mass: np.ndarray) -> list[dict]:
    """Per-bin window averages, with each bin's mean radius [m] and mass [kg] (from the
    first snapshot), which the equipartition comparison needs."""
    edges = ts.get("size_bin_edges")
    if edges is None or "size_bin_velocity_dispersion" not in ts:
        return []
    index = np.clip(np.searchsorted(edges, radius, side="right") - 1, 0, edges.size - 2)
    rows = []
    for k in range(edges.size - 1):
        members = index == k
        rows.append({
            "r_low": float(edges[k]),
            "r_high": float(edges[k + 1]),
            "velocity_dispersion": _window_stats(ts["size_bin_velocity_dispersion"][:, k], start,
                                                 quantities.unit("velocity_dispersion")),
            "thickness": _window_stats(ts["size_bin_thickness"][:, k], start,
                                       quantities.unit("thickness")),
            "n": int(round(float(np.mean(ts["size_bin_n"][start:, k])))),
            "mean_radius": _value(radius[members].mean() if members.any() else math.nan, 0.0,
                                  quantities.unit("mean_radius")),
            "mean_mass": _value(mass[members].mean() if members.any() else math.nan, 0.0,
                                quantities.unit("mean_mass")),
        })
    return rows


def size_dispersion_ratio(bins: list[dict], min_particles: int = 10) -> dict | None:
    """Velocity dispersion of the smallest over the largest populated size bin.

    Beside it the equipartition value for the SAME bins, sqrt(<m>_large / <m>_small)
    (equal mean kinetic energy per particle), so that the two are compared like for
    like; bins with fewer than ``min_particles`` particles are skipped.  None with fewer
    than two usable bins.

    Parameters
    ----------
    bins : the ``per_size_bin`` entries of an equilibrium
    min_particles : int
    """
    usable = [b for b in bins if b["n"] >= min_particles
              and math.isfinite(b["velocity_dispersion"]["mean"])]
    if len(usable) < 2:
        return None
    small, large = usable[0], usable[-1]
    r = _ratio_of(small["velocity_dispersion"], large["velocity_dispersion"])
    return {"ratio": r,
            "small_bin_m": [small["r_low"], small["r_high"]],
            "large_bin_m": [large["r_low"], large["r_high"]],
            "equipartition": math.sqrt(large["mean_mass"]["mean"] / small["mean_mass"]["mean"]),
            "units": {key: quantities.unit(f"size_ratio.{key}") for key in
                      ("small_bin_m", "large_bin_m", "equipartition")}}


def _ratio_of(a: dict, b: dict) -> dict:
    """a / b with first-order propagated standard error (independent a and b)."""
    if not (b["mean"] and math.isfinite(b["mean"]) and math.isfinite(a["mean"])):
        return _value(math.nan, math.nan, quantities.unit("ratio"))
    r = a["mean"] / b["mean"]
    rel = math.hypot(a["stderr"] / a["mean"] if a["mean"] else 0.0, b["stderr"] / b["mean"])
    return _value(r, abs(r) * rel, quantities.unit("ratio"))


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
    est = kinetic.kinetic_dispersion_estimate(restitution, radius, mass, optical_depth, Omega)
    out: dict[str, object] = {}
    for key in ("status", "reason", "representative", "velocity_dispersion",
                "velocity_dispersion_rOmega", "epsilon_critical", "effective_epsilon"):
        value = est[key]        # numpy floats become Python floats for the JSON
        out[key] = float(value) if isinstance(value, float | np.floating) else value
    out["units"] = quantities.units(("velocity_dispersion", "velocity_dispersion_rOmega"))
    return out


# --- tables ------------------------------------------------------------------------------------

def _fmt(value: dict, scale: float = 1.0) -> str:
    mean, err = value["mean"] * scale, value["stderr"] * scale
    if not math.isfinite(mean):
        return "n/a"
    return f"{mean:.4g} ± {err:.2g}"


#: Printed by ``analyze`` and ``compare`` for a run the finder did not call stationary.
NO_WINDOW_SNAPSHOT = ("WARNING: no snapshot lies in the equilibrium window; the local "
                      "dispersions, the cross-section-weighted thickness and the by-size "
                      "layers are from the last snapshot, which lies before it")
NOT_IN_EQUILIBRIUM = ("WARNING: {name} never reached equilibrium ({reason}); its numbers are "
                      "averages over a window that is too short or still drifting, not "
                      "equilibrium values")


def size_ratio_line(size_ratio: dict | None) -> str | None:
    """One line: the small/large dispersion ratio, its bins and equipartition's value."""
    if not size_ratio:
        return None
    (s0, s1), (l0, l1) = size_ratio["small_bin_m"], size_ratio["large_bin_m"]
    return (f"c(r in {s0:.3g}-{s1:.3g} m) / c(r in {l0:.3g}-{l1:.3g} m) = "
            f"{_fmt(size_ratio['ratio'])}; equipartition for these bins: "
            f"{size_ratio['equipartition']:.3g}")


def equilibrium_table(eq: dict) -> str:
    """Plain-text table of one equilibrium."""
    lines = [f"run: {eq['name']}  ({eq['n_particles']} particles, {eq['orbits']:.4g} orbits, "
             f"tau = {eq['optical_depth']:.3g}, status {eq.get('status', 'unknown')})"]
    if not eq["in_equilibrium"]:
        lines.append(NOT_IN_EQUILIBRIUM.format(name=eq["name"], reason=eq["reason"]))
    status = (f"in equilibrium ({eq['reason']})" if eq["in_equilibrium"]
              else "NOT IN EQUILIBRIUM (see the warning)")
    lines.append(f"equilibrium window from orbit {eq['equilibrium_from_orbit']['mean']:.3g}: "
                 f"{status}")
    if "tiled_copies_independent_from_orbit" in eq:
        tile = eq["scenario"]["sheet"]["initial_state"]["tile"]
        when = eq["tiled_copies_independent_from_orbit"]["mean"]
        lines.append(f"started from a snapshot tiled {tile[0]} x {tile[1]}: "
                     + (f"the copies are independent from orbit {when:.3g} (the window starts "
                        "no earlier)" if math.isfinite(when)
                        else "the copies are not independent by the last snapshot"))
    if eq.get("window_snapshots") == 0:
        lines.append(NO_WINDOW_SNAPSHOT)
    for key in TABLE_ROWS:
        q = quantities.QUANTITY[key]
        withheld = eq.get("aggregating") and key in aggregation.COLLISION_KEYS
        lines.append(f"  {q.headline_label:<42} "
                     + ("withheld: the ring aggregates" if withheld else _fmt(eq[key], q.scale)))
    lines += motions.motion_table_lines(eq)
    lines += gravity_table_lines(eq)
    lines += aggregation.aggregation_lines(eq)
    k = eq["kinetic_estimate"]
    if k["status"] == "equilibrium":
        lines.append(f"  {'dilute kinetic estimate c / (<r> Omega)':<42} "
                     f"{k['velocity_dispersion_rOmega']:.4g} (eps_crit = "
                     f"{k['epsilon_critical']:.3f}; {k['representative']})")
    else:
        lines.append(f"  {'dilute kinetic estimate':<42} {k['status']}: {k['reason']}")
    if eq["per_size_bin"]:
        c, h = quantities.QUANTITY["velocity_dispersion"], quantities.QUANTITY["thickness"]
        lines.append(f"  per size bin:   r [m]            n     c [{c.shown}]            "
                     f"H [{h.shown}]")
        for b in eq["per_size_bin"]:
            lines.append(f"    {b['r_low']:7.3g} - {b['r_high']:<7.3g} {b['n']:8d}   "
                         f"{_fmt(b['velocity_dispersion'], c.scale):<18} "
                         f"{_fmt(b['thickness'], h.scale)}")
        line = size_ratio_line(eq.get("size_ratio"))
        if line:
            lines.append("  " + line)
    lines += size_bins.size_bin_lines(eq)
    lines += ["  " + line for line in law_range_lines(eq)]
    lines += spins.spin_table_lines(eq, budget=not _gravity_balance_shown(eq))
    return "\n".join(lines)


def _gravity_balance_shown(eq: dict) -> bool:
    """Whether the table holds a gravitating run's energy balance (with nu_grav), which is
    then the run's one energy balance: the shear-heating budget without nu_grav is not
    printed beside it."""
    closure = eq.get("energy_closure")
    return closure is not None and math.isfinite(closure["mean"])
