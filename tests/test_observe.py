"""Synthetic occultations (``ringsim observe``): rays through the shear-periodic sheet.

Each test checks a transmission that is known without the tracer: the Poisson layer's
exp(-tau / sin B), the strip shadow of parallel cylinders, the monolayer's 1 - tau at B = 90
deg, the bar model's own curve, and the direction of a sheet's wakes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import ringsim
from ringsim.analysis import occultation as oc
from ringsim.analysis import wake_model, wakes
from ringsim.analysis.observe import asymmetry, window_snapshots
from ringsim.analysis.observe import observe as observe_run
from ringsim.cli import main


def _poisson_layer(rng, n: int, tau: float, r: float = 0.5, thickness: float = 50.0):
    """n spheres of radius r [m] at independent uniform positions: a box of optical depth tau,
    z uniform over ``thickness`` [m] (a thick layer: positions uncorrelated)."""
    L = math.sqrt(n * math.pi * r * r / tau)
    snap = {"x": (rng.random(n) - 0.5) * L, "y": (rng.random(n) - 0.5) * L,
            "z": (rng.random(n) - 0.5) * thickness, "radius": np.full(n, r)}
    return snap, L


@pytest.mark.parametrize("elevation", [10.0, 30.0, 90.0])
@pytest.mark.parametrize("azimuth", [0.0, 60.0])
def test_sparse_random_layer_transmits_exp_minus_tau_over_sin_b(elevation, azimuth):
    """Independent spheres (a Poisson layer): T = exp(-tau / sin B) for every azimuth.  The
    tolerance is 4 standard errors: the rays' binomial one and the layer's own Poisson scatter
    of the shadow count, T (tau / sin B) / sqrt(n) (an upper bound of the realisation's)."""
    rng = np.random.default_rng(7)
    n, tau = 40000, 0.1
    snap, L = _poisson_layer(rng, n, tau)
    assert oc.geometric_optical_depth(snap["radius"], L, L) == pytest.approx(tau)
    view = oc.trace_view(snap, L, L, 0.3 * L, elevation, azimuth, rng, rays=200_000)
    slant = tau / math.sin(math.radians(elevation))
    expected = math.exp(-slant)
    sigma = math.hypot(view["transmission_stderr"], expected * slant / math.sqrt(n))
    assert abs(view["transmission"] - expected) < 4.0 * sigma, (view, expected, sigma)
    assert view["normal_optical_depth"] == pytest.approx(
        tau, abs=4.0 * math.sin(math.radians(elevation)) * sigma / expected)


def _cylinders(n_bars: int, Lx: float, Ly: float, r: float, spacing: float) -> dict:
    """Parallel bars along y, one every Lx / n_bars in x: chains of spheres of radius r [m]
    ``spacing`` [m] apart (overlapping), each a cylinder of radius r up to scallops of depth
    r - sqrt(r^2 - spacing^2 / 4)."""
    ys = np.arange(-0.5 * Ly, 0.5 * Ly, spacing)
    xs = (np.arange(n_bars) + 0.5) * Lx / n_bars - 0.5 * Lx
    X, Y = np.meshgrid(xs, ys)
    return {"x": X.ravel(), "y": Y.ravel(), "z": np.zeros(X.size), "radius": np.full(X.size, r)}


@pytest.mark.parametrize("elevation, azimuth", [(30.0, 90.0), (30.0, 0.0), (30.0, 45.0),
                                                (10.0, 90.0)])
def test_parallel_bars_give_the_hand_calculated_transmission(elevation, azimuth):
    """Cylinders of radius r along y, lambda apart: a ray meets an axis closer than r when
    its crossing lies within r sqrt(cos^2 B cos^2 phi + sin^2 B) / sin B of it (the distance of
    two skew lines), so T = 1 - 2 r sqrt(cos^2 B cos^2 phi + sin^2 B) / (lambda sin B): 1 - 2r /
    lambda along the bars (phi = 90, any B), 1 - 2r / (lambda sin B) across them.  The shear
    offset moves the bars along themselves and changes nothing.  Tolerance: 4 binomial
    standard errors plus the scallops' depth."""
    r, lam, Ly, spacing = 0.5, 5.0, 20.0, 0.05
    Lx = 4 * lam
    snap = _cylinders(4, Lx, Ly, r, spacing)
    B, phi = math.radians(elevation), math.radians(azimuth)
    half = r * math.sqrt((math.cos(B) * math.cos(phi)) ** 2 + math.sin(B) ** 2) / math.sin(B)
    expected = 1.0 - 2.0 * half / lam
    view = oc.trace_view(snap, Lx, Ly, 7.3, elevation, azimuth, np.random.default_rng(3),
                         rays=100_000)
    scallop = 2.0 * (r - math.sqrt(r * r - spacing**2 / 4)) / math.sin(B) / lam
    assert abs(view["transmission"] - expected) < 4.0 * view["transmission_stderr"] + scallop, (
        view, expected)
    if azimuth == 90.0:
        assert expected == pytest.approx(0.8)
    if azimuth == 0.0:
        assert expected == pytest.approx(0.6)


def test_rays_cross_the_shear_periodic_images():
    """A ray at low B starting near the outer edge crosses into the radial image, which sits
    shifted in y by the shear offset: one sphere blocks exactly the rays whose crossing lies
    in its wrapped shadow, wherever that shadow lands."""
    Lx, Ly, shift = 10.0, 10.0, 3.0
    snap = {"x": np.array([4.0]), "y": np.array([0.0]), "z": np.array([2.0]),
            "radius": np.array([0.3])}
    B = 30.0
    s = oc.shadows(snap["x"], snap["y"], snap["z"], snap["radius"], B, 0.0, Lx, Ly, shift)
    # the shadow centre: x = 4 - 2 cot 30 = 0.536 (inside the box): no wrap
    cot = 1.0 / math.tan(math.radians(B))
    assert oc.blocked(s, np.array([4.0 - 2.0 * cot]), np.array([0.0]))[0]
    # with z = -2 the centre lands at x = 7.46, beyond Lx/2: wrapped to x - Lx, y + shift
    s = oc.shadows(snap["x"], snap["y"], -snap["z"], snap["radius"], B, 0.0, Lx, Ly, shift)
    x_img = 4.0 + 2.0 * cot - Lx
    assert oc.blocked(s, np.array([x_img]), np.array([shift]))[0]
    assert not oc.blocked(s, np.array([x_img]), np.array([0.0]))[0]


def test_dense_monolayer_is_more_opaque_than_its_geometric_optical_depth():
    """Non-overlapping spheres in one plane (jittered square lattice, tau = 0.5): seen face on
    their shadows never overlap, so T = 1 - tau and tau_n = -ln(1 - tau) = 1.386 tau exactly
    (the monolayer limit of the filling-factor correction, docs/observe.md); at every lower B
    tau_n still exceeds tau: T lies below the Poisson layer's exp(-tau / sin B)."""
    rng = np.random.default_rng(11)
    r, tau = 0.5, 0.5
    d = r * math.sqrt(math.pi / tau)
    m = 60
    gx, gy = np.meshgrid((np.arange(m) + 0.5) * d, (np.arange(m) + 0.5) * d)
    jitter = 0.5 * (d - 2.0 * r)
    snap = {"x": gx.ravel() + rng.uniform(-jitter, jitter, m * m) - 0.5 * m * d,
            "y": gy.ravel() + rng.uniform(-jitter, jitter, m * m) - 0.5 * m * d,
            "z": np.zeros(m * m), "radius": np.full(m * m, r)}
    L = m * d
    assert oc.geometric_optical_depth(snap["radius"], L, L) == pytest.approx(tau)
    face_on = oc.trace_view(snap, L, L, 0.0, 90.0, 0.0, rng, rays=100_000)
    assert abs(face_on["transmission"] - (1.0 - tau)) < 4.0 * face_on["transmission_stderr"]
    for b in (10.0, 30.0, 60.0):
        view = oc.trace_view(snap, L, L, 0.0, b, 30.0, rng, rays=100_000)
        poisson = math.exp(-tau / math.sin(math.radians(b)))
        # T below the Poisson layer's (also when no ray passes, tau_n infinite)
        assert view["transmission"] < poisson - 4.0 * view["transmission_stderr"], (b, view)


def _wake_sheet(rng, L: float, n: int, mode=(3, 1), width: float = 0.08):
    """Particles concentrated on straight crests of the lattice mode (m, n) of a square box
    (k = 2 pi (m, n) / L; trailing crests for m, n > 0), Gaussian across a crest (``width``
    of the wavelength), uniform along it; z Gaussian of 1 m."""
    k = 2.0 * np.pi * np.asarray(mode, dtype=float) / L
    khat = k / np.linalg.norm(k)
    lam = 2.0 * np.pi / np.linalg.norm(k)
    p = (rng.random((n, 2)) - 0.5) * L
    along_k = p @ khat
    offset = (np.round(along_k / lam) * lam + rng.normal(0.0, width * lam, n)) - along_k
    p = p + offset[:, None] * khat
    p = (p + 0.5 * L) % L - 0.5 * L
    return {"x": p[:, 0], "y": p[:, 1], "z": rng.normal(0.0, 1.0, n),
            "radius": np.full(n, 0.5), "mass": np.full(n, 1.0)}


def test_transmission_peaks_along_the_wakes_at_analyzes_pitch():
    """A sheet whose particles sit on trailing crests: the azimuth of peak transmission at
    low B is the crest direction, 90 deg + the pitch `analyze` reports (wake_statistics),
    within the 5 deg of the azimuth grid, and the bar model's fitted orientation agrees
    within 3 deg."""
    rng = np.random.default_rng(5)
    L, n = 100.0, 6000
    snap = _wake_sheet(rng, L, n)
    stats = wakes.wake_statistics(snap["x"], snap["y"], snap["mass"], L, L, 0.0)
    assert stats["significant"]
    assert stats["pitch_angle_deg"] == pytest.approx(math.degrees(math.atan(1 / 3)), abs=1.0)
    parallel = 90.0 + stats["pitch_angle_deg"]
    views = []
    for b in (5.0, 15.0, 45.0, 90.0):
        for a in np.arange(0.0, 180.0, 5.0):
            v = oc.trace_view(snap, L, L, 0.0, b, float(a), rng, rays=20_000)
            views.append({"elevation_deg": b, "azimuth_deg": float(a), **v})
    low = asymmetry(views)[0]
    assert abs(low["peak_transmission_azimuth_deg"] - parallel) <= 5.0, (low, parallel)
    fit = wake_model.fit_bar_model(*(np.array([v[k] for v in views]) for k in (
        "elevation_deg", "azimuth_deg", "normal_optical_depth",
        "normal_optical_depth_stderr")))
    assert fit["wake_orientation_deg"]["value"] == pytest.approx(parallel, abs=3.0)


#: The bar model's parameters of the synthetic views (S/lambda, H/lambda, tau_G, phi_W).
TRUTH = (0.6, 0.08, 0.3, 110.0)


def _bar_views(seed: int):
    """tau_n of the bar model `TRUTH` at B = 5-90 deg and phi every 15 deg with 1 % Gaussian
    noise: (B, phi, noisy tau_n, its error)."""
    rng = np.random.default_rng(seed)
    B, phi = np.meshgrid([5.0, 10.0, 20.0, 45.0, 90.0], np.arange(0.0, 360.0, 15.0))
    B, phi = B.ravel(), phi.ravel()
    tau = wake_model.bar_optical_depth(B, phi, *TRUTH)
    err = 0.01 * tau
    return B, phi, tau + rng.normal(0.0, 1.0, tau.size) * err, err


def test_bar_model_fit_recovers_its_own_parameters():
    """tau_n of the bar model itself, with 1 % Gaussian noise: the fit returns the four
    parameters and H/W within 4 of their standard errors."""
    truth = TRUTH
    fit = wake_model.fit_bar_model(*_bar_views(2))
    for name, value in zip(wake_model.PARAMETERS, truth, strict=True):
        got = fit[name]
        assert abs(got["value"] - value) < 4.0 * got["stderr"] + 1e-9, (name, got, value)
    hw = truth[1] / (1.0 - truth[0])
    assert abs(fit["height_over_width"]["value"] - hw) < 4.0 * fit["height_over_width"][
        "stderr"]
    assert fit["wake_angle_from_radial_deg"]["value"] == pytest.approx(70.0, abs=1.0)


def test_leaving_out_one_b_moves_a_fit_of_bars_little_and_one_of_no_bars_much():
    # tau_n of the bar model itself with 1 % noise: every refit without one B keeps H/W
    # within 1 % of the truth (the noise moves it by about its stderr, ~0.5 %)
    B, phi, noisy, err = _bar_views(3)
    rng = np.random.default_rng(4)
    dep = wake_model.view_dependence(B, phi, noisy, err)
    hw = TRUTH[1] / (1.0 - TRUTH[0])
    assert dep["left_out_deg"] == [5.0, 10.0, 20.0, 45.0, 90.0]
    assert len(dep["height_over_width"]["values"]) == 5
    assert hw * 0.99 < dep["height_over_width"]["min"] <= dep["height_over_width"]["max"] \
        < hw * 1.01
    assert dep["height_over_width"]["jackknife_stderr"] < 0.01 * hw
    # a layer without bars whose tau_n rises at low B (a thick layer's slant-path excess,
    # here tau (1 + 0.3 / sin B)): the bars fit it in several ways, and which B are given
    # decides between them
    layer = 0.5 * (1.0 + 0.3 / np.sin(np.radians(B)))
    free = wake_model.view_dependence(B, phi, layer + rng.normal(0.0, 0.005, B.size),
                                      np.full(B.size, 0.005))
    # (refits from H/W ~ 400 to ~ 1e14 here: orders of magnitude apart)
    assert free["height_over_width"]["max"] > 100 * free["height_over_width"]["min"]
    # fewer than three B: nothing to leave out
    two = B < 15.0
    assert wake_model.view_dependence(B[two], phi[two], noisy[two], err[two]) is None


def test_bar_model_is_the_hand_calculation():
    """T = (S/lambda - (H/lambda) |sin(phi - phi_W)| / tan B) exp(-tau_G / sin B): along the
    bars the gap fraction times the gap's slant transmission; across them at B = 45 deg the
    height's shadow H/lambda comes off."""
    T = wake_model.bar_transmission(np.array([30.0, 45.0]), np.array([110.0, 20.0]),
                                    0.6, 0.1, 0.2, 110.0)
    assert T[0] == pytest.approx(0.6 * math.exp(-0.4))
    assert T[1] == pytest.approx((0.6 - 0.1) * math.exp(-0.2 / math.sin(math.pi / 4)))


@pytest.fixture(scope="module")
def small_wake_run(tmp_path_factory):
    """The bundled wake scenario reduced (1500 particles, 1 orbit): a gravitating run of
    about 10 CPU-seconds with the command below."""
    from ringsim.config.scenario import load_scenario, with_overrides

    scenario = with_overrides(load_scenario(
        Path(__file__).resolve().parents[1] / "scenarios" / "a-ring-wakes.yaml"),
        {"sheet.n_particles": 1500, "integration.orbits": 1.0,
         "output.snapshot_every": 0.25})
    out = tmp_path_factory.mktemp("observe") / "w.h5"
    return ringsim.run(scenario, output=out, progress=False)


def test_observe_prints_the_asymmetry_and_the_fitted_height_over_width(
        small_wake_run, tmp_path, capsys):
    """`ringsim observe` on the reduced wake scenario: exit 0, the asymmetry table and the
    fitted H/W printed, the JSON with the documented keys and units, the four figures."""
    out = tmp_path / "obs.json"
    code = main(["observe", str(small_wake_run), "--elevation", "5", "20", "90",
                 "--azimuth", *[str(a) for a in range(0, 180, 20)], "--rays", "4000",
                 "--json", str(out), "--plots", str(tmp_path / "plots")])
    printed = capsys.readouterr().out
    assert code == 0
    assert "(max-min)/mean" in printed and "H/W = " in printed
    obs = json.loads(out.read_text())
    assert obs["geometric_optical_depth"] == pytest.approx(0.5, rel=1e-6)
    assert len(obs["views"]) == 27
    for key in ("elevation_deg", "azimuth_deg", "transmission", "transmission_stderr",
                "normal_optical_depth", "normal_optical_depth_stderr"):
        assert key in obs["views"][0]
    assert obs["units"]["normal_optical_depth"] == "dimensionless"
    assert "height_over_width" in obs["bar_model"]
    assert len(list((tmp_path / "plots").glob("observe_*.png"))) == 4
    # a vertical ray has no azimuth: no peak at B = 90 deg, one at the oblique views
    peaks = {row["elevation_deg"]: row["peak_transmission_azimuth_deg"]
             for row in obs["azimuthal_asymmetry"]}
    assert math.isnan(peaks[90.0]) and 0.0 <= peaks[5.0] < 180.0
    assert "none (a vertical ray has no azimuth)" in printed
    dep = obs["bar_model_view_dependence"]
    assert dep["left_out_deg"] == [5.0, 20.0, 90.0]
    assert "with each B left out in turn (5, 20, 90 deg): H/W" in printed


@pytest.fixture(scope="module")
def tiny_run_file(tmp_path_factory):
    """A tiny line-mode run (60 particles, 0.3 orbit, conftest's LINE)."""
    from conftest import LINE, _build_scenario

    out = tmp_path_factory.mktemp("observe_tiny") / "tiny.h5"
    return ringsim.run(_build_scenario(LINE), output=out, progress=False)


def test_observe_on_a_tiny_run_writes_every_view(tiny_run_file, tmp_path):
    """Default snapshots (the equilibrium window, or the last), two views: the JSON's views
    have the documented keys and T in [0, 1]."""
    out = tmp_path / "o.json"
    assert main(["observe", str(tiny_run_file), "--elevation", "30", "--azimuth", "0", "90",
                 "--rays", "2000", "--json", str(out)]) == 0
    obs = json.loads(out.read_text())
    assert [v["azimuth_deg"] for v in obs["views"]] == [0.0, 90.0]
    assert all(0.0 <= v["transmission"] <= 1.0 for v in obs["views"])
    assert obs["geometric_optical_depth"] == pytest.approx(0.2, rel=1e-6)
    # the traced snapshots are the window's when any lies in it, and the JSON says which
    run = ringsim.open_run(tiny_run_file)
    indices, in_window = window_snapshots(run)
    assert obs["snapshots"] == indices and obs["snapshots_in_window"] is in_window
    assert in_window is bool(run.snapshot_times[indices[0]] >= ringsim.equilibrium(run)[
        "equilibrium_from_orbit"]["mean"] * run.scenario.orbital_period * (1 - 1e-12))


@pytest.mark.parametrize("args, key", [
    (["--elevation", "0"], "--elevation"),
    (["--elevation", "1e-6"], "--elevation"),     # below the lowest opening angle, 0.5 deg
    (["--elevation", "95"], "--elevation"),
    (["--snapshot", "999"], "--snapshot"),
    (["--rays", "10"], "--rays"),
    (["--precision", "2"], "--precision"),
    (["--rays", "1000", "--precision", "0.1"], "not allowed with"),
])
def test_bad_arguments_exit_2_with_one_line(args, key, tmp_path, capsys, tiny_run_file):
    code = main(["observe", str(tiny_run_file), *args])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and key in err, err


def test_observe_figures_label_their_axes_and_show_the_model():
    """The tau_n figures from bar-model views: labelled axes with units, at least three
    labelled ticks on each, one marker series per B and the model drawn as lines."""
    from ringsim.plots.observe import tau_azimuth_figure, tau_elevation_figure

    truth = (0.6, 0.08, 0.3, 110.0)
    views = []
    for b in (5.0, 20.0, 90.0):
        for a in range(0, 360, 30):
            tau = float(wake_model.bar_optical_depth(b, float(a), *truth))
            views.append({"elevation_deg": b, "azimuth_deg": float(a), "transmission":
                          math.exp(-tau / math.sin(math.radians(b))),
                          "normal_optical_depth": tau, "normal_optical_depth_stderr": 0.01})
    obs = {"views": views, "geometric_optical_depth": 0.5,
           "azimuthal_asymmetry": asymmetry(views),
           "bar_model": wake_model.fit_bar_model(*(np.array([v[k] for v in views]) for k in (
               "elevation_deg", "azimuth_deg", "normal_optical_depth",
               "normal_optical_depth_stderr")))}
    for fig, unit in ((tau_azimuth_figure(obs), "[deg]"), (tau_elevation_figure(obs), "[deg]")):
        ax = fig.axes[0]
        assert unit in ax.get_xlabel() and "τ_n" in ax.get_ylabel()
        for axis in (ax.xaxis, ax.yaxis):
            labels = [t.get_text() for t in axis.get_ticklabels() if t.get_text()]
            assert len(labels) >= 3, labels
        assert len(ax.get_lines()) >= 3   # model curves and the geometric tau
        fig.clf()


def test_a_fit_without_wakes_says_so(tiny_run_file, capsys):
    """A run in which analyze finds no significant wake (no self-gravity) still gets a bar
    model fitted to its views, and the output says that its parameters are not wake
    parameters."""
    code = main(["observe", str(tiny_run_file), "--elevation", "30", "60", "--azimuth", "0",
                 "60", "120", "--rays", "2000"])
    printed = capsys.readouterr().out
    assert code == 0
    assert "H/W = " in printed
    assert "analyze finds no significant wake in these snapshots" in printed


def _simulated_ring(tmp_path, name, tau, epsilon, dispersion, orbits):
    """A run of 1000 identical 1 m ice particles, constant eps, line detection."""
    from ringsim.config.scenario import scenario_from_dict

    d = {"name": name, "seed": 3, "planet": {"Omega": 2.0e-4},
         "particles": {"density": 900.0, "size_distribution": {"kind": "monodisperse",
                                                               "radius": 1.0}},
         "sheet": {"optical_depth": tau, "n_particles": 1000,
                   "initial_dispersion": dispersion},
         "restitution": {"model": "constant", "epsilon": epsilon},
         "integration": {"orbits": orbits, "collision_detection": "line"},
         "output": {"timeseries_every": 0.05, "snapshot_every": 0.25}}
    return ringsim.open_run(ringsim.run(scenario_from_dict(d, source="<test>"),
                                        output=tmp_path / f"{name}.h5", progress=False))


def _depth_ratio(obs: dict, b: float) -> tuple[float, float]:
    """tau_n over the geometric optical depth at opening angle b, averaged over the
    azimuths, with its standard error (the views' errors, independent draws of rays)."""
    views = [v for v in obs["views"] if v["elevation_deg"] == b]
    tau = np.array([v["normal_optical_depth"] for v in views])
    err = np.array([v["normal_optical_depth_stderr"] for v in views])
    g = obs["geometric_optical_depth"]
    return float(tau.mean() / g), float(np.sqrt(np.sum(err**2)) / tau.size / g)


def test_a_simulated_sparse_thick_ring_is_seen_at_its_geometric_depth(tmp_path):
    # tau = 0.05, started and kept hot (eps = 0.9): rms height ~20 m against 1 m radii,
    # a midplane filling factor ~1e-3: no shadowing between particles to speak of
    run = _simulated_ring(tmp_path, "sparse", 0.05, 0.9, 20.0, 0.5)
    assert run.timeseries["thickness"][-1] > 10.0
    obs = observe_run(run, elevations=[10, 30, 60, 90], azimuths=[0, 45, 90, 135],
                      snapshot=-1, rays=40_000)
    for b in (10, 30, 60, 90):
        ratio, err = _depth_ratio(obs, b)
        assert abs(ratio - 1.0) < 4.0 * err, (b, ratio, err)


def test_a_simulated_dense_cold_ring_is_seen_deeper_than_its_geometric_depth(tmp_path):
    # tau = 0.5, eps = 0.1: a layer a few radii thick in which particles cannot overlap,
    # so they hide less of each other than randomly placed ones: tau_n > tau, but below
    # a perfect monolayer's -ln(1 - tau) / tau = 1.386 face on
    run = _simulated_ring(tmp_path, "dense", 0.5, 0.1, 2.0, 1.0)
    assert run.timeseries["thickness"][-1] < 3.0
    obs = observe_run(run, elevations=[10, 30, 60, 90], azimuths=[0, 45, 90, 135],
                      snapshot=-1, rays=40_000)
    for b in (10, 30, 60, 90):
        ratio, err = _depth_ratio(obs, b)
        assert ratio > 1.0 + 10.0 * err and ratio < -math.log(0.5) / 0.5, (b, ratio, err)
    # slant rays cross more of the layer's rarefied upper part: less excess at B = 10 deg
    # (1.091 against 1.131 at 30 deg, docs/validation.md; 7 combined standard errors)
    (low, e_low), (mid, e_mid) = _depth_ratio(obs, 10), _depth_ratio(obs, 30)
    assert mid - low > 4.0 * math.hypot(e_low, e_mid)
