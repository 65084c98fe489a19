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


def _brute_links(x, y, z, radius, lx, ly, shift, link):
    """Every linked pair by brute force over the radial images: {(i, j): d} with i < j
    and d = r_j - r_i of the nearest image [m]."""
    out = {}
    for i in range(x.size):
        j = np.arange(i + 1, x.size)
        images = []
        for k in (-1, 0, 1):        # radial images: x + k Lx at y - k shift
            dy = (y[j] - k * shift - y[i] + 0.5 * ly) % ly - 0.5 * ly
            images.append(np.column_stack([x[j] + k * lx - x[i], dy, z[j] - z[i]]))
        images = np.stack(images)
        nearest = np.argmin(np.linalg.norm(images, axis=2), axis=0)
        d = images[nearest, np.arange(j.size)]
        for m in np.flatnonzero(np.linalg.norm(d, axis=1) < link * (radius[i] + radius[j])):
            out[(i, int(j[m]))] = d[m]
    return out


def test_links_of_a_broad_size_distribution_are_every_touching_pair():
    """The search by radius classes finds exactly the pairs closer than 1.05 times the sum
    of their radii, across the sheared boundaries, with their nearest-image separations,
    in a dense sheet of radii drawn from 5 cm to 2 m (at least five classes)."""
    rng = np.random.default_rng(17)
    n, lx, ly, shift = 700, 10.0, 12.0, 4.3
    u = rng.uniform(size=n)
    radius = 0.05 * (1.0 - u * (1.0 - 40.0 ** -2)) ** -0.5      # q = 3 from 5 cm to 2 m
    x = rng.uniform(-0.5 * lx, 0.5 * lx, n)
    y = rng.uniform(-0.5 * ly, 0.5 * ly, n)
    z = rng.normal(0.0, 0.3, n)
    assert len(clumps.radius_classes(radius)) >= 5
    i, j, d = clumps._linked_pairs(x, y, z, radius, lx, ly, shift, clumps.CONTACT_LINK)
    want = _brute_links(x, y, z, radius, lx, ly, shift, clumps.CONTACT_LINK)
    assert len(want) > 100
    assert any(abs(x[a] - x[b]) > 0.5 * lx for a, b in want)    # some across the boundary
    got = {(min(a, b), max(a, b)): (v if a < b else -v) for a, b, v in zip(i, j, d, strict=True)}
    assert set(got) == set(want) and i.size == len(got)
    for key, v in want.items():
        np.testing.assert_allclose(got[key], v, rtol=0, atol=1e-12)


def test_links_of_equal_spheres_are_those_of_one_search():
    """Equal radii make one class: the search is `near_pairs` at twice the radius, as it
    was before the classes, pair for pair and bit for bit."""
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-0.5 * LX, 0.5 * LX, (2, 600))
    z = rng.normal(0.0, 1.0, 600)
    radius = np.full(600, 1.0)
    i, j, d = clumps._linked_pairs(x, y, z, radius, LX, LY, 9.0, clumps.CONTACT_LINK)
    a, b, e = clumps.near_pairs(x, y, z, LX, LY, 9.0, clumps.CONTACT_LINK * 2.0)
    keep = np.linalg.norm(e, axis=1) < clumps.CONTACT_LINK * 2.0
    assert np.array_equal(i, a[keep]) and np.array_equal(j, b[keep])
    assert np.array_equal(d, e[keep])
