"""The straight-path prediction of multiple encounters in a step
(``ringsim.analysis.encounters``): the pooled fraction's estimator and the contacts of
constructed pairs."""

import math

import numpy as np
import pytest

from ringsim.analysis.encounters import multi_encounter_fraction, predicted_contacts
from ringsim.engine.timestep import MULTI_ENCOUNTER_MASS_SHARE


def test_multi_encounter_fraction_is_unbiased_for_poisson_counts():
    rng = np.random.default_rng(5)
    rate = 0.04                                        # contacts per particle per window
    contacts = rng.poisson(rate, 400_000)
    fraction = multi_encounter_fraction(contacts, contacts)
    # stderr of the ratio ~ sqrt(2 rate^2 n) / (rate n) for n particles
    assert fraction == pytest.approx(rate, rel=4 * math.sqrt(2.0 / 400_000) / math.sqrt(rate))
    deflecting = rng.binomial(contacts, 0.5)
    assert multi_encounter_fraction(contacts, deflecting) == pytest.approx(
        0.5 * rate, rel=0.1), "only deflections count as first encounters"
    assert multi_encounter_fraction(np.zeros(5), np.zeros(5)) == 0.0


def test_predicted_contacts_of_simple_pairs():
    window = 10.0                                      # [s]
    # approaching, contact after 5 s; receding; overlapping now; far apart
    x = np.array([0.0, 2.25, 100.0, 102.5, 200.0, 201.5, 300.0, 330.0])
    vx = np.array([0.05, 0.0, -0.05, 0.0, 0.0, 0.0, 0.1, 0.0])
    zeros = np.zeros_like(x)
    radius = np.ones_like(x)
    mass = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    contacts, deflections = predicted_contacts(x, zeros, zeros, vx, zeros, zeros, radius,
                                               mass, 0.0, window, MULTI_ENCOUNTER_MASS_SHARE)
    np.testing.assert_array_equal(contacts, [1, 1, 0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(deflections, contacts)
    mass[0] = 1e3                                      # a boulder and a grain
    _, deflections = predicted_contacts(x, zeros, zeros, vx, zeros, zeros, radius, mass, 0.0,
                                        window, MULTI_ENCOUNTER_MASS_SHARE)
    np.testing.assert_array_equal(deflections, [0, 1, 0, 0, 0, 0, 0, 0])
