"""Wake statistics and gravitational viscosity from synthetic snapshots (analysis/wakes.py)."""

import numpy as np
import pytest

from ringsim.analysis import wakes as w
from ringsim.physics.constants import G_SI

LX = LY = 100.0
SHIFT = 30.0          # m: a shear offset that is not 0 mod Ly
OMEGA = 2.0e-4


def draw_wave(n, kx, ky, amplitude, seed):
    """n particles drawn from Sigma ~ 1 + A cos(kx x + ky y') (sheared coordinates, so the
    pattern is shear-periodic); physical wave vector (kx + alpha ky, ky)."""
    rng = np.random.default_rng(seed)
    alpha = SHIFT / LX
    parts, have = [], 0
    while have < n:
        x = rng.uniform(-LX / 2, LX / 2, n)
        yp = rng.uniform(-LY / 2, LY / 2, n)
        keep = rng.uniform(0, 1 + amplitude, n) < 1 + amplitude * np.cos(kx * x + ky * yp)
        parts.append(np.column_stack([x[keep], yp[keep]]))
        have += int(keep.sum())
    xy = np.vstack(parts)[:n]
    y = (xy[:, 1] - alpha * xy[:, 0] + LY / 2) % LY - LY / 2
    return np.column_stack([xy[:, 0], y, rng.normal(0.0, 1.0, n)]), np.full(n, 1.0e3)


@pytest.mark.parametrize("sign", [1, -1])
def test_recovers_wavelength_pitch_and_amplitude(sign):
    kx, ky = 2 * np.pi * 3 / LX, sign * 2 * np.pi / LY
    pos, mass = draw_wave(20000, kx, ky, 0.5, seed=3)
    kxp = kx + SHIFT / LX * ky
    stats = w.wake_statistics(pos[:, 0], pos[:, 1], mass, LX, LY, SHIFT, n=64)
    assert stats["significant"]
    # the grid holds the true mode exactly: wavelength and pitch to rounding
    assert stats["wavelength"] == pytest.approx(2 * np.pi / np.hypot(kxp, ky), rel=1e-9)
    pitch = np.degrees(np.arctan(ky / kxp))
    assert stats["pitch_angle_deg"] == pytest.approx(pitch, abs=1e-9)
    assert np.sign(stats["pitch_angle_deg"]) == sign          # + trailing, - leading
    # amplitude: shot noise of 20000 particles gives |delta_k| ~ 0.007, i.e. +-0.015 on A
    assert stats["peak_amplitude"] == pytest.approx(0.5, abs=0.03)


@pytest.mark.parametrize("m", [1, 2, 3])
def test_azimuthal_mode_counts_wavelengths_along_y(m):
    """A wave with m wavelengths along the box's azimuthal side is reported as mode m (1:
    the longest non-axisymmetric wave the box holds, whose share analyze prints)."""
    kx, ky = 2 * np.pi * 3 / LX, 2 * np.pi * m / LY
    pos, mass = draw_wave(20000, kx, ky, 0.5, seed=10 + m)
    stats = w.wake_statistics(pos[:, 0], pos[:, 1], mass, LX, LY, SHIFT, n=64)
    assert stats["significant"]
    assert stats["azimuthal_mode"] == m


def test_uniform_sheet_has_no_significant_wake():
    rng = np.random.default_rng(7)
    n = 5000
    x, y = rng.uniform(-LX / 2, LX / 2, n), rng.uniform(-LY / 2, LY / 2, n)
    stats = w.wake_statistics(x, y, np.full(n, 1.0), LX, LY, SHIFT, n=64)
    assert not stats["significant"], stats
    # rms contrast is the Poisson expectation (5 % for 3 standard errors of 4096 cells)
    assert stats["amplitude"] == pytest.approx(stats["poisson_amplitude"], rel=0.05)


@pytest.mark.parametrize("sign", [1, -1])
def test_gravitational_viscosity_of_a_wave(sign):
    kx, ky = 2 * np.pi * 3 / LX, sign * 2 * np.pi / LY
    pos, mass = draw_wave(20000, kx, ky, 0.5, seed=4)
    kxp = kx + SHIFT / LX * ky
    sigma0 = mass.sum() / (LX * LY)
    k = np.hypot(kxp, ky)
    expected = (w.wave_viscosity(0.5 * sigma0, kxp, ky, sigma0, OMEGA, G_SI)
                * w.vertical_stress_factor(pos[:, 2], mass, k))
    nu = w.gravitational_viscosity(pos, mass, LX, LY, OMEGA, SHIFT, n=64)
    assert np.sign(nu) == sign                                   # trailing: outward flux
    # shot noise on |Sigma_k|^2 of the wave mode: 2 |delta| sqrt(shot) / A ~ 3 %
    assert nu == pytest.approx(expected, rel=0.06)


def test_gravitational_viscosity_of_a_uniform_sheet_is_noise():
    pos, mass = draw_wave(20000, 0.0, 0.0, 0.0, seed=5)
    kx, ky = 2 * np.pi * 3 / LX, 2 * np.pi / LY
    sigma0 = mass.sum() / (LX * LY)
    wave = w.wave_viscosity(0.5 * sigma0, kx + SHIFT / LX * ky, ky, sigma0, OMEGA, G_SI)
    assert abs(w.gravitational_viscosity(pos, mass, LX, LY, OMEGA, SHIFT, n=64)) < 0.05 * wave


def test_vertical_factor_limits():
    z = np.zeros(100)
    assert np.allclose(w.vertical_stress_factor(z, np.ones(100), [0.1, 1.0]), 1.0)
    z = np.random.default_rng(1).normal(0, 5.0, 1000)
    f = w.vertical_stress_factor(z, np.ones(1000), [0.01, 0.1, 1.0])
    assert 1.0 > f[0] > f[1] > f[2] > 0.0
