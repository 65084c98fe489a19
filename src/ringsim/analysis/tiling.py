"""How far the copies of a tiled run have gone apart (``sheet.initial_state.tile``).

A run started from a sheet repeated n_x x n_y times holds identical copies at its start;
round-off, the P3M mesh (whose cells the copies' y shifts do not respect) and chaos part
them.  Its statistics are those of the larger box only once the copies are independent,
both particle by particle and as a field: in a gravitating ring the particles' velocities
part within about an orbit, while the wakes, coherent over many particles, stay alike
about an orbit longer (docs/gravity.md, "Tiled starts", with the measured correlations).

``copy_correlation`` measures both, against copy 0, for each other copy:

* particles: the mass-weighted correlation of each particle's velocity relative to the
  shear flow (vx, vy + 1.5 Omega x, vz; each copy centred on its own mean) with its copy's
  (copy c holds the particles c N ... (c + 1) N - 1, as the tiling made them: checked by
  their radii);
* field: the correlation of the surface-density fluctuation on a grid of ``FIELD_CELLS``
  x ``FIELD_CELLS`` cells over the small box, each copy's region mapped onto copy 0's (its
  radial shift d moves it by -1.5 Omega d t in y, as Hill's equations move the tiled
  sheet).
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.physics.constants import SHEAR

#: Largest particle-velocity correlation of an independent copy: a copy correlated at 0.1
#: shares 1 % of its velocity variance with copy 0 (a convention, not a measurement).
VELOCITY_INDEPENDENT = 0.1
#: Largest surface-density correlation of an independent copy's region: above the scatter
#: of independent wake fields on the ``FIELD_CELLS`` grid, below the correlation of copies
#: one orbit after a tiled start (docs/gravity.md, "Tiled starts").
FIELD_INDEPENDENT = 0.3
#: Cells per side of the small box for the surface-density correlation.
FIELD_CELLS = 16


def _correlation(a, b, w=None) -> float:
    """Weighted correlation of two centred samples (weights ``w``, default equal)."""
    w = np.ones_like(a) if w is None else w
    return float(np.sum(w * a * b) / math.sqrt(np.sum(w * a * a) * np.sum(w * b * b)))


def copy_correlation(snap: dict, Omega: float, Lx: float, Ly: float, n_x: int,
                     n_y: int) -> dict:
    """Correlation of each copy with copy 0: ``velocity`` (the largest over the three
    components) and ``surface_density`` (of its region), lists over copies 1 ... n_x n_y - 1
    [dimensionless; 1 identical, about 0 independent].

    Parameters
    ----------
    snap : dict of arrays
        A snapshot of the tiled run: x, y [m], vx, vy (with the shear flow), vz [m/s],
        radius [m], mass [kg], t [s] (the run's time, the tiling's).
    Omega : float [1/s]
    Lx, Ly : float [m]
        The large box.
    n_x, n_y : int
        The tiling.
    """
    copies = n_x * n_y
    x, y, mass = (np.asarray(snap[k], dtype=float) for k in ("x", "y", "mass"))
    n = x.size // copies
    radius = np.asarray(snap["radius"]).reshape(copies, -1) if x.size == copies * n else None
    if radius is None or np.any(radius != radius[:1]):
        raise ValueError("the snapshot's particles are not the tiling's copies in order")
    w = mass[:n]
    u = np.stack([snap["vx"], np.asarray(snap["vy"]) + SHEAR * Omega * x, snap["vz"]])
    u = u.reshape(3, copies, n)
    u = u - np.sum(u * w, axis=2, keepdims=True) / w.sum()
    velocity = [max(_correlation(u[k, c], u[k, 0], w) for k in range(3))
                for c in range(1, copies)]
    # each particle's region of the large box, and its place in copy 0's frame
    lx, ly = Lx / n_x, Ly / n_y
    i = np.clip(np.floor((x + 0.5 * Lx) / lx).astype(np.int64), 0, n_x - 1)
    d = (i - 0.5 * (n_x - 1)) * lx
    ys = np.mod(y + SHEAR * Omega * d * float(snap["t"]) + 0.5 * Ly, Ly)
    j = np.clip(np.floor(ys / ly).astype(np.int64), 0, n_y - 1)
    cx = np.clip(((x - d) / lx + 0.5) * FIELD_CELLS, 0, FIELD_CELLS - 1).astype(np.int64)
    cy = np.clip((ys - j * ly) / ly * FIELD_CELLS, 0, FIELD_CELLS - 1).astype(np.int64)
    sigma = np.zeros((n_x * n_y, FIELD_CELLS * FIELD_CELLS))
    np.add.at(sigma, (i * n_y + j, cx * FIELD_CELLS + cy), mass)
    sigma -= sigma.mean(axis=1, keepdims=True)
    field = [_correlation(sigma[c], sigma[0]) for c in range(1, copies)]
    return {"velocity": velocity, "surface_density": field}


def copy_correlations(run, last: int | None = None):
    """(orbit [orbits], ``copy_correlation``) of each snapshot of a tiled run, in order,
    read as they are asked for (up to snapshot ``last``, default the last one)."""
    sc = run.scenario
    box = (float(run.attrs["Lx"]), float(run.attrs["Ly"]))
    for k in range(run.n_snapshots if last is None else last + 1):
        snap = run.snapshot(k)
        yield (float(snap["t"]) / sc.orbital_period,
               copy_correlation(snap, sc.orbital_frequency, *box, *sc.sheet.initial_state.tile))


def independent_from_orbit(run, last: int | None = None) -> float | None:
    """Orbit [orbits] of the first snapshot of a tiled run at which every copy is independent
    of copy 0 (``copy_correlation`` below ``VELOCITY_INDEPENDENT`` and
    ``FIELD_INDEPENDENT``); None for a run not started from a tiled snapshot, inf if no
    snapshot (up to snapshot ``last``, an index >= 0; default all) has them independent.
    Snapshots are read in order until then (one or two orbits with self-gravity; without
    it round-off grows about a hundredfold per 0.2 orbit, from 1e-16, so a few orbits)."""
    state = run.scenario.sheet.initial_state
    if state is None or state.tile == (1, 1):
        return None
    for orbit, corr in copy_correlations(run, last):
        if max(corr["velocity"]) < VELOCITY_INDEPENDENT and \
                max(corr["surface_density"]) < FIELD_INDEPENDENT:
            return orbit
    return math.inf
