"""`P3MMesh.fields` keeps its bits: the mesh field of a P3M step is `==` to the plain
transcription of its arithmetic below (each operation on whole arrays, one after the
other), on 1 and 2 FFT workers, for even and odd meshes.  Faster arrangements of the same
operations (in-place work arrays, transforms on contiguous rows) may not change a bit:
finished gravitating runs must resume, and study summaries reproduce, exactly."""

import numpy as np
import pytest
import scipy.fft

from ringsim.physics import p3m_mesh


def plain_fields(mesh: p3m_mesh.P3MMesh, mass: np.ndarray, alpha: float) -> list:
    """The mesh field (gx, gy, gz) [m/s^2] of ``mass`` [kg] at shear ``alpha``, written
    out operation by operation."""
    nz, nx, ny = mass.shape
    cell = mesh.Lx / nx * mesh.Ly / ny
    s_hat = scipy.fft.rfft2(mass / cell, axes=(1, 2))
    s_hat *= mesh.inverse_window
    kxp = mesh.kx[:, None] + alpha * mesh.ky[None, :]
    ky = np.broadcast_to(mesh.ky[None, :], kxp.shape)
    k = np.hypot(kxp, ky).ravel()
    kphi_tab, gz_tab = mesh._kernel_tables(nz)
    f = k / mesh._ktab[1]
    i = f.astype(np.int64)
    w = (f - i)[:, None]
    phi_z = kphi_tab[i] * (1.0 - w) + kphi_tab[i + 1] * w
    with np.errstate(divide="ignore", invalid="ignore"):
        phi_z = np.where(k[:, None] > 0.0, phi_z / k[:, None], 0.0)
    gz_z = 1j * (gz_tab[i] * (1.0 - w) + gz_tab[i + 1] * w)
    gz_z[0] = 0.0
    s_t = np.moveaxis(s_hat, 0, -1).reshape(k.size, nz)
    s_z = scipy.fft.fft(s_t, n=mesh.z_length(nz), axis=-1)
    conv = scipy.fft.ifft(np.stack([s_z * phi_z, s_z * gz_z]), axis=-1)[:, :, :nz]
    pot_hat, gz_hat = (np.moveaxis(c.reshape(nx, -1, nz), -1, 0) for c in conv)
    deriv_x = -1j * kxp
    deriv_y = -1j * ky
    if nx % 2 == 0:
        deriv_x[nx // 2, :] = 0.0
        deriv_y = deriv_y.copy()
        deriv_y[nx // 2, :] = 0.0
    if ny % 2 == 0:
        deriv_x[:, -1] = 0.0
        deriv_y[:, -1] = 0.0
    return [scipy.fft.irfft2(h, s=(nx, ny), axes=(1, 2))
            for h in (deriv_x * pot_hat, deriv_y * pot_hat, gz_hat)]


@pytest.mark.parametrize("nz, nx, ny, alpha", [(1, 8, 8, 0.0), (13, 24, 24, 0.21),
                                                (20, 15, 18, -0.31), (40, 20, 9, 0.22)])
@pytest.mark.parametrize("workers", [1, 2])
def test_mesh_field_is_the_plain_arithmetic_bit_for_bit(nz, nx, ny, alpha, workers):
    # |alpha| <= Ly / (2 Lx): the shear of the coordinates stays within half a box
    rng = np.random.default_rng(nz * 1000 + nx)
    mass = rng.uniform(0.0, 1.0e6, (nz, nx, ny))
    mass[:, rng.integers(0, nx, 3), :] = 0.0     # empty columns, as a thin ring has
    mesh = p3m_mesh.P3MMesh(60.0, 60.0 * ny / nx, nx, ny, 0.6, 0.8, workers=workers)
    for got, want in zip(mesh.fields(mass, alpha), plain_fields(mesh, mass, alpha),
                         strict=True):
        assert got.shape == want.shape
        assert np.array_equal(got, want)
        assert np.signbit(got).tolist() == np.signbit(want).tolist()
