"""Rotational energy by size bin: the per-bin spin rows of a run file (pure numpy, SI).

For the particles of size bin b,

* E_rot,b = sum_b 1/2 k m R^2 |w|^2 [J], spins w relative to the rotating frame (as
  ``physics.friction.rotational_energy``: a sphere that keeps one face to the planet has
  none);
* E_tr,b = sum_b 1/2 m |v - <v>_m|^2 [J], velocities v relative to the shear flow about the
  sheet's mass-weighted mean velocity <v>_m, the reference of the per-bin velocity
  dispersions (``analysis.snapshot``);
* their ratio E_rot,b / E_tr,b, the ring's ``rotational_energy_ratio`` taken per size: how
  much of the random motion friction has moved into rotation in each size.

An empty bin gives NaN for both; a bin whose particles share the mean velocity exactly
gives a ratio of 0, as the ring's ratio does.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ringsim.physics.friction import rotational_energy
from ringsim.physics.sizes import size_bin_index


def size_bin_spin_row(mass: ArrayLike, radius: ArrayLike, velocity: ArrayLike,
                      spins: ArrayLike, k: float, edges: ArrayLike) -> dict[str, np.ndarray]:
    """``size_bin_rotational_energy`` [J] and ``size_bin_rotational_energy_ratio`` [1] of
    each size bin (module docstring).

    Parameters
    ----------
    mass : array (n,) [kg]
    radius : array (n,) [m]
    velocity : array (3, n) [m/s]
        Velocities relative to the shear flow (vx, vy + 3/2 Omega x, vz).
    spins : array (n, 3) [rad/s]
        Spins relative to the rotating frame.
    k : float [-]
        Moment-of-inertia factor.
    edges : array (n_bins + 1,) [m]
        Radius bin edges, increasing (np.histogram's convention).
    """
    m = np.asarray(mass, dtype=float)
    v = np.asarray(velocity, dtype=float)
    idx = size_bin_index(radius, edges)
    n_bins = np.asarray(edges).size - 1
    inside = idx >= 0
    b = idx[inside]
    dv = v - (v @ m / np.sum(m))[:, None]
    e_tr = np.bincount(b, weights=(0.5 * m * np.sum(dv * dv, axis=0))[inside],
                       minlength=n_bins)
    e_rot = np.bincount(b, weights=rotational_energy(m, radius, spins, k)[inside],
                        minlength=n_bins)
    filled = np.bincount(b, minlength=n_bins) > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(e_tr > 0.0, e_rot / e_tr, 0.0)
    return {"size_bin_rotational_energy": np.where(filled, e_rot, np.nan),
            "size_bin_rotational_energy_ratio": np.where(filled, ratio, np.nan)}
