"""Self-gravity of a shear-periodic sheet: a reference direct sum and a particle-mesh solver.

Geometry (REBOUND's shearing sheet, ``boundary = "shear"``): the box is [-Lx/2, Lx/2) x
[-Ly/2, Ly/2); a particle at (x, y, z) has images at (x + i Lx, y - i s + j Ly, z) with the
shear offset s = 1.5 Omega Lx t (mod Ly) at time t: the image one box further out has
drifted back (in -y) with the Keplerian shear.  There are no vertical images (REBOUND's
N_ghost_z = 0; its periodic z is a bookkeeping device).  Forces are Plummer-softened,
a = -G m d / (|d|^2 + b^2)^(3/2), as REBOUND's ``softening`` b.

The infinite image sum converges only conditionally (a uniform infinite sheet pulls in no
horizontal direction, but a truncated one does).  :func:`direct_accelerations` defines it as
the converged limit: images within (2K + 1) rows of (2K + 1) boxes, each row centred on the
source, are summed particle by particle; the same rows filled with the source's mass spread
uniformly (a rectangle of surface density m / (Lx Ly)) are subtracted and the field of an
infinite uniform sheet, -2 pi G (m / Lx Ly) sign(dz) vertically and nothing horizontally, is
added.  What remains beyond row K is the difference between point images and a uniform
sheet, whose lowest moment is a quadrupole: the truncation error falls as K^-2 (checked in
tests/test_selfgravity.py).

:func:`pm_accelerations` solves Poisson's equation on a grid in sheared coordinates
(x, y' = y + alpha x, alpha = s / Lx), where the shear-periodic box is exactly doubly periodic:
cloud-in-cell mass assignment onto horizontal layers z_l (thin sheets), a 2-D FFT in (x, y'),
for every horizontal mode k_phys = (kx + alpha ky, ky) the exact free-space vertical Green's
function of a thin sheet, -(2 pi G / |k|) exp(-|k| |z - z_l|), convolved along z by a zero-
padded FFT (no vertical images), spectral horizontal derivatives, and the same cloud-in-cell
kernel to interpolate back (momentum conserving: the pair force is antisymmetric and the
self-force vanishes).  Limits: forces between particles closer than about two cells (or two
layers) are underestimated; there is no short-range (P3M) correction, so the PM field is the
collective field of the sheet, not the granular near field (see docs/gravity.md for the
measured errors).  The P3M solver's mesh, which adds that correction, is
:mod:`ringsim.physics.p3m_mesh`.

:func:`slab_field` is the vertical field of the horizontally averaged sheet, the numpy twin
of the slab solver.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

from ringsim.physics.constants import G_SI, SHEAR


def shear_offset(Omega: float, Lx: float, Ly: float, t: float) -> float:
    """Azimuthal offset s of the radial images at time t, wrapped into [-Ly/2, Ly/2) [m].

    The image at x + Lx sits at y - s (+ any multiple of Ly), s = 1.5 Omega Lx t.

    Parameters
    ----------
    Omega : float [1/s]
    Lx, Ly : float [m]
    t : float [s]
    """
    s = (SHEAR * Omega * Lx * t) % Ly
    return s - Ly if s >= 0.5 * Ly else s


def _rectangle_field(u1, u2, v1, v2, Z, G_sigma):
    """Field [m/s^2] of a uniform rectangle [u1, u2] x [v1, v2] (coordinates relative to the
    target, in the plane a height -Z below it) of surface density G_sigma / G."""
    def asinh_ratio(a, b):
        return np.arcsinh(a / np.maximum(b, 1e-300))

    rho1, rho2 = np.hypot(u1, Z), np.hypot(u2, Z)
    gx = (asinh_ratio(v2, rho1) - asinh_ratio(v2, rho2)
          - asinh_ratio(v1, rho1) + asinh_ratio(v1, rho2))
    sig1, sig2 = np.hypot(v1, Z), np.hypot(v2, Z)
    gy = (asinh_ratio(u2, sig1) - asinh_ratio(u2, sig2)
          - asinh_ratio(u1, sig1) + asinh_ratio(u1, sig2))
    absz = np.abs(Z)

    def corner(u, v):
        return np.arctan2(u * v, absz * np.sqrt(u * u + v * v + Z * Z))

    solid = corner(u2, v2) - corner(u1, v2) - corner(u2, v1) + corner(u1, v1)
    gz = -np.sign(Z) * solid
    return G_sigma * gx, G_sigma * gy, G_sigma * gz


def pair_image_field(d, Lx, Ly, shift, softening, n_rows, G=G_SI):
    """Converged image sum of the field per unit source mass, for given pair offsets.

    Parameters
    ----------
    d : array (..., 3) [m]
        Target minus source position, minimum-imaged (|dx| <= Lx/2, |dy| <= Ly/2).
    Lx, Ly : float [m]
    shift : float [m]
        Shear offset s (see :func:`shear_offset`).
    softening : float [m]
    n_rows : int
        K: (2K + 1) rows of (2K + 1) images are summed directly.

    Returns
    -------
    array (..., 3) [m^3 s^-2 kg^-1 ... per kg]: multiply by the source mass for [m/s^2].
    The zero offset (a particle on itself) contributes only through its images.
    """
    d = np.asarray(d, dtype=float)
    out = np.zeros_like(d)
    b2 = softening**2
    dz = d[..., 2]
    G_sigma = G / (Lx * Ly)
    for ix in range(-n_rows, n_rows + 1):
        n_centre = int(np.round(ix * shift / Ly))
        row_y = -ix * shift + n_centre * Ly    # image y offset of the row's central box
        dx = d[..., 0] - ix * Lx
        for iy in range(-n_rows, n_rows + 1):
            dy = d[..., 1] - (row_y + iy * Ly)
            r2 = dx * dx + dy * dy + dz * dz
            with np.errstate(divide="ignore", invalid="ignore"):
                inv3 = np.where(r2 > 0.0, (r2 + b2) ** -1.5, 0.0)
            out[..., 0] -= G * dx * inv3
            out[..., 1] -= G * dy * inv3
            out[..., 2] -= G * dz * inv3
        # the row's boxes as a uniform rectangle, relative to the target
        u1, u2 = ix * Lx - 0.5 * Lx - d[..., 0], ix * Lx + 0.5 * Lx - d[..., 0]
        v1 = row_y - (n_rows + 0.5) * Ly - d[..., 1]
        v2 = row_y + (n_rows + 0.5) * Ly - d[..., 1]
        gx, gy, gz = _rectangle_field(u1, u2, v1, v2, dz, G_sigma)
        out[..., 0] -= gx
        out[..., 1] -= gy
        out[..., 2] -= gz
    out[..., 2] -= 2.0 * np.pi * G_sigma * np.sign(dz)
    return out


def minimum_image(d, Lx, Ly, shift):
    """Pair offsets d = target - source [m] mapped to the nearest shear-periodic image.

    Parameters
    ----------
    d : array (..., 3) [m]
    Lx, Ly, shift : float [m]
    """
    d = np.array(d, dtype=float, copy=True)
    n = np.round(d[..., 0] / Lx)
    d[..., 0] -= n * Lx
    d[..., 1] += n * shift     # the source's image at x + n Lx sits at y - n s
    d[..., 1] -= np.round(d[..., 1] / Ly) * Ly
    return d


def radial_images(x: np.ndarray, y: np.ndarray, z: np.ndarray, Lx: float, shift: float,
                  reach: float) -> tuple[np.ndarray, ...]:
    """The particles, then the shear-periodic images of those within ``reach`` of a radial
    edge, for pair searches across the boundary.

    Parameters
    ----------
    x, y, z : arrays [m]
    Lx : float [m]
        Radial box width.
    shift : float [m]
        Azimuthal offset of the radial neighbour boxes (1.5 Omega Lx t).
    reach : float [m]

    Returns
    -------
    index : array of int
        The original particle of each point.
    x, y, z : arrays [m]
        The points' positions.
    """
    near_high = np.flatnonzero(x > 0.5 * Lx - reach)
    near_low = np.flatnonzero(x < -0.5 * Lx + reach)
    index = np.concatenate([np.arange(x.size), near_high, near_low])
    px = np.concatenate([x, x[near_high] - Lx, x[near_low] + Lx])
    py = np.concatenate([y, y[near_high] + shift, y[near_low] - shift])
    return index, px, py, z[index]


def direct_accelerations(pos, mass, Lx, Ly, shift, softening, n_rows=4, G=G_SI,
                         targets=None, chunk=256):
    """Reference accelerations [m/s^2] of a shear-periodic sheet by direct summation.

    Cost: N_targets * N * (2K + 1)^2 pair evaluations; use for N up to a few thousand.

    Parameters
    ----------
    pos : array (N, 3) [m]
    mass : array (N,) [kg]
    Lx, Ly : float [m]
    shift : float [m]
        Shear offset s at the time of the positions (:func:`shear_offset`).
    softening : float [m]
        Plummer softening b.
    n_rows : int
        K of :func:`pair_image_field`; K = 4 converges to better than 1e-4 of the rms field
        for square boxes (tests/test_selfgravity.py).
    targets : array of int, optional
        Particles whose acceleration is wanted (default all).
    """
    pos = np.asarray(pos, dtype=float)
    mass = np.asarray(mass, dtype=float)
    idx = np.arange(len(pos)) if targets is None else np.asarray(targets)
    acc = np.empty((idx.size, 3))
    for start in range(0, idx.size, chunk):
        sel = idx[start:start + chunk]
        d = minimum_image(pos[sel, None, :] - pos[None, :, :], Lx, Ly, shift)
        field = pair_image_field(d, Lx, Ly, shift, softening, n_rows, G)
        acc[start:start + chunk] = np.einsum("ijk,j->ik", field, mass)
    return acc


# --- particle mesh -------------------------------------------------------------------------------

def _cic(coord, n, periodic):
    """Lower node index and the weights of the two nodes of a cloud-in-cell kernel."""
    lo = np.floor(coord)
    frac = coord - lo
    lo = lo.astype(np.int64)
    hi = lo + 1
    if periodic:
        lo %= n
        hi %= n
    return lo, hi, 1.0 - frac, frac


class ShearPM:
    """Particle-mesh gravity of a shear-periodic sheet (see the module docstring).

    Parameters
    ----------
    Lx, Ly : float [m]
    nx, ny : int
        Horizontal cells (powers of two or small primes for fast FFTs).
    dz : float [m]
        Spacing of the horizontal layers; the layers span the particles' z range at each
        call.
    G : float [m^3 kg^-1 s^-2]
    deconvolve : int
        Divide the horizontal spectrum by this power of the cloud-in-cell window (0: none;
        1: undo the assignment; 2: undo assignment and interpolation).
    """

    def __init__(self, Lx, Ly, nx, ny, dz, G=G_SI, deconvolve=0, workers=1):
        self.Lx, self.Ly, self.nx, self.ny, self.dz = Lx, Ly, int(nx), int(ny), float(dz)
        self.G = G
        self.deconvolve = deconvolve
        self.workers = workers
        self.kx = 2.0 * np.pi * np.fft.fftfreq(self.nx, Lx / self.nx)
        self.ky = 2.0 * np.pi * np.fft.rfftfreq(self.ny, Ly / self.ny)
        wx = np.sinc(np.fft.fftfreq(self.nx))        # sin(pi f)/(pi f): CIC is its square
        wy = np.sinc(np.fft.rfftfreq(self.ny))
        self.window = (wx[:, None] * wy[None, :]) ** 2

    def _layers(self, z):
        zmin, zmax = float(z.min()), float(z.max())
        nz = max(2, int(np.ceil((zmax - zmin) / self.dz)) + 2)
        z0 = 0.5 * (zmin + zmax) - 0.5 * (nz - 1) * self.dz
        return z0, nz

    def accelerations(self, pos, mass, shift):
        """Accelerations [m/s^2] of all particles.

        Parameters
        ----------
        pos : array (N, 3) [m]
        mass : array (N,) [kg]
        shift : float [m]
            Shear offset s (:func:`shear_offset`).
        """
        pos = np.asarray(pos, dtype=float)
        Lx, Ly, nx, ny = self.Lx, self.Ly, self.nx, self.ny
        alpha = shift / Lx                       # y' = y + alpha x
        yp = pos[:, 1] + alpha * pos[:, 0]
        gx_ = ((pos[:, 0] + 0.5 * Lx) / Lx % 1.0) * nx
        gy_ = ((yp + 0.5 * Ly) / Ly % 1.0) * ny
        z0, nz = self._layers(pos[:, 2])
        gz_ = (pos[:, 2] - z0) / self.dz
        ix0, ix1, wx0, wx1 = _cic(gx_, nx, True)
        iy0, iy1, wy0, wy1 = _cic(gy_, ny, True)
        iz0, iz1, wz0, wz1 = _cic(gz_, nz, False)
        corners = [(ix, iy, iz, w1 * w2 * w3)
                   for ix, w1 in ((ix0, wx0), (ix1, wx1))
                   for iy, w2 in ((iy0, wy0), (iy1, wy1))
                   for iz, w3 in ((iz0, wz0), (iz1, wz1))]
        sigma = np.zeros(nx * ny * nz)
        for ix, iy, iz, w in corners:
            sigma += np.bincount((ix * ny + iy) * nz + iz, weights=w * mass,
                                 minlength=nx * ny * nz)
        sigma = sigma.reshape(nx, ny, nz) / (Lx / nx * Ly / ny)      # [kg/m^2] per layer
        fields = self._solve(sigma, alpha)
        acc = np.zeros((len(pos), 3))
        flat = [f.reshape(-1) for f in fields]
        for ix, iy, iz, w in corners:
            node = (ix * ny + iy) * nz + iz
            for c in range(3):
                acc[:, c] += w * flat[c][node]
        return acc

    def _solve(self, sigma, alpha):
        """Fields (gx, gy, gz) [m/s^2] on the nodes from the layer surface densities."""
        nx, ny, nz = sigma.shape
        G = self.G
        s_hat = scipy.fft.rfft2(sigma, axes=(0, 1), workers=self.workers)
        if self.deconvolve:
            s_hat /= self.window[:, :, None] ** self.deconvolve
        kxp = self.kx[:, None] + alpha * self.ky[None, :]
        ky = np.broadcast_to(self.ky[None, :], kxp.shape)
        k = np.hypot(kxp, ky)
        # vertical kernels on offsets u = n dz, n = -(nz-1)..(nz-1), zero-padded FFT along z
        n_pad = 2 * nz
        offs = np.arange(n_pad)
        offs = np.where(offs < nz, offs, offs - n_pad) * self.dz
        offs[nz] = 0.0                           # the padding slot, never reached
        absu = np.abs(offs)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            decay = np.exp(-k[:, :, None] * absu[None, None, :])
            pot_kernel = np.where(k[:, :, None] > 0, -2.0 * np.pi * G / k[:, :, None] * decay,
                                  2.0 * np.pi * G * absu[None, None, :])
        gz_kernel = -2.0 * np.pi * G * np.sign(offs)[None, None, :] * decay
        s_z = scipy.fft.fft(s_hat, n=n_pad, axis=2, workers=self.workers)
        pot_hat = scipy.fft.ifft(s_z * scipy.fft.fft(pot_kernel, axis=2), axis=2,
                                 workers=self.workers)[:, :, :nz]
        gz_hat = scipy.fft.ifft(s_z * scipy.fft.fft(gz_kernel, axis=2), axis=2,
                                workers=self.workers)[:, :, :nz]
        # odd derivatives: drop the Nyquist planes, whose derivative is not real
        deriv_x = -1j * kxp
        deriv_y = -1j * ky.copy()
        if nx % 2 == 0:
            deriv_x[nx // 2, :] = 0.0
            deriv_y[nx // 2, :] = 0.0
        if ny % 2 == 0:
            deriv_x[:, -1] = 0.0
            deriv_y[:, -1] = 0.0
        shape = (nx, ny)
        gx = scipy.fft.irfft2(deriv_x[:, :, None] * pot_hat, s=shape, axes=(0, 1),
                              workers=self.workers)
        gy = scipy.fft.irfft2(deriv_y[:, :, None] * pot_hat, s=shape, axes=(0, 1),
                              workers=self.workers)
        gz = scipy.fft.irfft2(gz_hat, s=shape, axes=(0, 1), workers=self.workers)
        return gx, gy, gz


def pm_accelerations(pos, mass, Lx, Ly, shift, cell, dz=None, G=G_SI):
    """Particle-mesh accelerations [m/s^2] with square cells of about ``cell`` [m].

    Parameters
    ----------
    pos : array (N, 3) [m]
    mass : array (N,) [kg]
    Lx, Ly, shift : float [m]
    cell : float [m]
        Target horizontal cell size; the cell counts are rounded up to even numbers.
    dz : float [m], optional
        Layer spacing (default ``cell``).
    """
    nx = 2 * int(np.ceil(Lx / cell / 2))
    ny = 2 * int(np.ceil(Ly / cell / 2))
    return ShearPM(Lx, Ly, nx, ny, cell if dz is None else dz, G).accelerations(pos, mass, shift)


def slab_field(z, mass, Lx, Ly, G=G_SI):
    """Vertical field [m/s^2] of the horizontally averaged sheet (``sheet.gravity_solver:
    slab``; C twin ``rs_slab_field`` in ``ringsim/csrc/rs_gravity.c``).

    Each particle, spread over the box's area A = Lx Ly, is an infinite sheet pulling the
    others towards it with 2 pi G m / A:  a_z,i = -(2 pi G / A) sum_j m_j sign(z_i - z_j),
    j != i.  The k = 0 mode of the sheet's self-gravity, without any horizontal force or
    pull between neighbours (docs/gravity.md, "Slab").  O(N^2) here, for tests.

    Parameters
    ----------
    z : array [m]
    mass : array [kg]
    Lx, Ly : float [m]
    """
    z = np.asarray(z, dtype=float)
    mass = np.asarray(mass, dtype=float)
    sign = np.sign(z[:, None] - z[None, :])
    return -2.0 * np.pi * G / (Lx * Ly) * (sign * mass[None, :]).sum(axis=1)
