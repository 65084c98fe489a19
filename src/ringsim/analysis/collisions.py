"""Collisions and momentum transport of a ring patch: collision frequency, translational
and collisional viscosity, the coefficients of restitution applied.

===================  ======================================================  =======
quantity             definition                                              unit
===================  ======================================================  =======
collision frequency  impacts per particle per orbit, 2 N_coll / N / orbits   1/orbit
nu_trans             (2 / (3 Omega)) W_xy, W the mass-weighted dispersion    m^2/s
                     tensor of ``analysis.snapshot``: the stress carried by
                     the particles' random motions between collisions
nu_col               2 plog / (3 Omega Sigma Lx Ly dt): the stress carried   m^2/s
                     across the pair's separation in the collisions
===================  ======================================================  =======

The gravitational viscosity, the stress of the wakes' field, is ``analysis.wakes``.  SI in,
SI out; nothing here touches REBOUND or HDF5.

References
----------
Wisdom, J. & Tremaine, S. 1988, AJ 95, 925 (translational and collisional viscosity).
REBOUND 5.x: examples/shearing_sheet_diagnostics/problem.c (nu_trans, nu_col) and
src/collision.c, reb_collision_resolve_hardsphere (definition of collisions_plog).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ringsim.analysis.snapshot import dispersion_tensor
from ringsim.checks import finite_array, positive
from ringsim.physics.constants import TWO_PI

__all__ = [
    "collision_frequency",
    "collisional_viscosity",
    "epsilon_statistics",
    "translational_viscosity",
]


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
    if np.ndim(bins) == 0:      # a number of bins: a scalar or a 0-d array
        edges = np.linspace(0.0, 1.0, int(np.asarray(bins)) + 1)
    else:
        edges = np.asarray(bins, dtype=float)
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
