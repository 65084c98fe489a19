"""Random against coherent motion, and the weightings of the headline numbers (``analyze``).

The velocity dispersion c of the time series is the rms speed relative to the shear flow
of the whole sheet: in a ring with wakes it includes their coherent motion (Salo 1995;
Daisaka & Ida 1999).  The local velocity dispersion keeps only the random part: each
particle's velocity relative to the shear flow minus the mean velocity of its cell, the
sheet cut into (x, y) cells of side ``cell`` (columns through the layer).  The local
mean flow is the number-weighted mean velocity of the cell.  In a cell of n particles the
deviation d_i from that mean has E[d_i^2] = s_i^2 (1 - 2/n) + sum_j s_j^2 / n^2, so
s_i^2 = (d_i^2 - D / (n (n - 1))) / (1 - 2/n) with D = sum_j d_j^2 estimates particle i's
variance without bias, also where the particles of a cell differ in dispersion (small and
large ones); cells of fewer than three particles are left out.  These estimates are then
averaged over the particles by number or by mass.  A coherent flow of wavelength lambda
along a cell side leaks into it the share 1 - sinc^2(pi cell / lambda) of its variance
(5 % at cell = lambda/8).

The cell side (`local_cell`) is lambda_cr / 8, Toomre's critical wavelength 4 pi^2 G Sigma
/ Omega^2 being the scale of self-gravity wakes, but no smaller than the side that holds
four particles on average, so that the cell means are not made of single particles.

Thickness is reported weighted by number and by mass (the time series) and by cross
section pi r^2 (the weighting of the optical depth and of occultations; from the window's
snapshots); the velocity dispersion by number and by mass.  Units: SI (m, m/s).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ringsim.analysis import timeseries, window
from ringsim.physics import gravity as patch
from ringsim.quantities import QUANTITY, unit

#: The cell side of the local mean flow, as a fraction of lambda_cr.
CELL_PER_LAMBDA_CR = 1.0 / 8.0
#: The fewest particles a cell holds on average.
PARTICLES_PER_CELL = 4.0


def local_cell(Lx: float, Ly: float, n_particles: int, lambda_cr: float) -> float:
    """The side [m] of the cells of the local mean flow: lambda_cr / 8, at least
    sqrt(4 Lx Ly / N) (four particles per cell on average), at most min(Lx, Ly).

    Parameters
    ----------
    Lx, Ly : float [m]
        The box.
    n_particles : int
    lambda_cr : float [m]
        Toomre's critical wavelength.
    """
    least = math.sqrt(PARTICLES_PER_CELL * Lx * Ly / max(n_particles, 1))
    return min(max(CELL_PER_LAMBDA_CR * lambda_cr, least), Lx, Ly)


def _cells(x: np.ndarray, y: np.ndarray, Lx: float, Ly: float, cell: float) -> np.ndarray:
    """The index of each particle's (x, y) cell; the box is centred on 0 and periodic."""
    nx, ny = max(1, int(Lx // cell)), max(1, int(Ly // cell))
    ix = np.minimum((np.mod(x / Lx + 0.5, 1.0) * nx).astype(int), nx - 1)
    iy = np.minimum((np.mod(y / Ly + 0.5, 1.0) * ny).astype(int), ny - 1)
    return ix * ny + iy


def local_dispersion(x: ArrayLike, y: ArrayLike, u: ArrayLike, weights: ArrayLike,
                     Lx: float, Ly: float, cell: float) -> float:
    """1-D velocity dispersion about the local mean flow [m/s] (module docstring).

    Parameters
    ----------
    x, y : array (n,) [m]
        Positions in the box, centred on 0.
    u : array (n, 3) [m/s]
        Velocities relative to the shear flow (vy + 3/2 Omega x in the y column).
    weights : array (n,)
        Weights of the average over particles: ones (number) or the masses [kg].
    Lx, Ly : float [m]
        The box.
    cell : float [m]
        Side of the cells.

    Returns
    -------
    float
        sqrt(sum w s^2 / (3 sum w)) over the particles of cells of n >= 3, with s^2 the
        unbiased estimate of each particle's variance (module docstring); NaN if no cell
        holds three particles.
    """
    u = np.asarray(u, dtype=float)
    w = np.asarray(weights, dtype=float)
    index = _cells(np.asarray(x, float), np.asarray(y, float), Lx, Ly, cell)
    size = int(index.max()) + 1 if index.size else 0
    n = np.bincount(index, minlength=size).astype(float)
    mean = np.stack([np.bincount(index, weights=u[:, j], minlength=size)
                     for j in range(3)], axis=1) / np.maximum(n, 1.0)[:, None]
    d2 = np.sum((u - mean[index]) ** 2, axis=1)
    D = np.bincount(index, weights=d2, minlength=size)
    ni = n[index]
    keep = ni >= 3
    if not np.any(keep):
        return math.nan
    ni, Di = ni[keep], D[index][keep]
    s2 = (d2[keep] - Di / (ni * (ni - 1.0))) / (1.0 - 2.0 / ni)
    return math.sqrt(max(float(np.average(s2, weights=w[keep])), 0.0) / 3.0)


def weighted_thickness(z: ArrayLike, weights: ArrayLike) -> float:
    """rms z [m] about the weighted mean height, each particle weighted by ``weights``.

    Parameters
    ----------
    z : array (n,) [m]
    weights : array (n,)
        E.g. pi r^2 [m^2] for the thickness an occultation sees.
    """
    z, w = np.asarray(z, dtype=float), np.asarray(weights, dtype=float)
    mean = float(np.average(z, weights=w))
    return math.sqrt(float(np.average((z - mean) ** 2, weights=w)))


def snapshot_motions(snap: dict, Lx: float, Ly: float, Omega: float, cell: float) -> dict:
    """The local dispersions [m/s] (number and mass weighted) and the cross-section-weighted
    thickness [m] of one snapshot (a dict of arrays, ``Run.snapshot``).

    Parameters
    ----------
    Lx, Ly : float [m]
    Omega : float [1/s]
    cell : float [m]
    """
    u = np.stack([snap["vx"], snap["vy"] + 1.5 * Omega * snap["x"], snap["vz"]], axis=1)
    args = (snap["x"], snap["y"], u)
    return {"velocity_dispersion_local_number_weighted": local_dispersion(
                *args, np.ones(u.shape[0]), Lx, Ly, cell),
            "velocity_dispersion_local_mass_weighted": local_dispersion(
                *args, snap["mass"], Lx, Ly, cell),
            "thickness_cross_section_weighted": weighted_thickness(
                snap["z"], math.pi * snap["radius"] ** 2)}


def _value(mean: float, stderr: float, key: str) -> dict:
    return {"mean": float(mean), "stderr": float(stderr), "units": unit(key)}


def _window(values, key: str) -> dict:
    mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(values, dtype=float))
    return _value(mean, stderr, key)


#: The keys `motion_equilibrium` adds to an equilibrium, in the order ``analyze`` prints them.
MOTION_KEYS = ("velocity_dispersion_mass_weighted",
               "velocity_dispersion_local_number_weighted",
               "velocity_dispersion_local_mass_weighted", "thickness_mass_weighted",
               "thickness_cross_section_weighted")


def motion_equilibrium(run, start: int) -> dict:
    """Weighted and local dispersions and thicknesses of a run's window from row ``start``.

    Mass-weighted c and H are window means of the time series (autocorrelation-corrected
    standard errors); the local dispersions and the cross-section-weighted thickness are
    means over the snapshots at or after the window's first row (the last snapshot if none
    is), with the standard error of that mean.  Adds ``local_dispersion_cell`` [m].
    """
    ts = run.timeseries
    sc = run.scenario
    Omega = sc.orbital_frequency
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    first = run.snapshot(0)
    Sigma = patch.surface_density(float(np.sum(first["mass"])), Lx, Ly)
    cell = local_cell(Lx, Ly, first["radius"].size,
                      float(patch.toomre_wavelength(Sigma, Omega)))
    out = {key: _window(ts[key][start:], key) for key in
           ("velocity_dispersion_mass_weighted", "thickness_mass_weighted") if key in ts}
    indices, _ = window.window_snapshot_indices(run, start)
    per = [snapshot_motions(run.snapshot(i), Lx, Ly, Omega, cell) for i in indices]
    for key in ("velocity_dispersion_local_number_weighted",
                "velocity_dispersion_local_mass_weighted", "thickness_cross_section_weighted"):
        out[key] = _window([p[key] for p in per], key)
    out["local_dispersion_cell"] = {"mean": cell, "stderr": 0.0,
                                    "units": unit("local_dispersion_cell")}
    return out


#: The number-weighted headline numbers under names that say so (the same values).
NUMBER_WEIGHTED = {"velocity_dispersion_number_weighted": "velocity_dispersion",
                   "thickness_number_weighted": "thickness"}


def name_weightings(eq: dict) -> None:
    """Add the `NUMBER_WEIGHTED` names and ``weightings`` (key -> "number", "mass" or
    "cross section") for every weighted quantity of the equilibrium ``eq``."""
    for alias, key in NUMBER_WEIGHTED.items():
        eq[alias] = dict(eq[key])
    eq["weightings"] = {key: QUANTITY[key].weighting for key in eq
                        if key in QUANTITY and QUANTITY[key].weighting}


def motion_table_lines(eq: dict) -> list[str]:
    """The rows ``analyze`` prints for `MOTION_KEYS`, each naming its weighting."""
    lines = []
    for key in MOTION_KEYS:
        if key not in eq:
            continue
        q = QUANTITY[key]
        mean, err = eq[key]["mean"] * q.scale, eq[key]["stderr"] * q.scale
        text = f"{mean:.4g} ± {err:.2g}" if math.isfinite(mean) else "n/a"
        if key == "velocity_dispersion_local_number_weighted":
            text += f" (about the mean of cells of {eq['local_dispersion_cell']['mean']:.3g} m)"
        lines.append(f"  {q.headline_label:<42} {text}")
    return lines
