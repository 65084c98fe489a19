"""Planet geometry and the dimensionless numbers of a self-gravitating ring (physics/gravity.py).

Hand values for Saturn, GM = 3.7931e16 m^3/s^2, G = 6.67430e-11: M_p = GM / G = 5.6832e26 kg.
"""

import math

import numpy as np
import pytest

from ringsim.physics import gravity as g

GM_SATURN = 3.7931e16


def test_orbital_frequency_saturn():
    assert g.orbital_frequency(GM_SATURN, 1.0e8) == pytest.approx(1.947588e-4, rel=1e-6)


@pytest.mark.parametrize("a, expected", [(1.0e8, 0.82071), (1.3e8, 1.06692)])
def test_hill_parameter_of_identical_ice_spheres(a, expected):
    # (8 pi rho / (9 M_p))^(1/3) a / 2 with rho = 900: 1.64141e-8 a / 2; the issue's ~0.8
    # and ~1.1 are these, rounded; r_h of identical spheres does not depend on their size
    for r in (0.5, 1.0, 5.0):
        assert g.hill_parameter(r, r, 900.0, GM_SATURN, a) == pytest.approx(expected, rel=1e-4)


def test_mean_pair_hill_parameter():
    a = 1.0e8
    rh1 = float(g.hill_parameter(1.0, 1.0, 900.0, GM_SATURN, a))
    assert g.mean_pair_hill_parameter(np.ones(10), 900.0, GM_SATURN, a) == pytest.approx(rh1)
    # two radii, equal numbers: (2 identical pairs + 2 mixed pairs) / 4
    mixed = rh1 * (0.5**3 + 5.0**3) ** (1 / 3) / 5.5 / (2 ** (1 / 3) / 2)
    expected = 0.5 * rh1 + 0.5 * mixed
    got = g.mean_pair_hill_parameter([0.5, 5.0, 0.5, 5.0], 900.0, GM_SATURN, a)
    assert got == pytest.approx(expected, rel=1e-12)
    assert got > rh1          # mixed pairs have the larger r_h
    # a continuous distribution goes through the bins: close to the exact pair average
    rng = np.random.default_rng(1)
    radii = rng.uniform(0.5, 2.0, 400)
    exact = np.mean(g.hill_parameter(radii[:, None], radii[None, :], 900.0, GM_SATURN, a))
    assert g.mean_pair_hill_parameter(radii, 900.0, GM_SATURN, a) == pytest.approx(exact, rel=2e-3)


def test_hill_parameter_rejects_bad_radius():
    with pytest.raises(ValueError):
        g.hill_parameter(-1.0, 1.0, 900.0, GM_SATURN, 1e8)


def test_surface_density_lambda_cr_and_q():
    # tau = 0.5 of 1 m ice: Sigma = 0.5 * 4/3 * 900 * 1 = 600 kg/m^2
    sigma = g.surface_density_from_tau(0.5, 900.0, 1.0, 1.0)
    assert sigma == pytest.approx(600.0)
    assert g.surface_density(600.0 * 20.0 * 30.0, 20.0, 30.0) == pytest.approx(600.0)
    omega = g.orbital_frequency(GM_SATURN, 1.0e8)
    # 4 pi^2 G Sigma / Omega^2 = 39.478 * 4.00458e-8 / 3.79310e-8 = 41.679 m
    lam = g.toomre_wavelength(sigma, omega)
    assert lam == pytest.approx(41.679, rel=1e-4)
    # Q = sigma_x Omega / (3.36 G Sigma): sigma_x = 3.36 G Sigma / Omega gives Q = 1
    sigma_x = 3.36 * 6.67430e-11 * 600.0 / omega
    assert g.toomre_q(sigma_x, sigma, omega) == pytest.approx(1.0, rel=1e-12)
    # Q = 1 at 0.69 mm/s = 3.5 r Omega (r = 1 m)
    assert sigma_x == pytest.approx(6.909e-4, rel=1e-3)


def test_escape_speed_of_a_5_m_ice_sphere():
    # sqrt(2 G (4/3 pi 900 * 125) / 5) = 3.547 mm/s (the 3.5 mm/s)
    assert g.escape_speed(5.0, 900.0) == pytest.approx(3.5469e-3, rel=1e-4)
    assert g.escape_speed(1.0, 900.0) == pytest.approx(3.5469e-3 / 5, rel=1e-4)


def test_wake_box_advice():
    assert g.wake_box_spans(50.0, 80.0, 41.7)["level"] == "warn"
    assert g.wake_box_spans(166.0, 166.0, 41.7)["level"] == "advise"   # 3.98 lambda_cr
    advice = g.wake_box_spans(200.0, 400.0, 41.7)
    assert advice["level"] == "ok" and advice["smallest"] == pytest.approx(200.0 / 41.7)
    assert math.isclose(advice["y"], 400.0 / 41.7)
