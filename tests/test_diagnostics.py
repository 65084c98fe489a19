"""Snapshot diagnostics, equilibrium statistics and the dilute-ring kinetic estimate.

Every statistical test is seeded and states its tolerance in standard errors of the
estimator; analytic results are checked to rounding.
"""

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import special
from scipy.signal import lfilter

from ringsim.analysis import collisions, snapshot, timeseries
from ringsim.physics import kinetic

OMEGA = 2.0e-4  # [1/s]
LX = LY = 500.0  # [m]
ICE = 900.0  # [kg/m^3]


def sheared_snapshot(rng, n, W, mean_w=(0.0, 0.0, 0.0), thickness=1.0, radius=1.0):
    """Particles in a box whose velocities relative to the shear flow are N(mean_w, W)."""
    x = rng.uniform(-LX / 2, LX / 2, n)
    y = rng.uniform(-LY / 2, LY / 2, n)
    z = rng.normal(0.0, thickness, n)
    w = rng.multivariate_normal(mean_w, W, size=n)
    r = np.broadcast_to(np.asarray(radius, dtype=float), (n,)).copy()
    m = ICE * 4.0 / 3.0 * np.pi * r**3
    return dict(x=x, y=y, z=z, vx=w[:, 0], vy=w[:, 1] - 1.5 * OMEGA * x, vz=w[:, 2],
                radius=r, mass=m)


# --- velocity dispersion ----------------------------------------------------------------------

# An anisotropic tensor with a positive xy correlation, as in a sheared ring [m^2/s^2].
W_TRUE = np.array([[1.0e-6, 1.5e-7, 0.0], [1.5e-7, 2.5e-7, 0.0], [0.0, 0.0, 4.0e-7]])


def test_dispersion_tensor_of_anisotropic_maxwellian():
    """Each W_ij within 5 standard errors, sqrt((W_ii W_jj + W_ij^2) / N), of the truth."""
    rng = np.random.default_rng(20240501)
    n = 100_000
    s = sheared_snapshot(rng, n, W_TRUE, mean_w=(3e-4, -2e-4, 1e-4))
    W = snapshot.dispersion_tensor(s["x"], s["vx"], s["vy"], s["vz"], OMEGA)
    for i in range(3):
        for j in range(3):
            se = math.sqrt((W_TRUE[i, i] * W_TRUE[j, j] + W_TRUE[i, j] ** 2) / n)
            assert abs(W[i, j] - W_TRUE[i, j]) < 5 * se, f"W[{i},{j}] off by > 5 sigma"
    assert np.allclose(W, W.T, rtol=0, atol=0), "tensor must be symmetric"
    # c = sqrt(tr W / 3): delta method, var(tr) = 2 tr(W^2) / N.
    c_true = math.sqrt(np.trace(W_TRUE) / 3)
    se_c = math.sqrt(2 * np.trace(W_TRUE @ W_TRUE) / n) / 3 / (2 * c_true)
    c = snapshot.velocity_dispersion(s["x"], s["vx"], s["vy"], s["vz"], OMEGA)
    assert abs(c - c_true) < 5 * se_c, "1-D dispersion off by > 5 sigma"
    comps = snapshot.dispersion_components(W)
    assert comps["sigma_xy"] == W[0, 1] and comps["sigma_zz"] == W[2, 2]
    assert comps["velocity_dispersion_x"] == pytest.approx(math.sqrt(W[0, 0]), rel=1e-15)


def test_dispersion_is_relative_to_shear_flow_and_mean():
    """A uniform drift and the shear flow itself carry no dispersion."""
    rng = np.random.default_rng(7)
    s = sheared_snapshot(rng, 1000, W_TRUE)
    W0 = snapshot.dispersion_tensor(s["x"], s["vx"], s["vy"], s["vz"], OMEGA)
    W1 = snapshot.dispersion_tensor(s["x"], s["vx"] + 0.3, s["vy"] - 0.2, s["vz"] + 0.1, OMEGA)
    assert np.allclose(W0, W1, rtol=1e-6, atol=1e-18), "a uniform drift changed W"
    x = s["x"]
    cold = snapshot.dispersion_tensor(x, 0 * x, -1.5 * OMEGA * x, 0 * x, OMEGA)
    assert np.max(np.abs(cold)) < 1e-25, "pure Keplerian shear has W = 0"


def test_mass_weighted_dispersion_of_two_species():
    """Mass weighting: c^2 = sum(N_k m_k c_k^2) / sum(N_k m_k); within 5 sigma."""
    rng = np.random.default_rng(11)
    n_small, n_big = 80_000, 20_000
    c_small, c_big = 2e-3, 5e-4  # [m/s], small particles hotter
    s1 = sheared_snapshot(rng, n_small, np.eye(3) * c_small**2, radius=0.5)
    s2 = sheared_snapshot(rng, n_big, np.eye(3) * c_big**2, radius=2.0)
    s = {k: np.concatenate([s1[k], s2[k]]) for k in s1}
    m1, m2 = s1["mass"][0], s2["mass"][0]
    c2_true = (n_small * m1 * c_small**2 + n_big * m2 * c_big**2) / (n_small * m1 + n_big * m2)
    # var(c^2 estimate) = sum_k (m_k N_k)^2 * 2 c_k^4 / (3 N_k) / M^2
    M = n_small * m1 + n_big * m2
    se_c2 = math.sqrt((m1**2 * n_small * 2 * c_small**4 + m2**2 * n_big * 2 * c_big**4) / 3) / M
    c = snapshot.velocity_dispersion(s["x"], s["vx"], s["vy"], s["vz"], OMEGA, weights=s["mass"])
    assert abs(c**2 - c2_true) < 5 * se_c2, "mass-weighted dispersion off by > 5 sigma"
    # number weighting: c^2 = sum(N_k c_k^2) / N, a much hotter answer here
    n = n_small + n_big
    c2_number = (n_small * c_small**2 + n_big * c_big**2) / n
    se_number = math.sqrt((n_small * 2 * c_small**4 + n_big * 2 * c_big**4) / 3) / n
    c_n = snapshot.velocity_dispersion(s["x"], s["vx"], s["vy"], s["vz"], OMEGA)
    assert abs(c_n**2 - c2_number) < 5 * se_number, "number-weighted dispersion off by > 5 sigma"
    assert c_n > 2 * c


def test_translational_viscosity_from_known_tensor():
    """nu_trans = 2 W_xy / (3 Omega), W_xy within 5 sigma."""
    rng = np.random.default_rng(5)
    n = 100_000
    s = sheared_snapshot(rng, n, W_TRUE)
    nu = collisions.translational_viscosity(s["x"], s["vx"], s["vy"], OMEGA, mass=s["mass"])
    se = math.sqrt((W_TRUE[0, 0] * W_TRUE[1, 1] + W_TRUE[0, 1] ** 2) / n) * 2 / (3 * OMEGA)
    assert abs(nu - 2 * W_TRUE[0, 1] / (3 * OMEGA)) < 5 * se


def test_collisional_viscosity_matches_rebound_formula():
    """REBOUND's shearing_sheet_diagnostics: nu_col = 2/3/Omega/M_total/t * plog."""
    sigma, t, plog = 400.0, 1.0e5, 3.2e7  # [kg/m^2], [s], [kg m^2/s]
    M_total = sigma * LX * LY
    nu = collisions.collisional_viscosity(plog, t, LX, LY, sigma, OMEGA)
    assert nu == pytest.approx(2.0 / 3.0 / OMEGA / M_total / t * plog, rel=1e-14)
    with pytest.raises(ValueError):
        collisions.collisional_viscosity(plog, 0.0, LX, LY, sigma, OMEGA)


# --- vertical structure, optical depth, filling factor ----------------------------------------

def test_thickness_of_gaussian_layer():
    """rms z of a Gaussian layer within 5 sigma (se = H / sqrt(2N)); offset irrelevant."""
    rng = np.random.default_rng(3)
    n, H = 100_000, 3.7  # [m]
    z = 12.0 + rng.normal(0.0, H, n)
    assert abs(snapshot.thickness(z) - H) < 5 * H / math.sqrt(2 * n)
    masses = rng.uniform(1.0, 3.0, n)
    n_eff = masses.sum() ** 2 / np.sum(masses**2)
    assert abs(snapshot.thickness(z, masses) - H) < 5 * H / math.sqrt(2 * n_eff)


def test_optical_depth_is_exact():
    r = np.full(1000, 1.5)
    assert snapshot.optical_depth(r, LX, LY) == pytest.approx(1000 * np.pi * 1.5**2 / (LX * LY),
                                                        rel=1e-14)


def test_sphere_slab_volumes_are_exact():
    r = 2.0
    sphere = 4 / 3 * np.pi * r**3
    assert snapshot.sphere_slab_volume(0.0, r, -5.0, 5.0) == pytest.approx(sphere, rel=1e-14)
    assert snapshot.sphere_slab_volume(0.0, r, 0.0, 5.0) == pytest.approx(sphere / 2, rel=1e-14)
    a = 0.7  # cap of height a: pi a^2 (3r - a) / 3
    cap = np.pi * a**2 * (3 * r - a) / 3
    assert snapshot.sphere_slab_volume(0.0, r, r - a, 10.0) == pytest.approx(cap, rel=1e-13)
    assert snapshot.sphere_slab_volume(10.0, r, -1.0, 1.0) == 0.0
    # a central slab of half-width h: pi (2 r^2 h - 2 h^3 / 3)
    h = 0.5
    assert snapshot.sphere_slab_volume(0.0, r, -h, h) == pytest.approx(
        np.pi * (2 * r**2 * h - 2 * h**3 / 3), rel=1e-14)


def test_filling_factor_of_monolayer_lattice():
    """Identical spheres on a square lattice at z = 0: FF(h = r) = 2 tau / 3, FF(h -> 0) = tau."""
    r, spacing = 1.0, 2.5
    g = np.arange(-LX / 2 + spacing / 2, LX / 2, spacing)
    xx, yy = np.meshgrid(g, g)
    n = xx.size
    z = np.zeros(n)
    radius = np.full(n, r)
    tau = n * np.pi * r**2 / (LX * LY)
    assert snapshot.optical_depth(radius, LX, LY) == pytest.approx(tau, rel=1e-14)
    assert snapshot.filling_factor(z, radius, LX, LY) == pytest.approx(2 * tau / 3, rel=1e-13)
    assert (snapshot.filling_factor(z, radius, LX, LY, half_width=0.0)
            == pytest.approx(tau, rel=1e-13))
    assert (snapshot.filling_factor(z, radius, LX, LY, half_width=1e-7)
            == pytest.approx(tau, rel=1e-12))
    # a slab wider than the layer: FF = total particle volume / slab volume
    assert snapshot.filling_factor(z, radius, LX, LY, half_width=3.0) == pytest.approx(
        n * 4 / 3 * np.pi / (LX * LY * 6.0), rel=1e-13)


def test_filling_factor_of_uniform_random_slab():
    """Centres uniform in |z| < Z: E[FF] = N (4/3 pi r^3) / (2 Z Lx Ly) for h + r < Z; 5 sigma."""
    rng = np.random.default_rng(17)
    n, r, Z, h = 100_000, 0.8, 40.0, 1.0
    z = rng.uniform(-Z, Z, n)
    radius = np.full(n, r)
    expected = n * 4 / 3 * np.pi * r**3 / (2 * Z * LX * LY)
    ff = snapshot.filling_factor(z, radius, LX, LY, half_width=h, z_mid=0.0)
    per_particle = snapshot.sphere_slab_volume(z, radius, -h, h) / (LX * LY * 2 * h)
    se = per_particle.std() * math.sqrt(n)
    assert abs(ff - expected) < 5 * se, "random-slab filling factor off by > 5 sigma"


# --- per-size-bin statistics and the summary --------------------------------------------------

def test_snapshot_summary_size_bins():
    """A three-size mix: per-bin counts exact, per-bin c and thickness within 5 sigma."""
    rng = np.random.default_rng(99)
    sizes = [(0.6, 50_000, 2e-3, 4.0), (1.2, 30_000, 1e-3, 2.0), (3.0, 20_000, 4e-4, 1.0)]
    parts = [sheared_snapshot(rng, n, np.eye(3) * c**2, thickness=H, radius=r)
             for r, n, c, H in sizes]
    s = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    edges = snapshot.log_size_bins(0.5, 5.0, 3)
    assert edges == pytest.approx([0.5, 0.5 * 10 ** (1 / 3), 0.5 * 10 ** (2 / 3), 5.0])
    out = snapshot.snapshot_summary(s["x"], s["y"], s["z"], s["vx"], s["vy"], s["vz"], s["radius"],
                              s["mass"], OMEGA, LX, LY, size_bins=edges)
    assert list(out["size_bin_n"]) == [n for _, n, _, _ in sizes], "per-bin counts"
    for k, (_, n, c, H) in enumerate(sizes):
        assert abs(out["size_bin_velocity_dispersion"][k] - c) < 5 * c / math.sqrt(6 * n)
        assert abs(out["size_bin_thickness"][k] - H) < 5 * H / math.sqrt(2 * n)
    # an int asks for log bins spanning the radii present
    out3 = snapshot.snapshot_summary(s["x"], s["y"], s["z"], s["vx"], s["vy"], s["vz"], s["radius"],
                               s["mass"], OMEGA, LX, LY, size_bins=2)
    assert out3["size_bin_edges"] == pytest.approx([0.6, math.sqrt(0.6 * 3.0), 3.0])
    assert list(out3["size_bin_n"]) == [80_000, 20_000]


def test_snapshot_summary_has_contract_fields_and_agrees():
    rng = np.random.default_rng(1)
    s = sheared_snapshot(rng, 5000, W_TRUE, thickness=2.0, radius=rng.uniform(0.5, 2.0, 5000))
    out = snapshot.snapshot_summary(**s, Omega=OMEGA, Lx=LX, Ly=LY)
    for key in ("velocity_dispersion", "sigma_xx", "sigma_yy", "sigma_zz", "sigma_xy",
                "thickness", "filling_factor", "optical_depth", "mean_radius",
                "thickness_mass_weighted", "velocity_dispersion_mass_weighted"):
        assert np.isfinite(out[key]), key
    W = snapshot.dispersion_tensor(s["x"], s["vx"], s["vy"], s["vz"], OMEGA)
    assert out["sigma_xy"] == pytest.approx(W[0, 1], rel=1e-12)
    assert out["velocity_dispersion"] == pytest.approx(math.sqrt(np.trace(W) / 3), rel=1e-12)
    assert out["thickness"] == pytest.approx(snapshot.thickness(s["z"]), rel=1e-12)
    assert out["filling_factor"] == pytest.approx(
        snapshot.filling_factor(s["z"], s["radius"], LX, LY), rel=1e-12)
    assert out["optical_depth"] == pytest.approx(snapshot.optical_depth(s["radius"], LX, LY))
    assert list(out["size_bin_n"]) == [5000], "default: one bin with every particle"


def test_bad_input_raises():
    with pytest.raises(ValueError):
        snapshot.dispersion_tensor([0.0, 1.0], [0.0], [0.0, 0.0], [0.0, 0.0], OMEGA)
    with pytest.raises(ValueError):
        snapshot.thickness([0.0, np.nan])
    with pytest.raises(ValueError):
        snapshot.optical_depth([-1.0], LX, LY)
    with pytest.raises(ValueError):
        snapshot.velocity_dispersion([0.0], [0.0], [0.0], [0.0], Omega=0.0)


# --- collision statistics ---------------------------------------------------------------------

def test_collision_frequency_per_particle_per_orbit():
    """500 collisions of 100 particles in 2 orbits: 2 * 500 / 100 / 2 = 5 impacts per orbit."""
    orbit = 2 * np.pi / OMEGA
    assert collisions.collision_frequency(500, 100, 2 * orbit, OMEGA) == pytest.approx(
        5.0, rel=1e-14)


def test_epsilon_statistics():
    eps = np.array([0.1, 0.5, 0.5, 0.9])
    v = np.array([1.0, 2.0, 2.0, 0.0])
    st = collisions.epsilon_statistics(eps, bins=10, normal_speed=v)
    assert st["count"] == 4 and st["mean_epsilon"] == pytest.approx(0.5)
    assert st["histogram"].sum() == 4 and st["histogram"][5] == 2 and st["histogram"][9] == 1
    # energy-weighted: sqrt((0.01 * 1 + 0.25 * 4 * 2) / 9)
    assert st["effective_epsilon"] == pytest.approx(math.sqrt((0.01 + 2.0) / 9.0), rel=1e-14)
    empty = collisions.epsilon_statistics([])
    assert empty["count"] == 0 and math.isnan(empty["mean_epsilon"])
    with pytest.raises(ValueError):
        collisions.epsilon_statistics([1.2])


# --- equilibrium finder -----------------------------------------------------------------------

def ar1(rng, n, phi, sd):
    """Stationary AR(1) series of marginal standard deviation sd."""
    e = rng.normal(0.0, sd * math.sqrt(1 - phi**2), n)
    return lfilter([1.0], [1.0, -phi], e, zi=[phi * rng.normal(0.0, sd)])[0]


def test_autocorrelation_time_of_ar1():
    """tau_int = (1 + phi) / (1 - phi) = 19 for phi = 0.9; within 5% on 2e5 samples."""
    rng = np.random.default_rng(2)
    tau = timeseries.integrated_autocorrelation_time(ar1(rng, 200_000, 0.9, 1.0))
    assert abs(tau - 19.0) < 0.05 * 19.0
    assert timeseries.integrated_autocorrelation_time(rng.normal(size=50_000)) == pytest.approx(1.0,
                                                                                         abs=0.05)


def test_autocorrelated_mean_stderr_of_ar1():
    """stderr -> sd sqrt(tau_int / n), tau_int = 19 for phi = 0.9; within 10% on 1e5 samples."""
    rng = np.random.default_rng(21)
    n = 100_000
    mean, stderr, n_eff = timeseries.autocorrelated_mean(3.0 + ar1(rng, n, 0.9, 2.0))
    assert stderr == pytest.approx(2.0 * math.sqrt(19.0 / n), rel=0.1)
    assert n_eff == pytest.approx(n / 19.0, rel=0.1)
    assert abs(mean - 3.0) < 5 * stderr


def test_mser_finds_a_step():
    rng = np.random.default_rng(4)
    v = np.concatenate([np.full(300, 5.0), 10.0 + 0.1 * rng.normal(size=1700)])
    assert timeseries.mser_truncation(v) == 300


def test_equilibrium_coverage_on_ar1_with_transient():
    """AR(1) (phi 0.9) + exponential transient, 300 seeded replicates.

    The transient is mostly gone where the window starts, and the 1- and 2-sigma intervals
    cover the true mean at ~68% and ~95%.  MSER stops cutting where the transient left is
    about one noise standard deviation, which biases the mean by ~0.3 stderr for these
    4000-sample series (bias ~ 1/n, stderr ~ 1/sqrt(n)); the bias is asserted below 0.5 stderr.
    """
    rng = np.random.default_rng(2024)
    mu, amplitude, decay, n, reps = 10.0, 10.0, 100.0, 4000, 300
    t = np.arange(n) * 0.1  # [s]
    means, errs, starts, ok = [], [], [], []
    for _ in range(reps):
        v = mu + amplitude * np.exp(-np.arange(n) / decay) + ar1(rng, n, 0.9, 1.0)
        res = timeseries.stationary_mean(t, v)
        means.append(res.mean)
        errs.append(res.stderr)
        starts.append(res.start_index)
        ok.append(res.in_equilibrium)
        assert res.start_time == t[res.start_index]
    means, errs, starts = map(np.asarray, (means, errs, starts))
    left = np.exp(-starts / decay)  # fraction of the transient left at the window start
    assert np.median(left) < 0.15 and np.mean(left < 0.25) > 0.95, "start before transient end"
    assert np.median(starts) < 10 * decay, "far too much discarded"
    assert np.mean(ok) > 0.95, "stationary series declared out of equilibrium"
    cover1 = np.mean(np.abs(means - mu) < errs)
    cover2 = np.mean(np.abs(means - mu) < 2 * errs)
    assert 0.55 < cover1 < 0.80, f"1-sigma coverage {cover1:.2f}"
    assert 0.88 < cover2 < 0.99, f"2-sigma coverage {cover2:.2f}"
    assert abs(np.mean(means) - mu) < 0.5 * np.mean(errs), "biased mean"


def test_linear_trend_is_not_equilibrium():
    rng = np.random.default_rng(8)
    n = 3000
    t = np.arange(n) * 0.1
    v = 10.0 + 0.02 * t + ar1(rng, n, 0.9, 0.5)  # +6 over the series
    res = timeseries.stationary_mean(t, v)
    assert not res.in_equilibrium and "drifting" in res.reason
    assert res.slope == pytest.approx(0.02, rel=0.2)


def test_short_or_strongly_correlated_series_is_not_equilibrium():
    rng = np.random.default_rng(9)
    v = 5.0 + ar1(rng, 400, 0.99, 1.0)  # tau_int ~ 200: a couple of independent samples
    res = timeseries.stationary_mean(np.arange(400.0), v)
    assert not res.in_equilibrium and "too short" in res.reason
    res = timeseries.stationary_mean(np.arange(5.0), np.ones(5))
    assert not res.in_equilibrium


def test_constant_series_is_exact():
    res = timeseries.stationary_mean(np.arange(100.0), np.full(100, 3.25))
    assert res.mean == 3.25 and res.stderr == 0.0 and res.in_equilibrium


# --- dilute-ring kinetic theory ---------------------------------------------------------------

def test_gaussian_speed_moments_isotropic_closed_form():
    """For g ~ N(0, s^2 I): E|g| = 2 sqrt(2/pi) s, E|g|^3 = 8 sqrt(2/pi) s^3."""
    s2 = 2.0
    moments, mean_speed = kinetic._gaussian_speed_moments(np.full(3, s2))
    s = math.sqrt(s2)
    assert mean_speed == pytest.approx(2 * math.sqrt(2 / math.pi) * s, rel=1e-13)
    assert moments.sum() == pytest.approx(8 * math.sqrt(2 / math.pi) * s**3, rel=1e-13)


def test_gaussian_speed_moments_anisotropic_monte_carlo():
    """E[|g| g_k^2] for a strongly anisotropic Gaussian vs 4e5 samples, within 5 sigma."""
    rng = np.random.default_rng(31)
    lam = np.array([3.0, 0.05, 1.2])
    g = rng.normal(size=(400_000, 3)) * np.sqrt(lam)
    samples = np.linalg.norm(g, axis=1)[:, None] * g**2
    moments, _ = kinetic._gaussian_speed_moments(lam)
    se = samples.std(axis=0) / math.sqrt(g.shape[0])
    assert np.all(np.abs(moments - samples.mean(axis=0)) < 5 * se)


def test_gt78_critical_epsilon():
    """eps_cr(tau -> 0) = 0.627 (Goldreich & Tremaine 1978) and rises with tau.

    Independent check: Spaute & Greenberg (1987, Icarus 70, 289) find random motions grow
    for eps > 0.63 with smooth spheres, "in agreement with analytical models".
    """
    low = kinetic.gt78_steady_state(0.0)
    assert abs(low["epsilon_critical"] - 0.627) < 5e-4
    assert low["sigma_yy_over_xx"] == 0.25, "epicyclic ratio W_yy/W_xx = 1/4 without collisions"
    taus = [1e-3, 0.1, 0.25, 0.5, 1.0, 2.0]
    eps = [kinetic.critical_epsilon(t) for t in taus]
    assert np.all(np.diff(eps) > 0) and eps[-1] < 1.0
    assert abs(eps[0] - low["epsilon_critical"]) < 1e-5
    st = kinetic.gt78_steady_state(0.25)
    # energy balance of the steady state: shear heating 3 Omega W_xy equals the collisional
    # loss -trace(dW/dt|coll); the viscosity is positive
    a, b, s = st["sigma_yy_over_xx"], st["sigma_zz_over_xx"], st["sigma_xy_over_xx"]
    W = np.array([[1.0, s, 0.0], [s, a, 0.0], [0.0, 0.0, b]])
    C, _ = kinetic._gt78_collision_term(W, st["epsilon_critical"], 0.25)
    assert 3 * s == pytest.approx(-np.trace(C), rel=1e-10)
    assert s > 0 and st["viscosity_Omega_over_c2"] > 0
    # collision frequency ~ 3 tau Omega (GT78's estimate), i.e. ~ 6 pi tau per orbit
    assert 0.8 < st["impacts_per_orbit"] / (6 * np.pi * 0.25) < 1.2


def test_gt78_root_judged_by_its_residuals():
    """A root of the moment equations is accepted by its residuals (``ROOT_RESIDUAL``), not
    by MINPACK's status: status 3 ("xtol too small") at residuals of round-off is a root
    (it is what numpy without AVX-512 gives at the dilute limit), and a "converged" status
    with residuals above the limit, or with a NaN, is not."""
    from scipy.optimize import OptimizeResult

    at_root = OptimizeResult(x=np.array([0.4258, 0.6270]), fun=np.array([4.4e-16, -1e-16]),
                             success=False, status=3)
    assert kinetic._is_root(at_root)
    off = OptimizeResult(x=at_root.x, fun=np.array([0.0, 10 * kinetic.ROOT_RESIDUAL]),
                         success=True, status=1)
    assert not kinetic._is_root(off)
    assert not kinetic._is_root(OptimizeResult(x=at_root.x, fun=np.array([np.nan, 0.0]),
                                               success=True, status=1))


def test_gt78_without_avx512_kernels():
    """The set-up's kinetic estimate on a CPU without AVX-512: numpy's AVX-512 kernels turned
    off (NPY_DISABLE_CPU_FEATURES, read when numpy is imported, so in a fresh interpreter).
    Before ``_is_root`` MINPACK stopped with status 3 at the dilute limit there, and every
    ``ringsim run`` failed at set-up with those kernels off.  The roots agree with this process's to
    1e-12 (both solve the same equations to round-off)."""
    import os
    import subprocess
    import sys

    umath = getattr(getattr(np, "_core", None), "_multiarray_umath", None)
    dispatch = getattr(umath, "__cpu_dispatch__", [])
    found = getattr(umath, "__cpu_features__", {})
    avx512 = [name for name in dispatch
              if found.get(name) and (name.startswith("AVX512") or name == "X86_V4")]
    if not avx512:
        pytest.skip("numpy runs no AVX-512 kernels here: the default path is the one tested")
    code = ("from ringsim.physics import kinetic; st = kinetic.gt78_steady_state(0.25); "
            "print(repr(kinetic.gt78_steady_state(0.0)['epsilon_critical']), "
            "repr(st['epsilon_critical']), repr(st['sigma_zz_over_xx']))")
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=" ".join(avx512))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=False)
    assert done.returncode == 0, done.stderr
    eps0, eps, b = (float(v) for v in done.stdout.split())
    here = kinetic.gt78_steady_state(0.25)
    assert eps0 == pytest.approx(kinetic.gt78_steady_state(0.0)["epsilon_critical"], abs=1e-12)
    assert eps == pytest.approx(here["epsilon_critical"], abs=1e-12)
    assert b == pytest.approx(here["sigma_zz_over_xx"], abs=1e-12)


def test_effective_epsilon_of_bridges_law_closed_form():
    """Energy-weighted <eps^2> of eps = min(1, (v/v_c)^-b): incomplete gamma functions."""
    v_c, b = 7.7e-5, 0.234
    law = {"model": "bridges", "v_c": v_c, "exponent": b}
    for c in [1e-5, 6e-5, 2e-4, 1e-2]:
        a2 = (v_c / (2 * c)) ** 2
        eps2 = special.gammainc(2, a2) + (2 * c / v_c) ** (-2 * b) * special.gammaincc(
            2 - b, a2) * special.gamma(2 - b)
        assert kinetic.effective_epsilon(law, c, 0.5, 1.0) == pytest.approx(math.sqrt(eps2),
                                                                       abs=1e-7)
    const = {"model": "constant", "epsilon": 0.42}
    assert kinetic.effective_epsilon(const, 1e-3, 0.5, 1.0) == pytest.approx(0.42, rel=1e-13)


def test_kinetic_estimate_constant_epsilon_collapse_and_heating():
    mass = ICE * 4 / 3 * np.pi
    eps_cr = kinetic.critical_epsilon(0.25)
    cold = kinetic.kinetic_dispersion_estimate({"model": "constant", "epsilon": eps_cr - 0.05},
                                          1.0, mass, 0.25, OMEGA)
    assert cold["status"] == "collapse" and math.isnan(cold["velocity_dispersion"])
    hot = kinetic.kinetic_dispersion_estimate({"model": "constant", "epsilon": eps_cr + 0.05},
                                         1.0, mass, 0.25, OMEGA)
    assert hot["status"] == "heating" and "without bound" in hot["reason"]


def test_kinetic_estimate_bridges_law_balances_at_critical_epsilon():
    law = {"model": "bridges"}
    radius = np.array([0.5, 1.0, 1.5])  # a size mix: the mean radius and mass are used
    mass = ICE * 4 / 3 * np.pi * radius**3
    res = kinetic.kinetic_dispersion_estimate(law, radius, mass, 0.25, OMEGA)
    assert res["status"] == "equilibrium"
    c = res["velocity_dispersion"]
    assert np.isfinite(c) and c > 0
    assert res["radius"] == 1.0 and res["R_bar"] == 0.5
    assert res["velocity_dispersion_rOmega"] == pytest.approx(c / (1.0 * OMEGA))
    eps_eff = kinetic.effective_epsilon(law, c, res["R_bar"], res["M_bar"])
    assert abs(eps_eff - kinetic.critical_epsilon(0.25)) < 1e-8
    # stable: hotter -> more dissipative
    assert kinetic.effective_epsilon(law, 1.1 * c, 0.5, 1.0) < res["epsilon_critical"]


def test_kinetic_estimate_dilley_hotter_with_mass_dependence():
    """Dilley with kappa > 0: metre-sized particles are more elastic -> a hotter ring."""
    mass = ICE * 4 / 3 * np.pi
    c0 = kinetic.kinetic_dispersion_estimate({"model": "dilley", "kappa": 0.0}, 1.0, mass, 0.25,
                                        OMEGA)["velocity_dispersion"]
    c1 = kinetic.kinetic_dispersion_estimate({"model": "dilley", "kappa": 0.1}, 1.0, mass, 0.25,
                                        OMEGA)["velocity_dispersion"]
    assert np.isfinite(c0) and c1 > c0


@pytest.mark.parametrize("module", [snapshot, timeseries, kinetic])
def test_module_imports_neither_rebound_nor_h5py(module):
    tree = ast.parse(Path(module.__file__).read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module.split(".")[0])
    assert not names & {"rebound", "h5py"}


def test_kinetic_estimate_uses_one_consistent_particle():
    """A size mix is represented by the mean radius WITH its own mass (bulk density), not
    by the mean mass, which belongs to a larger sphere."""
    radius = np.array([0.5, 1.0, 2.5])
    mass = ICE * 4 / 3 * np.pi * radius**3
    res = kinetic.kinetic_dispersion_estimate({"model": "dilley", "kappa": 0.1}, radius, mass,
                                              0.25, OMEGA)
    r_mean = radius.mean()
    assert res["radius"] == pytest.approx(r_mean, rel=1e-15)
    assert res["mass"] == pytest.approx(ICE * 4 / 3 * np.pi * r_mean**3, rel=1e-13)
    assert res["mass"] < mass.mean() / 2, "the mean mass would be that of a 1.7 m sphere"
    assert res["M_bar"] == pytest.approx(res["mass"] / 2, rel=1e-15)
    assert "mean radius" in res["representative"]


def test_size_bins_are_measured_about_the_sheet_mean_not_their_own():
    """Sparse bins: about the sheet's mean motion c^2 is unbiased; about the bin's own mean
    it would be low by (1 - 1/n) = 1/2 for pairs.  300 bins of 2 particles each."""
    rng = np.random.default_rng(11)
    n_bins, sigma = 300, 0.01
    radius = np.repeat(np.geomspace(0.5, 5.0, n_bins), 2)
    edges = np.concatenate([[0.49], np.sqrt(radius[2::2] * radius[:-2:2]), [5.01]])
    n = radius.size
    x = rng.uniform(-LX / 2, LX / 2, n)
    w = rng.normal(0.0, sigma, (3, n))
    out = snapshot.snapshot_summary(x, rng.uniform(0, LY, n), rng.normal(0, 1.0, n), w[0],
                                    w[1] - 1.5 * OMEGA * x, w[2], radius, np.ones(n), OMEGA,
                                    LX, LY, size_bins=edges)
    assert list(out["size_bin_n"]) == [2] * n_bins
    mean_c2 = np.mean(out["size_bin_velocity_dispersion"] ** 2)
    # c^2 of a bin is a mean of 6 squared N(0, sigma) deviates: its mean over 300 bins has
    # a relative standard error sqrt(2 / 1800) = 3.3 %; 5 sigma = 17 % << the 50 % bias
    assert mean_c2 == pytest.approx(sigma**2, rel=0.17)
