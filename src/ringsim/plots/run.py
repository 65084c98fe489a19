"""The figures of ``ringsim analyze --plots DIR`` (one run) and ``ringsim compare --plots
DIR`` (several runs overlaid, each with its own colour, hatch and marker)."""

from __future__ import annotations

from pathlib import Path

from ringsim.analysis.gravitating import snapshot_wakes
from ringsim.plots.common import run_style, save_figure, short_run_labels
from ringsim.plots.compare_extras import extra_comparison_figures
from ringsim.plots.spins import spin_figure
from ringsim.plots.structure import (
    epsilon_histogram_figure,
    size_bin_figure,
    snapshot_figure,
    velocity_distribution_figure,
    vertical_profile_figure,
)
from ringsim.plots.timeseries import (
    ellipsoid_figure,
    per_size_timeseries_figure,
    timeseries_figure,
)
from ringsim.plots.wakes import wake_figure


def _entries(runs, equilibria):
    return [(run, eq, run_style(i))
            for i, (run, eq) in enumerate(zip(runs, equilibria, strict=True))]


def run_figures(run, eq: dict) -> dict:
    """File name -> matplotlib Figure of every figure of one run."""
    entries = _entries([run], [eq])
    figures = {"timeseries.png": timeseries_figure(entries, eq["name"]),
               "ellipsoid.png": ellipsoid_figure(entries)}
    if eq["per_size_bin"]:
        figures["size_bins.png"] = size_bin_figure(entries)
        figures["size_bins_timeseries.png"] = per_size_timeseries_figure(run, eq)
    figures["velocity_distribution.png"] = velocity_distribution_figure(entries)
    figures["vertical_profile.png"] = vertical_profile_figure(entries)
    figures["epsilon_histogram.png"] = epsilon_histogram_figure(entries)
    period = run.scenario.orbital_period
    snap = run.snapshot(-1)
    figures["snapshot.png"] = snapshot_figure(
        snap, float(run.attrs["Lx"]), float(run.attrs["Ly"]),
        f"{eq['name']}: last snapshot at {snap['t'] / period:.3g} orbits")
    if "lambda_cr" in eq:
        figures["wakes.png"] = _wake_figure(run, eq, snap)
    if eq.get("spin"):
        figures["spins.png"] = spin_figure(run, eq)
    return figures


def _wake_figure(run, eq: dict, snap: dict):
    """Top view of the last snapshot of a gravitating run, with its wake statistics."""
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    stats = snapshot_wakes(snap, Lx, Ly, run.scenario.orbital_frequency)
    period = run.scenario.orbital_period
    return wake_figure(snap, Lx, Ly, f"{eq['name']}: surface density at "
                       f"{snap['t'] / period:.3g} orbits", eq["lambda_cr"]["mean"], stats)


def comparison_figures(runs, equilibria: list[dict]) -> dict:
    """File name -> matplotlib Figure of every overlay figure of several runs."""
    labels, caption = short_run_labels([eq["name"] for eq in equilibria])
    equilibria = [dict(eq, name=label) for eq, label in zip(equilibria, labels, strict=True)]
    entries = _entries(runs, equilibria)
    names = " vs ".join(labels) + (f" (runs {caption})" if caption else "")
    figures = {"compare_timeseries.png": timeseries_figure(entries, names),
               "compare_ellipsoid.png": ellipsoid_figure(entries)}
    if any(eq["per_size_bin"] for eq in equilibria):
        figures["compare_size_bins.png"] = size_bin_figure(entries)
    figures["compare_velocity_distribution.png"] = velocity_distribution_figure(entries)
    figures["compare_vertical_profile.png"] = vertical_profile_figure(entries)
    figures["compare_epsilon_histogram.png"] = epsilon_histogram_figure(entries)
    figures.update(extra_comparison_figures(entries))
    return figures


def _save_all(figures: dict, directory: str | Path) -> list[Path]:
    return [save_figure(fig, Path(directory) / name) for name, fig in figures.items()]


def plot_run(run, eq: dict, directory: str | Path) -> list[Path]:
    """Figures of one run (``ringsim analyze --plots DIR``); returns the PNG paths."""
    return _save_all(run_figures(run, eq), directory)


def plot_comparison(runs, equilibria: list[dict], directory: str | Path) -> list[Path]:
    """Overlay figures of several runs (``ringsim compare --plots DIR``)."""
    return _save_all(comparison_figures(runs, equilibria), directory)
