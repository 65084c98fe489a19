"""The contact models behind the laws: integrate eqs. (5.1) and (3.3) and compare closed forms."""

import numpy as np
import pytest

from ringsim.physics import contact
from ringsim.physics import restitution as rs


@pytest.mark.parametrize("k, beta, M_bar", [
    (1.0e3, 1.0, 0.06),
    (5.0e4, 30.0, 0.06),
    (2.0e2, 0.5, 1.0),
    (1.0e6, 900.0, 2.0),
    (10.0, 0.0, 0.03),
])
def test_spring_dashpot_matches_eq_5_6_and_5_9(k, beta, M_bar):
    result = contact.spring_dashpot_contact(k, beta, M_bar, v=0.01)
    closed = contact.spring_dashpot_epsilon(k, beta, M_bar) if beta > 0 else 1.0
    assert abs(result.epsilon - closed) < 1e-6, "integrated eps vs eq. (5.6)"
    xi = beta / (2 * np.sqrt(k * M_bar))
    assert abs(result.epsilon - rs.epsilon_from_xi(xi)) < 1e-6, "integrated eps vs eq. (5.9)"
    omega = np.sqrt(k / M_bar) * np.sqrt(1 - xi**2)
    assert abs(result.contact_time * omega / np.pi - 1) < 1e-8, "contact lasts pi/omega"


def test_spring_dashpot_epsilon_independent_of_speed():
    """Without the v^-p dependence of tau (5.7), eps of the linear model is speed independent."""
    eps = [contact.spring_dashpot_contact(1e3, 2.0, 0.06, v).epsilon for v in (1e-4, 1e-2, 1.0)]
    np.testing.assert_allclose(eps, eps[0], rtol=1e-8)


def test_hertz_is_elastic_and_t_max_is_eq_3_6():
    result = contact.hertz_contact(k=1e9, R_bar=0.025, M_bar=0.06, v=0.01)
    assert abs(result.epsilon - 1) < 1e-9, "Hertz contact is elastic"
    assert abs(result.t_max / contact.hertz_t_max(1e9, 0.025, 0.06, 0.01) - 1) < 1e-3
    assert abs(result.contact_time / result.t_max - 2) < 1e-8, "symmetric contact"
    alpha_max = (5 * 0.06 * 0.01**2 / (4 * 1e9 * np.sqrt(0.025))) ** 0.4
    assert abs(result.alpha_max / alpha_max - 1) < 1e-9, "eq. (3.5)"


@pytest.mark.parametrize("which, expected", [("v", -0.2), ("M_bar", 0.4), ("R_bar", -0.2)])
def test_hertz_contact_time_exponents(which, expected):
    """Eq. (3.6): t_max ∝ v^-1/5 M_bar^2/5 R_bar^-1/5, fitted over three decades."""
    base = {"k": 1e9, "R_bar": 0.025, "M_bar": 0.06, "v": 0.01}
    values = base[which] * np.logspace(-1.5, 1.5, 7)
    times = []
    for value in values:
        args = dict(base, **{which: value})
        times.append(contact.hertz_contact(**args).contact_time)
    slope = np.polyfit(np.log(values), np.log(times), 1)[0]
    assert abs(slope - expected) < 1e-3, f"contact-time exponent in {which}"
