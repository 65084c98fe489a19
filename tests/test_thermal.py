"""The thermal-balance measures (ringsim.analysis.thermal) on series whose answer is known."""

import math

import numpy as np
import pytest

from ringsim.analysis import thermal


def test_growth_rate_of_an_exponential_dispersion_is_its_rate():
    """c = c0 exp(g t / 2) gives ln c^2 = ln c0^2 + g t: the slope is g, to round-off, and
    the rows before the relaxation are left out."""
    t = np.arange(0.0, 20.0, 0.1)
    c = 0.03 * np.exp(0.5 * 0.123 * t)
    c[t < 3.0] *= 5.0                        # a start that has not relaxed yet
    got = thermal.growth_rate(t, c)
    assert got["mean"] == pytest.approx(0.123, rel=1e-12)
    assert got["stderr"] == pytest.approx(0.0, abs=1e-12) and got["units"] == "1/orbit"


def test_growth_rate_error_covers_the_scatter_of_noisy_runs():
    """Over 200 noisy realisations of a random walk in ln c^2 about a slope of -0.01 per
    orbit, the batch-means error is the scatter of the slopes within a factor 2."""
    rng = np.random.default_rng(5)
    t = np.arange(3.0, 20.0, 0.1)
    slopes, errors = [], []
    for _ in range(200):
        y = -0.01 * t + np.cumsum(rng.normal(0.0, 0.01, t.size))
        got = thermal.growth_rate(t, np.sqrt(np.exp(y)))
        slopes.append(got["mean"])
        errors.append(got["stderr"])
    assert abs(np.mean(slopes) + 0.01) < 3.0 * np.std(slopes) / math.sqrt(200)
    assert 0.5 < np.median(errors) / np.std(slopes) < 2.0


def test_stress_ratios_are_the_ratios_of_the_means():
    t = np.arange(0.0, 10.0, 0.1)
    xx = np.full(t.size, 4.0)
    got = thermal.stress_ratios(t, xx, 0.12 + 0 * t, 1.0 + 0 * t, 1.7 + 0 * t)
    assert got["sigma_xy_over_xx"]["mean"] == pytest.approx(0.03, rel=1e-12)
    assert got["sigma_yy_over_xx"]["mean"] == pytest.approx(0.25, rel=1e-12)
    assert got["sigma_zz_over_xx"]["mean"] == pytest.approx(0.425, rel=1e-12)
    assert all(v["stderr"] == pytest.approx(0.0, abs=1e-15) for v in got.values())
