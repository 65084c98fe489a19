"""The energy balance of a gravitating sheet (analysis/gravitating.py): the collisional
dissipation from the impact-speed histograms, against exact integrals over a known
distribution of impact speeds."""

import numpy as np
import pytest
from scipy import stats

from ringsim.analysis import gravitating as g
from ringsim.engine.native import VN_BIN_EDGES
from ringsim.physics.restitution import epsilon_for_pair

#: Impact speeds like those of a cool gravitating ring: log-normal about 0.5 mm/s.
MEDIAN_SPEED = 5e-4
#: Expected counts in the bins (no sampling noise: the test sees the binning error only).
N_IMPACTS = 1.0e6
#: Bins are a factor 10^0.1 wide.  Measured for log-normal widths 0.5-1.5: the power-law
#: interpolation within bins is 0.6-3 x 10^-4 off the exact integral, the bin centres alone
#: 0.9 %; the bound 1e-3 separates the two.
TOLERANCE = 1e-3


def expected_counts(width):
    return N_IMPACTS * np.diff(stats.lognorm(s=width, scale=MEDIAN_SPEED).cdf(VN_BIN_EDGES))


def exact_mean(f, width):
    """int f(v) p(v) dv over the histogram's range (trapezoid in ln v, 2e5 points)."""
    x = np.linspace(np.log(VN_BIN_EDGES[0]), np.log(VN_BIN_EDGES[-1]), 200_001)
    v = np.exp(x)
    return np.trapezoid(f(v) * stats.lognorm(s=width, scale=MEDIAN_SPEED).pdf(v) * v, x)


@pytest.mark.parametrize("width", [0.5, 0.8, 1.5])
def test_bin_means_of_v_squared_are_the_exact_moment(width):
    counts = expected_counts(width)
    means = g.bin_means(counts, VN_BIN_EDGES, lambda v: v**2)
    exact = N_IMPACTS * stats.lognorm(s=width, scale=MEDIAN_SPEED).moment(2)
    assert counts @ means == pytest.approx(exact, rel=TOLERANCE)
    centres = np.sqrt(VN_BIN_EDGES[:-1] * VN_BIN_EDGES[1:])
    assert abs(counts @ centres**2 / exact - 1.0) > 5 * TOLERANCE   # what the slope buys


@pytest.mark.parametrize("law", [{"model": "constant", "epsilon": 0.5},
                                 {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234}])
@pytest.mark.parametrize("width", [0.5, 1.5])
def test_dissipation_rate_of_identical_particles(law, width):
    """(1 - eps(v)^2) (m/4) v_n^2 per impact of identical particles, per area and time."""
    m, r, area, dt = 3770.0, 1.0, 1.0e4, 1600.0
    counts = expected_counts(width)
    ts = {"t": np.array([0.0, dt]),
          "impact_speed_bin_edges": np.concatenate([[0.0], VN_BIN_EDGES, [np.inf]]),
          "impact_speed_histogram": np.vstack([np.zeros(counts.size + 2),
                                               np.concatenate([[0.0], counts, [0.0]])])}

    def loss(v):
        return (1.0 - np.asarray(epsilon_for_pair(law, v, 0.5 * r, 0.5 * m)) ** 2) * v**2

    expected = 0.25 * m * N_IMPACTS * exact_mean(loss, width) / (area * dt)
    rates = g.dissipation_rates(ts, law, np.full(10, r), np.full(10, m), area)
    assert np.isnan(rates[0])                      # row 0: the initial state, no interval
    assert rates[1] == pytest.approx(expected, rel=TOLERANCE)


def test_no_dissipation_rate_for_a_size_distribution():
    ts = {"t": np.array([0.0, 1.0]),
          "impact_speed_bin_edges": np.concatenate([[0.0], VN_BIN_EDGES, [np.inf]]),
          "impact_speed_histogram": np.zeros((2, VN_BIN_EDGES.size + 1))}
    law = {"model": "constant", "epsilon": 0.5}
    assert g.dissipation_rates(ts, law, np.array([1.0, 2.0]), np.array([1.0, 8.0]), 1.0) is None
