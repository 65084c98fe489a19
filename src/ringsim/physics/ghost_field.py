"""The field that REBOUND's finite ghost-box sum leaves out of a shearing sheet.

REBOUND's tree (``sheet.gravity_solver: tree``) sums the box and its ghost copies; its sum
has no uniform-background term, so the sheet beyond the ghost boxes is missing, and its pull
falls only as 1 / N_ghost (docs/gravity.md, section 4).  :func:`ghost_truncation_field`
supplies it analytically; the runs add its C twin (``rs_ghost_field`` in
``ringsim/csrc/rs_gravity.c``, installed by ``ringsim.gravity.tree``), which the tests
compare with it.  Pure numpy, SI.
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.physics.constants import G_SI
from ringsim.physics.selfgravity import _rectangle_field


def rebound_row_offsets(Omega: float, Lx: float, Ly: float, t: float, n_ghost_x: int):
    """Azimuthal offsets [m] of REBOUND's ghost-box rows i = -n..n at time t [s].

    Row i's ghost boxes sit at (i Lx, j Ly + offset_i) for j = -n_ghost_y..n_ghost_y, with
    offset_i congruent to -1.5 Omega i Lx t modulo Ly and in REBOUND 5.2.2's range
    (``reb_boundary_get_ghostbox``: (-Ly, 0] for i > 0, [0, Ly) for i < 0, (-Ly, Ly) for 0).
    """
    offsets = []
    for i in range(-n_ghost_x, n_ghost_x + 1):
        shiftvy = -1.5 * i * Omega * Lx
        if i == 0:
            shift = -math.fmod(shiftvy * t, Ly)
        elif i > 0:
            shift = -math.fmod(shiftvy * t - 0.5 * Ly, Ly) - 0.5 * Ly
        else:
            shift = -math.fmod(shiftvy * t + 0.5 * Ly, Ly) + 0.5 * Ly
        offsets.append(-shift)
    return np.array(offsets)


def ghost_truncation_field(pos, mass, Lx, Ly, Omega, t, n_ghost_x, n_ghost_y, G=G_SI):
    """The field [m/s^2] that REBOUND's finite ghost-box sum leaves out, for each particle.

    REBOUND sums the box and its (2 n_x + 1)(2 n_y + 1) ghost copies; everything beyond is
    missing.  Beyond the ghost boxes the sheet is modelled as uniform, of surface density
    M / (Lx Ly), in the plane of the centre of mass z_cm and with the ghost boxes' union
    shifted by the centre of mass (x_cm, y_cm) (the box's mass dipole): the missing field is
    that of an infinite uniform sheet (vertical only, -2 pi G Sigma sign(z - z_cm)) minus
    that of the ghost boxes' union, each row a uniform rectangle.  Exact to first order in
    (z - z_cm) / (distance to the missing images) and up to the quadrupole of the point
    images, which falls as n^-2 beyond the ghost boxes.  Adding it to REBOUND's tree
    accelerations (an additional force, cost O(N n_x)) removes the truncation error that
    otherwise falls only as 1 / n (docs/gravity.md).

    Parameters
    ----------
    pos : array (N, 3) [m]
    mass : array (N,) [kg]
    Lx, Ly : float [m]
    Omega : float [1/s]
    t : float [s]
        Time of the positions (sets REBOUND's row offsets).
    n_ghost_x, n_ghost_y : int
    """
    pos = np.asarray(pos, dtype=float)
    mass = np.asarray(mass, dtype=float)
    x_cm, y_cm, z_cm = (np.sum(mass[:, None] * pos, axis=0) / np.sum(mass)).tolist()
    G_sigma = G * float(np.sum(mass)) / (Lx * Ly)
    Z = pos[:, 2] - z_cm
    out = np.zeros_like(pos)
    out[:, 2] = -2.0 * np.pi * G_sigma * np.sign(Z)
    offsets = rebound_row_offsets(Omega, Lx, Ly, t, n_ghost_x)
    for i, off in zip(range(-n_ghost_x, n_ghost_x + 1), offsets, strict=True):
        u1 = x_cm + (i - 0.5) * Lx - pos[:, 0]
        u2 = x_cm + (i + 0.5) * Lx - pos[:, 0]
        v1 = y_cm + off - (n_ghost_y + 0.5) * Ly - pos[:, 1]
        v2 = y_cm + off + (n_ghost_y + 0.5) * Ly - pos[:, 1]
        gx, gy, gz = _rectangle_field(u1, u2, v1, v2, Z, G_sigma)
        out[:, 0] -= gx
        out[:, 1] -= gy
        out[:, 2] -= gz
    return out
