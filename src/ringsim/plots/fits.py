"""The figure of ``ringsim fit --plot``: measured coefficients of restitution against impact
speed with the fitted laws, one panel per (R_bar, M_bar) group of the data.  Speeds in mm/s,
as in every ringsim figure."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ringsim.analysis.fit_data import RestitutionData
from ringsim.plots import common
from ringsim.plots.common import SPEED_SCALE, SPEED_UNIT, pyplot, set_readable_axis

#: Most panels of a fit figure; data with more size-mass groups share one panel.
MAX_PANELS = 16


def _groups(data: RestitutionData) -> list[tuple[float | None, float | None, np.ndarray]]:
    """(R_bar [m], M_bar [kg], mask) of each distinct size-mass pair of the data."""
    if data.R_bar is None or data.M_bar is None:   # not data.has_sizes
        return [(None, None, np.ones(len(data), dtype=bool))]
    pairs = np.column_stack([data.R_bar, data.M_bar])
    unique = np.unique(pairs, axis=0)
    return [(float(r), float(m), (data.R_bar == r) & (data.M_bar == m)) for r, m in unique]


def _panels(data: RestitutionData
            ) -> tuple[list[tuple[float | None, float | None, np.ndarray]], bool]:
    """The panels (R_bar [m], M_bar [kg], mask of the points shown) and whether the data
    share one panel: more than `MAX_PANELS` size-mass groups (so the data have sizes) are
    drawn together, with the curves at the median R_bar and M_bar."""
    groups = _groups(data)
    if len(groups) <= MAX_PANELS or data.R_bar is None or data.M_bar is None:
        return groups, False
    return [(float(np.median(data.R_bar)), float(np.median(data.M_bar)),
             np.ones(len(data), dtype=bool))], True


def _fitted_values(result: dict) -> dict[str, float]:
    """A fit's parameter values by name (SI)."""
    return {name: entry["value"] for name, entry in result["parameters"].items()}


def plot_fits(data: RestitutionData, results: Sequence[dict], path: str | Path) -> Path:
    """Write `fit_figure` as a PNG at ``path``; returns the path."""
    return common.save_figure(fit_figure(data, results), path)  # looked up when called


def fit_figure(data: RestitutionData, results: Sequence[dict]):
    """Data (with error bars if sigma is known) against impact speed and each fitted curve,
    one panel per (R_bar, M_bar) group of the data (a matplotlib Figure).

    Parameters
    ----------
    data : RestitutionData
    results : fits (``analysis.fit.fit_model`` dicts), drawn in order
    """
    plt = pyplot()
    panels, shared = _panels(data)
    ncols = min(len(panels), 4)
    nrows = math.ceil(len(panels) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols + 0.8, 3.6 * nrows + 0.6),
                             squeeze=False, sharey=True)
    v_curve = np.geomspace(data.v.min() / 1.5, data.v.max() * 1.5, 300)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (r_bar, m_bar, mask) in zip(axes.flat, panels, strict=False):
        err = data.sigma[mask] if data.sigma is not None else None
        ax.errorbar(data.v[mask] / SPEED_SCALE, data.epsilon[mask], yerr=err, fmt="o", ms=3,
                    color="k", ecolor="0.6", elinewidth=0.8, label="data", zorder=3)
        curve_data = RestitutionData(
            v=v_curve, epsilon=np.zeros_like(v_curve),
            R_bar=None if r_bar is None else np.full_like(v_curve, r_bar),
            M_bar=None if m_bar is None else np.full_like(v_curve, m_bar))
        for i, result in enumerate(results):
            if result["model"] == "dilley" and r_bar is None:
                continue
            ax.plot(v_curve / SPEED_SCALE,
                    curve_data.law_epsilon({"model": result["model"], **_fitted_values(result)}),
                    color=colours[(i + 1) % len(colours)],
                    label=f"{result['model']} (AIC {result['aic']:.4g})")
        set_readable_axis(ax, "x", v_curve / SPEED_SCALE, log=True, pad=0.0)
        ax.set_ylim(-0.02, 1.05)
        ax.set_xlabel(f"normal impact speed v [{SPEED_UNIT}]")
        ax.set_ylabel("coefficient of restitution ε [dimensionless]")
        if r_bar is not None:
            title = f"R̄ = {r_bar:.4g} m, M̄ = {m_bar:.4g} kg"
            ax.set_title(("curves at the median: " if shared else "") + title, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"Restitution fits to {Path(data.source).name}")
    return fig
