"""Overlap-free random placement of the initial particles (`ringsim.engine.sheet.initial_state`).

Particles are drawn at random; in each round, the particle that yields in every overlapping
pair is drawn again, until no pair overlaps (`yielding`): the smaller of the two where the
other is more than `YIELD_RATIO` times larger, else the higher index. The largest particles
are so placed first and much smaller ones, most of a broad size distribution, fill the room
around them; with the higher index alone a metre-sized particle would be drawn again among
thousands of centimetre-sized ones and never find room. Within a factor `YIELD_RATIO` in
radius the higher index yields, as for identical particles. Which particles are drawn again,
and so the use of the random generator, is fixed by that rule and the exact pair test alone:
how the overlapping pairs are found does not change a bit of the result. They are found on
grids of cells (`OverlapGrid`, ``rs_grid`` in ``csrc/rs_setup.c``), one per radius class
(radii within a factor 2), each particle looking at the cells of a class within its radius
plus the class's largest radius; after the first round only around the particles just drawn
again, since a pair of particles that were not drawn again did not overlap before and still
does not (the test depends on the two particles' positions alone). `overlapping_later` is
the same test in numpy (the Python twin, for tests). Heights enter the test as they are (not
from a frame that moves between rounds), so a pair within rounding of contact is judged
alike in every round. The search's cost at scale: docs/performance.md, "Set-up and snapshot
I/O at scale".
"""

from __future__ import annotations

import ctypes

import numpy as np

#: Searched distances are this much (relative) longer than r_i + r_j, so that rounding of a
#: cell index never hides a neighbour.
REACH_MARGIN = 1e-9
#: Radii of one class of the grid differ by less than this factor.
CLASS_RATIO = 2.0
#: Of an overlapping pair, a particle more than this many times smaller than the other is
#: drawn again (RS_YIELD_RATIO in csrc/rs_setup.c); within this factor the higher index is.
#: Wide enough that a size distribution spanning at most this factor (0.5-5 m, say) keeps
#: the placement of identical particles bit for bit, narrow enough that a metre-sized
#: particle never yields to the centimetre-sized ones around it.
YIELD_RATIO = 10.0
#: Classes at most (RS_MAX_CLASSES in csrc/rs_setup.c): radii spanning 2^31.
MAX_CLASSES = 32
_DOUBLE_P = ctypes.POINTER(ctypes.c_double)
_INT64_P = ctypes.POINTER(ctypes.c_int64)


def radius_classes(radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Radius class of each particle (int32, 0 for the smallest radii; each class spans a
    factor `CLASS_RATIO`) and the largest radius [m] of each class.

    A particle looks for overlaps in the cells of each class within its radius plus the
    class's largest radius, so that small particles, most of a broad size distribution,
    are not compared with everything within twice the largest radius of all.

    Parameters
    ----------
    radii : array [m]
    """
    if radii.size == 0:
        return np.zeros(0, np.int32), np.ones(1)
    label = np.floor(np.log(radii / radii.min()) / np.log(CLASS_RATIO)).astype(np.int64)
    used, class_of = np.unique(label, return_inverse=True)
    if used.size > MAX_CLASSES:
        raise ValueError(f"radii spanning more than {CLASS_RATIO}^{MAX_CLASSES}")
    largest = np.zeros(used.size)
    np.maximum.at(largest, class_of, radii)
    return np.ascontiguousarray(class_of, dtype=np.int32), largest


def wrap_horizontal(pos: np.ndarray, Lx: float, Ly: float) -> tuple[np.ndarray, np.ndarray]:
    """x in [0, Lx) and y in [0, Ly) [m] of positions centred on the box (contiguous arrays).

    Parameters
    ----------
    pos : array (N, 3) [m]
    Lx, Ly : float [m]
    """
    return (np.ascontiguousarray((pos[:, 0] + 0.5 * Lx) % Lx),
            np.ascontiguousarray((pos[:, 1] + 0.5 * Ly) % Ly))


def yielding(lo: np.ndarray, hi: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """The particle of each pair (lo < hi, indices) drawn again when they overlap: the
    smaller one where the other is more than `YIELD_RATIO` times larger, else the higher
    index (``rs_test_pair``).

    Parameters
    ----------
    lo, hi : int arrays
    radii : array [m]
    """
    r_lo, r_hi = radii[lo], radii[hi]
    return np.where(r_lo > YIELD_RATIO * r_hi, hi,
                    np.where(r_hi > YIELD_RATIO * r_lo, lo, hi))


def overlapping_later(x: np.ndarray, y: np.ndarray, z: np.ndarray, radii: np.ndarray,
                      i: np.ndarray, j: np.ndarray, Lx: float, Ly: float) -> np.ndarray:
    """Sorted unique `yielding` particles of the candidate pairs (i, j) that overlap (numpy
    twin).

    Periodic in x and y (at t = 0 the radial images are not shifted in y).  Each pair is
    tested with its lower index first, so the test does not depend on the candidates' order.

    Parameters
    ----------
    x, y : arrays [m]
        `wrap_horizontal` positions.
    z : array [m]
    radii : array [m]
    i, j : int arrays
        Candidate pairs (any order, duplicates allowed, i != j).
    Lx, Ly : float [m]
    """
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    d = np.column_stack([x[lo] - x[hi], y[lo] - y[hi], z[lo] - z[hi]])
    d[:, 0] -= Lx * np.round(d[:, 0] / Lx)
    d[:, 1] -= Ly * np.round(d[:, 1] / Ly)
    overlap = np.sum(d * d, axis=1) < (radii[lo] + radii[hi]) ** 2
    return np.unique(yielding(lo, hi, radii)[overlap])


class OverlapGrid:
    """The C grid of cells (``rs_grid`` in ``csrc/rs_setup.c``) over particles whose
    positions live in the numpy arrays given here; a context manager that frees it.

    The grid keeps copies of the positions: the caller changes positions in the arrays and
    then calls `move` with the indices of the particles that changed.

    Parameters
    ----------
    x, y : float arrays [m]
        `wrap_horizontal` positions.
    z : float array [m]
    radii : float array [m]
    Lx, Ly : float [m]
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, radii: np.ndarray,
                 Lx: float, Ly: float):
        from ringsim.engine.native import _LIB

        self._lib = _LIB
        self.arrays = tuple(np.ascontiguousarray(a, dtype=np.float64)
                            for a in (x, y, z, radii))
        self.n = int(radii.size)
        if any(a.shape != (self.n,) for a in self.arrays):
            raise ValueError("positions and radii must be 1-D arrays of one length")
        self.class_of, largest = radius_classes(self.arrays[3])
        z_lo, z_hi = (float(z.min()), float(z.max())) if self.n else (0.0, 0.0)
        self._grid = _LIB.rs_grid_create(
            self.n, largest.size, self.class_of.ctypes.data_as(ctypes.POINTER(ctypes.c_int32)),
            largest.ctypes.data_as(_DOUBLE_P), Lx, Ly, z_lo, z_hi, REACH_MARGIN,
            *(a.ctypes.data_as(_DOUBLE_P) for a in self.arrays))
        self._found = np.empty(max(self.n, 1), dtype=np.int64)
        if not self._grid:
            raise MemoryError(f"rs_grid_create: no memory for the grid of {self.n} particles")

    def move(self, index: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
        """Particles ``index`` are now at x, y, z [m] (arrays of all particles)."""
        index = np.ascontiguousarray(index, dtype=np.int64)
        arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (x, y, z)]
        self._lib.rs_grid_move(self._grid, index.size, index.ctypes.data_as(_INT64_P),
                               *(a.ctypes.data_as(_DOUBLE_P) for a in arrays))

    def overlapping_later(self, searched: np.ndarray | None = None) -> np.ndarray:
        """Sorted `yielding` particles of the overlapping pairs with a particle of
        ``searched`` (indices; None: all pairs)."""
        index = None if searched is None else np.ascontiguousarray(searched, dtype=np.int64)
        count = self._lib.rs_grid_overlapping(
            self._grid, 0 if index is None else index.size,
            None if index is None else index.ctypes.data_as(_INT64_P),
            self._found.ctypes.data_as(_INT64_P))
        if count < 0:
            raise MemoryError("rs_grid_overlapping: no memory")
        return np.sort(self._found[:count])

    def close(self) -> None:
        if self._grid:
            self._lib.rs_grid_free(self._grid)
            self._grid = None

    def __enter__(self) -> OverlapGrid:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
