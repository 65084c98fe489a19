"""Straight rays through a snapshot of the shearing sheet: synthetic stellar occultations.

Geometry.  x is radial (outward), y azimuthal (the direction of orbital motion), z vertical.
A line of sight at ring opening angle B (elevation above the ring plane) and azimuth phi
(measured from +x toward +y) runs along d = (cos B cos phi, cos B sin phi, sin B).  Each
particle is an opaque sphere (geometric optics).  A ray is named by the point where it
crosses the plane z = 0; a sphere of radius r centred at (x, y, z) blocks every ray whose
crossing lies inside the sphere's *shadow*: an ellipse centred at (x - z cot B cos phi,
y - z cot B sin phi) with semi-axis r / sin B along (cos phi, sin phi) and r across it.  Tracing
rays through the sheet is therefore a two-dimensional question: is a point covered by an
ellipse?

Shear periodicity.  The infinite sheet is the box and its images at (x + i Lx, y - i s + j Ly)
for all integers i, j, s the shear offset at the snapshot's time
(``ringsim.physics.selfgravity.shear_offset``).  Projection commutes with these translations,
so the shadows form the same lattice in the plane z = 0: every shadow is wrapped into the box
[-Lx/2, Lx/2) x [-Ly/2, Ly/2) along the lattice, and the images that reach into the box across
its edges are added.  A ray at any low B thus crosses as many radial images of the box as its
path needs, each shifted by the shear.

Speed.  The shadows are registered in a cell list over the box, in the ray's own frame
(cells about one shadow long along the ray's horizontal direction and one wide across it;
every shadow in each cell its bounding box touches); a ray is tested only against the
shadows of its cell.  Everything is vectorised numpy.

Statistics.  Rays are placed uniformly at random in the box (a seeded generator), so the
number that pass is binomial: T = n_pass / N, its standard error sqrt(T (1 - T) / N), and the
normal optical depth tau_n = -sin B ln T with standard error sin B sigma_T / T.  ``rays_for``
gives the number of rays for a chosen relative error of tau_n.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Rays tested per vectorised batch (bounds the memory of the ray-shadow pairs).
BATCH = 20000


def geometric_optical_depth(radius, Lx: float, Ly: float) -> float:
    """Sum(pi r^2) / (Lx Ly) [dimensionless].

    Parameters
    ----------
    radius : array [m]
    Lx, Ly : float [m]
    """
    r = np.asarray(radius, dtype=float)
    return float(np.pi * np.sum(r * r) / (Lx * Ly))


def wrap_into_box(x, y, Lx: float, Ly: float, shift: float) -> tuple[np.ndarray, np.ndarray]:
    """Points moved along the shear-periodic lattice into [-Lx/2, Lx/2) x [-Ly/2, Ly/2) [m].

    The image of (x, y) at x + Lx sits at y - shift, so a point n boxes out in x comes back
    by (-n Lx, +n shift).

    Parameters
    ----------
    x, y : array [m]
    Lx, Ly, shift : float [m]
    """
    x = np.asarray(x, dtype=float)
    n = np.floor((x + 0.5 * Lx) / Lx)
    xw = x - n * Lx
    yw = np.asarray(y, dtype=float) + n * shift
    yw = yw - np.floor((yw + 0.5 * Ly) / Ly) * Ly
    return xw, yw


@dataclass(frozen=True)
class Shadows:
    """The shadows of a snapshot in the plane z = 0 for one line of sight, in a cell list.

    The cell list lives in the frame of the ray: p along its horizontal direction (ux, uy),
    q across it, so that a shadow's bounding box is exactly 2a x 2b and the cells are about
    one shadow long and one wide.  ``cp, cq`` [m] centres, ``a`` [m] semi-axes along p, ``b``
    [m] across; ``members`` the shadow indices of every cell in cell order, ``starts`` where
    each cell's list begins; ``p0, q0`` [m] the corner, ``hp, hq`` [m] the cell sizes and
    ``np_, nq`` the cells of the grid that covers the box ``Lx, Ly`` [m] (lattice offset
    ``shift`` [m]).
    """

    cp: np.ndarray
    cq: np.ndarray
    a: np.ndarray
    b: np.ndarray
    ux: float
    uy: float
    members: np.ndarray
    starts: np.ndarray
    p0: float
    q0: float
    hp: float
    hq: float
    np_: int
    nq: int
    Lx: float
    Ly: float
    shift: float

    def cells(self, p, q) -> np.ndarray:
        """Cell index of points (p, q) [m] of the ray's frame (clipped to the grid)."""
        ip = np.clip(np.floor((p - self.p0) / self.hp), 0, self.np_ - 1).astype(np.int64)
        iq = np.clip(np.floor((q - self.q0) / self.hq), 0, self.nq - 1).astype(np.int64)
        return ip * self.nq + iq


def _expand(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(owner, rank) of every item when item k of a list owns counts[k] consecutive slots."""
    owner = np.repeat(np.arange(counts.size), counts)
    first = np.cumsum(counts) - counts
    return owner, np.arange(owner.size) - first[owner]


def _images(cx, cy, ex, ey, Lx: float, Ly: float, shift: float):
    """Every lattice image of the wrapped shadows whose bounding box (half-extents ex, ey
    [m]) reaches into the box: (index of the shadow, x, y) [m]."""
    ni = int(math.ceil(float(np.max(ex, initial=0.0)) / Lx))
    nj = int(math.ceil(float(np.max(ey, initial=0.0)) / Ly))
    keep_i, keep_x, keep_y = [], [], []
    index = np.arange(cx.size)
    for i in range(-ni, ni + 1):
        xi, yi = cx + i * Lx, cy - i * shift
        yi = yi - np.floor((yi + 0.5 * Ly) / Ly) * Ly
        near_x = (xi + ex > -0.5 * Lx) & (xi - ex < 0.5 * Lx)
        for j in range(-nj, nj + 1):
            yj = yi + j * Ly
            inside = near_x & (yj + ey > -0.5 * Ly) & (yj - ey < 0.5 * Ly)
            keep_i.append(index[inside])
            keep_x.append(xi[inside])
            keep_y.append(yj[inside])
    return np.concatenate(keep_i), np.concatenate(keep_x), np.concatenate(keep_y)


def _grid(extent: float, size: float, most: int) -> tuple[int, float]:
    """Cells along one side of ``extent`` [m], about ``size`` [m] each, at most ``most``."""
    n = int(min(max(1, extent / max(size, 1e-300)), most))
    return n, extent / n


def shadows(x, y, z, radius, elevation_deg: float, azimuth_deg: float, Lx: float, Ly: float,
            shift: float) -> Shadows:
    """The shadows of spheres at (x, y, z) [m] of ``radius`` [m] for one line of sight.

    Parameters
    ----------
    x, y, z, radius : array [m]
    elevation_deg : float [deg]
        Ring opening angle B, in (0, 90].
    azimuth_deg : float [deg]
        Azimuth phi of the ray's horizontal direction, from +x (radial) toward +y (orbital
        motion).
    Lx, Ly : float [m]
        The box.
    shift : float [m]
        Shear offset of the radial images at the snapshot's time.
    """
    B, phi = math.radians(elevation_deg), math.radians(azimuth_deg)
    sin_b = math.sin(B)
    cot_b = math.cos(B) / sin_b
    ux, uy = math.cos(phi), math.sin(phi)
    r = np.asarray(radius, dtype=float)
    z = np.asarray(z, dtype=float)
    px, py = wrap_into_box(np.asarray(x) - z * cot_b * ux, np.asarray(y) - z * cot_b * uy,
                           Lx, Ly, shift)
    a_all = r / sin_b
    ex = np.sqrt((a_all * ux) ** 2 + (r * uy) ** 2)
    ey = np.sqrt((a_all * uy) ** 2 + (r * ux) ** 2)
    idx, cx, cy = _images(px, py, ex, ey, Lx, Ly, shift)
    a, b = a_all[idx], r[idx]
    cp, cq = cx * ux + cy * uy, cy * ux - cx * uy
    # the box's corners in the ray's frame bound the grid
    corners = np.array([[sx * 0.5 * Lx, sy * 0.5 * Ly] for sx in (-1, 1) for sy in (-1, 1)])
    pc, qc = corners @ [ux, uy], corners @ [-uy, ux]
    p0, q0 = float(pc.min()), float(qc.min())
    span_p, span_q = float(pc.max()) - p0, float(qc.max()) - q0
    med_a = 2.0 * float(np.median(a)) if a.size else span_p
    med_b = 2.0 * float(np.median(b)) if b.size else span_q
    np_, hp = _grid(span_p, med_a, 4096)
    nq, hq = _grid(span_q, med_b, max(1, 4_000_000 // np_))
    ip0 = np.clip(np.floor((cp - a - p0) / hp), 0, np_ - 1).astype(np.int64)
    ip1 = np.clip(np.floor((cp + a - p0) / hp), 0, np_ - 1).astype(np.int64)
    iq0 = np.clip(np.floor((cq - b - q0) / hq), 0, nq - 1).astype(np.int64)
    iq1 = np.clip(np.floor((cq + b - q0) / hq), 0, nq - 1).astype(np.int64)
    width = iq1 - iq0 + 1
    owner, rank = _expand((ip1 - ip0 + 1) * width)
    cells = (ip0[owner] + rank // width[owner]) * nq + iq0[owner] + rank % width[owner]
    order = np.argsort(cells, kind="stable")
    starts = np.concatenate([[0], np.cumsum(np.bincount(cells, minlength=np_ * nq))])
    return Shadows(cp, cq, a, b, ux, uy, owner[order], starts, p0, q0, hp, hq, np_, nq,
                   Lx, Ly, shift)


def blocked(s: Shadows, qx, qy) -> np.ndarray:
    """Whether each ray crossing z = 0 at (qx, qy) [m] is blocked by a sphere (bool array).

    The points may lie anywhere in the plane; they are wrapped into the box first.
    """
    qx, qy = wrap_into_box(qx, qy, s.Lx, s.Ly, s.shift)
    out = np.zeros(qx.size, dtype=bool)
    for lo in range(0, qx.size, BATCH):
        bx, by = qx[lo:lo + BATCH], qy[lo:lo + BATCH]
        p, q = bx * s.ux + by * s.uy, by * s.ux - bx * s.uy
        cell = s.cells(p, q)
        ray, rank = _expand(s.starts[cell + 1] - s.starts[cell])
        k = s.members[s.starts[cell[ray]] + rank]
        along = (p[ray] - s.cp[k]) / s.a[k]
        across = (q[ray] - s.cq[k]) / s.b[k]
        hit = along * along + across * across <= 1.0
        out[lo:lo + BATCH] = np.bincount(ray[hit], minlength=bx.size) > 0
    return out


def view_statistics(n_pass: int, n_rays: int, elevation_deg: float) -> dict:
    """Transmission and normal optical depth of ``n_pass`` free rays out of ``n_rays``.

    Returns
    -------
    dict: ``transmission`` and ``transmission_stderr`` (binomial) [dimensionless],
    ``normal_optical_depth`` = -sin B ln T and its ``normal_optical_depth_stderr``
    [dimensionless] (infinite and NaN when no ray passed), ``rays``.
    """
    return transmission_summary(n_pass / n_rays, math.sqrt(
        max(n_pass * (n_rays - n_pass), 0) / n_rays**3), elevation_deg, n_rays)


def transmission_summary(T: float, T_err: float, elevation_deg: float, rays: int) -> dict:
    """``view_statistics`` from a transmission T and its standard error [dimensionless]."""
    sin_b = math.sin(math.radians(elevation_deg))
    tau = -sin_b * math.log(T) if T > 0 else math.inf
    tau_err = sin_b * T_err / T if T > 0 else math.nan
    return {"transmission": float(T), "transmission_stderr": float(T_err),
            "normal_optical_depth": float(tau), "normal_optical_depth_stderr": float(tau_err),
            "rays": int(rays)}


def rays_for(transmission: float, relative_error: float, largest: int = 200_000) -> int:
    """Rays for a relative standard error ``relative_error`` of tau_n at transmission T.

    sigma_tau / tau = sqrt((1 - T) / (N T)) / |ln T|, so N = (1 - T) / (T (rel ln T)^2); at
    most ``largest`` (nearly clear or nearly opaque views would need without bound).
    """
    T = min(max(transmission, 1e-6), 1.0 - 1e-9)
    need = (1.0 - T) / (T * (relative_error * math.log(T)) ** 2)
    return int(min(max(math.ceil(need), 1000), largest))


def trace_view(snap: dict, Lx: float, Ly: float, shift: float, elevation_deg: float,
               azimuth_deg: float, rng: np.random.Generator, rays: int | None = None,
               precision: float = 0.01) -> dict:
    """One (B, phi) view of one snapshot: ``view_statistics`` of random rays in the box.

    With ``rays`` None, a pilot of 2000 rays estimates T and ``rays_for`` sets the number
    for a relative error ``precision`` of tau_n (the pilot's rays count too).

    Parameters
    ----------
    snap : dict with x, y, z, radius [m]
    Lx, Ly, shift : float [m]
    elevation_deg, azimuth_deg : float [deg]
    rng : numpy Generator
    rays : int or None
    precision : float [dimensionless]
    """
    s = shadows(snap["x"], snap["y"], snap["z"], snap["radius"], elevation_deg, azimuth_deg,
                Lx, Ly, shift)

    def count(n: int) -> int:
        qx = (rng.random(n) - 0.5) * Lx
        qy = (rng.random(n) - 0.5) * Ly
        return int(n - np.count_nonzero(blocked(s, qx, qy)))

    if rays is not None:
        return view_statistics(count(rays), rays, elevation_deg)
    pilot = 2000
    passed = count(pilot)
    total = max(rays_for(passed / pilot, precision), pilot)
    passed += count(total - pilot) if total > pilot else 0
    return view_statistics(passed, total, elevation_deg)


def line_of_sight_image(snap: dict, Lx: float, Ly: float, shift: float,
                        elevation_deg: float, azimuth_deg: float,
                        pixels: int = 400) -> np.ndarray:
    """The sheet seen along the line of sight: 1 where a ray passes, 0 where it is blocked,
    on a (ny, nx) grid of ray crossings over the box (rows along y) [dimensionless]."""
    nx = pixels
    ny = max(8, int(round(pixels * Ly / Lx)))
    gx = (np.arange(nx) + 0.5) / nx * Lx - 0.5 * Lx
    gy = (np.arange(ny) + 0.5) / ny * Ly - 0.5 * Ly
    X, Y = np.meshgrid(gx, gy)
    s = shadows(snap["x"], snap["y"], snap["z"], snap["radius"], elevation_deg, azimuth_deg,
                Lx, Ly, shift)
    return (~blocked(s, X.ravel(), Y.ravel())).reshape(ny, nx).astype(float)


def radial_scan(snap: dict, Lx: float, Ly: float, shift: float, elevation_deg: float,
                azimuth_deg: float, resolution: float, y0: float = 0.0, step: float = 0.05,
                boxes: int = 1) -> dict:
    """Transmission along a radial track (fixed y = ``y0`` [m] of the rays' crossings), finely
    sampled every ``step`` [m] and averaged into bins of ``resolution`` [m] (an instrument's
    radial resolution), over ``boxes`` box widths of the shear-periodic sheet.

    Returns
    -------
    dict: ``x`` [m] and ``transmission`` of the fine samples; ``bin_edges`` [m] and
    ``binned`` (mean transmission per bin) [dimensionless].
    """
    s = shadows(snap["x"], snap["y"], snap["z"], snap["radius"], elevation_deg, azimuth_deg,
                Lx, Ly, shift)
    length = boxes * Lx
    x = np.arange(-0.5 * length, 0.5 * length, step) + 0.5 * step
    free = (~blocked(s, x, np.full_like(x, y0))).astype(float)
    n_bins = max(1, int(length / resolution))
    edges = -0.5 * length + np.arange(n_bins + 1) * resolution
    which = np.clip(((x + 0.5 * length) / resolution).astype(np.int64), 0, n_bins - 1)
    binned = np.bincount(which, weights=free, minlength=n_bins) / np.maximum(
        np.bincount(which, minlength=n_bins), 1)
    return {"x": x, "transmission": free, "bin_edges": edges, "binned": binned}
