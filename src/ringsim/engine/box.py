"""The box of a shearing sheet: its geometry, REBOUND's shear-periodic root grid, and the
overlap count of a state in it.

`SheetGeometry` holds the root boxes and Omega; `box_geometry` sizes the box for a set of
radii at an optical depth; `configure_box` sets a REBOUND simulation up as Hill's equations
in that box; `count_overlaps` counts the pairs that overlap across its shear-periodic
boundaries (in C).  Imports nothing of the engine but the compiled library (``native``),
so that the sheet builder, the set-up from a file and the test harness share it without
importing each other.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import rebound

from ringsim.engine.native import _LIB, use_threaded_sei
from ringsim.physics.constants import SHEAR

#: Overlaps deeper than this fraction of the smaller radius are reported.
OVERLAP_REPORT_FRACTION = 0.1


@dataclass(frozen=True)
class SheetGeometry:
    """The box of a sheet.

    Attributes
    ----------
    root_size : float [m]
        Edge of one cubic root box.
    n_root_x, n_root_y, n_root_z : int
        Root boxes along x, y, z.
    Omega : float [1/s]
    """

    root_size: float
    n_root_x: int
    n_root_y: int
    n_root_z: int
    Omega: float

    @property
    def Lx(self) -> float:
        """Radial box size [m]."""
        return self.root_size * self.n_root_x

    @property
    def Ly(self) -> float:
        """Azimuthal box size [m]."""
        return self.root_size * self.n_root_y

    @property
    def z_period(self) -> float:
        """Vertical period of the box [m]."""
        return self.root_size * self.n_root_z

    @property
    def orbit(self) -> float:
        """Orbital period 2 pi / Omega [s]."""
        return 2.0 * math.pi / self.Omega

    def attributes(self) -> dict:
        """Geometry as run-file attributes (SI)."""
        return {"root_size": self.root_size, "N_root_x": self.n_root_x,
                "N_root_y": self.n_root_y, "N_root_z": self.n_root_z, "Lx": self.Lx,
                "Ly": self.Ly, "Omega": self.Omega}


def box_geometry(radii: np.ndarray, optical_depth: float, aspect: float, Omega: float,
                 z_half_height: float) -> SheetGeometry:
    """Root boxes holding ``radii`` at dynamical optical depth ``optical_depth``.

    The horizontal box satisfies sum(pi r^2) = tau Lx Ly exactly; Ly/Lx is the closest
    ratio of small integers to ``aspect`` (REBOUND's root boxes are cubes).  The vertical
    period is at least 2 ``z_half_height``.

    Parameters
    ----------
    radii : array [m]
    optical_depth : float [dimensionless]
    aspect : float [dimensionless]
        Requested Ly / Lx.
    Omega : float [1/s]
    z_half_height : float [m]
        Half of the smallest acceptable vertical period.
    """
    ratio = Fraction(aspect).limit_denominator(8)
    if ratio <= 0:
        ratio = Fraction(1, 8)
    n_x, n_y = ratio.denominator, ratio.numerator
    area = float(np.sum(np.pi * radii**2)) / optical_depth
    root_size = math.sqrt(area / (n_x * n_y))
    n_z = max(1, math.ceil(2.0 * z_half_height / root_size))
    return SheetGeometry(root_size, n_x, n_y, n_z, Omega)


def configure_box(sim: rebound.Simulation, geometry: SheetGeometry) -> None:
    """Hill's equations (SEI, OMEGA = OMEGAZ) in the shear-periodic box of ``geometry``.

    REBOUND 5.2 has no configure_box: the root grid is set field by field, before any
    particle is added (the tree is built as particles arrive).
    """
    sim.integrator = "sei"
    use_threaded_sei(sim)      # REBOUND's SEI, bit for bit, on threads
    sim.OMEGA = geometry.Omega
    sim.OMEGAZ = geometry.Omega
    sim.root_size = geometry.root_size
    sim.N_root_x, sim.N_root_y, sim.N_root_z = (geometry.n_root_x, geometry.n_root_y,
                                                geometry.n_root_z)
    sim.boundary = "shear"


def count_overlaps(arrays: dict[str, np.ndarray], geometry: SheetGeometry, t: float = 0.0,
                   fraction: float = OVERLAP_REPORT_FRACTION, threads: int = 1) -> int:
    """Pairs overlapping by more than ``fraction`` of the smaller radius, each pair once.

    Shear-periodic like the sheet: periodic in y; across the radial boundary a particle's
    image at x +- Lx is shifted in y by -+ 1.5 Omega Lx t (the shear flow carries the
    neighbouring boxes along), so pairs straddling that boundary are counted correctly; not
    periodic in z.  Counted in C (``rs_count_overlaps`` in ``csrc/rs_setup.c``, on the
    placement's per-radius-class grids, its search on ``threads`` OpenMP threads: the count
    does not depend on them); ``ringsim.testing.count_overlaps_numpy`` is the numpy twin the
    tests compare it with.

    Parameters
    ----------
    arrays : particle arrays (SI): x, y, z [m] in the box, radius [m]
    geometry : SheetGeometry
    t : float [s]
        Time of the state (sets the shear offset of the radial images).
    fraction : float [dimensionless]
    threads : int
        OpenMP threads of the search (a speed setting).
    """
    columns = [np.ascontiguousarray(arrays[key], dtype=np.float64)
               for key in ("x", "y", "z", "radius")]
    double_p = ctypes.POINTER(ctypes.c_double)
    count = _LIB.rs_count_overlaps(columns[3].size, *(c.ctypes.data_as(double_p)
                                                      for c in columns),
                                   geometry.Lx, geometry.Ly,
                                   SHEAR * geometry.Omega * geometry.Lx * t, fraction,
                                   max(1, int(threads)))
    if count < 0:
        raise MemoryError(f"rs_count_overlaps: no memory for {columns[3].size} particles")
    return int(count)
