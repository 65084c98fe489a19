"""Gravitational aggregates in a snapshot: groups of touching particles and whether they fit
inside their own Hill sphere.

A measure of the regime transitions of a self-gravitating ring: at small r_h the tide
pulls touching particles apart, at large r_h they stay together as aggregates.  Particles
are linked when their centres are closer than ``CONTACT_LINK`` times the sum of their radii
(friends of friends, shear-periodic: the images across the radial boundary are shifted by
the shear offset, as ``engine.box.count_overlaps`` does).  A group *fits its
Hill sphere* when every member lies inside the Hill radius of the group's mass about its
centre of mass, R_H = a (M / 3 M_p)^(1/3), counting the member's radius:
max_i (|r_i - r_cm| + R_i) < R_H.  For a touching pair of identical spheres this is r_h > 1,
the condition that the pair's mutual Hill sphere contains it; a compact pile fits at a
somewhat smaller r_h.  This is a geometric criterion, not an energy one: a group that fits
can still be flying apart, and one that does not fit can be a passing contact.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ringsim.physics.constants import G_SI
from ringsim.physics.selfgravity import radial_images

#: Centres closer than this times the sum of the radii are linked (touching, with room for
#: the overlap and separation a step's detection leaves) [dimensionless].
CONTACT_LINK = 1.05
#: Groups of at least this many particles count as groups in ``grouped_fraction``.
MIN_GROUP = 10
#: The linked-pair search's radius classes are this factor apart [dimensionless].
RADIUS_CLASS_FACTOR = 2.0


def near_pairs(x, y, z, Lx, Ly, shift, reach):
    """Every pair of particles whose centres are closer than ``reach``, across the
    shear-periodic boundaries: original indices (i, j) and separation vectors r_j - r_i [m]
    (of the image of j nearest to i).

    Parameters
    ----------
    x, y, z : array [m]
    Lx, Ly : float [m]
    shift : float [m]
        Shear offset of the radial images (``physics.selfgravity.shear_offset``).
    reach : float [m]
        Less than half of Lx and Ly.
    """
    x, y, z = (np.asarray(v, dtype=float) for v in (x, y, z))
    index, px, py, pz = radial_images(x, y, z, Lx, shift, reach)
    tree = cKDTree(_tree_points(px, py, pz, Ly, px.min(), pz.min()),
                   boxsize=[1e300, Ly, 1e300])
    pairs = tree.query_pairs(reach, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3))
    a, b = pairs[:, 0], pairs[:, 1]
    d = np.column_stack([px[b] - px[a], py[b] - py[a], pz[b] - pz[a]])
    d[:, 1] = (d[:, 1] + 0.5 * Ly) % Ly - 0.5 * Ly
    i, j = index[a], index[b]
    keep = (i != j) & (np.linalg.norm(d, axis=1) < reach)
    i, j, d = i[keep], j[keep], d[keep]
    # a pair near a corner can be found through two images: keep one
    _, first = np.unique(np.minimum(i, j) * (x.size + 1) + np.maximum(i, j),
                         return_index=True)
    return i[first], j[first], d[first]


def _tree_points(x, y, z, Ly, x0, z0):
    """Points for a cKDTree periodic in y only (x, z shifted by a common origin >= 0)."""
    return np.column_stack([x - x0, np.mod(y + 0.5 * Ly, Ly), z - z0])


def pairs_between(a, b, x, y, z, Lx, Ly, shift, reach):
    """Pairs of a particle of ``a`` and one of ``b`` (disjoint index arrays) whose centres
    are closer than ``reach`` across the shear-periodic boundaries, as `near_pairs` gives
    them: indices (i in a, j in b) and separations r_j - r_i [m] of the image of j nearest
    to i."""
    index, px, py, pz = radial_images(x[b], y[b], z[b], Lx, shift, reach)
    x0, z0 = min(px.min(), x[a].min()), min(pz.min(), z[a].min())
    box = [1e300, Ly, 1e300]
    mine = cKDTree(_tree_points(x[a], y[a], z[a], Ly, x0, z0), boxsize=box)
    theirs = cKDTree(_tree_points(px, py, pz, Ly, x0, z0), boxsize=box)
    found = mine.sparse_distance_matrix(theirs, reach, output_type="ndarray")
    ia, ib = found["i"].astype(int), found["j"].astype(int)
    d = np.column_stack([px[ib] - x[a][ia], py[ib] - y[a][ia], pz[ib] - z[a][ia]])
    d[:, 1] = (d[:, 1] + 0.5 * Ly) % Ly - 0.5 * Ly
    i, j = a[ia], b[index[ib]]
    keep = np.linalg.norm(d, axis=1) < reach
    return i[keep], j[keep], d[keep]


def radius_classes(radius, factor=RADIUS_CLASS_FACTOR) -> list[np.ndarray]:
    """The particles' indices in classes of radius ``factor`` apart, smallest first."""
    level = np.floor(np.log(radius / radius.min()) / np.log(factor)).astype(int)
    return [np.flatnonzero(level == k) for k in np.unique(level)]


def _linked_pairs(x, y, z, radius, Lx, Ly, shift, link):
    """Linked pairs (i, j) of original indices and the separation vectors r_j - r_i [m],
    in the order of (min(i, j), max(i, j)).

    The search goes class by class of radius (`radius_classes`, as the line detector's
    reach classes): within a class, and between two, out to ``link`` times the sum of
    their largest radii, so that a broad distribution (2.5 cm to 5 m) does not look for
    every particle's partners out to twice the largest radius."""
    x, y, z = (np.asarray(v, dtype=float) for v in (x, y, z))
    classes = radius_classes(radius)
    parts = []
    for k, a in enumerate(classes):
        for b in classes[k:]:
            reach = link * (float(radius[a].max()) + float(radius[b].max()))
            if b is a:
                i, j, d = near_pairs(x[a], y[a], z[a], Lx, Ly, shift, reach)
                i, j = a[i], a[j]
            else:
                i, j, d = pairs_between(a, b, x, y, z, Lx, Ly, shift, reach)
            keep = np.linalg.norm(d, axis=1) < link * (radius[i] + radius[j])
            parts.append((i[keep], j[keep], d[keep]))
    i, j, d = (np.concatenate(c) for c in zip(*parts, strict=True))
    key = np.minimum(i, j) * (x.size + 1) + np.maximum(i, j)
    _, first = np.unique(key, return_index=True)
    return i[first], j[first], d[first]


def contact_groups(x, y, z, radius, Lx, Ly, shift, link=CONTACT_LINK):
    """Groups of linked particles and each particle's position relative to its group's
    first member, unwrapped across the periodic boundaries.

    Parameters
    ----------
    x, y, z : array [m]
    radius : array [m]
    Lx, Ly : float [m]
    shift : float [m]
        Shear offset of the radial images (``physics.selfgravity.shear_offset``).
    link : float [dimensionless]

    Returns
    -------
    (labels, relative): labels (N,) int, group of each particle; relative (N, 3) [m].
    """
    x, y, z, radius = (np.asarray(v, dtype=float) for v in (x, y, z, radius))
    n = radius.size
    i, j, d = _linked_pairs(x, y, z, radius, Lx, Ly, shift, link)
    graph = coo_matrix((np.ones(i.size), (i, j)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    neighbours: list[list[tuple[int, np.ndarray]]] = [[] for _ in range(n)]
    for a, b, v in zip(i.tolist(), j.tolist(), d, strict=True):
        neighbours[a].append((b, v))
        neighbours[b].append((a, -v))
    relative = np.zeros((n, 3))
    seen = np.zeros(n, dtype=bool)
    for root in range(n):
        if seen[root]:
            continue
        seen[root] = True
        queue = deque([root])
        while queue:
            a = queue.popleft()
            for b, v in neighbours[a]:
                if not seen[b]:
                    seen[b] = True
                    relative[b] = relative[a] + v
                    queue.append(b)
    return labels, relative


def clump_statistics(snap: dict, Lx: float, Ly: float, shift: float, GM: float, a: float,
                     G: float = G_SI) -> dict:
    """Aggregation measures of one snapshot (module docstring).

    Parameters
    ----------
    snap : dict with x, y, z, radius [m], mass [kg]
    Lx, Ly, shift : float [m]
    GM : float [m^3/s^2]
        The planet's.
    a : float [m]
        Orbital radius of the patch.
    G : float [m^3 kg^-1 s^-2]

    Returns
    -------
    dict [mass fractions, dimensionless]: ``largest_group`` (the largest group's share of
    the mass), ``grouped`` (share in groups of at least `MIN_GROUP` particles),
    ``in_hill_groups`` (share in groups of two or more that fit their Hill sphere),
    ``hill_groups`` (how many such groups), ``largest_hill_group`` (particles in the
    largest of them).
    """
    mass = np.asarray(snap["mass"], dtype=float)
    radius = np.asarray(snap["radius"], dtype=float)
    labels, rel = contact_groups(snap["x"], snap["y"], snap["z"], radius, Lx, Ly, shift)
    total = float(mass.sum())
    group_mass = np.bincount(labels, weights=mass)
    members = np.bincount(labels)
    planet_mass = GM / G
    fits = np.zeros(members.size, dtype=bool)
    for g in np.flatnonzero(members >= 2):
        inside = labels == g
        m = mass[inside]
        cm = np.sum(rel[inside] * m[:, None], axis=0) / m.sum()
        extent = np.max(np.linalg.norm(rel[inside] - cm, axis=1) + radius[inside])
        fits[g] = extent < a * np.cbrt(m.sum() / (3.0 * planet_mass))
    return {
        "largest_group": float(group_mass.max() / total),
        "grouped": float(group_mass[members >= MIN_GROUP].sum() / total),
        "in_hill_groups": float(group_mass[fits].sum() / total),
        "hill_groups": int(np.count_nonzero(fits)),
        "largest_hill_group": int(members[fits].max()) if fits.any() else 0,
    }
