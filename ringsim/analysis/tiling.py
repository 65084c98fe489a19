"""How far the copies of a tiled run have gone apart (``sheet.initial_state.tile``).

A run started from a sheet repeated n_x x n_y times holds identical copies at its start;
only round-off, the P3M mesh (whose cells the copies' y shifts do not respect) and chaos
part them.  Its statistics are those of the larger box only once the copies are
independent, which this measures: per snapshot, the rms difference between copy c and
copy 0 of each particle in vx, in vy + 1.5 Omega x (the velocity relative to the shear
flow, the same for a copy wherever the sheet's images have moved it) and in vz, over the
rms of that velocity: 0 for identical copies, sqrt(2) for independent ones.  Particles keep
the order the tiling gave them (copy c holds indices c N ... (c + 1) N - 1).
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.physics.constants import SHEAR

#: Components of ``copy_difference``, in its order.
COMPONENTS = ("vx", "vy_peculiar", "vz")
#: ``copy_difference`` above which the copies count as independent, in every component:
#: sqrt(2 (1 - rho)) with a correlation rho = 0.1 between a particle and its copy.
INDEPENDENT = math.sqrt(2.0 * (1.0 - 0.1))


def copy_difference(vx, vy, vz, x, Omega: float, copies: int) -> np.ndarray:
    """rms difference between the copies of a tiled sheet and its copy 0, per component
    (``COMPONENTS``), over the rms of that component [dimensionless; sqrt(2) when
    independent].

    Parameters
    ----------
    vx, vy, vz : arrays [m/s]
        Velocities of a snapshot (vy including the shear flow), copies in order.
    x : array [m]
    Omega : float [1/s]
    copies : int
        n_x n_y of the tiling.
    """
    n = np.asarray(x).size // copies
    u = np.stack([vx, np.asarray(vy) + SHEAR * Omega * np.asarray(x), vz])
    u = u[:, :copies * n].reshape(3, copies, n)
    return np.sqrt(np.mean((u[:, 1:, :] - u[:, :1, :]) ** 2, axis=(1, 2))
                   / np.mean(u ** 2, axis=(1, 2)))


def independent_from_orbit(run) -> float | None:
    """Orbit [orbits] of the first snapshot of a tiled run at which its copies are
    independent (``copy_difference`` at least ``INDEPENDENT`` in every component); None for
    a run not started from a tiled snapshot, inf if no snapshot has them independent yet.
    Snapshots are read in order until then (one or two orbits with self-gravity, a few
    without: round-off parts the copies, tenfold in about 0.2 orbit)."""
    state = run.scenario.sheet.initial_state
    if state is None or state.tile == (1, 1):
        return None
    copies = state.tile[0] * state.tile[1]
    Omega = run.scenario.orbital_frequency
    for i in range(run.n_snapshots):
        snap = run.snapshot(i)
        diff = copy_difference(snap["vx"], snap["vy"], snap["vz"], snap["x"], Omega, copies)
        if np.all(diff >= INDEPENDENT):
            return float(snap["t"]) * Omega / (2.0 * math.pi)
    return math.inf
