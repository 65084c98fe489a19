"""The ``compare`` figures of what only some runs have: Toomre Q and the self-gravity wakes
of gravitating runs, the spins of rough runs.

Each figure overlays the runs that have the quantity (each run in its own colour and line
style, its equilibrium window shaded and its mean dashed, as in ``compare_timeseries.png``)
and is made only when at least one run has it.
"""

from __future__ import annotations

import numpy as np

from ringsim.plots.common import equilibrium_note, pyplot, set_readable_axis, wrapped
from ringsim.plots.timeseries import time_panel

#: The wake statistics of a gravitating run's equilibrium: key, axis label, scale.
WAKE_QUANTITIES = (
    ("wake_wavelength", "wake spacing λ_wake / λ_cr [dimensionless]", "lambda_cr"),
    ("wake_pitch_angle", "pitch angle from the azimuth [deg]", None),
    ("wake_amplitude", "density contrast of the wakes [dimensionless]", None),
)


def _time_axis(ax, entries) -> None:
    orbits = np.concatenate([run.timeseries["orbits"] for run, _eq, _s in entries])
    set_readable_axis(ax, "x", orbits, log=False, pad=0.0, include_zero=True, max_ticks=8)
    ax.set_xlabel("time [orbits]")


def _title(fig, what: str, entries) -> None:
    fig.suptitle(wrapped(f"{what}\nshaded: equilibrium window, dashed: its mean  "
                         f"({equilibrium_note([eq for _r, eq, _s in entries])})", width=95),
                 fontsize=9)


def toomre_figure(entries):
    """Toomre Q against time of the gravitating runs (a matplotlib Figure)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.8))
    time_panel(ax, entries, lambda run: run.timeseries["toomre_Q"],
               "Toomre Q = σ_x Ω / (3.36 G Σ), number-weighted\n[dimensionless]")
    _time_axis(ax, entries)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    _title(fig, "Toomre Q of the gravitating runs", entries)
    return fig


def spin_comparison_figure(entries):
    """E_rot / E_tr and the rms spin |ω| / Ω against time of the rough runs."""
    plt = pyplot()
    fig, (ax_e, ax_w) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    time_panel(ax_e, entries, lambda run: run.timeseries["rotational_energy_ratio"],
               "E_rot / E_tr\n[dimensionless]")
    time_panel(ax_w, entries, lambda run: run.timeseries["rms_spin"],
               "rms spin |ω| / Ω (rotating frame)\n[dimensionless]")
    _time_axis(ax_w, entries)
    ax_e.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    _title(fig, "Spins of the rough runs", entries)
    return fig


def wake_comparison_figure(entries):
    """The equilibrium wake statistics of the gravitating runs side by side, each with its
    standard error (points at the run, one panel per statistic)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(WAKE_QUANTITIES), figsize=(4.2 * len(WAKE_QUANTITIES), 4.8))
    positions = np.arange(len(entries), dtype=float)
    for ax, (key, label, scale_key) in zip(axes, WAKE_QUANTITIES, strict=True):
        shown = []
        for x, (_run, eq, style) in zip(positions, entries, strict=True):
            scale = eq[scale_key]["mean"] if scale_key else 1.0
            value = eq[key]
            ax.errorbar([x], [value["mean"] / scale], yerr=[value["stderr"] / scale],
                        marker=style["marker"], color=style["color"], capsize=4)
            shown += [(value["mean"] - value["stderr"]) / scale,
                      (value["mean"] + value["stderr"]) / scale]
        set_readable_axis(ax, "y", shown, log=False)
        ax.set_xticks(positions)
        ax.set_xticklabels([eq["name"] for _r, eq, _s in entries], rotation=20, ha="right")
        ax.set_xlim(-0.6, len(entries) - 0.4)
        ax.set_xlabel("run")
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(wrapped("Self-gravity wakes over the equilibrium window (means ± standard "
                         "errors over its snapshots; λ_cr: Toomre's critical wavelength)\n"
                         f"({equilibrium_note([eq for _r, eq, _s in entries])})", width=95),
                 fontsize=9)
    return fig


def _measured(value) -> bool:
    """A statistic with a finite mean and standard error (a run without wakes has None)."""
    return bool(value) and all(isinstance(value.get(k), (int, float))
                               and np.isfinite(value[k]) for k in ("mean", "stderr"))


def extra_comparison_figures(entries) -> dict:
    """File name -> Figure of the compare figures that some runs have (none if no run
    has them): Toomre Q and wakes of gravitating runs, spins of rough runs."""
    figures = {}
    gravitating = [e for e in entries if "toomre_Q" in e[1] and "toomre_Q" in e[0].timeseries]
    if gravitating:
        figures["compare_toomre_q.png"] = toomre_figure(gravitating)
    waking = [e for e in gravitating if all(_measured(e[1].get(k)) for k, _l, _s in
                                            WAKE_QUANTITIES)]
    if waking:
        figures["compare_wakes.png"] = wake_comparison_figure(waking)
    rough = [e for e in entries if e[1].get("spin") and "rms_spin" in e[0].timeseries]
    if rough:
        figures["compare_spins.png"] = spin_comparison_figure(rough)
    return figures
