"""The equilibrium numbers of a self-gravitating run (``ringsim analyze``, issue 12).

What a ring dynamicist reads for a self-gravitating sheet, beside the equilibrium of
``analysis.equilibrium``:

* ``r_h`` (mean pair), ``lambda_cr`` [m]: the run's own numbers, stored by ``ringsim run``
  in the file's root attributes (``engine.gravity.sheet_gravity``), constants of the run
  (stderr 0); computed from the first snapshot with the same ``physics.gravity`` functions
  for files that lack them;
* ``toomre_Q``: the window mean of the run's Toomre Q series (``toomre_Q`` rows, Q =
  sigma_x Omega / (3.36 G Sigma)), autocorrelation-corrected stderr as every time series;
* ``wake_wavelength`` [m], ``wake_pitch_angle`` [deg], ``wake_amplitude``: the dominant
  density wave of each snapshot inside the equilibrium window (``analysis.wakes.
  wake_statistics``), mean and standard error over those snapshots (treated as independent:
  snapshots are ``output.snapshot_every`` apart, an orbit or more, while wakes live about an
  orbit); with one snapshot the stderr is that snapshot's own spread of the spectral peak;
* ``gravitational_viscosity`` [m^2/s]: ``analysis.wakes.gravitational_viscosity`` of the same
  snapshots, mean and stderr over them.

A snapshot's wake is reported whether or not it is significant against Poisson noise;
``wake_significant_fraction`` says in how many of the window's snapshots it was.
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.analysis import timeseries, wakes
from ringsim.physics import gravity as patch
from ringsim.physics.selfgravity import shear_offset

#: Gravity quantities of the equilibrium: key -> (label, JSON unit, unit shown, scale).
GRAVITY_QUANTITIES = {
    "r_h": ("Hill parameter r_h (mean pair)", "dimensionless", "", 1.0),
    "toomre_Q": ("Toomre Q (from sigma_x)", "dimensionless", "", 1.0),
    "lambda_cr": ("Toomre wavelength lambda_cr", "m", "m", 1.0),
    "wake_wavelength": ("wake wavelength", "m", "m", 1.0),
    "wake_pitch_angle": ("wake pitch angle (trailing > 0)", "deg", "deg", 1.0),
    "wake_amplitude": ("wake amplitude (peak contrast)", "dimensionless", "", 1.0),
    "gravitational_viscosity": ("gravitational viscosity", "m^2/s", "m^2/s", 1.0),
}


def _value(mean: float, stderr: float, units: str) -> dict:
    return {"mean": float(mean), "stderr": float(stderr), "units": units}


def _over_snapshots(values: list[float], own_error: float, units: str) -> dict:
    """Mean and standard error over snapshots (one snapshot: its own error)."""
    if not values:
        return _value(math.nan, math.nan, units)
    a = np.asarray(values, dtype=float)
    stderr = float(np.std(a, ddof=1) / math.sqrt(a.size)) if a.size > 1 else own_error
    return _value(float(np.mean(a)), stderr, units)


def run_constants(run) -> dict:
    """r_h, Sigma [kg/m^2] and lambda_cr [m] of a gravitating run: its root attributes, or
    computed from the first snapshot for files written before they were stored."""
    attrs = run.attrs
    if "lambda_cr" in attrs:
        return {"r_h": float(attrs["r_h"]), "Sigma": float(attrs["Sigma"]),
                "lambda_cr": float(attrs["lambda_cr"])}
    sc = run.scenario
    first = run.snapshot(0)
    Sigma = patch.surface_density(float(np.sum(first["mass"])), float(attrs["Lx"]),
                                  float(attrs["Ly"]))
    planet = sc.planet
    r_h = (math.nan if planet.GM is None else
           patch.mean_pair_hill_parameter(first["radius"], sc.particles.density, planet.GM,
                                          planet.a))
    return {"r_h": r_h, "Sigma": Sigma,
            "lambda_cr": float(patch.toomre_wavelength(Sigma, sc.orbital_frequency))}


def window_snapshot_indices(run, from_orbit: float) -> list[int]:
    """Indices of the snapshots at or after ``from_orbit`` [orbits]."""
    period = run.scenario.orbital_period
    return [i for i in range(run.n_snapshots)
            if run.snapshot(i)["t"] / period >= from_orbit - 1e-9]


def snapshot_wakes(snap: dict, Lx: float, Ly: float, Omega: float) -> dict:
    """``wake_statistics`` and ``gravitational_viscosity`` [m^2/s] of one snapshot.

    Parameters
    ----------
    snap : dict with x, y, z [m], mass [kg], t [s]
    Lx, Ly : float [m]
    Omega : float [1/s]
    """
    shift = shear_offset(Omega, Lx, Ly, float(snap["t"]))
    stats = wakes.wake_statistics(snap["x"], snap["y"], snap["mass"], Lx, Ly, shift)
    pos = np.column_stack([snap["x"], snap["y"], snap["z"]])
    stats["gravitational_viscosity"] = wakes.gravitational_viscosity(pos, snap["mass"], Lx, Ly,
                                                                     Omega, shift)
    return stats


def gravity_equilibrium(run, start: int) -> dict:
    """The gravity entries of a run's equilibrium (module docstring), from row ``start``.

    Returns
    -------
    dict of the `GRAVITY_QUANTITIES` keys (each ``{"mean", "stderr", "units"}``) plus
    ``wake_snapshots`` (how many snapshots were analysed) and ``wake_significant_fraction``.
    """
    ts = run.timeseries
    const = run_constants(run)
    Omega = run.scenario.orbital_frequency
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    orbits = ts["orbits"]
    from_orbit = float(orbits[start]) if start < orbits.size else float(orbits[-1])
    indices = window_snapshot_indices(run, from_orbit) or [run.n_snapshots - 1]
    per = [snapshot_wakes(run.snapshot(i), Lx, Ly, Omega) for i in indices]
    out = {"r_h": _value(const["r_h"], 0.0, "dimensionless"),
           "lambda_cr": _value(const["lambda_cr"], 0.0, "m")}
    if "toomre_Q" in ts:
        mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(ts["toomre_Q"][start:]))
        out["toomre_Q"] = _value(mean, stderr, "dimensionless")
    else:
        out["toomre_Q"] = _value(math.nan, math.nan, "dimensionless")
    out["wake_wavelength"] = _over_snapshots([s["wavelength"] for s in per],
                                             per[0]["wavelength_err"], "m")
    out["wake_pitch_angle"] = _over_snapshots([s["pitch_angle_deg"] for s in per],
                                              per[0]["pitch_angle_err_deg"], "deg")
    out["wake_amplitude"] = _over_snapshots([s["peak_amplitude"] for s in per], math.nan,
                                            "dimensionless")
    out["gravitational_viscosity"] = _over_snapshots(
        [s["gravitational_viscosity"] for s in per], math.nan, "m^2/s")
    out["wake_snapshots"] = len(per)
    out["wake_significant_fraction"] = float(np.mean([s["significant"] for s in per]))
    return out


def gravity_table_lines(eq: dict) -> list[str]:
    """Rows of the plain-text equilibrium table for a gravitating run (empty otherwise)."""
    if "lambda_cr" not in eq:
        return []
    lines = []
    for key, (label, _units, shown, scale) in GRAVITY_QUANTITIES.items():
        value = eq[key]
        mean = value["mean"] * scale
        text = "n/a" if not math.isfinite(mean) else (
            f"{mean:.4g}" if not value["stderr"] else f"{mean:.4g} ± {value['stderr']:.2g}")
        if key == "r_h" and not math.isfinite(mean):
            text = "unknown (planet given by Omega only)"
        lines.append(f"  {label + (f' [{shown}]' if shown else ''):<42} {text}")
    ratio = eq["wake_wavelength"]["mean"] / eq["lambda_cr"]["mean"]
    lines.append(f"  {'wake wavelength / lambda_cr':<42} {ratio:.3g} "
                 f"({eq['wake_snapshots']} snapshots, significant wake in "
                 f"{100 * eq['wake_significant_fraction']:.0f} %)")
    return lines
