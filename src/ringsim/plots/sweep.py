"""Figure of a sweep (``ringsim sweep --plots DIR``): equilibrium c and H against the swept
parameter, from the sweep's ``summary.h5``.

The x axis is the first grid key that is not ``seed`` (``seed`` itself if it is the only
key); points that differ in further keys become separate series; repeated seeds sit side
by side around their x value with their own error bars (standard errors of each run), and
a black bar gives the mean over seeds with the standard error of that mean from the
run-to-run scatter.  Points not in equilibrium are drawn as open markers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ringsim.plots.common import (
    SPEED_SCALE,
    axis_label,
    label_fontsize,
    pyplot,
    run_style,
    save_figure,
    set_readable_axis,
)


def read_summary(path: str | Path) -> dict:
    """The columns of a sweep's ``summary.h5`` as numpy arrays, with ``grid_keys``,
    ``units`` (column -> unit) and ``parameters`` (grid key -> array)."""
    import h5py

    with h5py.File(path, "r") as f:
        keys = [k.decode() if isinstance(k, bytes) else str(k) for k in f.attrs["grid_keys"]]
        out: dict[str, Any] = {"grid_keys": keys, "units": {}, "parameters": {}}
        for key in keys:
            ds = f["parameters"][key]
            out["parameters"][key] = ds.asstr()[...] if ds.dtype.kind == "O" else ds[...]
            out["units"][key] = str(ds.attrs.get("units", ""))
        for name, ds in f.items():
            if name == "parameters":
                continue
            out[name] = ds.asstr()[...] if ds.dtype.kind == "O" else ds[...]
            out["units"][name] = str(ds.attrs.get("units", ""))
    return out


def _axis_key(keys: list[str]) -> str:
    others = [k for k in keys if k != "seed"]
    return others[0] if others else keys[0]


def sweep_figure(summary: dict, title: str = ""):
    """c [mm/s] and H [m] in equilibrium against the swept parameter (see module doc)."""
    plt = pyplot()
    keys = summary["grid_keys"]
    x_key = _axis_key(keys)
    x_raw = summary["parameters"][x_key]
    numeric = np.issubdtype(np.asarray(x_raw).dtype, np.number)
    categories = [] if numeric else list(dict.fromkeys(x_raw.tolist()))   # a text key's values
    x = (np.asarray(x_raw, dtype=float) if numeric
         else np.array([categories.index(v) for v in x_raw.tolist()], dtype=float))
    series_keys = [k for k in keys if k not in (x_key, "seed")]
    series = [tuple(summary["parameters"][k][i] for k in series_keys) for i in range(x.size)]
    labels = list(dict.fromkeys(series))
    ok = summary["status"] == "finished"
    in_eq = summary["in_equilibrium"].astype(bool)
    fig, (ax_c, ax_h) = plt.subplots(1, 2, figsize=(12, 4.8))
    distinct = np.unique(x)
    gap = np.min(np.diff(distinct)) if distinct.size > 1 else 1.0
    log_x = numeric and np.all(distinct > 0) and distinct.max() / distinct.min() > 20
    for ax, stem, scale in ((ax_c, "velocity_dispersion_m_s", SPEED_SCALE),
                            (ax_h, "thickness_m", 1.0)):
        mean = summary[f"{stem}_mean"] / scale
        err = summary[f"{stem}_stderr"] / scale
        for j, label in enumerate(labels):
            style = run_style(j)
            members = np.array([s == label for s in series]) & ok
            name = ", ".join(f"{k} = {v}" for k, v in zip(series_keys, label, strict=True))
            for value in np.unique(x[members]):
                at = np.flatnonzero(members & (x == value))
                offsets = (np.arange(at.size) - (at.size - 1) / 2) * 0.06
                xs = value * 10.0 ** offsets if log_x else value + offsets * gap
                for xi, i in zip(xs, at, strict=True):
                    ax.errorbar(xi, mean[i], yerr=err[i], marker=style["marker"], ms=5,
                                color=style["color"], mfc=style["color"] if in_eq[i]
                                else "white", capsize=2, linewidth=0.8)
                if at.size > 1:
                    scatter = np.std(mean[at], ddof=1) / np.sqrt(at.size)
                    ax.errorbar(value, np.mean(mean[at]), yerr=scatter, marker="_", ms=18,
                                color="k", capsize=5, linewidth=1.2, zorder=4)
            means = [np.mean(mean[members & (x == v)]) for v in np.unique(x[members])]
            ax.plot(np.unique(x[members]), means, color=style["color"], linewidth=0.8,
                    label=name or "runs (error bars: standard errors)")
        values = np.concatenate([(mean - err)[ok], (mean + err)[ok]])
        set_readable_axis(ax, "y", values)
        if numeric:
            span = x[ok] if ok.any() else x
            set_readable_axis(ax, "x", np.concatenate([span * (1.15 if log_x else 1.0),
                                                       span / (1.15 if log_x else 1.0)]),
                              log=bool(log_x), pad=0.0 if log_x else 0.08)
        else:
            ax.set_xticks(range(len(categories)), [str(c) for c in categories])
            ax.set_xlim(-0.5, len(categories) - 0.5)
        unit = summary["units"].get(x_key, "")
        shown = "dimensionless" if unit in ("", "text") and numeric else unit
        ax.set_xlabel(f"{x_key} [{shown}]" if shown and shown != "text" else x_key)
        ax.grid(alpha=0.3, which="both")
    ax_c.set_ylabel(axis_label("velocity_dispersion"))
    ax_h.set_ylabel(axis_label("thickness"))
    ax_c.plot([], [], "o", mfc="white", color="0.3", label="open: NOT in equilibrium")
    if "seed" in keys:
        ax_c.plot([], [], "_", ms=12, color="k", label="black: mean over seeds ± scatter/√n")
    ax_c.legend(fontsize=label_fontsize(len(labels) + 2))
    n_bad = int(np.sum(~ok))
    fig.suptitle(f"{title}equilibrium against {x_key} ({int(ok.sum())} finished points"
                 + (f", {n_bad} not finished and not shown" if n_bad else "") + ")",
                 fontsize=10)
    return fig


def plot_sweep(summary_h5: str | Path, directory: str | Path) -> list[Path]:
    """Figures of a finished sweep from its ``summary.h5``; returns the PNG paths."""
    summary = read_summary(summary_h5)
    title = f"{Path(summary_h5).parent.name}: "
    return [save_figure(sweep_figure(summary, title), Path(directory) / "sweep.png")]
