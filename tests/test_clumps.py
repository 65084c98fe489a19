"""Contact groups and Hill-sphere aggregates of a snapshot (analysis/clumps.py)."""

import numpy as np
import pytest

from ringsim.analysis import clumps
from ringsim.physics import gravity as patch

GM = 3.7931e16          # [m^3/s^2] Saturn
DENSITY = 900.0         # [kg/m^3]
LX = LY = 50.0


def snapshot(points, r=1.0):
    points = np.asarray(points, dtype=float)
    n = len(points)
    return {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2],
            "radius": np.full(n, r), "mass": np.full(n, DENSITY * 4.0 / 3.0 * np.pi * r**3)}


def distance_for(r_h):
    """Orbital radius [m] at which a pair of 1 m ice spheres has Hill parameter r_h."""
    return 1.0e8 * r_h / float(patch.hill_parameter(1.0, 1.0, DENSITY, GM, 1.0e8))


@pytest.mark.parametrize("r_h, fits", [(0.95, False), (1.05, True)])
def test_a_touching_pair_fits_its_hill_sphere_when_r_h_exceeds_one(r_h, fits):
    snap = snapshot([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [10.0, 10.0, 0.0]])
    stats = clumps.clump_statistics(snap, LX, LY, 0.0, GM, distance_for(r_h))
    assert stats["hill_groups"] == int(fits)
    assert stats["in_hill_groups"] == pytest.approx(2.0 / 3.0 if fits else 0.0)
    assert stats["largest_group"] == pytest.approx(2.0 / 3.0)


def test_a_group_across_the_sheared_radial_boundary_is_one_group():
    # a chain of 12 touching spheres along x through the radial boundary x = +-Lx/2: the part
    # beyond it is the image at x + Lx of box particles at y + shift (the image of a box
    # particle at x + Lx sits at y - s, physics.selfgravity.shear_offset)
    shift = 13.0
    xs = 0.5 * LX - 11.0 + 2.0 * np.arange(12)
    pts = [[x, 5.0, 0.0] if x < 0.5 * LX else [x - LX, 5.0 + shift, 0.0] for x in xs]
    pts.append([0.0, -20.0, 0.0])
    labels, rel = clumps.contact_groups(*np.asarray(pts).T, np.ones(13), LX, LY, shift)
    assert len(set(labels[:12])) == 1 and labels[12] != labels[0]
    # unwrapped: the chain is straight, 22 m long
    span = rel[:12] - rel[0]
    assert np.ptp(span[:, 0]) == pytest.approx(22.0) and np.ptp(span[:, 1]) == pytest.approx(0.0)
    stats = clumps.clump_statistics(snapshot(pts), LX, LY, shift, GM, distance_for(1.3))
    assert stats["grouped"] == pytest.approx(12.0 / 13.0)
    assert stats["hill_groups"] == 0                      # a 24 m chain is no aggregate


def test_separated_particles_form_no_groups():
    grid = [[x, y, 0.0] for x in np.arange(-20.0, 20.0, 5.0) for y in np.arange(-20.0, 20.0, 5.0)]
    stats = clumps.clump_statistics(snapshot(grid), LX, LY, 7.0, GM, distance_for(1.5))
    assert stats["largest_group"] == pytest.approx(1.0 / len(grid))
    assert stats["grouped"] == 0.0 and stats["hill_groups"] == 0
