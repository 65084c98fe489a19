"""Size distributions of real rings: centimetre-to-metre power laws and the exponential cutoff.

The drawn radii's moments <R^k> must match the analytic (or quadrature) moments within their
sampling error.  The error of the sample mean of R^k over n independent draws is
sigma_k = sqrt((<R^2k> - <R^k>^2) / n), with the distribution's own moments (central limit
theorem); a test allows 4 sigma_k, so that a correct sampler fails one moment in ~16000.
"""

import math

import numpy as np
import pytest

from ringsim.config.schema import ScenarioError
from ringsim.physics.sizes import PowerLaw, PowerLawCutoff

#: Draws per test: enough for 4 sigma to be a tight test, a few ms to draw.
N_DRAWS = 400_000
#: Allowed deviation in units of the sampling error (two-sided normal tail 6e-5).
Z_LIMIT = 4.0


def z_scores(sizes, radii: np.ndarray, orders=(1, 2, 3)) -> dict[int, float]:
    """(sample mean of R^k - <R^k>) / sigma_k for each order k (see the module's doc)."""
    out = {}
    for k in orders:
        mean, second = sizes.moment(k), sizes.moment(2 * k)
        sigma = math.sqrt((second - mean**2) / radii.size)
        out[k] = (float(np.mean(radii**k)) - mean) / sigma
    return out


def test_q3_from_1_cm_to_5_m_draws_its_analytic_moments():
    sizes = PowerLaw(q=3.0, r_min=0.01, r_max=5.0)
    # the analytic moments of q = 3: <R> = 2 r_min r_max / (r_min + r_max) for k = 1
    assert sizes.moment(1) == pytest.approx(2 * 0.01 * 5.0 / 5.01, rel=1e-12)
    radii = sizes.draw_radii(N_DRAWS, np.random.default_rng(39))
    assert radii.min() >= 0.01 and radii.max() <= 5.0
    scores = z_scores(sizes, radii)
    assert all(abs(z) < Z_LIMIT for z in scores.values()), scores


def test_the_moment_test_sees_a_wrong_slope():
    # radii of q = 3.5 are far outside the q = 3 moments' sampling error: the test can fail
    wrong = PowerLaw(q=3.5, r_min=0.01, r_max=5.0).draw_radii(N_DRAWS,
                                                              np.random.default_rng(39))
    scores = z_scores(PowerLaw(q=3.0, r_min=0.01, r_max=5.0), wrong)
    assert abs(scores[1]) > 10 * Z_LIMIT, scores


@pytest.mark.parametrize("q", [2.75, 3.0, 3.5])
def test_slopes_of_saturns_rings_draw_their_moments(q):
    # the range Brilliantov et al. (2015) derive, 2.75 <= q <= 3.5, from 1 cm to 10 m
    sizes = PowerLaw(q=q, r_min=0.01, r_max=10.0)
    scores = z_scores(sizes, sizes.draw_radii(N_DRAWS, np.random.default_rng(7)))
    assert all(abs(z) < Z_LIMIT for z in scores.values()), scores


@pytest.mark.parametrize("r_cut, s", [(2.0, 3.0), (1.0, 1.0)])
def test_exponential_cutoff_draws_its_quadrature_moments(r_cut, s):
    sizes = PowerLawCutoff(q=3.0, r_min=0.01, r_max=10.0, r_cut=r_cut, cutoff_exponent=s)
    radii = sizes.draw_radii(N_DRAWS, np.random.default_rng(11))
    assert radii.size == N_DRAWS and radii.min() >= 0.01 and radii.max() <= 10.0
    scores = z_scores(sizes, radii)
    assert all(abs(z) < Z_LIMIT for z in scores.values()), scores
    # the cutoff removes large particles: <R^3> well below the plain power law's
    assert sizes.moment(3) < 0.5 * PowerLaw(3.0, 0.01, 10.0).moment(3)


def test_a_far_cutoff_is_the_plain_power_law():
    # the quadrature against the closed form (relative error of Simpson's rule < 1e-10)
    far = PowerLawCutoff(q=3.0, r_min=0.01, r_max=5.0, r_cut=1e6)
    plain = PowerLaw(q=3.0, r_min=0.01, r_max=5.0)
    for k in (0.5, 1, 2, 3, 6):
        assert far.moment(k) == pytest.approx(plain.moment(k), rel=1e-9)
    assert far.acceptance() == pytest.approx(1.0, abs=1e-9)


def test_cutoff_is_read_from_a_scenario(broad_scenario):
    sc = broad_scenario({"particles.size_distribution": {
        "kind": "powerlaw_cutoff", "q": 3.0, "r_min": 0.5, "r_max": 5.0, "r_cut": 2.0}})
    sizes = sc.particles.size_distribution
    assert sizes == PowerLawCutoff(3.0, 0.5, 5.0, 2.0, 3.0)     # cutoff_exponent: default 3
    assert sc.to_dict()["particles"]["size_distribution"]["cutoff_exponent"] == 3.0
    with pytest.raises(ScenarioError, match="size_distribution.r_cut: .* fewer than"):
        broad_scenario({"particles.size_distribution": {
            "kind": "powerlaw_cutoff", "q": 3.0, "r_min": 0.5, "r_max": 5.0, "r_cut": 0.05}})
    with pytest.raises(ScenarioError, match="size_distribution.r_min"):
        broad_scenario({"particles.size_distribution": {
            "kind": "powerlaw_cutoff", "q": 3.0, "r_min": 6.0, "r_max": 5.0, "r_cut": 2.0}})
