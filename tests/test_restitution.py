"""The restitution laws of Dilley (1993), checked against the paper's equations and numbers."""

import math

import numpy as np
import pytest

from ringsim.physics import dilley_spheres
from ringsim.physics import restitution as rs

CM = 0.01  # [m]
CM_S = 0.01  # [m/s]
GRAM = 1e-3  # [kg]


# --- Dilley's viscous-dissipation law ---------------------------------------------------------

def test_reference_pair_at_one_cm_per_s():
    """eps(1 cm/s, 2.5 cm, 60 g) = exp(-0.16 pi / sqrt(1 - 0.16^2)), eq. (5.9) with (5.11)."""
    expected = math.exp(-0.16 * math.pi / math.sqrt(1 - 0.16**2))
    eps = rs.dilley_epsilon(1 * CM_S, 2.5 * CM, 60 * GRAM)
    assert abs(eps - expected) < 1e-12, "Dilley eps at the reference point"


def test_reference_pair_at_point_two_cm_per_s():
    xi = 0.16 * 0.2**0.65
    expected = math.exp(-math.pi * xi / math.sqrt(1 - xi**2))
    assert abs(rs.dilley_epsilon(0.2 * CM_S, 2.5 * CM, 60 * GRAM) - expected) < 1e-12
    assert abs(rs.dilley_xi(0.2 * CM_S, 2.5 * CM, 60 * GRAM) - xi) < 1e-15


def test_xi_epsilon_round_trip():
    rng = np.random.default_rng(1)
    v = 10 ** rng.uniform(-5, -1, 1000)
    R = 10 ** rng.uniform(-3, 1, 1000)
    M = 10 ** rng.uniform(-4, 5, 1000)
    kappa = 0.1
    xi = rs.dilley_xi(v, R, M, kappa=kappa)
    eps = rs.dilley_epsilon(v, R, M, kappa=kappa)
    ok = (xi < 0.95) & (eps > 1e-200)
    assert ok.sum() > 500
    np.testing.assert_allclose(rs.xi_from_epsilon(eps[ok]), xi[ok], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(rs.epsilon_from_xi(rs.xi_from_epsilon(eps)), eps, rtol=1e-12)


def test_epsilon_tends_to_one_and_decreases_with_speed():
    v = np.logspace(-12, 0, 2000)
    eps = rs.dilley_epsilon(v, 2.5 * CM, 60 * GRAM, kappa=0.1)
    assert eps[0] > 1 - 1e-6, "eps -> 1 as v -> 0"
    assert np.all(np.diff(eps) <= 0), "eps decreases monotonically with v"
    assert rs.dilley_epsilon(0.0, 1.0, 1.0) == 1.0


def test_no_rebound_beyond_xi_one():
    # xi = 1 at v = (1/0.16)^(1/0.65) cm/s for the reference pair
    v1 = (1 / 0.16) ** (1 / 0.65) * CM_S
    assert rs.dilley_epsilon(v1 * 1.0001, 2.5 * CM, 60 * GRAM) == 0.0
    assert rs.dilley_epsilon(v1 * 0.999, 2.5 * CM, 60 * GRAM) > 0.0
    assert rs.epsilon_from_xi(1.0) == 0.0
    assert rs.xi_from_epsilon(0.0) == 1.0


def test_signed_speed_uses_magnitude():
    assert rs.dilley_epsilon(-0.3 * CM_S, 0.1, 1.0) == rs.dilley_epsilon(0.3 * CM_S, 0.1, 1.0)


def test_size_mass_cancellation_only_at_kappa_minus_0_2_over_3():
    """Below eq. (5.16): against a brick, M ∝ R^3: eps is independent of R iff kappa = -0.2/3."""
    R = np.array([0.25, 2.5, 25.0, 250.0]) * CM
    M = 900.0 * 4 / 3 * np.pi * R**3
    R_bar = rs.reduced_radius(R, np.inf)
    M_bar = rs.reduced_mass(M, np.inf)
    np.testing.assert_array_equal(R_bar, R)
    np.testing.assert_array_equal(M_bar, M)
    xi = rs.dilley_xi(0.5 * CM_S, R_bar, M_bar, kappa=-0.2 / 3)
    np.testing.assert_allclose(xi, xi[0], rtol=1e-13)
    for kappa in (0.0, 0.1, -0.1):
        xi = rs.dilley_xi(0.5 * CM_S, R_bar, M_bar, kappa=kappa)
        assert np.ptp(xi) / xi.mean() > 0.1, f"kappa={kappa} must not cancel"


def test_equal_density_reformulation_matches_direct_formula():
    """Eqs. (5.17)-(5.21) against (5.15) with reduced radius and mass."""
    rng = np.random.default_rng(2)
    R1 = 10 ** rng.uniform(-3, 1, 500)
    delta = rng.uniform(0, 1, 500)
    v = 10 ** rng.uniform(-5, -2, 500)
    for density in (rs.RHO_REF, 900.0, 400.0):
        for kappa in (0.0, 0.1, -0.2 / 3):
            R2 = np.where(delta > 0, R1 / np.where(delta > 0, delta, 1), np.inf)
            M1 = density * 4 / 3 * np.pi * R1**3
            M2 = density * 4 / 3 * np.pi * R2**3
            direct = rs.dilley_xi(v, rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2),
                                  kappa=kappa)
            reform = dilley_spheres.dilley_xi_equal_density(v, R1, delta, kappa=kappa,
                                                            density=density)
            np.testing.assert_allclose(reform, direct, rtol=1e-12)


def test_f_delta_kappa_limits():
    assert dilley_spheres.dilley_f(0.0, 0.1) == 1.0
    assert abs(dilley_spheres.dilley_f(1.0, 0.1) - 2**0.2 * 2**0.1) < 1e-15


# --- reduced radius and mass ------------------------------------------------------------------

def test_reduced_quantities():
    assert rs.reduced_radius(2.0, 2.0) == 1.0
    assert rs.reduced_mass(3.0, 6.0) == 2.0
    assert rs.reduced_radius(0.3, np.inf) == 0.3
    assert rs.reduced_mass(np.inf, 5.0) == 5.0
    np.testing.assert_allclose(rs.reduced_radius([1.0, 2.0], [1.0, np.inf]), [0.5, 2.0])


# --- a base class per law: physical properties every law must satisfy ------------------------

class LawChecks:
    """Checks shared by every restitution law (subclasses set ``law`` and ``tol``)."""

    tol = 1e-12
    v = np.logspace(-7, -1, 400)  # [m/s]

    def law(self, v):
        raise NotImplementedError

    def test_range(self):
        eps = self.law(self.v)
        assert np.all((eps >= 0) & (eps <= 1)), "eps in [0, 1]"

    def test_monotone_non_increasing(self):
        eps = self.law(self.v)
        assert np.all(np.diff(eps) <= self.tol), "eps does not increase with speed"

    def test_broadcast_and_sign(self):
        v = self.v.reshape(20, 20)
        np.testing.assert_array_equal(self.law(v), self.law(-v))
        assert self.law(v).shape == (20, 20)

    def test_non_finite_speed_rejected(self):
        with pytest.raises(ValueError, match="v"):
            self.law(np.array([1e-3, np.nan]))


class TestDilleyLaw(LawChecks):
    def law(self, v):
        return rs.dilley_epsilon(v, 0.5, 235.0, kappa=0.1)


class TestBridgesLaw(LawChecks):
    def law(self, v):
        return rs.bridges_epsilon(v)

    def test_formula(self):
        assert rs.bridges_epsilon(7.7e-5) == 1.0
        assert rs.bridges_epsilon(1e-6) == 1.0
        assert abs(rs.bridges_epsilon(7.7e-3) - 100 ** -0.234) < self.tol


class TestAndrewsLaw(LawChecks):
    v_c = 0.0809 * CM_S

    def law(self, v):
        return rs.andrews_epsilon(v, self.v_c)

    def test_elastic_below_critical_speed(self):
        v = np.linspace(0, self.v_c, 50)
        np.testing.assert_array_equal(self.law(v), 1.0)

    def test_defining_equation(self):
        v = self.v[self.v > self.v_c]
        eps = self.law(v)
        u = v / self.v_c
        rhs = (-2 + np.sqrt(30 * u**2 - 5)) / (3 * u**2)
        np.testing.assert_allclose(eps**2, rhs, rtol=0, atol=self.tol)

    def test_continuous_at_critical_speed(self):
        assert abs(self.law(self.v_c * (1 + 1e-9)) - 1.0) < 1e-8


class TestTaborLaw(LawChecks):
    v_c = 0.0809 * CM_S
    q = 0.371

    def law(self, v):
        return rs.tabor_epsilon(v, self.v_c, self.q)

    def test_elastic_below_critical_speed(self):
        v = np.linspace(0, self.v_c, 50)
        np.testing.assert_array_equal(self.law(v), 1.0)

    def test_defining_equation(self):
        v = np.logspace(np.log10(self.v_c) + 1e-9, 2, 3000)
        eps = self.law(v)
        u = v / self.v_c
        rhs = u ** -(1 - 2 * self.q) * ((1 - self.q * eps**2) / (1 - self.q)) ** self.q
        np.testing.assert_allclose(eps, rhs, rtol=0, atol=self.tol)

    def test_q_three_eighths_is_eq_4_8(self):
        v = np.logspace(np.log10(self.v_c) + 1e-6, -1, 500)
        eps = rs.tabor_epsilon(v, self.v_c, 3 / 8)
        rhs = (self.v_c / v) ** 0.25 * ((1 - 3 * eps**2 / 8) / (1 - 3 / 8)) ** (3 / 8)
        np.testing.assert_allclose(eps, rhs, rtol=0, atol=self.tol)
        # and eq. (4.5) with K of eq. (4.7)
        K = self.v_c**0.25 / (5 / 8) ** (3 / 8)
        np.testing.assert_allclose(eps, K / v**0.25 * (1 - 3 / 8 * eps**2) ** (3 / 8),
                                   rtol=0, atol=self.tol)


class TestTaborCurveD(TestTaborLaw):
    v_c = 0.0314 * CM_S
    q = 0.42


class TestConstantLaw(LawChecks):
    def law(self, v):
        return rs.constant_epsilon(v, 0.5)

    def test_value(self):
        np.testing.assert_array_equal(self.law(self.v), 0.5)


# --- argument checking ------------------------------------------------------------------------

@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: rs.dilley_epsilon(1e-3, -1.0, 1.0), "R_bar"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, -1.0), "M_bar"),
        (lambda: rs.dilley_epsilon(1e-3, np.inf, 1.0), "R_bar"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, np.nan), "M_bar"),
        (lambda: rs.dilley_epsilon(1e-3, 0.0, 1.0), "R_bar"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, 1.0, xi0=0.0), "xi0"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, 1.0, xi0=-0.1), "xi0"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, 1.0, p=0.0), "p"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, 1.0, kappa=float("nan")), "kappa"),
        (lambda: rs.dilley_epsilon(1e-3, 1.0, 1.0, kappa="0.1"), "kappa"),
        (lambda: rs.reduced_radius(-1.0, 1.0), "R1"),
        (lambda: rs.reduced_radius(1.0, np.nan), "R2"),
        (lambda: rs.reduced_mass(1.0, -2.0), "M2"),
        (lambda: rs.reduced_mass(np.inf, np.inf), "M1"),
        (lambda: rs.tabor_epsilon(1e-3, 1e-4, q=0.5), "q"),
        (lambda: rs.andrews_epsilon(1e-3, v_c=0.0), "v_c"),
        (lambda: rs.constant_epsilon(1e-3, 1.5), "epsilon"),
        (lambda: rs.xi_from_epsilon(-0.1), "eps"),
        (lambda: rs.epsilon_for_pair({"model": "dilley", "kapa": 0.1}, 1e-3, 1, 1), "kapa"),
        (lambda: rs.epsilon_for_pair({"model": "hertz"}, 1e-3, 1, 1), "model"),
        (lambda: rs.epsilon_for_pair({"model": "constant"}, 1e-3, 1, 1), "epsilon"),
    ],
)
def test_bad_arguments_name_the_argument(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_epsilon_for_pair_dispatches():
    v = np.logspace(-5, -2, 10)
    np.testing.assert_array_equal(
        rs.epsilon_for_pair({"model": "dilley", "kappa": 0.1}, v, 0.3, 50.0),
        rs.dilley_epsilon(v, 0.3, 50.0, kappa=0.1))
    np.testing.assert_array_equal(rs.epsilon_for_pair({"model": "bridges"}, v, 1, 1),
                                  rs.bridges_epsilon(v))
    np.testing.assert_array_equal(
        rs.epsilon_for_pair({"model": "tabor", "v_c": 1e-4, "q": 0.4}, v, 1, 1),
        rs.tabor_epsilon(v, 1e-4, 0.4))
    np.testing.assert_array_equal(rs.epsilon_for_pair({"model": "andrews", "v_c": 1e-4}, v, 1, 1),
                                  rs.andrews_epsilon(v, 1e-4))
