"""The long-range (mesh) part of the P3M self-gravity solver: the Gaussian force split and
its mesh on a shear-periodic sheet.

The Newtonian pair force is cut in two (Hockney & Eastwood 1988; GADGET-2, Springel 2005,
MNRAS 364, 1105, eq. 21-22): the force between Gaussian clouds of scale r_s, a fraction
:func:`long_range_fraction` L(r) of the pair force, is solved here on a mesh
(:class:`P3MMesh`, numpy and scipy.fft); the short-range rest 1 - L(r) is summed over pairs
closer than the cutoff r_c in C (``ringsim/csrc/rs_p3m.c``, ``rs_p3m_short``), which also
assigns the mass to the mesh and interpolates the field back.  The solver in REBOUND is
``ringsim.gravity.p3m``; its length scales are declared in :mod:`ringsim.physics.p3m_scales`.

Geometry: REBOUND's shearing sheet, as in :mod:`ringsim.physics.selfgravity`: the mesh
works in sheared coordinates (x, y' = y + alpha x, alpha = s / Lx), where the
shear-periodic box is exactly doubly periodic, on horizontal layers coupled by the exact
free-space vertical kernels (no vertical images).  Accuracy and cost of the defaults:
docs/gravity.md, section 4b.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.fft
import scipy.special

from ringsim.physics.constants import G_SI
from ringsim.physics.p3m_scales import P3M_TABLES


def long_range_fraction(r, split):
    """L(r): the fraction of the Newtonian pair force G m / r^2 carried by the mesh [-].

    The Gaussian split of Hockney & Eastwood and GADGET-2 (Springel 2005, MNRAS 364, 1105,
    eq. 21-22): the long-range potential is the Newtonian one multiplied by exp(-k^2 r_s^2)
    in Fourier space, i.e. the potential of Gaussian clouds, and in real space
    L(r) = erf(u) - (2 u / sqrt(pi)) exp(-u^2), u = r / (2 r_s).  The short-range rest
    1 - L(r) = erfc(u) + (2 u / sqrt(pi)) exp(-u^2) is summed over pairs in C
    (``rs_p3m_short``) within the cutoff r_c; beyond it the rest is left out: at the
    default r_c = 5 r_s (u = 2.5) it is 1 - L(5 r_s) = 5.85e-3 of the pair force.

    Parameters
    ----------
    r : array [m]
    split : float [m]
        r_s.
    """
    u = np.asarray(r, dtype=float) / (2.0 * split)
    return scipy.special.erf(u) - 2.0 / np.sqrt(np.pi) * u * np.exp(-u * u)


def core_heights(z, tail_fraction):
    """The heights (zlo, zhi) [m] a mesh with the sparse tail apart spans: the order
    statistics k and N - 1 - k of the particles' heights, k = floor(tail_fraction N / 2),
    so that at most ``tail_fraction`` of the particles lie beyond them (half above, half
    below); (min z, max z) if k = 0.  Exact order statistics (numpy's partition): a pure
    function of the state, independent of the particles' order.

    Parameters
    ----------
    z : array [m]
        The particles' heights.
    tail_fraction : float [-]
        The fraction of particles the mesh may leave beyond its layers, in [0, 1).
    """
    z = np.asarray(z, dtype=float)
    n = z.size
    if n == 0:
        return 0.0, 0.0
    k = int(np.floor(tail_fraction * n / 2.0))
    if k == 0:
        return float(z.min()), float(z.max())
    part = np.partition(z, (k, n - 1 - k))
    return float(part[k]), float(part[n - 1 - k])


def split_layer_kernels(k, d, split, G=G_SI):
    """Long-range potential and vertical field of a horizontal sheet mode, per unit Sigma_k.

    For a sheet of surface density Sigma_k exp(i k.r) at height 0, the Gaussian-filtered
    (exp(-K^2 r_s^2), K the 3-D wave number) potential and vertical field at height d are
    the 2-D Ewald kernels (Parry 1975 form):

        phi = -(pi G / k) [exp(k d) erfc(k r_s + d / 2 r_s) + exp(-k d) erfc(k r_s - d / 2 r_s)]
        g_z =   pi G      [exp(k d) erfc(k r_s + d / 2 r_s) - exp(-k d) erfc(k r_s - d / 2 r_s)]

    -> -(2 pi G / k) exp(-k |d|) and -2 pi G sign(d) exp(-k |d|) far from the sheet; at k = 0
    g_z = -2 pi G erf(d / 2 r_s) and phi is set to 0 (it exerts no horizontal force).
    Written with erfcx so that nothing overflows.

    Parameters
    ----------
    k : array [1/m]
        |k| >= 0 of the physical wave vector.
    d : array [m]
        Height above the sheet (broadcast against k).
    split : float [m]
        r_s.

    Returns
    -------
    (phi [m^3 kg^-1 s^-2 per m^-1: multiply by Sigma_k [kg/m^2] for m^2/s^2],
     g_z [m^3 kg^-1 s^-2 per m^-2: times Sigma_k for m/s^2])
    """
    k, d = np.broadcast_arrays(np.asarray(k, float), np.asarray(d, float))
    absd = np.abs(d)
    a = k * split + absd / (2.0 * split)
    b = k * split - absd / (2.0 * split)
    gauss = np.exp(-(k * split) ** 2 - (absd / (2.0 * split)) ** 2)
    e_plus = scipy.special.erfcx(a) * gauss
    with np.errstate(over="ignore", invalid="ignore"):
        e_minus = np.where(b >= 0.0, scipy.special.erfcx(np.maximum(b, 0.0)) * gauss,
                           np.exp(-k * absd) * scipy.special.erfc(np.minimum(b, 0.0)))
        phi = np.where(k > 0.0, -np.pi * G / np.where(k > 0.0, k, 1.0) * (e_plus + e_minus),
                       0.0)
    gz = np.pi * G * np.sign(d) * (e_plus - e_minus)
    return phi, gz


class P3MMesh:
    """The long-range (mesh) part of the shear-periodic P3M solver.

    Same geometry as :class:`ringsim.physics.selfgravity.ShearPM` (sheared coordinates,
    horizontal layers, exact free-space vertical coupling by a zero-padded FFT along z),
    with every mode filtered by the Gaussian split (:func:`split_layer_kernels`), so that
    the mesh carries only the forces between Gaussian clouds of scale r_s and may be a few
    times coarser than r_s.
    The cloud-in-cell window is divided out twice (assignment and interpolation),
    horizontally, as in GADGET-2's PM; vertically the layer kernels are corrected for the
    mean smoothing of cloud-in-cell between layers (``layer_correction``: K - dz^2/6 K'';
    its effect on the force error is in docs/gravity.md, 4b).  The k = 0 vertical field,
    the largest, is left to ``rs_p3m_mean_vertical`` (fine layers in C) unless
    ``mean_vertical_in_c`` is False.

    Parameters
    ----------
    Lx, Ly : float [m]
    nx, ny : int
    dz : float [m]
        Layer spacing.
    split : float [m]
        r_s.
    workers : int
        scipy.fft threads.
    deconvolve : int
        Powers of the horizontal cloud-in-cell window divided out (2: assignment and
        interpolation).
    """

    def __init__(self, Lx, Ly, nx, ny, dz, split, G=G_SI, workers=1, deconvolve=2,
                 mean_vertical_in_c=True, layer_correction=True):
        self.mean_vertical_in_c = mean_vertical_in_c
        self.layer_correction = layer_correction
        self.Lx, self.Ly, self.nx, self.ny = Lx, Ly, int(nx), int(ny)
        self.dz, self.split, self.G, self.workers = float(dz), float(split), G, workers
        self.kx = 2.0 * np.pi * np.fft.fftfreq(self.nx, Lx / self.nx)
        self.ky = 2.0 * np.pi * np.fft.rfftfreq(self.ny, Ly / self.ny)
        wx = np.sinc(np.fft.fftfreq(self.nx))
        wy = np.sinc(np.fft.rfftfreq(self.ny))
        self.inverse_window = 1.0 / ((wx[:, None] * wy[None, :]) ** 2) ** deconvolve
        # the largest physical |k| on the sheared mesh (|alpha| <= Ly / (2 Lx))
        k_max = np.hypot(np.abs(self.kx).max() + 0.5 * Ly / Lx * self.ky.max(), self.ky.max())
        self._ktab = np.linspace(0.0, 1.001 * k_max, 8193)
        self._tables: dict = {}     # layer count -> kernel spectra, at most P3M_TABLES
        self.tables_built = 0       # kernel tables made so far (benchmarks read it)

    @staticmethod
    def z_length(nz: int) -> int:
        """Length of the zero-padded FFT along z for ``nz`` layers: the vertical coupling
        is a linear convolution over the offsets -(nz-1)..(nz-1), so any length >= 2 nz - 1
        is exact; scipy's next fast length, since 2 nz can have a large prime factor (292 =
        4 x 73 at nz = 146) that makes the vertical FFTs slow (docs/performance.md)."""
        return scipy.fft.next_fast_len(2 * nz - 1, real=True)

    def _kernel_tables(self, nz):
        """Vertical spectra of the layer kernels on a fine |k| grid (cached per nz).

        Returns (k phi, g_z) as arrays (n_k, z_length(nz)): the kernels of
        :func:`split_layer_kernels` on the layer offsets 0..nz-1, zero-padded to
        ``z_length(nz)`` with the negative offsets at the end (phi even, g_z odd in the
        offset), transformed along z.  phi's spectrum is real, g_z's imaginary (its
        imaginary part is stored).  Linear interpolation in |k| is accurate to < 1e-4 of
        the kernel (8193 nodes)."""
        if nz not in self._tables:
            self.tables_built += 1
            d = np.arange(nz)[:, None] * self.dz
            phi, gz = split_layer_kernels(self._ktab[None, :], d, self.split, self.G)
            if self.layer_correction:
                # cloud-in-cell assignment and interpolation between layers each turn a
                # kernel K into K + dz^2 / 12 K'' on average over the particles' positions
                # within their layers (linear interpolation): K - dz^2 / 6 K'' undoes it
                h = 1e-3 * self.split
                up = split_layer_kernels(self._ktab[None, :], d + h, self.split, self.G)
                down = split_layer_kernels(self._ktab[None, :], d - h, self.split, self.G)
                c = -self.dz**2 / 6.0 / h**2
                phi = phi + c * (up[0] - 2.0 * phi + down[0])
                gz = gz + c * (up[1] - 2.0 * gz + down[1])
            kphi = phi * self._ktab[None, :]
            kphi[:, 0] = -2.0 * np.pi * self.G          # the k -> 0 limit of k phi
            n_z = self.z_length(nz)
            padded = np.zeros((2, self._ktab.size, n_z))
            padded[0, :, :nz] = kphi.T
            padded[0, :, n_z - nz + 1:] = kphi.T[:, :0:-1]
            padded[1, :, :nz] = gz.T
            padded[1, :, n_z - nz + 1:] = -gz.T[:, :0:-1]
            spectra = scipy.fft.fft(padded, axis=-1)
            if len(self._tables) >= P3M_TABLES:     # the least recently used goes
                del self._tables[next(iter(self._tables))]
            self._tables[nz] = (np.ascontiguousarray(spectra[0].real),
                                np.ascontiguousarray(spectra[1].imag))
        self._tables[nz] = self._tables.pop(nz)     # now the most recently used
        return self._tables[nz]

    def fields(self, mass, alpha):
        """Mesh fields (gx, gy, gz) [m/s^2] on the nodes, arrays (nz, nx, ny).

        Parameters
        ----------
        mass : array (nz, nx, ny) [kg]
            Cloud-in-cell mass on the nodes (layers dz apart, outermost axis).
        alpha : float
            Shear of the coordinates, s / Lx [-].
        """
        nz, nx, ny = mass.shape
        workers = self.workers
        cell = self.Lx / nx * self.Ly / ny
        s_hat = scipy.fft.rfft2(mass / cell, axes=(1, 2), workers=workers)
        s_hat *= self.inverse_window
        kxp = self.kx[:, None] + alpha * self.ky[None, :]
        ky = np.broadcast_to(self.ky[None, :], kxp.shape)
        k = np.hypot(kxp, ky).ravel()
        # vertical coupling along the last (contiguous) axis, layout (modes, z_length): the
        # kernels' z-spectra interpolated linearly in |k| from the tables
        kphi_tab, gz_tab = self._kernel_tables(nz)
        s_t = np.moveaxis(s_hat, 0, -1).reshape(k.size, nz)
        coupled = np.empty((2, k.size, nz), dtype=complex)

        def couple(rows: slice) -> None:
            # the vertical coupling of a block of modes: the z-spectra of the kernels at
            # their |k|, the layers' transform, the products transformed back; numpy and
            # scipy release the GIL, so blocks on threads run at once, and every element's
            # arithmetic is the same in any block
            phi_z, gz_z = _interpolated(kphi_tab, gz_tab, k[rows], self._ktab[1])
            if self.mean_vertical_in_c and rows.start == 0:
                gz_z[0] = 0.0   # the k = 0 vertical field is added on fine layers in C
            s_z = scipy.fft.fft(s_t[rows], n=self.z_length(nz), axis=-1)
            for out, kernel in zip(coupled, (phi_z, gz_z), strict=True):
                out[rows] = scipy.fft.ifft(s_z * kernel, axis=-1)[:, :nz]

        blocks = [slice(b[0], b[-1] + 1) for b in np.array_split(np.arange(k.size),
                                                                    max(workers, 1)) if b.size]
        if len(blocks) == 1:
            couple(blocks[0])
        else:
            with ThreadPoolExecutor(len(blocks)) as pool:
                list(pool.map(couple, blocks))
        # the layers made contiguous again (nz, nx, ny/2+1): the horizontal transforms
        # below then read whole rows
        pot_hat, gz_hat = (np.ascontiguousarray(np.moveaxis(c.reshape(nx, -1, nz), -1, 0))
                           for c in coupled)
        deriv_x = -1j * kxp
        deriv_y = -1j * ky
        if nx % 2 == 0:
            deriv_x[nx // 2, :] = 0.0
            deriv_y = deriv_y.copy()
            deriv_y[nx // 2, :] = 0.0
        if ny % 2 == 0:
            deriv_x[:, -1] = 0.0
            deriv_y[:, -1] = 0.0
        shape = (nx, ny)
        out = [scipy.fft.irfft2(h, s=shape, axes=(1, 2), workers=workers)
               for h in (deriv_x * pot_hat, deriv_y * pot_hat, gz_hat)]
        return [np.ascontiguousarray(g) for g in out]


def _interpolated(kphi_tab, gz_tab, k, k_step):
    """The vertical kernel spectra at the modes' |k| (``P3MMesh.fields``): phi (real, 0 at
    k = 0) and g_z (imaginary), each interpolated linearly between the tables' rows
    ``k_step`` [1/m] apart, in place on two work arrays."""
    f = k / k_step
    i = f.astype(np.int64)
    w = (f - i)[:, None]
    one_w = 1.0 - w
    phi = np.take(kphi_tab, i, axis=0)
    phi *= one_w
    upper = np.take(kphi_tab, i + 1, axis=0)
    upper *= w
    phi += upper
    positive = k > 0.0
    np.divide(phi, k[:, None], out=phi, where=positive[:, None])
    phi[~positive] = 0.0
    g = np.take(gz_tab, i, axis=0)
    g *= one_w
    np.take(gz_tab, i + 1, axis=0, out=upper)
    upper *= w
    g += upper
    return phi, 1j * g
