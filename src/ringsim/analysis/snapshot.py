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

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ringsim.checks import finite_array, nonnegative_array, positive, same_length
from ringsim.physics.constants import SHEAR, TWO_PI

FloatArray = NDArray[np.float64]


__all__ = [
    "collision_frequency",
    "collisional_viscosity",
    "dispersion_components",
    "dispersion_tensor",
    "epsilon_statistics",
    "filling_factor",
    "log_size_bins",
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


def _weights(weights: ArrayLike | None, n: int) -> FloatArray | None:
    if weights is None:
        return None
    w = nonnegative_array("weights", weights)
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
    Omega = positive("Omega", Omega)
    x, vx, vy, vz = (finite_array(n, a) for n, a in (("x", x), ("vx", vx), ("vy", vy), ("vz", vz)))
    same_length(x=x, vx=vx, vy=vy, vz=vz)
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
    z = finite_array("z", z)
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
    r = nonnegative_array("radius", radius)
    return float(math.pi * np.dot(r, r) / (positive("Lx", Lx) * positive("Ly", Ly)))


def surface_density(mass: ArrayLike, Lx: float, Ly: float) -> float:
    """Surface mass density Sigma = sum(m) / (Lx Ly) [kg/m^2].

    Parameters
    ----------
    mass : array [kg]
    Lx, Ly : float [m]
    """
    m = nonnegative_array("mass", mass)
    return float(np.sum(m) / (positive("Lx", Lx) * positive("Ly", Ly)))


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
    z = finite_array("z", z)
    r = nonnegative_array("radius", radius)
    same_length(z=z, radius=r)
    area = positive("Lx", Lx) * positive("Ly", Ly)
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
    r_min = positive("r_min", r_min)
    r_max = positive("r_max", r_max)
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
    edges = finite_array("size_bins", size_bins)
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


def _binned_statistics(idx: NDArray[np.intp], n_bins: int, w: FloatArray, z: FloatArray,
                       w_ref: FloatArray, z_ref: float) -> dict[str, FloatArray]:
    """Per-bin count, 1-D dispersion and rms height about the SHEET's mean motion.

    Deviations are taken from the sheet's mass-weighted mean velocity ``w_ref`` (relative to
    the shear flow) and mean height ``z_ref``, not from each bin's own mean: a bin's own
    mean would remove one degree of freedom per component and bias a sparse bin of n
    particles low by sqrt(1 - 1/n), and it would hide a bin that moves as a whole relative
    to the rest of the ring.
    """
    inside = idx >= 0
    b = idx[inside]
    counts = np.bincount(b, minlength=n_bins).astype(float)

    def bin_mean_square(deviation: FloatArray) -> FloatArray:
        return np.bincount(b, weights=deviation * deviation, minlength=n_bins) / counts

    with np.errstate(invalid="ignore", divide="ignore"):
        square_sum = sum(bin_mean_square(comp - ref) for comp, ref in zip(w[:, inside], w_ref,
                                                                          strict=True))
        z_square = bin_mean_square(z[inside] - z_ref)
    usable = counts >= 1
    c = np.where(usable, np.sqrt(square_sum / 3.0), np.nan)
    h = np.where(usable, np.sqrt(z_square), np.nan)
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
        ``size_bin_thickness`` [m] (about the sheet's mass-weighted mean velocity and
        height, see ``_binned_statistics``; NaN for an empty bin).
    """
    Omega = positive("Omega", Omega)
    arrays = {name: finite_array(name, a) for name, a in (("x", x), ("y", y), ("z", z), ("vx", vx),
                                                    ("vy", vy), ("vz", vz))}
    r = nonnegative_array("radius", radius)
    m = nonnegative_array("mass", mass)
    n = same_length(**arrays, radius=r, mass=m)
    area = positive("Lx", Lx) * positive("Ly", Ly)
    if not np.sum(m) > 0.0:
        raise ValueError("mass must not be all zero")

    w = np.stack([arrays["vx"], arrays["vy"] + SHEAR * Omega * arrays["x"], arrays["vz"]])
    components = dispersion_components(_tensor(w, None))
    W_mass = _tensor(w, m)
    zz = arrays["z"]

    edges = _bin_edges(r, size_bins)
    binned = _binned_statistics(_bin_index(r, edges), edges.size - 1, w, zz,
                                w_ref=w @ m / np.sum(m), z_ref=float(np.dot(m, zz) / np.sum(m)))

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
    orbits = positive("elapsed_time", elapsed_time) * positive("Omega", Omega) / TWO_PI
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
    x = finite_array("x", x)
    W = dispersion_tensor(x, vx, vy, np.zeros_like(x), Omega, weights=mass)
    return float(2.0 * W[0, 1] / (3.0 * positive("Omega", Omega)))


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
    mass = positive("surface_density", surface_density) * positive("Lx", Lx) * positive(
        "Ly", Ly)
    if not math.isfinite(float(plog)):
        raise ValueError("plog must be finite")
    return float(2.0 * plog / (3.0 * positive("Omega", Omega) * mass
                               * positive("elapsed_time", elapsed_time)))


# Gravitational viscosity: ringsim.analysis.wakes (from the surface density's field).


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
        v = np.abs(finite_array("normal_speed", normal_speed))
        if v.size != eps.size:
            raise ValueError("normal_speed and epsilon must have equal lengths")
        v2 = v * v
        total = np.sum(v2)
        out["effective_epsilon"] = (float(math.sqrt(np.dot(eps * eps, v2) / total))
                                    if total > 0.0 else math.nan)
    return out
