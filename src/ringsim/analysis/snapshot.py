"""Diagnostics of one snapshot of a shearing-sheet ring patch: velocity dispersion, vertical
structure, optical depth, filling factor, and their values per size bin.

Data flow one way: snapshot arrays (x, y, z, vx, vy, vz [m, m/s], radius [m], mass [kg]) in
REBOUND's shearing-sheet frame -- x radial, y azimuthal, z vertical, Keplerian shear flow
``vy = -1.5 Omega x`` -- go in; plain numbers and numpy arrays (SI) come out.  Nothing here
touches REBOUND or HDF5.  :func:`snapshot_summary` gathers every diagnostic of one output
(one time-series row of a run).

=========================  ======================================================  =======
quantity                   definition                                              unit
=========================  ======================================================  =======
peculiar velocity w        (vx, vy + 1.5 Omega x, vz), velocity relative to the    m/s
                           Keplerian shear flow
dispersion tensor W_ij     <(w_i - <w_i>)(w_j - <w_j>)>, number- or mass-weighted  m^2/s^2
sigma_xx, _yy, _zz, _xy    components W_xx, W_yy, W_zz, W_xy of that tensor:       m^2/s^2
                           all four are second moments (variances and the
                           covariance), NOT rms speeds
velocity_dispersion c      sqrt(trace W / 3), the 1-D rms speed                    m/s
velocity_dispersion_x/y/z  sqrt(W_xx), sqrt(W_yy), sqrt(W_zz), rms speeds          m/s
thickness                  sqrt(<(z - <z>)^2>), rms height about the mean plane    m
optical_depth tau          dynamical optical depth sum(pi r^2) / (Lx Ly)           1
filling_factor             volume fraction of particles inside the slab            1
                           |z - <z>| < h, exact sphere-slab intersections
nu_trans                   (2 / (3 Omega)) W_xy (mass-weighted)                    m^2/s
=========================  ======================================================  =======

The collision frequency, the viscosities (nu_trans of a snapshot as a function, nu_col)
and the statistics of the applied coefficients of restitution are
:mod:`ringsim.analysis.collisions`; the statistics of a time series (the equilibrium
window, autocorrelated errors) :mod:`ringsim.analysis.timeseries`.

References
----------
Wisdom, J. & Tremaine, S. 1988, AJ 95, 925 (translational viscosity).
REBOUND 5.x: examples/shearing_sheet_diagnostics/problem.c (nu_trans, the filling factor).
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ringsim.checks import finite_array, nonnegative_array, positive, same_length
from ringsim.physics.constants import SHEAR
from ringsim.physics.friction import SOLID_SPHERE_INERTIA, spin_row
from ringsim.physics.sizes import size_bin_index
from ringsim.physics.spin_by_size import size_bin_spin_row

FloatArray = NDArray[np.float64]


__all__ = [
    "dispersion_components",
    "dispersion_tensor",
    "filling_factor",
    "log_size_bins",
    "optical_depth",
    "peculiar_velocity",
    "snapshot_summary",
    "sphere_slab_volume",
    "surface_density",
    "thickness",
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
    """Bin edges [m] from `snapshot_summary`'s ``size_bins``: None one bin, a number (any
    0-d value) that many log-spaced bins over the radii present, else the edges given."""
    if size_bins is None:
        size_bins = 1
    if np.ndim(size_bins) == 0:
        n_bins = int(np.asarray(size_bins))    # a scalar or a 0-d array
        return log_size_bins(float(radius.min()), float(radius.max()), n_bins)
    edges = finite_array("size_bins", size_bins)
    single_radius = edges.size == 2 and edges[0] == edges[1]
    if edges.size < 2 or (np.any(np.diff(edges) <= 0.0) and not single_radius):
        raise ValueError("size_bins must be increasing edges, at least two")
    return edges


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
        squares = [bin_mean_square(comp - ref) for comp, ref in zip(w[:, inside], w_ref,
                                                                    strict=True)]
        z_square = bin_mean_square(z[inside] - z_ref)
    usable = counts >= 1
    c = np.where(usable, np.sqrt(sum(squares) / 3.0), np.nan)
    h = np.where(usable, np.sqrt(z_square), np.nan)
    return {"n": counts.astype(np.int64), "velocity_dispersion": c, "thickness": h,
            **{f"sigma_{axis}": np.where(usable, np.sqrt(square), np.nan)
               for axis, square in zip("xyz", squares, strict=True)}}


def snapshot_summary(x: ArrayLike, y: ArrayLike, z: ArrayLike, vx: ArrayLike, vy: ArrayLike,
                     vz: ArrayLike, radius: ArrayLike, mass: ArrayLike, Omega: float,
                     Lx: float, Ly: float, size_bins: ArrayLike | int | None = None,
                     filling_half_width: float | None = None, spins: ArrayLike | None = None,
                     inertia_factor: float = SOLID_SPHERE_INERTIA) -> dict[str, object]:
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
    spins : array (N, 3) [rad/s], optional
        Spins relative to the rotating frame (rough spheres), with their moment-of-inertia
        factor ``inertia_factor`` [1]: adds the spin entries below.

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
        ``size_bin_thickness`` [m], ``size_bin_sigma_x/_y/_z`` [m/s] (the velocity
        ellipsoid's rms deviations; about the sheet's mass-weighted mean velocity and
        height, see ``_binned_statistics``; NaN for an empty bin).  With ``spins``: the
        entries of ``physics.friction.spin_row`` and, per bin,
        ``size_bin_rotational_energy`` [J] and ``size_bin_rotational_energy_ratio``
        (``physics.spin_by_size``).
    """
    Omega = positive("Omega", Omega)
    arrays, r, m, n, _ = _snapshot_arrays(x, y, z, vx, vy, vz, radius, mass, Lx, Ly)
    w = np.stack([arrays["vx"], arrays["vy"] + SHEAR * Omega * arrays["x"], arrays["vz"]])
    zz = arrays["z"]
    h = float(np.mean(r)) if filling_half_width is None else float(filling_half_width)
    summary: dict[str, object] = {"n_particles": n}
    summary.update(_velocity_entries(w, m, Omega))
    summary.update(_layer_entries(zz, r, m, Lx, Ly, h))
    summary.update(_size_bin_entries(r, m, w, zz, size_bins))
    if spins is not None:
        summary.update(_spin_entries(summary, m, r, w, spins, inertia_factor, Omega))
    return summary


def _spin_entries(summary: dict[str, object], m: FloatArray, r: FloatArray, w: FloatArray,
                  spins: ArrayLike, k: float, Omega: float) -> dict[str, object]:
    """The spin entries of `snapshot_summary` (``physics.friction.spin_row``, and per size
    bin ``physics.spin_by_size``), from its ``summary`` so far and the peculiar velocities
    w (3, N) [m/s]."""
    c_m = cast(float, summary["velocity_dispersion_mass_weighted"])
    return {**spin_row(m, r, spins, k, Omega, 1.5 * float(np.sum(m)) * c_m**2),
            **size_bin_spin_row(m, r, w, spins, k,
                                cast(FloatArray, summary["size_bin_edges"]))}


def _layer_entries(z: FloatArray, r: FloatArray, m: FloatArray, Lx: float, Ly: float,
                   h: float) -> dict[str, float]:
    """The layer's entries of `snapshot_summary`: thickness by number and by mass [m],
    filling factor in the slab |z| < h [m], optical depth, surface density [kg/m^2], mean
    radius [m] and mass [kg]."""
    area = Lx * Ly
    return {"thickness": thickness(z), "thickness_mass_weighted": thickness(z, m),
            "filling_factor": filling_factor(z, r, Lx, Ly, half_width=h),
            "filling_half_width": h,
            "optical_depth": float(math.pi * np.dot(r, r) / area),
            "surface_density": float(np.sum(m) / area),
            "mean_radius": float(np.mean(r)), "mean_mass": float(np.mean(m))}


def _velocity_entries(w: FloatArray, m: FloatArray, Omega: float) -> dict[str, float]:
    """The velocity entries of `snapshot_summary` from the peculiar velocities w (3, N)
    [m/s] and masses m [kg]: the number-weighted tensor's components
    (`dispersion_components`), the mass-weighted 1-D dispersion [m/s] and the
    translational viscosity (2 / (3 Omega)) W_xy of the mass-weighted tensor [m^2/s]."""
    W_mass = _tensor(w, m)
    return {**dispersion_components(_tensor(w, None)),
            "velocity_dispersion_mass_weighted": float(math.sqrt(max(np.trace(W_mass), 0.0)
                                                                 / 3.0)),
            "translational_viscosity": float(2.0 * W_mass[0, 1] / (3.0 * Omega))}


def _snapshot_arrays(x: ArrayLike, y: ArrayLike, z: ArrayLike, vx: ArrayLike, vy: ArrayLike,
                     vz: ArrayLike, radius: ArrayLike, mass: ArrayLike, Lx: float, Ly: float
                     ) -> tuple[dict[str, FloatArray], FloatArray, FloatArray, int, float]:
    """The checked arrays of a snapshot: {x, y, z, vx, vy, vz} (finite), radius and mass
    (>= 0, not all masses zero), their common length, and the box's area Lx Ly [m^2]."""
    arrays = {name: finite_array(name, a) for name, a in (("x", x), ("y", y), ("z", z),
                                                          ("vx", vx), ("vy", vy), ("vz", vz))}
    r = nonnegative_array("radius", radius)
    m = nonnegative_array("mass", mass)
    n = same_length(**arrays, radius=r, mass=m)
    area = positive("Lx", Lx) * positive("Ly", Ly)
    if not np.sum(m) > 0.0:
        raise ValueError("mass must not be all zero")
    return arrays, r, m, n, area


def _size_bin_entries(r: FloatArray, m: FloatArray, w: FloatArray, z: FloatArray,
                      size_bins: ArrayLike | int | None) -> dict[str, object]:
    """The per-bin entries of `snapshot_summary` (``size_bin_*``): deviations from the
    sheet's mass-weighted mean velocity w (3, N) [m/s] and height z [m]."""
    edges = _bin_edges(r, size_bins)
    binned = _binned_statistics(size_bin_index(r, edges), edges.size - 1, w, z,
                                w_ref=w @ m / np.sum(m), z_ref=float(np.dot(m, z) / np.sum(m)))
    return {"size_bin_edges": edges, "size_bin_n": binned["n"],
            "size_bin_velocity_dispersion": binned["velocity_dispersion"],
            "size_bin_thickness": binned["thickness"],
            **{f"size_bin_sigma_{axis}": binned[f"sigma_{axis}"] for axis in "xyz"}}
