"""Diagnostics of a shearing-sheet ring patch and equilibrium statistics of its time series.

Data flow one way: snapshot arrays (x, y, z, vx, vy, vz [m, m/s], radius [m], mass [kg]) in
REBOUND's shearing-sheet frame -- x radial, y azimuthal, z vertical, Keplerian shear flow
``vy = -1.5 Omega x`` -- go in; plain numbers and numpy arrays (SI) come out.  Nothing here
touches REBOUND or HDF5.

==========================  =====================================================  ===========
quantity                    definition                                             unit
==========================  =====================================================  ===========
peculiar velocity w         (vx, vy + 1.5 Omega x, vz), velocity relative to the   m/s
                            Keplerian shear flow
dispersion tensor W_ij      <(w_i - <w_i>)(w_j - <w_j>)>, number- or mass-weighted m^2/s^2
sigma_xx, _yy, _zz, _xy     components W_xx, W_yy, W_zz, W_xy of that tensor:      m^2/s^2
                            all four are second moments (variances and the
                            covariance), NOT rms speeds
velocity_dispersion c       sqrt(trace W / 3), the 1-D rms speed                   m/s
velocity_dispersion_x/y/z   sqrt(W_xx), sqrt(W_yy), sqrt(W_zz), rms speeds         m/s
thickness                   sqrt(<(z - <z>)^2>), rms height about the mean plane   m
optical_depth tau           dynamical optical depth sum(pi r^2) / (Lx Ly)          1
filling_factor              volume fraction of particles inside the slab           1
                            |z - <z>| < h, exact sphere-slab intersections
collision frequency         impacts per particle per orbit, 2 N_coll / N / orbits  1/orbit
nu_trans                    (2 / (3 Omega)) W_xy (mass-weighted)                   m^2/s
nu_col                      2 plog / (3 Omega Sigma Lx Ly dt)                      m^2/s
==========================  =====================================================  ===========

The equilibrium finder (``equilibrium``) truncates the start-up transient with MSER-5
(White 1997; White, Cobb & Spratt 2000), estimates the standard error of the mean with the
integrated autocorrelation time and Sokal's automatic window (Madras & Sokal 1988; Sokal
1997), and refuses to call a series equilibrated if the kept window still drifts or holds
fewer than ``min_effective_samples`` independent samples.

The dilute-ring kinetic estimate (``kinetic_dispersion_estimate``) balances viscous heating
against collisional dissipation as in Goldreich & Tremaine (1978); the critical coefficient
of restitution eps_cr(tau) is computed here from their model (triaxial Gaussian velocity
distribution of identical smooth spheres), which reproduces their eps_cr -> 0.627 for
tau -> 0.

References
----------
Goldreich, P. & Tremaine, S. 1978, Icarus 34, 227 ("The velocity dispersion in Saturn's rings").
Madras, N. & Sokal, A. D. 1988, J. Stat. Phys. 50, 109.
Sokal, A. D. 1997, in Functional Integration, NATO ASI Series B 361, 131 (Plenum).
White, K. P. 1997, Simulation 69, 323 (MSER truncation heuristic).
White, K. P., Cobb, M. J. & Spratt, S. C. 2000, Proc. Winter Simulation Conf., 755 (MSER-5).
Wisdom, J. & Tremaine, S. 1988, AJ 95, 925 (translational and collisional viscosity).
REBOUND 5.x: examples/shearing_sheet_diagnostics/problem.c (nu_trans, nu_col) and
src/collision.c, reb_collision_resolve_hardsphere (definition of collisions_plog).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize

FloatArray = NDArray[np.float64]

#: Shear parameter of a Keplerian disk: the shear flow is vy = -SHEAR * Omega * x.
SHEAR = 1.5
TWO_PI = 2.0 * math.pi

__all__ = [
    "EquilibriumResult",
    "autocorrelated_mean",
    "collision_frequency",
    "collisional_viscosity",
    "critical_epsilon",
    "dispersion_components",
    "dispersion_tensor",
    "effective_epsilon",
    "epsilon_statistics",
    "equilibrium",
    "filling_factor",
    "gt78_steady_state",
    "integrated_autocorrelation_time",
    "kinetic_dispersion_estimate",
    "log_size_bins",
    "mser_truncation",
    "optical_depth",
    "peculiar_velocity",
    "snapshot_summary",
    "sphere_slab_volume",
    "surface_density",
    "thickness",
    "translational_viscosity",
    "velocity_dispersion",
]


# --- input checks -----------------------------------------------------------------------------

def _array(name: str, value: ArrayLike) -> FloatArray:
    a = np.asarray(value, dtype=float)
    if a.ndim != 1:
        a = a.reshape(-1)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


def _same_length(**arrays: FloatArray) -> int:
    lengths = {name: a.size for name, a in arrays.items()}
    n = next(iter(lengths.values()))
    if any(size != n for size in lengths.values()):
        raise ValueError(f"arrays must have equal lengths, got {lengths}")
    if n == 0:
        raise ValueError("no particles")
    return n


def _positive(name: str, value: float) -> float:
    x = float(value)
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return x


def _nonnegative_array(name: str, value: ArrayLike) -> FloatArray:
    a = _array(name, value)
    if np.any(a < 0.0):
        raise ValueError(f"{name} must be >= 0")
    return a


def _weights(weights: ArrayLike | None, n: int) -> FloatArray | None:
    if weights is None:
        return None
    w = _nonnegative_array("weights", weights)
    if w.size != n:
        raise ValueError(f"weights has {w.size} entries, expected {n}")
    if not np.sum(w) > 0.0:
        raise ValueError("weights must not all be zero")
    return w


def _mean(values: FloatArray, weights: FloatArray | None) -> float:
    if weights is None:
        return float(np.mean(values))
    return float(np.dot(weights, values) / np.sum(weights))


# --- velocity dispersion ----------------------------------------------------------------------

def peculiar_velocity(x: ArrayLike, vx: ArrayLike, vy: ArrayLike, vz: ArrayLike,
                      Omega: float) -> FloatArray:
    """Velocities relative to the Keplerian shear flow, as a (3, N) array [m/s].

    Parameters
    ----------
    x : array [m]
        Radial positions.
    vx, vy, vz : array [m/s]
        Velocities in the shearing-sheet frame.
    Omega : float [1/s]
        Orbital frequency of the patch.

    Returns
    -------
    array (3, N) [m/s]
        (vx, vy + 1.5 Omega x, vz).
    """
    Omega = _positive("Omega", Omega)
    x, vx, vy, vz = (_array(n, a) for n, a in (("x", x), ("vx", vx), ("vy", vy), ("vz", vz)))
    _same_length(x=x, vx=vx, vy=vy, vz=vz)
    return np.stack([vx, vy + SHEAR * Omega * x, vz])


def _tensor(w: FloatArray, weights: FloatArray | None) -> FloatArray:
    """Mean-subtracted second-moment tensor of the (3, N) array w."""
    if weights is None:
        d = w - w.mean(axis=1, keepdims=True)
        return (d @ d.T) / w.shape[1]
    total = np.sum(weights)
    d = w - (w @ weights / total)[:, None]
    return ((d * weights) @ d.T) / total


def dispersion_tensor(x: ArrayLike, vx: ArrayLike, vy: ArrayLike, vz: ArrayLike, Omega: float,
                      weights: ArrayLike | None = None) -> FloatArray:
    """Velocity dispersion tensor W_ij = <(w_i - <w_i>)(w_j - <w_j>)> [m^2/s^2].

    w = (vx, vy + 1.5 Omega x, vz) is the velocity relative to the shear flow.  The mean
    <w> is subtracted (it is zero for a sheet with no net drift), so W is the covariance
    matrix of w; it is the population (1/N) covariance, not the 1/(N-1) one.

    Parameters
    ----------
    x : array [m]
        Radial positions.
    vx, vy, vz : array [m/s]
        Velocities.
    Omega : float [1/s]
        Orbital frequency.
    weights : array, optional
        Per-particle weights, e.g. masses [kg] for the mass-weighted tensor; None for the
        number-weighted one.

    Returns
    -------
    array (3, 3) [m^2/s^2]
        Rows/columns in the order x, y, z.
    """
    w = peculiar_velocity(x, vx, vy, vz, Omega)
    return _tensor(w, _weights(weights, w.shape[1]))


def velocity_dispersion(x: ArrayLike, vx: ArrayLike, vy: ArrayLike, vz: ArrayLike, Omega: float,
                        weights: ArrayLike | None = None) -> float:
    """One-dimensional velocity dispersion c = sqrt(trace W / 3) [m/s].

    Parameters as for ``dispersion_tensor``: x [m], vx, vy, vz [m/s], Omega [1/s],
    weights (None, or e.g. masses [kg]).
    """
    return float(math.sqrt(np.trace(dispersion_tensor(x, vx, vy, vz, Omega, weights)) / 3.0))


def dispersion_components(tensor: ArrayLike) -> dict[str, float]:
    """Named components of a dispersion tensor.

    Parameters
    ----------
    tensor : array (3, 3) [m^2/s^2]
        As returned by ``dispersion_tensor``.

    Returns
    -------
    dict
        ``sigma_xx, sigma_yy, sigma_zz, sigma_xy`` [m^2/s^2]: the second moments W_xx, W_yy,
        W_zz and the covariance W_xy (sigma_ij = <w_i w_j>; variances, not rms values);
        ``velocity_dispersion`` [m/s] = sqrt(trace/3); ``velocity_dispersion_x/_y/_z`` [m/s]
        = sqrt(W_xx), sqrt(W_yy), sqrt(W_zz), the rms speeds along each axis.
    """
    W = np.asarray(tensor, dtype=float)
    if W.shape != (3, 3):
        raise ValueError(f"tensor must be 3x3, got shape {W.shape}")
    diag = np.clip(np.diag(W), 0.0, None)
    return {
        "sigma_xx": float(W[0, 0]),
        "sigma_yy": float(W[1, 1]),
        "sigma_zz": float(W[2, 2]),
        "sigma_xy": float(W[0, 1]),
        "velocity_dispersion": float(math.sqrt(diag.sum() / 3.0)),
        "velocity_dispersion_x": float(math.sqrt(diag[0])),
        "velocity_dispersion_y": float(math.sqrt(diag[1])),
        "velocity_dispersion_z": float(math.sqrt(diag[2])),
    }


# --- vertical structure and optical depth -----------------------------------------------------

def thickness(z: ArrayLike, weights: ArrayLike | None = None) -> float:
    """Rms height about the mean plane, sqrt(<(z - <z>)^2>) [m].

    Parameters
    ----------
    z : array [m]
        Vertical positions.
    weights : array, optional
        None (number-weighted) or e.g. masses [kg] (mass-weighted).
    """
    z = _array("z", z)
    if z.size == 0:
        raise ValueError("no particles")
    w = _weights(weights, z.size)
    dz = z - _mean(z, w)
    return float(math.sqrt(_mean(dz * dz, w)))


def optical_depth(radius: ArrayLike, Lx: float, Ly: float) -> float:
    """Dynamical optical depth sum(pi r^2) / (Lx Ly) [dimensionless].

    Parameters
    ----------
    radius : array [m]
        Particle radii.
    Lx, Ly : float [m]
        Radial and azimuthal box sizes.
    """
    r = _nonnegative_array("radius", radius)
    return float(math.pi * np.dot(r, r) / (_positive("Lx", Lx) * _positive("Ly", Ly)))


def surface_density(mass: ArrayLike, Lx: float, Ly: float) -> float:
    """Surface mass density Sigma = sum(m) / (Lx Ly) [kg/m^2].

    Parameters
    ----------
    mass : array [kg]
    Lx, Ly : float [m]
    """
    m = _nonnegative_array("mass", mass)
    return float(np.sum(m) / (_positive("Lx", Lx) * _positive("Ly", Ly)))


def sphere_slab_volume(z_center: ArrayLike, radius: ArrayLike, z_low: float,
                       z_high: float) -> FloatArray:
    """Exact volume of each sphere lying between the planes z_low < z < z_high [m^3].

    The slice of a sphere of radius r centred at z_c between heights u = z - z_c in
    [lo, hi] (clipped to [-r, r]) has volume pi [r^2 u - u^3/3] evaluated from lo to hi.

    Parameters
    ----------
    z_center : array [m]
        Heights of the sphere centres.
    radius : array [m]
        Sphere radii (broadcast against z_center).
    z_low, z_high : float [m]
        The slab, z_low <= z_high.
    """
    zc = np.asarray(z_center, dtype=float)
    r = np.asarray(radius, dtype=float)
    if z_high < z_low:
        raise ValueError("z_high must be >= z_low")
    lo = np.minimum(np.maximum(z_low - zc, -r), r)
    hi = np.minimum(np.maximum(z_high - zc, -r), r)
    return math.pi * (r * r * (hi - lo) - (hi * hi * hi - lo * lo * lo) / 3.0)


def filling_factor(z: ArrayLike, radius: ArrayLike, Lx: float, Ly: float,
                   half_width: float | None = None, z_mid: float | None = None) -> float:
    """Midplane volume filling factor [dimensionless].

    FF = sum_i V_i / (Lx Ly 2h), where V_i is the exact volume of particle i inside the
    slab |z - z_mid| < h.  For h -> 0 this tends to sum(pi (r^2 - (z - z_mid)^2)_+)/(Lx Ly),
    the area fraction of the midplane covered by particles (the definition of REBOUND's
    shearing_sheet_diagnostics example), which is used when ``half_width == 0``.
    A monolayer of identical spheres at z = z_mid has FF(h = r) = (2/3) tau.

    Parameters
    ----------
    z : array [m]
        Vertical positions.
    radius : array [m]
        Particle radii.
    Lx, Ly : float [m]
        Box sizes.
    half_width : float [m], optional
        h; default: the mean particle radius.
    z_mid : float [m], optional
        Midplane height; default: the mean z.
    """
    z = _array("z", z)
    r = _nonnegative_array("radius", radius)
    _same_length(z=z, radius=r)
    area = _positive("Lx", Lx) * _positive("Ly", Ly)
    z0 = float(np.mean(z)) if z_mid is None else float(z_mid)
    h = float(np.mean(r)) if half_width is None else float(half_width)
    if not (math.isfinite(h) and h >= 0.0):
        raise ValueError(f"half_width must be finite and >= 0, got {half_width!r}")
    dz = z - z0
    if h == 0.0:
        return float(math.pi * np.sum(np.clip(r * r - dz * dz, 0.0, None)) / area)
    return float(np.sum(sphere_slab_volume(dz, r, -h, h)) / (area * 2.0 * h))


# --- size bins --------------------------------------------------------------------------------

def log_size_bins(r_min: float, r_max: float, n_bins: int) -> FloatArray:
    """Edges of n_bins logarithmically spaced radius bins from r_min to r_max [m].

    Parameters
    ----------
    r_min, r_max : float [m]
        0 < r_min <= r_max.  For r_min == r_max a single bin [r, r] is returned.
    n_bins : int
        Number of bins (>= 1).
    """
    r_min = _positive("r_min", r_min)
    r_max = _positive("r_max", r_max)
    if r_max < r_min:
        raise ValueError("r_max must be >= r_min")
    if int(n_bins) < 1:
        raise ValueError("n_bins must be >= 1")
    if r_max == r_min:
        return np.array([r_min, r_max])
    return np.geomspace(r_min, r_max, int(n_bins) + 1)


def _bin_edges(radius: FloatArray, size_bins: ArrayLike | int | None) -> FloatArray:
    if size_bins is None:
        size_bins = 1
    if np.ndim(size_bins) == 0:
        return log_size_bins(float(radius.min()), float(radius.max()), int(size_bins))
    edges = _array("size_bins", size_bins)
    single_radius = edges.size == 2 and edges[0] == edges[1]
    if edges.size < 2 or (np.any(np.diff(edges) <= 0.0) and not single_radius):
        raise ValueError("size_bins must be increasing edges, at least two")
    return edges


def _bin_index(radius: FloatArray, edges: FloatArray) -> NDArray[np.intp]:
    """Bin of each particle (np.histogram convention: last bin closed); -1 outside."""
    n_bins = edges.size - 1
    idx = np.searchsorted(edges, radius, side="right") - 1
    idx[radius == edges[-1]] = n_bins - 1
    idx[(radius < edges[0]) | (radius > edges[-1])] = -1
    return idx


def _binned_statistics(idx: NDArray[np.intp], n_bins: int, w: FloatArray,
                       z: FloatArray) -> dict[str, FloatArray]:
    """Per-bin count, 1-D dispersion about the bin's mean velocity, rms z about <z>_bin."""
    inside = idx >= 0
    b = idx[inside]
    counts = np.bincount(b, minlength=n_bins).astype(float)

    def bin_variance(values: FloatArray) -> FloatArray:
        # Two passes (bin mean, then squared deviations) to avoid cancellation.
        mean = np.bincount(b, weights=values, minlength=n_bins) / counts
        dev = values - mean[b]
        return np.bincount(b, weights=dev * dev, minlength=n_bins) / counts

    with np.errstate(invalid="ignore", divide="ignore"):
        var_sum = sum(bin_variance(comp) for comp in w[:, inside])
        zvar = bin_variance(z[inside])
    usable = counts >= 2
    c = np.where(usable, np.sqrt(np.clip(var_sum, 0.0, None) / 3.0), np.nan)
    h = np.where(usable, np.sqrt(zvar), np.nan)
    return {"n": counts.astype(np.int64), "velocity_dispersion": c, "thickness": h}


def snapshot_summary(x: ArrayLike, y: ArrayLike, z: ArrayLike, vx: ArrayLike, vy: ArrayLike,
                     vz: ArrayLike, radius: ArrayLike, mass: ArrayLike, Omega: float,
                     Lx: float, Ly: float, size_bins: ArrayLike | int | None = None,
                     filling_half_width: float | None = None) -> dict[str, object]:
    """All single-snapshot diagnostics of a shearing-sheet patch, SI.

    Parameters
    ----------
    x, y, z : array [m]
        Positions (y is accepted for a uniform call signature; no diagnostic uses it).
    vx, vy, vz : array [m/s]
        Velocities in the shearing-sheet frame (shear flow vy = -1.5 Omega x).
    radius : array [m]
    mass : array [kg]
    Omega : float [1/s]
    Lx, Ly : float [m]
        Radial and azimuthal box sizes.
    size_bins : None, int, or array of edges [m]
        Radius bins for the per-bin statistics: edges (increasing; the last bin includes
        its upper edge, as np.histogram), or a number of log-spaced bins spanning the
        radii present (``log_size_bins``); None means one bin holding every particle.
    filling_half_width : float [m], optional
        Half-width h of the midplane slab of the filling factor; default the mean radius.

    Returns
    -------
    dict
        Scalars: ``n_particles``; ``velocity_dispersion`` [m/s]; ``sigma_xx``,
        ``sigma_yy``, ``sigma_zz``, ``sigma_xy`` [m^2/s^2] (number-weighted tensor
        components, see ``dispersion_components``); ``velocity_dispersion_x/_y/_z`` [m/s];
        ``velocity_dispersion_mass_weighted`` [m/s]; ``thickness`` and
        ``thickness_mass_weighted`` [m]; ``filling_factor`` [1] and
        ``filling_half_width`` [m]; ``optical_depth`` [1]; ``surface_density`` [kg/m^2];
        ``mean_radius`` [m]; ``mean_mass`` [kg]; ``translational_viscosity`` [m^2/s].
        Per-bin arrays (length n_bins): ``size_bin_edges`` [m] (n_bins + 1),
        ``size_bin_n``, ``size_bin_velocity_dispersion`` [m/s] and
        ``size_bin_thickness`` [m] (NaN where a bin holds fewer than 2 particles).
    """
    Omega = _positive("Omega", Omega)
    arrays = {name: _array(name, a) for name, a in (("x", x), ("y", y), ("z", z), ("vx", vx),
                                                    ("vy", vy), ("vz", vz))}
    r = _nonnegative_array("radius", radius)
    m = _nonnegative_array("mass", mass)
    n = _same_length(**arrays, radius=r, mass=m)
    area = _positive("Lx", Lx) * _positive("Ly", Ly)
    if not np.sum(m) > 0.0:
        raise ValueError("mass must not be all zero")

    w = np.stack([arrays["vx"], arrays["vy"] + SHEAR * Omega * arrays["x"], arrays["vz"]])
    components = dispersion_components(_tensor(w, None))
    W_mass = _tensor(w, m)
    zz = arrays["z"]

    edges = _bin_edges(r, size_bins)
    binned = _binned_statistics(_bin_index(r, edges), edges.size - 1, w, zz)

    h = float(np.mean(r)) if filling_half_width is None else float(filling_half_width)
    summary: dict[str, object] = {"n_particles": n}
    summary.update(components)
    summary.update({
        "velocity_dispersion_mass_weighted": float(math.sqrt(max(np.trace(W_mass), 0.0) / 3.0)),
        "thickness": thickness(zz),
        "thickness_mass_weighted": thickness(zz, m),
        "filling_factor": filling_factor(zz, r, Lx, Ly, half_width=h),
        "filling_half_width": h,
        "optical_depth": float(math.pi * np.dot(r, r) / area),
        "surface_density": float(np.sum(m) / area),
        "mean_radius": float(np.mean(r)),
        "mean_mass": float(np.mean(m)),
        "translational_viscosity": float(2.0 * W_mass[0, 1] / (3.0 * Omega)),
        "size_bin_edges": edges,
        "size_bin_n": binned["n"],
        "size_bin_velocity_dispersion": binned["velocity_dispersion"],
        "size_bin_thickness": binned["thickness"],
    })
    return summary


# --- collision rates and viscosity ------------------------------------------------------------

def collision_frequency(n_collisions: float, n_particles: int, elapsed_time: float,
                        Omega: float) -> float:
    """Impacts per particle per orbit [1/orbit].

    Each collision involves two particles, so the frequency is
    2 n_collisions / n_particles / (elapsed_time Omega / 2 pi).

    Parameters
    ----------
    n_collisions : float
        Number of (pair) collisions counted during ``elapsed_time``.
    n_particles : int
        Number of particles in the box.
    elapsed_time : float [s]
    Omega : float [1/s]
    """
    if not (math.isfinite(float(n_collisions)) and n_collisions >= 0):
        raise ValueError(f"n_collisions must be finite and >= 0, got {n_collisions!r}")
    if int(n_particles) < 1:
        raise ValueError("n_particles must be >= 1")
    orbits = _positive("elapsed_time", elapsed_time) * _positive("Omega", Omega) / TWO_PI
    return float(2.0 * n_collisions / int(n_particles) / orbits)


def translational_viscosity(x: ArrayLike, vx: ArrayLike, vy: ArrayLike, Omega: float,
                            mass: ArrayLike | None = None) -> float:
    """Translational (local) kinematic viscosity nu_trans = (2 / (3 Omega)) W_xy [m^2/s].

    W_xy = <(w_x - <w_x>)(w_y - <w_y>)>, mass-weighted when ``mass`` is given, with
    w_y = vy + 1.5 Omega x (Wisdom & Tremaine 1988; REBOUND's
    examples/shearing_sheet_diagnostics/problem.c uses the same formula number-weighted
    and without subtracting the mean).

    Parameters
    ----------
    x : array [m]
    vx, vy : array [m/s]
    Omega : float [1/s]
    mass : array [kg], optional
    """
    x = _array("x", x)
    W = dispersion_tensor(x, vx, vy, np.zeros_like(x), Omega, weights=mass)
    return float(2.0 * W[0, 1] / (3.0 * _positive("Omega", Omega)))


def collisional_viscosity(plog: float, elapsed_time: float, Lx: float, Ly: float,
                          surface_density: float, Omega: float) -> float:
    """Collisional (non-local) kinematic viscosity from REBOUND's ``collisions_plog`` [m^2/s].

    REBOUND accumulates, for every resolved collision (src/collision.c,
    reb_collision_resolve_hardsphere), plog += |x_outer - x_inner| * m_outer * dvy_outer:
    the radial separation of the pair times the azimuthal momentum given to the outer
    particle -- the collisional flux of y-momentum across a radius.  Dividing by the
    elapsed time and the area gives the collisional pressure tensor component, and

        nu_col = 2 plog / (3 Omega Sigma Lx Ly elapsed_time),

    which is REBOUND's examples/shearing_sheet_diagnostics/problem.c formula
    2/3/Omega/M_total/t * plog with M_total = Sigma Lx Ly (Wisdom & Tremaine 1988).
    ``plog`` must have been reset (set to 0) ``elapsed_time`` ago.

    Parameters
    ----------
    plog : float [kg m^2/s]
        Accumulated collisions_plog.
    elapsed_time : float [s]
        Time over which plog was accumulated.
    Lx, Ly : float [m]
        Box sizes.
    surface_density : float [kg/m^2]
    Omega : float [1/s]
    """
    mass = _positive("surface_density", surface_density) * _positive("Lx", Lx) * _positive(
        "Ly", Ly)
    if not math.isfinite(float(plog)):
        raise ValueError("plog must be finite")
    return float(2.0 * plog / (3.0 * _positive("Omega", Omega) * mass
                               * _positive("elapsed_time", elapsed_time)))


# Gravitational viscosity (from pairwise forces) is not implemented here: it needs the
# pairwise gravitational torques, which a snapshot of positions and velocities alone does
# not give without an O(N^2) or tree force evaluation.


# --- applied coefficients of restitution ------------------------------------------------------

def epsilon_statistics(epsilon: ArrayLike, bins: int | ArrayLike = 20,
                       normal_speed: ArrayLike | None = None) -> dict[str, object]:
    """Mean and histogram of applied coefficients of restitution (e.g. a collision log).

    Parameters
    ----------
    epsilon : array [dimensionless], in [0, 1]
        The coefficients applied, one per collision.
    bins : int or array
        Number of equal bins on [0, 1], or explicit edges.
    normal_speed : array [m/s], optional
        Normal impact speed of each collision; adds the energy-weighted effective
        coefficient sqrt(sum(eps^2 v^2) / sum(v^2)), the one that sets the dissipation rate.

    Returns
    -------
    dict
        ``count``, ``mean_epsilon``, ``std_epsilon``, ``mean_epsilon_squared``,
        ``histogram`` (counts per bin), ``bin_edges``; ``effective_epsilon`` when
        ``normal_speed`` is given.  Means are NaN when there is no collision.
    """
    eps = np.asarray(epsilon, dtype=float).reshape(-1)
    if not np.all(np.isfinite(eps)) or np.any((eps < 0.0) | (eps > 1.0)):
        raise ValueError("epsilon must be finite and lie in [0, 1]")
    edges = np.linspace(0.0, 1.0, int(bins) + 1) if np.ndim(bins) == 0 else np.asarray(
        bins, dtype=float)
    counts, edges = np.histogram(eps, bins=edges)
    out: dict[str, object] = {
        "count": int(eps.size),
        "mean_epsilon": float(eps.mean()) if eps.size else math.nan,
        "std_epsilon": float(eps.std()) if eps.size else math.nan,
        "mean_epsilon_squared": float(np.mean(eps * eps)) if eps.size else math.nan,
        "histogram": counts,
        "bin_edges": edges,
    }
    if normal_speed is not None:
        v = np.abs(_array("normal_speed", normal_speed))
        if v.size != eps.size:
            raise ValueError("normal_speed and epsilon must have equal lengths")
        v2 = v * v
        total = np.sum(v2)
        out["effective_epsilon"] = (float(math.sqrt(np.dot(eps * eps, v2) / total))
                                    if total > 0.0 else math.nan)
    return out


# --- equilibrium of a time series -------------------------------------------------------------

@dataclass(frozen=True)
class EquilibriumResult:
    """Equilibrium value of a time series.

    Attributes
    ----------
    mean : float
        Mean over the equilibrium window [units of the series].
    stderr : float
        Standard error of that mean, corrected for autocorrelation [units of the series].
    start_index : int
        First sample of the window (end of the transient, MSER-5).
    start_time : float
        Time of that sample [units of series_t, s for ringsim].
    n_effective : float
        Window length / integrated autocorrelation time: independent samples.
    in_equilibrium : bool
        False if the window is too short or still drifts (see ``reason``).
    reason : str
        Why it is (or is not) in equilibrium.
    autocorrelation_time : float
        Integrated autocorrelation time tau_int [samples].
    slope : float
        Least-squares slope over the window [series units per unit of series_t].
    slope_stderr : float
        Its autocorrelation-corrected standard error.
    relative_drift : float
        |slope| * window duration / |mean| [dimensionless].
    """

    mean: float
    stderr: float
    start_index: int
    start_time: float
    n_effective: float
    in_equilibrium: bool
    reason: str
    autocorrelation_time: float = math.nan
    slope: float = math.nan
    slope_stderr: float = math.nan
    relative_drift: float = math.nan


def mser_truncation(values: ArrayLike, batch_size: int = 5, max_fraction: float = 0.5) -> int:
    """Truncation point of the initial transient by MSER-m (MSER-5 for batch_size = 5).

    The series is cut into batches of ``batch_size`` samples (an incomplete last batch is
    dropped); with batch means Y_1..Y_k, the statistic

        MSER(d) = sum_{j > d} (Y_j - mean(Y_{d+1..k}))^2 / (k - d)^2

    is minimised over d = 0 .. floor(max_fraction k) (White 1997; White, Cobb & Spratt
    2000, who restrict d to the first half of the run).

    Parameters
    ----------
    values : array
        The series (uniformly sampled).
    batch_size : int
        m; 5 is the published MSER-5 choice.
    max_fraction : float
        Largest fraction of the batches that may be discarded.

    Returns
    -------
    int
        Index of the first sample after the transient.
    """
    y = np.asarray(values, dtype=float).reshape(-1)
    m = int(batch_size)
    if m < 1:
        raise ValueError("batch_size must be >= 1")
    k = y.size // m
    if k < 2:
        return 0
    batches = y[: k * m].reshape(k, m).mean(axis=1)
    batches = batches - batches.mean()  # shift-invariant; avoids cancellation
    # Tail sums from d to the end, for every d.
    s1 = np.cumsum(batches[::-1])[::-1]
    s2 = np.cumsum((batches * batches)[::-1])[::-1]
    remaining = np.arange(k, 0, -1, dtype=float)
    sse = np.clip(s2 - s1 * s1 / remaining, 0.0, None)
    d_max = min(int(math.floor(max_fraction * k)), k - 2)
    stat = sse[: d_max + 1] / remaining[: d_max + 1] ** 2
    return int(np.argmin(stat)) * m


def _autocovariance(y: FloatArray) -> FloatArray:
    """Autocovariance (biased, 1/n) of y at lags 0..n-1, by FFT."""
    n = y.size
    d = y - y.mean()
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(d, n=size)
    return np.fft.irfft(f * np.conjugate(f), n=size)[:n] / n


def integrated_autocorrelation_time(values: ArrayLike, window_factor: float = 5.0) -> float:
    """Integrated autocorrelation time tau_int = 1 + 2 sum_t rho(t) [samples].

    The sum is cut at the smallest window M with M >= window_factor * tau_int(M)
    (Sokal's automatic windowing; Madras & Sokal 1988; Sokal 1997).  The variance of the
    mean of n samples is then var * tau_int / n.  Returns 1 for a constant series and never
    less than 1 (anticorrelation is not credited).

    Parameters
    ----------
    values : array
        Uniformly sampled series.
    window_factor : float
        Sokal's c (5 for nearly exponential autocorrelations).
    """
    y = np.asarray(values, dtype=float).reshape(-1)
    if y.size < 2:
        return 1.0
    acov = _autocovariance(y)
    if not acov[0] > 0.0:
        return 1.0
    taus = 2.0 * np.cumsum(acov / acov[0]) - 1.0
    lags = np.arange(y.size)
    ok = lags >= window_factor * taus
    window = int(np.argmax(ok)) if np.any(ok) else y.size - 1
    return float(max(taus[window], 1.0))


def autocorrelated_mean(values: ArrayLike,
                        window_factor: float = 5.0) -> tuple[float, float, float]:
    """Mean of a stationary series and its standard error, corrected for autocorrelation.

    stderr = sqrt(var tau_int / n) with ``integrated_autocorrelation_time``; no transient
    is removed (see ``equilibrium`` for that).  Non-finite samples are dropped.

    Parameters
    ----------
    values : array
        Uniformly sampled series [any unit].
    window_factor : float
        Sokal's window constant c.

    Returns
    -------
    (mean, stderr, n_effective)
        Mean and standard error [units of the series]; n_effective = n / tau_int.  For
        fewer than 2 samples the standard error is NaN.
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan, 0.0
    if v.size < 2:
        return float(v[0]), math.nan, 1.0
    tau = integrated_autocorrelation_time(v, window_factor)
    return float(np.mean(v)), math.sqrt(float(np.var(v)) * tau / v.size), v.size / tau


def equilibrium(series_t: ArrayLike, series_values: ArrayLike, *, min_fraction: float = 0.5,
                batch_size: int = 5, min_effective_samples: float = 20.0,
                trend_sigma: float = 3.0, max_relative_drift: float = 0.05,
                window_factor: float = 5.0) -> EquilibriumResult:
    """Equilibrium mean and its standard error of a time series, with a drift test.

    1. The transient is cut by MSER-5 (``mser_truncation``), discarding at most
       1 - ``min_fraction`` of the samples.
    2. Over the kept window, the mean and its standard error sqrt(var tau_int / n) with the
       integrated autocorrelation time (``integrated_autocorrelation_time``).
    3. Not in equilibrium when (a) the window holds fewer than ``min_effective_samples``
       effective samples n / tau_int; or (b) a straight-line fit over the window has a
       slope beyond ``trend_sigma`` times its standard error (the OLS error inflated by
       sqrt(tau_int) of the residuals) AND the fitted change over the window exceeds
       ``max_relative_drift`` times |mean|; or (c) MSER put the truncation at its limit,
       i.e. the transient may not be over.

    Non-finite samples are dropped first.  The series should be sampled uniformly in time.

    Parameters
    ----------
    series_t : array
        Sample times [s] (any unit; ``start_time`` and ``slope`` use it).
    series_values : array
        The quantity [any unit].
    min_fraction : float
        Smallest fraction of the series kept as the equilibrium window (0 < f <= 1).
    batch_size : int
        MSER batch size (5: MSER-5).
    min_effective_samples : float
        Fewest independent samples for an equilibrium verdict.
    trend_sigma : float
        Significance of a slope, in standard errors, to count as a drift.
    max_relative_drift : float
        Largest tolerated fitted change over the window relative to |mean|.
    window_factor : float
        Sokal's window constant c.
    """
    t = np.asarray(series_t, dtype=float).reshape(-1)
    v = np.asarray(series_values, dtype=float).reshape(-1)
    if t.size != v.size:
        raise ValueError("series_t and series_values must have equal lengths")
    if not 0.0 < min_fraction <= 1.0:
        raise ValueError("min_fraction must lie in (0, 1]")
    keep = np.isfinite(t) & np.isfinite(v)
    t, v = t[keep], v[keep]
    if v.size < 3:
        return EquilibriumResult(
            mean=float(np.mean(v)) if v.size else math.nan, stderr=math.nan, start_index=0,
            start_time=float(t[0]) if t.size else math.nan, n_effective=float(v.size),
            in_equilibrium=False, reason=f"too short: {v.size} finite samples")

    start = mser_truncation(v, batch_size=batch_size, max_fraction=1.0 - min_fraction)
    k = v.size // int(batch_size)
    at_limit = start > 0 and start // int(batch_size) >= min(
        int(math.floor((1.0 - min_fraction) * k)), k - 2)
    tw, vw = t[start:], v[start:]
    n = vw.size
    mean, stderr, n_eff = autocorrelated_mean(vw, window_factor)
    tau = n / n_eff
    var = float(np.var(vw))

    # Drift: OLS slope with an autocorrelation-corrected error.
    dt = tw - tw.mean()
    sxx = float(np.dot(dt, dt))
    if sxx > 0.0 and n > 2:
        slope = float(np.dot(dt, vw - mean) / sxx)
        resid = vw - mean - slope * dt
        tau_res = integrated_autocorrelation_time(resid, window_factor)
        slope_err = math.sqrt(float(np.dot(resid, resid)) / (n - 2) / sxx * tau_res)
        duration = float(tw[-1] - tw[0])
        scale = abs(mean) if mean != 0.0 else math.sqrt(var)
        drift = abs(slope) * duration / scale if scale > 0.0 else 0.0
    else:
        slope, slope_err, drift = 0.0, math.nan, 0.0
    significant = slope_err > 0.0 and abs(slope) > trend_sigma * slope_err
    if slope_err == 0.0 and slope != 0.0:
        significant = True  # a noiseless straight line

    problems = []
    if significant and drift > max_relative_drift:
        sigmas = abs(slope) / slope_err if slope_err > 0.0 else math.inf
        problems.append(f"still drifting: slope {slope:.3g} per time unit is {sigmas:.1f} sigma, "
                        f"a change of {100 * drift:.1f}% over the window")
    if at_limit:
        problems.append("transient may not be over: MSER truncation at its limit "
                        f"({100 * (1 - min_fraction):.0f}% of the series)")
    if n_eff < min_effective_samples:
        problems.append(f"too short: {n_eff:.1f} effective samples after the transient "
                        f"(need {min_effective_samples:g})")
    ok = not problems
    reason = "; ".join(problems) if problems else (
        f"stationary after sample {start}: {n_eff:.0f} effective samples, "
        f"drift {100 * drift:.1f}% over the window")
    return EquilibriumResult(mean=mean, stderr=stderr, start_index=int(start),
                             start_time=float(t[start]), n_effective=float(n_eff),
                             in_equilibrium=ok, reason=reason, autocorrelation_time=tau,
                             slope=slope, slope_stderr=slope_err, relative_drift=drift)


# --- dilute-ring kinetic theory (Goldreich & Tremaine 1978) -----------------------------------

# Nodes of the trapezoid rule in y = ln(s lambda_mean) for the Gaussian speed moments below;
# the integrands are analytic in a strip |Im y| < pi and decay like exp(-|y|/2), so the rule
# with step 0.25 is exact to rounding.
_LOG_S = np.arange(-80.0, 80.0, 0.25)
_LOG_S_STEP = 0.25


def _gaussian_speed_moments(variances: FloatArray) -> tuple[FloatArray, float]:
    """E[|g| g_k^2] (k = 1..3) and E[|g|] for g ~ N(0, diag(variances)).

    Uses |g| = (4 pi)^(-1/2) int_0^inf (1 - exp(-s g^2)) s^(-3/2) ds and the Gaussian
    E[g_k^2 exp(-s g^2)] = lam_k / (1 + 2 s lam_k) prod_m (1 + 2 s lam_m)^(-1/2).
    """
    lam = np.asarray(variances, dtype=float)
    s = np.exp(_LOG_S)[:, None] / lam.mean()
    log1p = np.log1p(2.0 * s * lam[None, :])
    half = 0.5 * log1p.sum(axis=1, keepdims=True)
    # expm1 keeps the small-s end (where 1 - exp(...) ~ s) accurate.
    weight = _LOG_S_STEP / (2.0 * math.sqrt(math.pi)) / np.sqrt(s)
    moments = np.sum(-np.expm1(-half - log1p) * lam[None, :] * weight, axis=0)
    mean_speed = float(np.sum(-np.expm1(-half[:, 0]) * weight[:, 0]))
    return moments, mean_speed


def _gt78_collision_term(W: FloatArray, epsilon: float, tau: float) -> tuple[FloatArray, float]:
    """Collisional rate of change of W, in units of Omega W (W is dimensionless here).

    For identical smooth spheres of radius r with constant epsilon, a Gaussian velocity
    distribution of covariance W and a Gaussian vertical profile of scale height
    H = sqrt(W_zz)/Omega, the change per particle and unit time is

        dW/dt|coll = tau (1 + eps) / (2 sqrt(pi) H)
                     * E_g[ |g| ( -(3 - eps)/4 g g^T + (1 + eps)/12 |g|^2 I ) ],

    g ~ N(0, 2W) the relative velocity.  Returns that (divided by Omega) and the impact
    rate per particle divided by Omega, 2 tau E|g| / (sqrt(pi) H Omega).
    """
    lam, Q = np.linalg.eigh(2.0 * W)
    moments, mean_speed = _gaussian_speed_moments(np.clip(lam, 1e-300, None))
    M = -(3.0 - epsilon) / 4.0 * (Q * moments) @ Q.T + (1.0 + epsilon) / 12.0 * moments.sum() \
        * np.eye(3)
    H = math.sqrt(W[2, 2])
    rate = tau / (2.0 * math.sqrt(math.pi) * H)
    return rate * (1.0 + epsilon) * M, 4.0 * rate * mean_speed


def _gt78_residuals(p: FloatArray, tau: float) -> list[float]:
    """Steady-state moment equations of the shearing sheet, W_xx = 1."""
    a, b, s, eps = p
    W = np.array([[1.0, s, 0.0], [s, a, 0.0], [0.0, 0.0, b]])
    C, _ = _gt78_collision_term(W, eps, tau)
    # dW/dt from Hill's equations (dw_x/dt = 2 Omega w_y, dw_y/dt = -Omega w_x / 2) + collisions;
    # vertically, <vz^2> = Omega^2 <z^2> leaves only the collision term.
    return [4.0 * s + C[0, 0], -s + C[1, 1], 2.0 * a - 0.5 + C[0, 1], C[2, 2]]


@lru_cache(maxsize=1)
def _gt78_dilute_limit() -> tuple[float, float]:
    """tau -> 0 solution (a = 1/4, s = 0): W_zz/W_xx and eps_cr(0)."""
    def residuals(p: FloatArray) -> list[float]:
        b, eps = p
        moments, _ = _gaussian_speed_moments(2.0 * np.array([1.0, 0.25, b]))
        M = -(3.0 - eps) / 4.0 * moments + (1.0 + eps) / 12.0 * moments.sum()
        return [M[0] + 4.0 * M[1], M[2]]
    sol = optimize.root(residuals, [0.5, 0.6], tol=1e-14)
    if not sol.success:
        raise RuntimeError(f"GT78 dilute limit did not converge: {sol.message}")
    return float(sol.x[0]), float(sol.x[1])


@lru_cache(maxsize=256)
def _gt78_solution(tau: float) -> tuple[float, float, float, float, float]:
    b0, eps0 = _gt78_dilute_limit()
    guess = np.array([0.25, b0, 0.0, eps0])
    if tau == 0.0:
        return 0.25, float(b0), 0.0, float(eps0), 0.0
    # Continuation in log tau from the dilute limit keeps the solver on the physical branch.
    steps = np.geomspace(min(1e-3, tau), tau, max(2, int(np.ceil(np.log10(tau / 1e-3) * 4)) + 1))
    for t_step in steps:
        sol = optimize.root(_gt78_residuals, guess, args=(float(t_step),), tol=1e-13)
        if not sol.success or not np.all(sol.x[:2] > 0.0):
            raise RuntimeError(f"GT78 steady state not found at tau={t_step:g}: {sol.message}")
        guess = sol.x
    a, b, s, eps = guess
    _, impact_rate = _gt78_collision_term(np.array([[1.0, s, 0.0], [s, a, 0.0], [0.0, 0.0, b]]),
                                          eps, tau)
    return float(a), float(b), float(s), float(eps), float(impact_rate)


def gt78_steady_state(optical_depth: float) -> dict[str, float]:
    """Steady state of a dilute ring of identical smooth spheres with constant eps (GT78).

    Solves the second-moment equations of the shearing sheet for a triaxial Gaussian
    velocity distribution (Goldreich & Tremaine 1978, Icarus 34, 227): Hill's equations
    plus the exact collision integrals of smooth hard spheres with a constant coefficient
    of restitution eps, a Gaussian vertical profile of scale height sqrt(W_zz)/Omega, no
    self-gravity, and no finite-size (non-local) terms.  The equations are homogeneous in
    the dispersion, so the steady state fixes only eps (the critical value eps_cr at which
    heating by the shear balances dissipation) and the shape of the tensor, not its scale.
    For tau -> 0 this gives eps_cr = 0.6270 and W_yy/W_xx = 1/4 (the epicyclic ratio),
    GT78's values; Spaute & Greenberg (1987, Icarus 70, 289) likewise find random motions
    of smooth spheres grow for eps > 0.63.  eps_cr rises with tau (0.651 at 0.25, 0.812 at 1).

    Limits: dilute ring only -- particles small compared with the scale height and mean
    free path (c >> r Omega); dense rings need finite-size terms (Araki & Tremaine 1986),
    which raise the heating and let rings with eps < eps_cr settle near c ~ 2-3 r Omega.

    Equations (W_xx = 1, Omega = 1): 4 W_xy + C_xx = 0, -W_xy + C_yy = 0,
    2 W_yy - W_xx/2 + C_xy = 0, C_zz = 0, with the collision term C of
    ``_gt78_collision_term``; the Gaussian speed moments are exact 1-D integrals.

    Parameters
    ----------
    optical_depth : float [dimensionless]
        tau = N pi r^2 / area, >= 0.

    Returns
    -------
    dict
        ``epsilon_critical``; ``sigma_yy_over_xx``, ``sigma_zz_over_xx``,
        ``sigma_xy_over_xx`` (tensor shape); ``impacts_per_orbit`` (collisions per particle
        per orbit); ``viscosity_Omega_over_c2`` = nu_trans Omega / c^2 with c^2 = trace/3.
    """
    tau = float(optical_depth)
    if not (math.isfinite(tau) and tau >= 0.0):
        raise ValueError(f"optical_depth must be finite and >= 0, got {optical_depth!r}")
    a, b, s, eps, impact_rate = _gt78_solution(tau)
    c2 = (1.0 + a + b) / 3.0
    return {
        "optical_depth": tau,
        "epsilon_critical": eps,
        "sigma_yy_over_xx": a,
        "sigma_zz_over_xx": b,
        "sigma_xy_over_xx": s,
        "impacts_per_orbit": TWO_PI * impact_rate,
        "viscosity_Omega_over_c2": 2.0 * s / 3.0 / c2,
    }


def critical_epsilon(optical_depth: float) -> float:
    """GT78 critical coefficient of restitution eps_cr(tau) [dimensionless].

    A dilute ring of identical smooth spheres with constant eps heats without bound for
    eps > eps_cr(tau) and cools (collapses towards a monolayer) for eps < eps_cr(tau).
    eps_cr rises from 0.6270 at tau -> 0 (GT78) towards 1 at large tau; see
    ``gt78_steady_state`` for the model.

    Parameters
    ----------
    optical_depth : float [dimensionless]
    """
    return gt78_steady_state(optical_depth)["epsilon_critical"]


# Gauss-Legendre panels on s = v_n / (2c) in [0, 9] for the impact-speed averages
# (exp(-81) makes the tail negligible); many short panels keep the error at kinks of eps(v)
# (Bridges' v_c, Andrews' v_c) small, and fixed nodes keep the average continuous in c.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_S_EDGES = np.linspace(0.0, 9.0, 1201)
_S_NODES = ((_S_EDGES[:-1, None] + _S_EDGES[1:, None]) / 2.0
            + (np.diff(_S_EDGES)[:, None] / 2.0) * _GL_X[None, :]).ravel()
_S_WEIGHTS = ((np.diff(_S_EDGES)[:, None] / 2.0) * _GL_W[None, :]).ravel()


def effective_epsilon(restitution: Mapping[str, object], velocity_dispersion: float,
                      R_bar: float, M_bar: float, weighting: str = "energy") -> float:
    """Impact-averaged coefficient of restitution for an isotropic Maxwellian [dimensionless].

    With a 1-D dispersion c, the relative velocity of a pair is Gaussian with variance 2c^2
    per component; a collision's normal speed u is then distributed with the flux weight,
    p(u) ~ u exp(-u^2 / 4c^2).  Returns sqrt(<eps(u)^2>), the average taken with

    * ``weighting="energy"`` (default): collisions weighted by their normal kinetic energy,
      ~ u^3 exp(-u^2/4c^2) -- the eps of a constant-eps ring losing energy at the same rate,
      the one to compare with eps_cr;
    * ``weighting="collision"``: every collision equally, ~ u exp(-u^2/4c^2).

    Parameters
    ----------
    restitution : mapping
        A scenario's restitution section (``ringsim.restitution.epsilon_for_pair``).
    velocity_dispersion : float [m/s]
        c, > 0.
    R_bar : float [m]
        Reduced radius of the colliding pair.
    M_bar : float [kg]
        Reduced mass of the colliding pair.
    weighting : {"energy", "collision"}
    """
    # Imported here so the snapshot statistics above stay usable without the restitution laws.
    from ringsim.restitution import epsilon_for_pair

    c = _positive("velocity_dispersion", velocity_dispersion)
    if weighting == "energy":
        kernel = _S_NODES**3
    elif weighting == "collision":
        kernel = _S_NODES.copy()
    else:
        raise ValueError(f"weighting must be 'energy' or 'collision', got {weighting!r}")
    weights = _S_WEIGHTS * kernel * np.exp(-_S_NODES**2)
    eps = np.asarray(epsilon_for_pair(restitution, 2.0 * c * _S_NODES, R_bar, M_bar), dtype=float)
    return float(math.sqrt(np.dot(weights, eps * eps) / np.sum(weights)))


def kinetic_dispersion_estimate(restitution: Mapping[str, object], radius: ArrayLike,
                                mass: ArrayLike, optical_depth: float, Omega: float, *,
                                c_min: float = 1e-10, c_max: float = 1e3,
                                n_scan: int = 131,
                                weighting: str = "energy") -> dict[str, object]:
    """Equilibrium velocity dispersion of a dilute ring from kinetic energy balance.

    Assumptions (as in Goldreich & Tremaine 1978): dilute ring (no finite-size, non-local
    heating or transport -- valid while c >> r Omega), identical smooth spheres (no
    spin), no self-gravity, and for the velocity dependence of eps an isotropic Maxwellian
    of impact velocities.  A size distribution is represented by identical particles of the
    MEAN radius and MEAN mass (R_bar = r/2, M_bar = m/2).

    Balance: the ring is in thermal equilibrium at the c where the impact-averaged
    coefficient of restitution (``effective_epsilon``, energy-weighted by default) equals
    GT78's critical value eps_cr(tau) (``critical_epsilon``).  Roots are bracketed by a
    log-spaced scan of c over [c_min, c_max] and refined with Brent's method; a root is
    stable where eps_eff falls through eps_cr as c grows (hotter -> more dissipative).

    Parameters
    ----------
    restitution : mapping
        A scenario's restitution section.
    radius : float or array [m]
    mass : float or array [kg]
    optical_depth : float [dimensionless]
    Omega : float [1/s]
    c_min, c_max : float [m/s]
        Range searched.
    n_scan : int
        Scan points (log-spaced).
    weighting : {"energy", "collision"}
        See ``effective_epsilon``.

    Returns
    -------
    dict
        ``status``: "equilibrium", "collapse" (eps_eff < eps_cr at every c: the dilute ring
        cools until finite-size effects, not modelled here, stop it), "heating"
        (eps_eff > eps_cr at every c: no thermal balance, c grows without bound), or
        "unstable" (only unstable balances); ``reason`` (text);
        ``velocity_dispersion`` [m/s] (lowest stable root, NaN otherwise);
        ``velocity_dispersion_rOmega`` (c / (r Omega)); ``epsilon_critical``;
        ``effective_epsilon`` (at c, NaN if none); ``roots`` (list of
        {"velocity_dispersion", "stable"}); ``radius`` [m], ``mass`` [kg], ``R_bar`` [m],
        ``M_bar`` [kg], ``optical_depth``, ``weighting``; ``gt78`` (``gt78_steady_state``).
    """
    r = float(np.mean(_nonnegative_array("radius", np.atleast_1d(radius))))
    m = float(np.mean(_nonnegative_array("mass", np.atleast_1d(mass))))
    r = _positive("radius", r)
    m = _positive("mass", m)
    Omega = _positive("Omega", Omega)
    c_min = _positive("c_min", c_min)
    c_max = _positive("c_max", c_max)
    if c_max <= c_min or int(n_scan) < 2:
        raise ValueError("need c_min < c_max and n_scan >= 2")
    steady = gt78_steady_state(optical_depth)
    eps_cr = steady["epsilon_critical"]
    R_bar, M_bar = r / 2.0, m / 2.0

    def excess(log_c: float) -> float:
        return effective_epsilon(restitution, math.exp(log_c), R_bar, M_bar, weighting) - eps_cr

    log_c = np.linspace(math.log(c_min), math.log(c_max), int(n_scan))
    f = np.array([excess(x) for x in log_c])
    roots: list[dict[str, object]] = []
    for i in range(log_c.size - 1):
        if f[i] == 0.0:
            roots.append({"velocity_dispersion": math.exp(log_c[i]),
                          "stable": bool(f[i + 1] < 0.0 or (i > 0 and f[i - 1] > 0.0))})
        elif f[i] * f[i + 1] < 0.0:
            x = optimize.brentq(excess, log_c[i], log_c[i + 1], xtol=1e-14, rtol=1e-15,
                                maxiter=200)
            roots.append({"velocity_dispersion": math.exp(x), "stable": bool(f[i] > 0.0)})

    result: dict[str, object] = {
        "epsilon_critical": eps_cr, "radius": r, "mass": m, "R_bar": R_bar, "M_bar": M_bar,
        "optical_depth": float(optical_depth), "weighting": weighting, "roots": roots,
        "gt78": steady, "velocity_dispersion": math.nan,
        "velocity_dispersion_rOmega": math.nan, "effective_epsilon": math.nan,
    }
    stable = [root for root in roots if root["stable"]]
    if stable:
        c = float(stable[0]["velocity_dispersion"])
        result.update(status="equilibrium", velocity_dispersion=c,
                      velocity_dispersion_rOmega=c / (r * Omega),
                      effective_epsilon=effective_epsilon(restitution, c, R_bar, M_bar,
                                                          weighting))
        note = "" if c > 10.0 * r * Omega else (
            "; c < 10 r Omega, where the dilute (local) approximation fails")
        result["reason"] = (f"thermal balance at c = {c:.4g} m/s = {c / (r * Omega):.4g} r Omega "
                            f"(eps_eff = eps_cr = {eps_cr:.4f}){note}")
    elif roots:
        result.update(status="unstable", reason=(
            "only unstable balances (eps_eff rises through eps_cr with c): the ring either "
            "collapses or heats without bound depending on its initial c"))
    elif np.all(f < 0.0):
        result.update(status="collapse", reason=(
            f"eps_eff < eps_cr = {eps_cr:.4f} at every c in [{c_min:g}, {c_max:g}] m/s: "
            "collisions dissipate more than the shear supplies; the dilute ring collapses "
            "(to a near-monolayer held up by finite-size effects, not modelled here)"))
    else:
        result.update(status="heating", reason=(
            f"eps_eff > eps_cr = {eps_cr:.4f} at every c in [{c_min:g}, {c_max:g}] m/s: "
            "no thermal balance, the velocity dispersion grows without bound"))
    return result
