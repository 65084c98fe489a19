"""What every ringsim figure shares: the speed unit, axis scales and ticks chosen from the
data, one style per run, the equilibrium window, and `save_figure`.

Units of the figures (all commands): speeds in mm/s (velocity dispersions, impact speeds
of the restitution laws and of the fit data), lengths in m, time in orbits; quantities
scaled by the mean radius <r> or by <r> Omega say so in their label.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from ringsim.quantities import QUANTITY, SPEED_FACTOR, SPEED_SHOWN

#: The speed unit of every figure (``ringsim.quantities``), and its size in m/s.
SPEED_UNIT = SPEED_SHOWN
SPEED_SCALE = 1.0 / SPEED_FACTOR  # [m/s] per SPEED_UNIT

#: Hatches that tell runs apart where their shaded windows overlap.
HATCHES = ("//", "\\\\", "xx", "..", "++", "oo", "--", "||")


def axis_label(name: str, separator: str = " ") -> str:
    """The axis label of a quantity declared in ``ringsim.quantities``: its label, then its
    shown unit in brackets (``separator`` between them, e.g. a line break)."""
    return QUANTITY[name].axis_label(separator)


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def lay_out(fig) -> None:
    """Lay out ``fig`` as it is saved: its own layout engine, or else ``tight_layout``."""
    if not fig.get_layout_engine():
        fig.tight_layout()


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it as a PNG (creating the folder) and close it."""
    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lay_out(fig)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def run_style(index: int) -> dict:
    """Colour, hatch, marker and line style of the ``index``-th run of a figure."""
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
               "tab:pink", "tab:gray", "tab:olive", "tab:cyan")
    return {"color": colours[index % len(colours)], "hatch": HATCHES[index % len(HATCHES)],
            "marker": "osD^v<>p"[index % 8],
            "linestyle": ("-", "--", "-.", ":")[(index // len(colours)) % 4]}


# --- readable axes -------------------------------------------------------------------------

def _finite_range(values) -> tuple[float, float] | None:
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    return float(v.min()), float(v.max())


def _decimal_label(value: float, decimals: int) -> str:
    text = f"{value:.{max(decimals, 0)}f}"
    return "0" if float(text) == 0.0 else text


def _power_label(value: float) -> str:
    exponent = int(round(math.log10(value)))
    if -3 <= exponent <= 4:
        return f"{value:g}"
    mantissa = value / 10.0 ** exponent
    if abs(mantissa - 1.0) < 1e-9:
        return f"$10^{{{exponent}}}$"
    return f"${mantissa:g}\\times10^{{{exponent}}}$"


#: Mantissas of the labelled ticks of a log axis, densest last: a range under a decade or
#: two gets the finer ones, so that every axis carries at least three labels.
_LOG_MANTISSAS = ((1.0, 2.0, 5.0), (1.0, 3.0), (1.0,), (1.0, 1.5, 2.0, 3.0, 5.0, 7.0))


def _log_ticks(lo: float, hi: float, max_ticks: int) -> list[float]:
    decades = math.log10(hi / lo)
    e_lo, e_hi = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    sets = [[m * 10.0 ** e for e in range(e_lo, e_hi + 1) for m in subs
             if lo * (1 - 1e-9) <= m * 10.0 ** e <= hi * (1 + 1e-9)]
            for subs in _LOG_MANTISSAS]
    for ticks in sets:
        if 3 <= len(ticks) <= max_ticks:
            return ticks
    if decades < 1.0:   # under a decade: evenly spaced plain numbers, as on a linear axis
        from matplotlib import ticker

        even = [t for t in ticker.MaxNLocator(nbins=max_ticks - 1, steps=[1, 2, 2.5, 5, 10])
                .tick_values(lo, hi) if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
        if len(even) >= 3:
            return even
    for ticks in sets:
        if 2 <= len(ticks) <= max_ticks:
            return ticks
    step = max(1, math.ceil(decades / (max_ticks - 1)))
    ticks = [10.0 ** e for e in range(e_lo, e_hi + 1) if e % step == 0
             and lo * (1 - 1e-9) <= 10.0 ** e <= hi * (1 + 1e-9)]
    return ticks if len(ticks) >= 2 else [lo, hi]


def set_readable_axis(ax, which: str, values, log: bool | None = None, max_ticks: int = 6,
                      pad: float = 0.06, include_zero: bool = False) -> bool:
    """Scale, limits and tick labels of one axis chosen from the data it shows.

    Log scale when ``log`` is None, the data are positive and span more than a factor of 4;
    at most ``max_ticks`` labelled ticks with plain numbers (``0.5 1 2 5``, ``1.00 1.05
    1.10``, powers of ten as ``10^-5``), unlabelled minor ticks, so that labels never run
    into each other for any data range.

    Parameters
    ----------
    ax : matplotlib Axes
    which : "x" or "y"
    values : array of the plotted values (any unit; non-finite ignored)
    log : bool or None
    max_ticks : int
    pad : fraction of the range (linear) or of a decade (log) added on both sides
    include_zero : a linear axis reaches down (or up) to 0

    Returns
    -------
    bool : whether the axis is logarithmic
    """
    axis = ax.xaxis if which == "x" else ax.yaxis
    set_scale = ax.set_xscale if which == "x" else ax.set_yscale
    set_lim = ax.set_xlim if which == "x" else ax.set_ylim
    rng = _finite_range(values)
    if rng is None:
        return False
    lo, hi = rng
    if log is None:
        log = lo > 0 and hi / lo > 4.0
    if log and lo <= 0:
        log = False
    if log:
        factor = 10.0 ** max(pad, 0.02)
        lo, hi = lo / factor, hi * factor
    else:
        if include_zero:
            lo, hi = min(lo, 0.0), max(hi, 0.0)
        span = hi - lo
        if span <= 0:
            span = abs(hi) * 0.1 or 1.0
        lo, hi = lo - pad * span, hi + pad * span
        if include_zero and rng[0] >= 0:
            lo = 0.0
    set_scale("log" if log else "linear")
    set_lim(lo, hi)
    readable_ticks(axis, lo, hi, log, max_ticks)
    return log


def readable_ticks(axis, lo: float, hi: float, log: bool, max_ticks: int = 6) -> None:
    """At most ``max_ticks`` labelled ticks in [lo, hi] with plain labels on a matplotlib
    Axis (also a secondary axis), minor ticks unlabelled."""
    from matplotlib import ticker

    lo, hi = min(lo, hi), max(lo, hi)
    if log:
        ticks = _log_ticks(lo, hi, max_ticks)
        axis.set_major_locator(ticker.FixedLocator(ticks))
        axis.set_major_formatter(ticker.FuncFormatter(lambda v, _pos: _power_label(v)))
        axis.set_minor_locator(ticker.LogLocator(base=10.0, subs="auto", numticks=50))
        axis.set_minor_formatter(ticker.NullFormatter())
        return
    span = hi - lo
    for nbins in range(max_ticks - 1, 2 * max_ticks):   # finer steps until 3 fall inside
        locator = ticker.MaxNLocator(nbins=nbins, steps=[1, 2, 2.5, 5, 10])
        ticks = [t for t in locator.tick_values(lo, hi)
                 if lo - 1e-9 * span <= t <= hi + 1e-9 * span]
        if len(ticks) >= 3:
            break
    step = ticks[1] - ticks[0] if len(ticks) > 1 else span
    decimals = next((d for d in range(12) if abs(round(step, d) - step) <= 1e-6 * step), 12)
    biggest = max(abs(lo), abs(hi))
    if biggest >= 1e5 or biggest < 1e-3:
        # very large or small numbers: one exponent in the corner instead of long labels
        formatter = ticker.ScalarFormatter(useMathText=True)
        formatter.set_powerlimits((-3, 4))
        axis.set_major_formatter(formatter)
    else:
        axis.set_major_formatter(ticker.FuncFormatter(
            lambda v, _pos: _decimal_label(v, decimals)))
    axis.set_major_locator(ticker.FixedLocator(ticks))
    axis.set_minor_locator(ticker.AutoMinorLocator())
    axis.set_minor_formatter(ticker.NullFormatter())


def secondary_scaled_axis(ax, which: str, scale: float, label: str, log: bool):
    """A second axis on the right (``which="y"``) or top showing the primary values divided
    by ``scale`` (e.g. c / (<r> Omega) next to c [mm/s]); readable ticks."""
    make = ax.secondary_yaxis if which == "y" else ax.secondary_xaxis
    sec = make("right" if which == "y" else "top",
               functions=(lambda v: np.asarray(v) / scale, lambda v: np.asarray(v) * scale))
    lo, hi = ax.get_ylim() if which == "y" else ax.get_xlim()
    readable_ticks(sec.yaxis if which == "y" else sec.xaxis, lo / scale, hi / scale, log)
    (sec.set_ylabel if which == "y" else sec.set_xlabel)(label)
    return sec


# --- the equilibrium window ----------------------------------------------------------------

def equilibrium_start(eq: dict) -> float | None:
    """First orbit of the equilibrium window, or None when the run is not in equilibrium."""
    start = eq["equilibrium_from_orbit"]["mean"]
    if not eq.get("in_equilibrium", False) or not math.isfinite(start):
        return None
    return float(start)


def shade_equilibrium(ax, eq: dict, end_orbit: float, style: dict, label: str | None = None):
    """Shade the equilibrium window of a run (its colour and hatch); nothing when the run is
    not in equilibrium.  Returns the patch or None."""
    start = equilibrium_start(eq)
    if start is None:
        return None
    from matplotlib.colors import to_rgba

    return ax.axvspan(start, end_orbit, facecolor=to_rgba(style["color"], 0.06),
                      edgecolor=to_rgba(style["color"], 0.35), hatch=style["hatch"],
                      linewidth=0.0, label=label, zorder=0)


def equilibrium_note(equilibria: list[dict]) -> str:
    """A short line saying which runs are in equilibrium (for titles)."""
    parts = []
    for eq in equilibria:
        start = equilibrium_start(eq)
        if start is None:
            parts.append(f"{eq['name']}: NOT in equilibrium, no window")
        else:
            parts.append(f"{eq['name']}: equilibrium from orbit {start:.3g}")
    return "; ".join(parts)


def wrapped(text: str, width: int = 100) -> str:
    """``text`` broken into lines of at most ``width`` characters (existing breaks kept),
    so that titles naming many runs stay inside the figure."""
    return "\n".join(textwrap.fill(line, width) for line in text.split("\n"))


def label_fontsize(n: int) -> float:
    """Legend font size for ``n`` entries."""
    return 8.0 if n <= 6 else 7.0 if n <= 10 else 6.0


def short_run_labels(names: list[str]) -> tuple[list[str], str]:
    """Legend labels of several runs and the one caption that holds what they share.

    Run names made by a sweep or a study join the base name and the point's values with
    ``_`` (``tutorial-kappa_restitution.kappa=0.1``).  The labels keep the parts that differ
    between the runs, a dotted key shortened to its last part (``kappa=0.1``); the caption
    gives the shared parts once (``tutorial-kappa``).  Names that share nothing, or whose
    short forms would coincide, are returned unchanged with an empty caption.
    """
    parts = [name.split("_") for name in names]
    if len(names) < 2 or len({len(p) for p in parts}) != 1:
        return list(names), ""
    shared = [i for i in range(len(parts[0])) if len({p[i] for p in parts}) == 1]
    if not shared:
        return list(names), ""

    def short(part: str) -> str:
        key, equals, value = part.partition("=")
        return f"{key.rsplit('.', 1)[-1]}={value}" if equals else part

    labels = [", ".join(short(p[i]) for i in range(len(p)) if i not in shared) for p in parts]
    if len(set(labels)) != len(labels) or not all(labels):
        return list(names), ""
    return labels, ", ".join(parts[0][i] for i in shared)
