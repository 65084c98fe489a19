"""Whether a ring heats or cools, and the shape of its velocity ellipsoid: the measures of
the Goldreich & Tremaine (1978) thermal-balance threshold (studies/validation-threshold).

Below the critical coefficient of restitution a dilute ring of identical smooth spheres
cools, above it the shear heats it without bound; near the threshold the equilibrium
finder has no stationary window to average over, so the measure is the growth rate of
ln c^2 (c the velocity dispersion) fitted over the rows after the start's anisotropy has
relaxed.  Its error comes from batch means: ln c^2 near the threshold drifts like a random
walk, and one run's slope scatters by more than its residuals suggest.  The stress ratios
sigma_xy / sigma_xx, sigma_yy / sigma_xx and sigma_zz / sigma_xx over the same rows are
what GT78's moment equations predict (``physics.kinetic.gt78_steady_state``).
"""

from __future__ import annotations

import math

import numpy as np

#: The fit of the growth rate starts here [orbits]: a start with an isotropic velocity
#: ellipsoid relaxes within the first orbits.
GROWTH_FROM_ORBIT = 3.0
#: Contiguous batches of the fitted rows whose slopes give the growth rate's error.
GROWTH_BATCHES = 5


def _batched(values: np.ndarray, batches: int) -> list[np.ndarray]:
    return [b for b in np.array_split(np.arange(values.size), batches) if b.size >= 2]


def growth_rate(orbits, c, from_orbit: float = GROWTH_FROM_ORBIT,
                batches: int = GROWTH_BATCHES) -> dict:
    """The growth rate of ln c^2 [1/orbit] over the rows from ``from_orbit``.

    Parameters
    ----------
    orbits : array [orbits]
    c : array [m/s]
        The velocity dispersion of each row.

    Returns
    -------
    dict ``{mean, stderr, units}``: the least-squares slope of ln c^2 against the orbit
    over the rows from ``from_orbit``, and the standard error of the mean of the slopes of
    ``batches`` contiguous batches of those rows (NaN with fewer than two batches).
    """
    t, c = np.asarray(orbits, dtype=float), np.asarray(c, dtype=float)
    keep = (t >= from_orbit) & (c > 0.0)
    t, y = t[keep], np.log(c[keep] ** 2)
    if t.size < 3:
        return {"mean": math.nan, "stderr": math.nan, "units": "1/orbit"}
    slope = float(np.polyfit(t, y, 1)[0])
    parts = [float(np.polyfit(t[b], y[b], 1)[0]) for b in _batched(t, batches)]
    err = (float(np.std(parts, ddof=1) / math.sqrt(len(parts))) if len(parts) >= 2
           else math.nan)
    return {"mean": slope, "stderr": err, "units": "1/orbit"}


def stress_ratios(orbits, sigma_xx, sigma_xy, sigma_yy, sigma_zz,
                  from_orbit: float = GROWTH_FROM_ORBIT,
                  batches: int = GROWTH_BATCHES) -> dict:
    """sigma_xy / sigma_xx, sigma_yy / sigma_xx and sigma_zz / sigma_xx over the rows
    from ``from_orbit``, each ``{mean, stderr, units}``: the ratio of the rows' means, and
    the standard error of the batch means' ratios (``batches`` contiguous batches).

    Parameters
    ----------
    orbits : array [orbits]
    sigma_xx, sigma_xy, sigma_yy, sigma_zz : arrays [m^2/s^2]
        The velocity dispersion tensor's components of each row.
    """
    t = np.asarray(orbits, dtype=float)
    keep = t >= from_orbit
    xx = np.asarray(sigma_xx, dtype=float)[keep]
    out = {}
    for name, comp in (("sigma_xy_over_xx", sigma_xy), ("sigma_yy_over_xx", sigma_yy),
                       ("sigma_zz_over_xx", sigma_zz)):
        v = np.asarray(comp, dtype=float)[keep]
        if v.size < 2 or not np.sum(xx):
            out[name] = {"mean": math.nan, "stderr": math.nan, "units": "dimensionless"}
            continue
        parts = [float(np.mean(v[b]) / np.mean(xx[b])) for b in _batched(v, batches)]
        err = (float(np.std(parts, ddof=1) / math.sqrt(len(parts))) if len(parts) >= 2
               else math.nan)
        out[name] = {"mean": float(np.mean(v) / np.mean(xx)), "stderr": err,
                     "units": "dimensionless"}
    return out


def thermal_balance(run) -> dict:
    """The growth rate of ln c^2 and the stress ratios of a run (``ringsim.open_run``)
    over its rows from `GROWTH_FROM_ORBIT`, each ``{mean, stderr, units}``."""
    ts = run.timeseries
    orbits = np.asarray(ts["orbits"], dtype=float)
    out = {"growth_rate": growth_rate(orbits, ts["velocity_dispersion"])}
    out.update(stress_ratios(orbits, ts["sigma_xx"], ts["sigma_xy"], ts["sigma_yy"],
                             ts["sigma_zz"]))
    return out
