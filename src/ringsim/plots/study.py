"""Figure of a study (``ringsim study``): its ratios, one point per equilibrium quantity.

Each ratio of the study (numerator case / denominator case) is one series: its value for
every quantity of the report, a thick error bar for the statistical error and a thin one
for the total (statistical and systematic in quadrature, where measured).  Where its cases
have two or more seeds in common, an open marker beside it gives the seed-paired ratio
with its statistical error.  A variant whose budget is ``range`` (a model parameter at the
other end of the range its value is known within) is a cross joined to the ratio by a
dotted line: the ratio moved by the variant's relative shift over the variant seeds, the
other end of the range, not an error.  The ratios are
pure numbers; the dashed line marks 1 (no change).  The legend sits above the axes, off
the data.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ringsim.analysis.equilibrium import TABLE_ROWS
from ringsim.plots.common import pyplot, run_style, save_figure, set_readable_axis


def _finite(x) -> float:
    return float(x) if x is not None and math.isfinite(x) else math.nan


def _paired_series(ax, entries: list[Mapping], x, style: Mapping, label: str) -> list[float]:
    """The seed-paired ratios (open markers, their statistical error) beside the ratios of
    the seed means, where two or more seeds are common; the values they reach."""
    paired = [e.get("paired") or {} for e in entries]
    if not any(p.get("n_replicas", 0) > 1 for p in paired):
        return []
    mean = np.array([_finite(p.get("mean")) for p in paired])
    err = np.nan_to_num(np.array([_finite(p.get("stderr")) for p in paired]))
    ax.errorbar(x, mean, yerr=err, fmt=style["marker"], color=style["color"],
                markerfacecolor="white", elinewidth=1.4, capsize=2, label=label)
    return list(mean - err) + list(mean + err)


def _range_series(ax, entries: list[Mapping], x, style: Mapping, label: str) -> list[float]:
    """The ratios moved by each ``range`` variant's relative shift (crosses, dotted to the
    ratio); the values they reach."""
    reach: list[float] = []
    mean = np.array([_finite(e["mean"]) for e in entries])
    for variant in dict.fromkeys(v for e in entries for v in e.get("range_parts", {})):
        parts = [e.get("range_parts", {}).get(variant, {}) for e in entries]
        moved = mean * np.array([_finite(p.get("ratio")) / _finite(p.get("ratio_without"))
                                 if _finite(p.get("ratio_without")) else math.nan
                                 for p in parts])
        ax.vlines(x, np.fmin(mean, moved), np.fmax(mean, moved), colors=style["color"],
                  linestyles=":", linewidth=1.0)
        ax.plot(x, moved, "x", color=style["color"], markersize=7,
                label=f"{label} with {variant} (range)")
        reach += list(moved)
    return reach


def ratio_figure(report: Mapping):
    """The figure of a study's ``report.json`` content; None without ratios."""
    entries = report["ratios"]
    if not entries:
        return None
    plt = pyplot()
    quantities = list(report["quantities"])
    pairs = list(dict.fromkeys((e["numerator"], e["denominator"]) for e in entries))
    by = {(e["numerator"], e["denominator"], e["quantity"]): e for e in entries}
    fig, ax = plt.subplots(figsize=(max(6.0, 1.0 * len(quantities) + 2.5), 5.2),
                           layout="constrained")
    width = 0.6 / max(len(pairs), 1)
    shown = [1.0]
    for i, (num, den) in enumerate(pairs):
        style = run_style(i)
        x = np.arange(len(quantities)) + (i - (len(pairs) - 1) / 2) * width
        mean = np.array([_finite(by[(num, den, q)]["mean"]) for q in quantities])
        stat = np.array([_finite(by[(num, den, q)]["stat"]) for q in quantities])
        total = np.array([_finite(by[(num, den, q)]["total"]) for q in quantities])
        total = np.where(np.isfinite(total), total, stat)
        ax.errorbar(x, mean, yerr=total, fmt="none", ecolor=style["color"], elinewidth=0.9,
                    capsize=4)
        ax.errorbar(x, mean, yerr=stat, fmt=style["marker"], color=style["color"],
                    elinewidth=2.6, capsize=0, label=f"{num} / {den}")
        reach = np.nan_to_num(total)   # a ratio without an error (one seed) is still shown
        shown += list(mean - reach) + list(mean + reach)
        shown += _paired_series(ax, [by[(num, den, q)] for q in quantities], x + width / 3,
                                style, f"{num} / {den}, seed-paired")
        shown += _range_series(ax, [by[(num, den, q)] for q in quantities], x - width / 3,
                               style, f"{num} / {den}")
    ax.axhline(1.0, color="0.4", linestyle="--", linewidth=0.8, label="1 (no change)")
    positive = [v for v in shown if math.isfinite(v) and v > 0]
    set_readable_axis(ax, "y", positive if len(positive) == len(shown) else shown)
    ax.set_xticks(range(len(quantities)))
    ax.set_xticklabels([TABLE_ROWS[q][0] for q in quantities], rotation=30, ha="right")
    ax.set_xlim(-0.6, len(quantities) - 0.4)
    ax.set_xlabel("equilibrium quantity (each ratio divides like by like)")
    ax.set_ylabel("ratio [dimensionless]")
    ax.grid(axis="y", color="0.9")
    form = f"{report['form']} form" + (", partial" if report.get("partial") else "")
    paired = any((e.get("paired") or {}).get("n_replicas", 0) > 1 for e in entries)
    title = (f"study {report['study']} ({form}): thick bars statistical, "
             "thin bars total error" + ("\nopen markers: the seed-paired ratio" if paired
                                        else ""))
    if any(e.get("range_parts") for e in entries):
        title += "\ncrosses: the other end of a model parameter's range"
    for ncols in range(min(len(pairs) + 1, 4), 0, -1):   # the most columns that fit
        legend = fig.legend(loc="outside upper center", ncols=ncols, frameon=False,
                            title=title)
        fig.draw_without_rendering()
        if ncols == 1 or legend.get_window_extent().width <= fig.bbox.width:
            break
        legend.remove()
    return fig


def plot_ratios(report: Mapping, directory: str | Path) -> Path | None:
    """Write ``ratios.png`` into ``directory``; None (nothing written) without ratios."""
    fig = ratio_figure(report)
    return None if fig is None else save_figure(fig, Path(directory) / "ratios.png")
