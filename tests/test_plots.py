"""Figures: readable for any size range and ring thickness, units on every axis, the
equilibrium window shaded only in equilibrium, runs told apart, one speed unit.

Each test builds the matplotlib Figure (the same builders the commands use), draws it and
inspects it: tick-label bounding boxes of an axis must not intersect, every axis that shows
tick labels carries a label with a unit in brackets.
"""

from types import SimpleNamespace

import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.config.scenario import scenario_from_dict, with_overrides
from ringsim.plots import common, epsilon_figure, paper_curves, run_figures
from ringsim.plots.run import comparison_figures
from ringsim.plots.structure import size_bin_figure, snapshot_figure
from ringsim.plots.sweep import read_summary, sweep_figure
from ringsim.plots.timeseries import timeseries_figure, velocity_ellipsoid

plt = common.pyplot()


# --- helpers -------------------------------------------------------------------------------

def _all_axes(fig):
    for ax in fig.axes:
        if ax.get_visible():
            yield ax
            yield from (child for child in ax.child_axes if child.get_visible())


def _tick_labels(axis):
    return [t for t in axis.get_ticklabels() if t.get_visible() and t.get_text().strip()]


def overlapping_tick_labels(fig) -> list[str]:
    """Pairs of tick labels of one axis whose drawn bounding boxes intersect."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    for ax in _all_axes(fig):
        for axis in (ax.xaxis, ax.yaxis):
            labels = _tick_labels(axis)
            boxes = [t.get_window_extent(renderer).expanded(1.0, 1.0) for t in labels]
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    # a 0.5 pixel margin: touching is fine, overlapping is not
                    a, b = boxes[i].padded(-0.5), boxes[j].padded(-0.5)
                    if a.overlaps(b):
                        problems.append(f"{labels[i].get_text()!r} / {labels[j].get_text()!r}")
    return problems


def axes_without_units(fig) -> list[str]:
    """Axes that show tick labels but whose label has no '[unit]'."""
    fig.canvas.draw()
    missing = []
    for ax in _all_axes(fig):
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if _tick_labels(axis) and not ("[" in label and "]" in label):
                missing.append(f"{ax.get_title()!r}: {label!r}")
    return missing


def check_readable(fig):
    assert overlapping_tick_labels(fig) == [], "tick labels overlap"
    assert axes_without_units(fig) == [], "axis label without a unit"


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# --- readable axes for any range -------------------------------------------------------------

RANGES = [(0.5, 5.0), (1.0, 1.2), (0.01, 10.0), (1e-6, 1e-2), (0.0, 3e-4), (-40.0, 40.0),
          (2e3, 3e7), (0.999, 1.001), (3.0, 3.0)]


@pytest.mark.parametrize("lo, hi", RANGES)
@pytest.mark.parametrize("which", ["x", "y"])
def test_readable_axis_for_any_range(lo, hi, which):
    fig, ax = plt.subplots(figsize=(4, 3))
    values, other = np.linspace(lo, hi, 50), np.linspace(0.0, 1.0, 50)
    ax.plot(*((values, other) if which == "x" else (other, values)))
    log = common.set_readable_axis(ax, which, values)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    check_readable(fig)
    axis = ax.xaxis if which == "x" else ax.yaxis
    labels = [t.get_text() for t in _tick_labels(axis)]
    assert 2 <= len(labels) <= 6, labels
    assert log == (lo > 0 and hi / lo > 4), "log scale exactly when positive over > x4"
    assert not any("10^{0}" in t or "times" in t for t in labels), labels


def test_log_axis_uses_plain_numbers_within_a_few_decades():
    fig, ax = plt.subplots()
    common.set_readable_axis(ax, "x", [0.5, 5.0])
    fig.canvas.draw()
    assert [t.get_text() for t in _tick_labels(ax.xaxis)] == ["0.5", "1", "2", "5"]


# --- per-size figure: mixtures at their radii, any size range ----------------------------------

def _fake_entry(size_distribution, radii, name="r", in_eq=True, index=0):
    """A run-like object with just what the per-size figure reads, and its equilibrium."""
    from ringsim.physics.sizes import size_bin_edges

    sc = scenario_from_dict({"name": name, "seed": 1, "planet": {"Omega": 2e-4},
                             "particles": {"size_distribution": size_distribution},
                             "sheet": {"optical_depth": 0.01, "n_particles": 100000}},
                            source="<test>")
    edges = size_bin_edges(sc.particles.size_distribution)
    rng = np.random.default_rng(5)
    bins = []
    for k in range(edges.size - 1):
        c = 1e-3 * (1 + rng.random())
        bins.append({"r_low": float(edges[k]), "r_high": float(edges[k + 1]),
                     "velocity_dispersion": {"mean": c, "stderr": 0.05 * c},
                     "thickness": {"mean": 5 * c / 2e-4, "stderr": 0.1},
                     "n": int(np.sum((radii >= edges[k]) & (radii < edges[k + 1])))})
    run = SimpleNamespace(scenario=sc, snapshot=lambda i: {"radius": radii})
    eq = {"name": name, "per_size_bin": bins, "in_equilibrium": in_eq}
    return run, eq, common.run_style(index)


def test_mixture_points_sit_at_the_species_radii():
    radii = np.repeat([0.3, 1.0, 4.0], [50, 30, 20])
    entry = _fake_entry({"kind": "mixture", "components": [
        {"radius": 0.3, "number_fraction": 0.5}, {"radius": 1.0, "number_fraction": 0.3},
        {"radius": 4.0, "number_fraction": 0.2}]}, radii)
    fig = size_bin_figure([entry])
    check_readable(fig)
    for ax in fig.axes:
        np.testing.assert_allclose(ax.lines[0].get_xdata(), [0.3, 1.0, 4.0], rtol=1e-12)


@pytest.mark.parametrize("r_min, r_max", [(0.5, 5.0), (1.0, 1.2), (0.01, 10.0)])
def test_size_bins_readable_for_any_size_range(r_min, r_max):
    rng = np.random.default_rng(2)
    radii = np.exp(rng.uniform(np.log(r_min), np.log(r_max), 400))
    entry = _fake_entry({"kind": "powerlaw", "q": 3.0, "r_min": r_min, "r_max": r_max}, radii)
    fig = size_bin_figure([entry])
    check_readable(fig)
    ax = fig.axes[0]
    x = ax.lines[0].get_xdata()
    edges = [entry[1]["per_size_bin"][0]["r_low"]] + [b["r_high"]
                                                      for b in entry[1]["per_size_bin"]]
    inside = (x > np.array(edges[:-1])) & (x < np.array(edges[1:]))
    assert inside.all(), "each point at its bin's mean radius, inside the bin"
    assert ax.get_xscale() == ("log" if r_max / r_min > 4 else "linear")


# --- side view: a cold monolayer and a hot ring --------------------------------------------

def _snapshot(n, r, h, box):
    rng = np.random.default_rng(7)
    return {"x": rng.uniform(-box / 2, box / 2, n), "y": rng.uniform(-box / 2, box / 2, n),
            "z": rng.normal(0.0, h, n), "radius": np.full(n, r)}


@pytest.mark.parametrize("h_over_r, box_over_r", [(1.0, 30.0), (150.0, 30.0), (0.1, 100.0),
                                                  (3.0, 60.0)])
def test_side_view_readable_for_cold_and_hot_rings(h_over_r, box_over_r):
    r = 1.0
    box = box_over_r * r
    fig = snapshot_figure(_snapshot(200, r, h_over_r * r, box), box, box, "test")
    check_readable(fig)
    fig.canvas.draw()
    side = fig.axes[1].get_window_extent()
    top = fig.axes[0].get_window_extent()
    ratio = side.height / side.width
    assert 0.2 <= ratio <= 0.75, f"side view height/width {ratio:.3f}: sliver or needle"
    assert side.width > 0.5 * top.width, "side view squashed sideways"
    title = fig.axes[1].get_title()
    to_scale = abs(fig.axes[1].get_aspect() - 1.0) < 0.01
    assert ("drawn to scale" in title) == to_scale, "the title says whether z is to scale"
    assert ("vertical scale ×" in title) == (not to_scale)
    if h_over_r >= 100:
        assert "vertical scale ×0.0" in title, "a hot ring's side view is compressed"


# --- the velocity ellipsoid ------------------------------------------------------------------

def test_velocity_ellipsoid_recovers_a_rotated_tensor():
    angle = np.radians(np.array([-30.0, 0.0, 12.0, 40.0]))
    a, b = 3.0e-3, 1.5e-3  # [m/s] principal rms speeds
    c, s = np.cos(angle), np.sin(angle)
    sxx = a**2 * c**2 + b**2 * s**2
    syy = a**2 * s**2 + b**2 * c**2
    sxy = (a**2 - b**2) * c * s
    shape = velocity_ellipsoid(sxx, syy, np.full(4, (1e-3) ** 2), sxy)
    np.testing.assert_allclose(shape["tilt"], angle, atol=1e-12)
    np.testing.assert_allclose(shape["minor_over_major"], 0.5, rtol=1e-12)
    np.testing.assert_allclose(shape["vertical_over_major"], 1.0 / 3.0, rtol=1e-12)


# --- figures of real runs ------------------------------------------------------------------

@pytest.fixture(scope="module")
def two_runs(tmp_path_factory, ring_scenario):
    base = ring_scenario(name="p0", seed=4, **{
        "sheet.optical_depth": 0.3, "sheet.n_particles": 150, "integration.orbits": 1.0,
        "integration.collision_detection": "line", "output.snapshot_every": 0.25})
    other = with_overrides(base, {"name": "p1", "restitution.kappa": 0.1})
    d = tmp_path_factory.mktemp("plotruns")
    paths = [ringsim.run(sc, output=d / f"{sc.name}.h5", progress=False)
             for sc in (base, other)]
    runs = [ringsim.open_run(p) for p in paths]
    return runs, [ringsim.equilibrium(r) for r in runs]


def _with_window(eq, start):
    return dict(eq, in_equilibrium=True, equilibrium_from_orbit={"mean": start, "stderr": 0.0})


def _windows(ax):
    return [p for p in ax.patches if p.get_zorder() == 0]


def test_every_run_figure_is_readable(two_runs):
    runs, eqs = two_runs
    for eq in (eqs[0], _with_window(eqs[0], 0.5)):
        figures = run_figures(runs[0], eq)
        assert {"timeseries.png", "ellipsoid.png", "size_bins.png", "size_bins_timeseries.png",
                "velocity_distribution.png", "vertical_profile.png", "epsilon_histogram.png",
                "snapshot.png"} == set(figures)
        for name, fig in figures.items():
            assert overlapping_tick_labels(fig) == [], name
            assert axes_without_units(fig) == [], name


def test_window_shaded_only_in_equilibrium(two_runs):
    runs, eqs = two_runs
    entry = lambda eq: [(runs[0], eq, common.run_style(0))]  # noqa: E731
    not_eq = dict(eqs[0], in_equilibrium=False)
    fig = timeseries_figure(entry(not_eq), "t")
    assert all(_windows(ax) == [] for ax in fig.axes), "no window without equilibrium"
    assert "NOT in equilibrium" in fig._suptitle.get_text()
    fig = timeseries_figure(entry(_with_window(eqs[0], 0.5)), "t")
    for ax in fig.axes:
        (window,) = _windows(ax)
        x0 = window.get_x() if hasattr(window, "get_x") else window.get_xy()[0][0]
        assert x0 == pytest.approx(0.5)


def test_compare_windows_have_distinct_colours_and_hatches(two_runs):
    runs, eqs = two_runs
    eqs = [_with_window(eqs[0], 0.5), _with_window(eqs[1], 0.7)]
    figures = comparison_figures(runs, eqs)
    for name in ("compare_timeseries.png", "compare_ellipsoid.png"):
        for ax in figures[name].axes:
            windows = _windows(ax)
            assert len(windows) == 2, name
            assert windows[0].get_hatch() != windows[1].get_hatch()
            assert windows[0].get_facecolor() != windows[1].get_facecolor()
        assert overlapping_tick_labels(figures[name]) == []
    lines = figures["compare_timeseries.png"].axes[0].lines
    assert len({line.get_color() for line in lines}) >= 2


def test_vertical_profile_is_a_normalised_density(two_runs):
    runs, eqs = two_runs
    fig = run_figures(runs[0], eqs[0])["vertical_profile.png"]
    ax = fig.axes[0]
    # the stairs are drawn as patches after the window; each should integrate to <= 1
    # (<= because |z| beyond 4 H falls outside the histogram range) and close to 1
    for patch in [p for p in ax.patches if p.get_zorder() != 0]:
        path = patch.get_path().vertices
        x, y = path[:, 0], path[:, 1]
        area = np.sum(np.diff(x) * y[:-1])
        assert 0.9 < area <= 1.0 + 1e-9


# --- one speed unit everywhere -------------------------------------------------------------

def test_epsilon_and_fit_share_the_speed_unit(tmp_path, monkeypatch):
    fig = epsilon_figure(paper_curves())
    check_readable(fig)
    assert all(f"[{common.SPEED_UNIT}]" in ax.get_xlabel() for ax in fig.axes
               if ax.get_visible())
    captured = []
    monkeypatch.setattr(common, "save_figure", lambda fig, path, **kw: captured.append(fig))
    from ringsim.analysis.fit import fit_models, read_data
    from ringsim.plots.fits import plot_fits

    csv = tmp_path / "d.csv"
    v = np.geomspace(5e-4, 3e-2, 8)
    eps = ringsim.restitution.dilley_epsilon(v, 0.025, 0.06)
    rows = [f"{float(a)!r},0.025,0.06,{float(e)!r}\n" for a, e in zip(v, eps, strict=True)]
    csv.write_text("v_m_s,R_bar_m,M_bar_kg,epsilon\n" + "".join(rows))
    data = read_data(csv, need_sizes=False)
    plot_fits(data, fit_models(data, ("bridges",)), tmp_path / "fit.png")
    (fit_fig,) = captured
    check_readable(fit_fig)
    assert f"[{common.SPEED_UNIT}]" in fit_fig.axes[0].get_xlabel()
    line = fit_fig.axes[0].lines[0]
    np.testing.assert_allclose(np.sort(line.get_xdata()), v / common.SPEED_SCALE)


# --- sweeps -------------------------------------------------------------------------------

def _summary(tmp_path, keys, points):
    from ringsim.store.summary import write_summary

    sweep = SimpleNamespace(keys=tuple(keys), source_text="", source="s.yaml",
                            base=SimpleNamespace(yaml_text=""))
    results = []
    for params, c, in_eq in points:
        eq = {"in_equilibrium": in_eq, "reason": "",
              "velocity_dispersion": {"mean": c, "stderr": 0.05 * c},
              "thickness": {"mean": 2 * c / 2e-4, "stderr": 0.5}}
        results.append(SimpleNamespace(params=params, file="f.h5", status="finished",
                                       action="run", equilibrium=eq, wall_time=1.0, error=""))
    write_summary(tmp_path, sweep, results)
    return read_summary(tmp_path / "summary.h5")


def test_sweep_figure_c_and_h_against_the_parameter(tmp_path):
    points = [({"restitution.kappa": k, "seed": s}, 1e-3 * (1 + 3 * k) * (1 + 0.01 * s),
               not (k == 0.1 and s == 2)) for k in (0.0, 0.05, 0.1) for s in (1, 2, 3)]
    fig = sweep_figure(_summary(tmp_path, ["restitution.kappa", "seed"], points))
    check_readable(fig)
    ax_c, ax_h = fig.axes
    assert "restitution.kappa [dimensionless]" == ax_c.get_xlabel()
    assert f"[{common.SPEED_UNIT}]" in ax_c.get_ylabel() and "[m]" in ax_h.get_ylabel()
    # nine runs with error bars, three seed means, and the open marker of the one run
    # not in equilibrium
    markers = [line for line in ax_c.lines if line.get_marker() not in ("None", "", None)]
    open_markers = [line for line in markers if line.get_markerfacecolor() == "white"
                    and len(line.get_xdata())]
    assert len(open_markers) == 1
    assert open_markers[0].get_ydata()[0] == pytest.approx(1e3 * 1e-3 * 1.3 * 1.02)


def test_sweep_plots_option_end_to_end(tmp_path, capsys):
    base = tmp_path / "base.yaml"
    base.write_text("name: b\nseed: 1\nplanet: {Omega: 2.0e-4}\n"
                    "particles: {size_distribution: {kind: monodisperse, radius: 1.0}}\n"
                    "sheet: {n_particles: 60}\nrestitution: {model: constant, epsilon: 0.5}\n"
                    "integration: {orbits: 0.3}\n"
                    "output: {timeseries_every: 0.02, snapshot_every: 0.3}\n")
    sweep = tmp_path / "s.yaml"
    sweep.write_text("base: base.yaml\ngrid:\n  restitution.epsilon: [0.3, 0.6]\n")
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--plots",
                 str(blocker)]) == 2
    assert not (tmp_path / "o").exists(), "nothing written on bad input"
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--plots", str(tmp_path / "figs")]) == 0
    png = tmp_path / "figs" / "sweep.png"
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000
    assert "wrote" in capsys.readouterr().out
