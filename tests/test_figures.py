"""Every figure ringsim makes, rendered for a tiny run of each kind and checked by program.

Kinds: a plain ring and its kappa = 0.1 twin (``analyze`` and ``compare``), a rough ring
(spins), a self-gravitating sheet (wakes, Toomre Q, and ``observe``'s occultations), a
sweep (``sweep.png``), a study (``ratios.png``), and the figures without runs
(``epsilon``, ``epsilon --restitution``, ``fit``).  Each figure is built by the function
the command uses, laid out as ``save_figure`` lays it out, drawn, and checked:

* no text outside the canvas (a title running off an edge, a label cut off);
* no legend overlapping a title (the axes' or the figure's);
* no legend covering plotted data points (lines and markers inside the axes);
* at least three labelled ticks on every axis that shows tick labels, and plain labels
  (no "a x 10^n") for values between 10^-3 and 10^4.

The runs are tiny (a few seconds in all): the checks are about layout, not physics.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

import ringsim
from ringsim.analysis.fit import fit_model
from ringsim.analysis.fit_data import read_data
from ringsim.analysis.observe import observation_pictures, observe
from ringsim.cli import main
from ringsim.config.scenario import with_overrides
from ringsim.plots import common, epsilon_figure, paper_curves
from ringsim.plots.compare_extras import wake_comparison_figure
from ringsim.plots.fits import fit_figure
from ringsim.plots.observe import (
    scan_figure,
    sightline_figure,
    tau_azimuth_figure,
    tau_elevation_figure,
)
from ringsim.plots.run import comparison_figures, run_figures
from ringsim.plots.study import ratio_figure
from ringsim.plots.sweep import read_summary, sweep_figure
from ringsim.userlaw import law_title, read_law, user_curves, user_curves_figure

ROOT = Path(__file__).resolve().parents[1]
plt = common.pyplot()


# --- the checks ----------------------------------------------------------------------------

def _texts(fig):
    """Every text the figure draws: the labels of the ticks inside each axis's view (the
    ones matplotlib draws) and every other visible, non-empty text (titles, axis labels,
    legends, notes)."""
    from matplotlib.text import Text

    tick_labels, drawn = set(), []
    for ax in _axes(fig):
        for axis in (ax.xaxis, ax.yaxis):
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                tick_labels.update((id(tick.label1), id(tick.label2)))
            if axis.get_visible():
                drawn += [t for tick in axis._update_ticks() for t in (tick.label1, tick.label2)
                          if t.get_visible() and t.get_text().strip()]
    drawn += [t for t in fig.findobj(Text)
              if id(t) not in tick_labels and _visible(t) and t.get_text().strip()]
    return drawn


def _visible(artist) -> bool:
    """The artist and its axes are visible."""
    ax = getattr(artist, "axes", None)
    return artist.get_visible() and (ax is None or ax.get_visible())


def text_outside_canvas(fig) -> list[str]:
    """The texts whose drawn box leaves the canvas by more than a pixel."""
    renderer = fig.canvas.get_renderer()
    canvas = fig.bbox
    problems = []
    for text in _texts(fig):
        box = text.get_window_extent(renderer)
        if (box.x0 < canvas.x0 - 1 or box.y0 < canvas.y0 - 1 or box.x1 > canvas.x1 + 1
                or box.y1 > canvas.y1 + 1):
            problems.append(text.get_text()[:60])
    return problems


def _legends(fig):
    found = [leg for ax in fig.axes for leg in [ax.get_legend()] if leg is not None]
    return [leg for leg in found + list(fig.legends) if leg.get_visible()]


def legend_over_title(fig) -> list[str]:
    """The titles (of the axes and the figure) a legend's box overlaps."""
    renderer = fig.canvas.get_renderer()
    titles = [t for ax in fig.axes if ax.get_visible()
              for t in (ax.title, ax._left_title, ax._right_title) if t.get_text().strip()]
    if fig._suptitle is not None and fig._suptitle.get_text().strip():
        titles.append(fig._suptitle)
    problems = []
    for legend in _legends(fig):
        box = legend.get_window_extent(renderer)
        for title in titles:
            if box.overlaps(title.get_window_extent(renderer)):
                problems.append(title.get_text()[:60])
    return problems


def _along(display: np.ndarray, samples: int = 12) -> np.ndarray:
    """Points along the segments between consecutive finite vertices (display space), so
    that a line crossing a legend counts even where its vertices lie outside it."""
    a, b = display[:-1], display[1:]
    good = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1)
    t = np.linspace(0.0, 1.0, samples)[:, None, None]
    return (a[good] + t * (b[good] - a[good])).reshape(-1, 2)


def _data_points(ax) -> np.ndarray:
    """Display coordinates along the lines, steps and markers an axes plots (not the
    reference lines that span the axes, nor shaded areas)."""
    points = []
    for line in ax.lines:
        x, y = (np.asarray(v, dtype=float) for v in line.get_data())
        if x.size < 2 or np.nanmax(x) == np.nanmin(x) or np.nanmax(y) == np.nanmin(y):
            continue   # axhline / axvline: reference lines, drawn across everything
        display = line.get_transform().transform(np.column_stack([x, y]))
        points.append(_along(display) if line.get_linestyle() not in ("None", "") else
                      display[np.isfinite(display).all(axis=1)])
    for patch in ax.patches:   # histograms drawn as steps (not the shaded windows)
        if type(patch).__name__ in ("StepPatch", "Polygon") and not patch.get_fill():
            points.append(_along(patch.get_transform().transform(patch.get_path().vertices)))
    for collection in ax.collections:
        offsets = np.asarray(collection.get_offsets(), dtype=float)
        if offsets.ndim == 2 and len(offsets) > 1 and offsets.shape[0] < 5000:
            points.append(collection.get_offset_transform().transform(offsets))
    return np.vstack(points) if points else np.empty((0, 2))


def legend_over_data(fig) -> list[str]:
    """The axes whose legend, inside them, covers points along their plotted data."""
    renderer = fig.canvas.get_renderer()
    problems = []
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None or not legend.get_visible() or not ax.get_visible():
            continue
        box = legend.get_window_extent(renderer)
        if not ax.bbox.overlaps(box):
            continue   # outside the axes
        points = _data_points(ax)
        inside = ((points[:, 0] > box.x0) & (points[:, 0] < box.x1) & (points[:, 1] > box.y0)
                  & (points[:, 1] < box.y1)) if len(points) else np.array([])
        if inside.any():
            problems.append(f"{_title(ax)}: {int(inside.sum())} points")
    return problems


def _axes(fig):
    for ax in fig.axes:
        if ax.get_visible():
            yield ax
            yield from (child for child in ax.child_axes if child.get_visible())


def _numeric(label: str) -> bool:
    """A tick label that shows a number (plain, or matplotlib's math text of a power)."""
    bare = re.sub(r"\\mathdefault|\\times|[${}^\s]", "", label)
    return re.fullmatch(r"[-−+]?[\d.]+(?:×?10[-−+]?\d+)?|10[-−+]?\d+", bare) is not None


def _title(ax) -> str:
    return repr(ax.get_title()[:40]) if hasattr(ax, "get_title") else "(secondary axis)"


def too_few_ticks(fig) -> list[str]:
    """Numeric axes with fewer than three labelled ticks in view, and labels written as
    a × 10^n for values between 10^-3 and 10^4."""
    problems = []
    for ax in _axes(fig):
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            if not axis.get_visible():
                continue
            lo, hi = sorted(axis.get_view_interval())
            shown = [(t, v) for minor in (False, True)   # matplotlib labels minor ticks too
                     for t, v in zip(axis.get_ticklabels(minor=minor),
                                     axis.get_ticklocs(minor=minor), strict=False)
                     if t.get_visible() and t.get_text().strip()
                     and lo - 1e-9 * abs(hi - lo) <= v <= hi + 1e-9 * abs(hi - lo)]
            if not all(_numeric(t.get_text()) for t, _v in shown):
                continue   # a categorical axis (run names, quantities)
            if shown and len(shown) < 3:
                problems.append(f"{_title(ax)} {name}: {[t.get_text() for t, _v in shown]}")
            problems += [f"{_title(ax)} {name}: {t.get_text()!r}" for t, v in shown
                         if re.search(r"times|×", t.get_text()) and 1e-3 <= abs(v) <= 1e4]
    return problems


def check_figure(name: str, fig) -> list[str]:
    """Every defect the checks find in ``fig``, laid out as it is saved; closes it."""
    common.lay_out(fig)
    fig.canvas.draw()
    found = [f"{name}: text outside the canvas: {p}" for p in text_outside_canvas(fig)]
    found += [f"{name}: legend over the title {p}" for p in legend_over_title(fig)]
    found += [f"{name}: legend over data {p}" for p in legend_over_data(fig)]
    found += [f"{name}: fewer than 3 ticks or not plain {p}" for p in too_few_ticks(fig)]
    plt.close(fig)
    return found


def test_the_checks_find_defects():
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0, 1, 2, 3], [0, 1, 2, 3], "o", label="data")
    ax.set_xticks([0, 3])
    ax.set_title("a title much too long for so narrow a figure: it runs off both edges")
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, 1.25))
    problems = check_figure("defects", fig)
    assert any("outside the canvas" in p for p in problems)
    assert any("legend over the title" in p for p in problems)
    assert any("fewer than 3 ticks" in p for p in problems)
    fig, ax = plt.subplots()
    ax.plot(np.linspace(0, 1, 50), np.linspace(0, 1, 50), label="data")
    ax.legend(loc="center")
    assert any("legend over data" in p for p in check_figure("on data", fig))
    fig, ax = plt.subplots()   # matplotlib's own labels of a log axis under a decade
    ax.plot([0.6, 2.2], [1.0, 2.0])
    ax.set_xscale("log")
    assert any("not plain" in p and "times" in p for p in check_figure("log", fig))


# --- tiny runs of every kind ---------------------------------------------------------------

def _run(scenario, directory: Path):
    path = ringsim.run(scenario, output=directory / f"{scenario.name}.h5", progress=False)
    run = ringsim.open_run(path)
    return run, ringsim.equilibrium(run)


@pytest.fixture(scope="module")
def runs(tmp_path_factory, ring_scenario, rough_scenario, gravitating_scenario):
    d = tmp_path_factory.mktemp("figure-runs")
    plain = ring_scenario(name="plain", seed=4, **{
        "sheet.optical_depth": 0.3, "sheet.n_particles": 150, "integration.orbits": 1.0,
        "integration.collision_detection": "line", "output.snapshot_every": 0.25})
    rough = rough_scenario({"model": "coulomb", "mu": 0.5}, name="rough")
    grav = gravitating_scenario(name="grav")
    return {sc.name: _run(sc, d) for sc in (
        plain, with_overrides(plain, {"name": "plain-kappa", "restitution.kappa": 0.1}),
        rough, with_overrides(rough, {"name": "rough-kappa", "restitution.kappa": 0.0}),
        grav, with_overrides(grav, {"name": "grav-eps", "restitution.v_c": 1.5e-4}))}


@pytest.fixture(scope="module")
def batch_figures(tmp_path_factory, runs):
    """The figures of a tiny sweep and a tiny study, made through the command line."""
    d = tmp_path_factory.mktemp("figure-batches")
    base = {"name": "tiny", "seed": 1, "planet": {"Omega": 2e-4},
            "particles": {"density": 900.0, "size_distribution": {
                "kind": "powerlaw", "q": 3.0, "r_min": 1.0, "r_max": 3.0}},
            "sheet": {"optical_depth": 0.25, "n_particles": 60},
            "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0},
            "integration": {"orbits": 0.5, "collision_detection": "line"},
            "output": {"timeseries_every": 0.05, "snapshot_every": 0.25}}
    (d / "base.yaml").write_text(yaml.safe_dump(base))
    (d / "sweep.yaml").write_text(yaml.safe_dump({"base": "base.yaml", "grid": {
        "restitution.kappa": [0.0, 0.1], "seed": [1, 2]}}))
    assert main(["sweep", str(d / "sweep.yaml"), "--workers", "1", "--out",
                 str(d / "sweep")]) == 0
    (d / "study.yaml").write_text(yaml.safe_dump({
        "name": "tiny-study", "base": "base.yaml", "seeds": [1, 2],
        "cases": {"k0": {}, "k01": {"restitution.kappa": 0.1}}, "ratios": [["k01", "k0"]],
        "length": {"orbits": 0.5}}))
    assert main(["study", str(d / "study.yaml"), "--workers", "1", "--out",
                 str(d / "study")]) == 0
    import json

    report = json.loads((d / "study" / "report.json").read_text())
    # a variant whose budget is range: its crosses and dotted lines (the ratio set by hand)
    ranged = {**report, "ratios": [{**e, "range_parts": {"ref_600g": {
        "ratio": 0.9 * e["mean"], "ratio_without": e["mean"]}}} for e in report["ratios"]]}
    return {"sweep.png": sweep_figure(read_summary(d / "sweep" / "summary.h5"), "sweep"),
            "ratios.png": ratio_figure(report),
            "ratios.png (a range variant)": ratio_figure(ranged)}


def _all_figures(runs, batch_figures):
    """(name, Figure) of every figure, made one command's set at a time."""
    for name in ("plain", "rough", "grav"):   # the twins only in compare
        run, eq = runs[name]
        yield from ((f"analyze {name}/{k}", f) for k, f in run_figures(run, eq).items())
    for pair in (("plain", "plain-kappa"), ("rough", "rough-kappa"), ("grav", "grav-eps")):
        chosen = [runs[p] for p in pair]
        yield from ((f"compare {'+'.join(pair)}/{k}", f) for k, f in comparison_figures(
            [r for r, _ in chosen], [e for _, e in chosen]).items())
    # compare_wakes.png of the gravitating pair; a box this small measures no wakes, so the
    # statistics are set by hand (the check is of the layout, not of the numbers)
    wakes = {"wake_wavelength": 0.9, "wake_pitch_angle": 21.0, "wake_amplitude": 0.6}
    entries = [(run, {**eq, **{k: {"mean": v * (1 + 0.1 * i), "stderr": 0.05 * v}
                               for k, v in wakes.items()}}, common.run_style(i))
               for i, (run, eq) in enumerate((runs["grav"], runs["grav-eps"]))]
    yield "compare_wakes.png (set statistics)", wake_comparison_figure(entries)
    yield from batch_figures.items()
    run, _eq = runs["grav"]   # ringsim observe: a few views of the gravitating sheet
    obs = observe(run, [10.0, 45.0], [0.0, 45.0, 90.0], snapshot=-1, rays=300)
    pictures = observation_pictures(run, obs)
    yield from {"observe_tau_azimuth.png": tau_azimuth_figure(obs),
                "observe_tau_elevation.png": tau_elevation_figure(obs),
                "observe_scan.png": scan_figure(pictures),
                "observe_sightline.png": sightline_figure(pictures)}.items()
    figures = {}
    figures["epsilon.png"] = epsilon_figure(paper_curves())
    law, density, radii = read_law("model=dilley,kappa=0.1", None, [0.5, 1.0, 5.0])
    figures["epsilon --restitution"] = user_curves_figure(user_curves(law, density, radii),
                                                          law_title(law, density),
                                                          law["model"])
    data = read_data(ROOT / "docs" / "data" / "hatzes_like.csv")
    figures["fit.png"] = fit_figure(data, [fit_model(data, m) for m in ("dilley", "bridges")])
    yield from figures.items()


def test_a_range_variant_is_drawn_as_crosses_at_the_ratio_moved_by_its_shift(batch_figures):
    """The range variant of the tiny study (its ratio 0.9 of the ratio without it over the
    variant seeds) is a cross at 0.9 times each ratio, labelled as a range; the figure
    without one has no cross."""
    def crosses(fig):
        return [line for line in fig.axes[0].get_lines() if line.get_marker() == "x"]
    fig = batch_figures["ratios.png (a range variant)"]
    (line,) = crosses(fig)
    assert line.get_label() == "k01 / k0 with ref_600g (range)"
    (ratio,) = [c for c in fig.axes[0].containers if c.get_label() == "k01 / k0"]
    means = np.asarray(ratio.lines[0].get_ydata(), dtype=float)
    assert np.all(np.isfinite(means)) and means.size >= 1
    assert np.asarray(line.get_ydata()) == pytest.approx(0.9 * means, rel=1e-12)
    assert crosses(batch_figures["ratios.png"]) == []


def test_every_figure_passes_the_checks(runs, batch_figures):
    problems, names = [], []
    for name, fig in _all_figures(runs, batch_figures):
        names.append(name)
        problems += check_figure(name, fig)
    assert {"analyze rough/spins.png", "analyze grav/wakes.png", "sweep.png",
            "ratios.png", "compare rough+rough-kappa/compare_spins.png",
            "compare grav+grav-eps/compare_toomre_q.png"} <= set(names)
    assert problems == [], "\n".join(problems)
    # docs/figures.md describes every file a command writes
    listed = (ROOT / "docs" / "figures.md").read_text()
    files = {name.rsplit("/", 1)[-1].split(" ")[0] for name in names if ".png" in name}
    assert {f for f in files if not re.search(rf"[`/]{re.escape(f)}", listed)} == set()
