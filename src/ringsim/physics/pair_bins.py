"""Sampled collisions sorted by the size bins of both partners (pure numpy, SI).

The resolver logs a sample of its collisions with the pair's reduced radius
R_bar = r1 r2 / (r1 + r2) [m] and reduced mass M_bar = m1 m2 / (m1 + m2) [kg], not the two
radii.  For spheres of one bulk density rho the two radii follow from them: with
k = 4/3 pi rho, s = r1 + r2 and r1 r2 = R_bar s, r1^3 + r2^3 = s^3 - 3 R_bar s^2, so
M_bar / k = R_bar^3 s / (s - 3 R_bar), i.e. s = 3 R_bar mu / (mu - R_bar^3) with
mu = M_bar / k, and r1, r2 = (s -+ sqrt(s^2 - 4 R_bar s)) / 2.  Equal spheres give
s^2 = 4 R_bar s (the root is clipped at 0 against round-off).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ringsim.checks import positive


def pair_radii(R_bar: ArrayLike, M_bar: ArrayLike, density: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """The smaller and the larger radius [m] of each pair (module docstring).

    Parameters
    ----------
    R_bar : array [m]
        Reduced radii.
    M_bar : array [kg]
        Reduced masses.
    density : float [kg/m^3]
        The bulk density of every particle.
    """
    R = np.asarray(R_bar, dtype=float)
    mu = np.asarray(M_bar, dtype=float) / (4.0 / 3.0 * math.pi * positive("density", density))
    s = 3.0 * R * mu / (mu - R**3)
    root = np.sqrt(np.maximum(s * s - 4.0 * R * s, 0.0))
    return 0.5 * (s - root), 0.5 * (s + root)


def pair_bin_sums(R_bar: ArrayLike, M_bar: ArrayLike, epsilon: ArrayLike, density: float,
                  edges: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Counts and summed eps of the sampled collisions per (bin of the smaller partner,
    bin of the larger partner), each flattened row-major to n_bins^2 entries.

    Parameters
    ----------
    R_bar : array [m]
    M_bar : array [kg]
    epsilon : array [dimensionless]
        The law's eps of each collision.
    density : float [kg/m^3]
    edges : array (n_bins + 1,) [m]
        Radius bin edges; radii outside them count in the first or last bin.

    Returns
    -------
    (counts int64, eps_sums float), each of shape (n_bins^2,); entry i n_bins + j holds the
    pairs whose smaller partner is in bin i and larger in bin j (i <= j).  Pairs whose
    R_bar and M_bar no two spheres of ``density`` give (mu <= R_bar^3) are left out.
    """
    edges = np.asarray(edges, dtype=float)
    n_bins = edges.size - 1
    small, large = pair_radii(R_bar, M_bar, density)
    # a pair whose masses do not fit the density (no real radii) is left out
    fits = np.isfinite(small) & np.isfinite(large) & (small > 0)

    def index(r):
        return np.clip(np.searchsorted(edges, r[fits], side="right") - 1, 0, n_bins - 1)

    cell = index(small) * n_bins + index(large)
    counts = np.bincount(cell, minlength=n_bins * n_bins).astype(np.int64)
    sums = np.bincount(cell, weights=np.asarray(epsilon, dtype=float)[fits],
                       minlength=n_bins * n_bins)
    return counts, sums.astype(float)     # (bincount of nothing gives integers)
