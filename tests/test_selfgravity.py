"""Self-gravity of the shear-periodic sheet: reference sum, PM solver, REBOUND's tree."""

import numpy as np
import pytest

from ringsim import testing
from ringsim.gravity import tree
from ringsim.physics import ghost_field
from ringsim.physics import selfgravity as sg
from ringsim.physics.constants import G_SI


def sheared_wave(n=16, Lx=100.0, Ly=120.0, shift=37.0, height=15.0, amplitude=0.5):
    """A thin lattice sheet whose mass follows a shear-periodic cosine, with massless test
    particles `height` above it, and the analytic field at the test particles."""
    alpha = shift / Lx
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    x = ((i + 0.5) / n - 0.5) * Lx
    yp = ((j + 0.5) / n - 0.5) * Ly
    kx, ky = 2 * np.pi * 2 / Lx, 2 * np.pi / Ly
    theta = (kx * x + ky * yp).ravel()
    m0 = 1.0e6
    mass = m0 * (1 + amplitude * np.cos(theta))
    y = (yp - alpha * x + 0.5 * Ly) % Ly - 0.5 * Ly
    sheet = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    tests = sheet + [0.0, 0.0, height]
    sigma0 = m0 * n * n / (Lx * Ly)
    kvec = np.array([kx + alpha * ky, ky])     # the physical wave vector of the sheared mode
    k = np.hypot(*kvec)
    wave = 2 * np.pi * G_SI * amplitude * sigma0 * np.exp(-k * height)
    field = np.zeros((n * n, 3))
    field[:, :2] = (-wave / k * np.sin(theta))[:, None] * kvec
    field[:, 2] = -2 * np.pi * G_SI * sigma0 - wave * np.cos(theta)
    pos = np.vstack([sheet, tests])
    masses = np.concatenate([mass, np.zeros(n * n)])
    return pos, masses, np.arange(n * n, 2 * n * n), field, wave, (Lx, Ly, shift)


def test_shear_offset_wraps_and_matches_rebound_rows():
    Omega, Lx, Ly, t = 2e-4, 70.0, 90.0, 12345.0
    s = sg.shear_offset(Omega, Lx, Ly, t)
    assert -0.5 * Ly <= s < 0.5 * Ly
    assert (s - 1.5 * Omega * Lx * t) / Ly == pytest.approx(round((s - 1.5 * Omega * Lx * t) / Ly))
    rows = ghost_field.rebound_row_offsets(Omega, Lx, Ly, t, 2)     # i = -2..2
    for i, off in zip(range(-2, 3), rows, strict=True):
        k = (off + i * s) / Ly                             # REBOUND: row i at y - i s (mod Ly)
        assert k == pytest.approx(round(k), abs=1e-9)


def test_direct_sum_reproduces_a_sheared_density_wave():
    pos, mass, targets, field, wave, (Lx, Ly, shift) = sheared_wave()
    acc = sg.direct_accelerations(pos, mass, Lx, Ly, shift, 0.0, n_rows=3, targets=targets)
    # the lattice's graininess 2.4 lattice spacings above it is ~exp(-2 pi 2.4) ~ 3e-7 of
    # the mean field; what remains is the K = 3 truncation (measured 7e-4 of the wave
    # horizontally, and a uniform vertical offset of 3e-4 of the mean field 2 pi G Sigma)
    err = np.abs(acc - field).max(axis=0)
    mean_field = np.abs(field[:, 2]).mean()
    assert np.all(err[:2] < 2e-3 * wave), f"horizontal field off the analytic wave: {err / wave}"
    assert err[2] < 5e-4 * mean_field, f"vertical field off: {err[2] / mean_field:.2g}"


def test_pm_reproduces_the_wave_with_second_order_layers():
    pos, mass, targets, field, wave, (Lx, Ly, shift) = sheared_wave()
    errs = []
    for dz in (1.0, 0.5):
        acc = sg.ShearPM(Lx, Ly, 32, 32, dz).accelerations(pos, mass, shift)[targets]
        errs.append(np.abs(acc - field).max() / wave)
    assert errs[1] < 0.01, f"PM error {errs[1]:.3g} of the wave amplitude at dz = 0.5 m"
    assert 3.0 < errs[0] / errs[1] < 5.0, f"not second order in dz: {errs}"


@pytest.fixture(scope="module")
def sheet():
    return testing.random_sheet(400, seed=5)


@pytest.fixture(scope="module")
def t_ref():
    return 2345.6    # s: a non-trivial shear offset


@pytest.fixture(scope="module")
def reference(sheet, t_ref):
    return {k: testing.reference_for(sheet, t=t_ref, n_rows=k) for k in (2, 4, 6)}


def test_reference_converges_as_k_to_minus_two(reference):
    e2 = testing.force_errors(reference[2], reference[6])["normalised"]
    e4 = testing.force_errors(reference[4], reference[6])["normalised"]
    assert e4 < 1e-4, f"K = 4 not converged: {e4:.2g}"
    assert e2 / e4 > 3.0, "truncation error does not fall at least as K^-1.6"


def test_reference_conserves_momentum(sheet, reference):
    a = reference[4]
    total = np.sum(sheet["mass"][:, None] * a, axis=0)
    scale = np.sum(sheet["mass"]) * np.sqrt(np.mean(np.sum(a * a, axis=1)))
    assert np.all(np.abs(total) < 1e-12 * scale)


def test_pm_conserves_momentum(sheet, t_ref):
    shift = sg.shear_offset(sheet["geometry"].Omega, sheet["Lx"], sheet["Ly"], t_ref)
    a = sg.pm_accelerations(sheet["pos"], sheet["mass"], sheet["Lx"], sheet["Ly"], shift, 1.0)
    total = np.sum(sheet["mass"][:, None] * a, axis=0)
    scale = np.sum(sheet["mass"]) * np.sqrt(np.mean(np.sum(a * a, axis=1)))
    assert np.all(np.abs(total) < 1e-12 * scale)


def test_tree_at_defaults_with_truncation_field_is_within_one_percent(sheet, t_ref, reference):
    sim = testing.tree_simulation(sheet, t=t_ref)      # defaults: opening angle 0.3, 1 ghost ring
    raw = testing.tree_accelerations(sim)
    missing = ghost_field.ghost_truncation_field(
        sheet["pos"], sheet["mass"], sheet["Lx"], sheet["Ly"], sheet["geometry"].Omega, t_ref,
        tree.DEFAULT_GHOST_BOXES, tree.DEFAULT_GHOST_BOXES)
    corrected = testing.force_errors(raw + missing, reference[6])
    assert corrected["rms_relative"] < 0.01, corrected
    # without the field the truncated sheet is off by ~1 / (2 N_ghost + 1) of the field
    assert testing.force_errors(raw, reference[6])["normalised"] > 0.05
