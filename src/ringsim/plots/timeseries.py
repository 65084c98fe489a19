"""Figures against time: velocity dispersion, thickness, collision rate, filling factor,
the velocity ellipsoid and the per-size velocity dispersion and thickness.

Every builder takes a list of ``(run, eq, style)`` entries (a run file, its
``ringsim.equilibrium`` and a `common.run_style`) and returns a matplotlib Figure; the
equilibrium window of a run is shaded (its colour and hatch) only when the run is in
equilibrium.
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.analysis import timeseries as ts_stats
from ringsim.analysis.collisions import collision_frequency
from ringsim.plots.common import (
    SPEED_SCALE,
    axis_label,
    equilibrium_note,
    equilibrium_start,
    label_fontsize,
    pyplot,
    secondary_scaled_axis,
    set_readable_axis,
    shade_equilibrium,
    wrapped,
)


def collision_rate(run) -> np.ndarray:
    """Collisions per particle per orbit in each output interval [1/orbit] (NaN for row 0,
    which has no interval), by ``collisions.collision_frequency``."""
    ts = run.timeseries
    n = int(run.snapshot(0)["radius"].size)
    Omega = run.scenario.orbital_frequency
    t = ts["t"]
    rate = np.full(t.size, np.nan)
    for i in range(1, t.size):
        if t[i] > t[i - 1]:
            rate[i] = collision_frequency(float(ts["collisions"][i]), n, t[i] - t[i - 1], Omega)
    return rate


def velocity_ellipsoid(sigma_xx, sigma_yy, sigma_zz, sigma_xy) -> dict:
    """Shape of the velocity ellipsoid from the dispersion tensor's components.

    Parameters
    ----------
    sigma_xx, sigma_yy, sigma_zz, sigma_xy : array [m^2/s^2]
        Second moments of the peculiar velocity (as stored in ``/timeseries``).

    Returns
    -------
    dict of arrays
        ``major``, ``minor`` [m/s]: rms speeds along the principal axes in the x-y plane;
        ``vertical`` [m/s] = sqrt(sigma_zz); ``minor_over_major`` and
        ``vertical_over_major`` [dimensionless]; ``tilt`` [rad] = 0.5 atan2(2 sigma_xy,
        sigma_xx - sigma_yy), the angle of the major axis from the radial (x) direction
        towards y.
    """
    sxx, syy, szz, sxy = (np.asarray(a, dtype=float) for a in
                          (sigma_xx, sigma_yy, sigma_zz, sigma_xy))
    half_trace = 0.5 * (sxx + syy)
    radius = np.hypot(0.5 * (sxx - syy), sxy)
    major = np.sqrt(np.clip(half_trace + radius, 0.0, None))
    minor = np.sqrt(np.clip(half_trace - radius, 0.0, None))
    vertical = np.sqrt(np.clip(szz, 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        return {"major": major, "minor": minor, "vertical": vertical,
                "minor_over_major": minor / major, "vertical_over_major": vertical / major,
                "tilt": 0.5 * np.arctan2(2.0 * sxy, sxx - syy)}


def window_mean(values: np.ndarray, orbits: np.ndarray, eq: dict) -> tuple[float, float] | None:
    """Mean and autocorrelation-corrected standard error of ``values`` over the equilibrium
    window (``timeseries.autocorrelated_mean``); None when the run is not in equilibrium."""
    start = equilibrium_start(eq)
    if start is None:
        return None
    mean, stderr, _ = ts_stats.autocorrelated_mean(np.asarray(values)[orbits >= start])
    return float(mean), float(stderr)


def _common_scale(values: list[float]) -> float | None:
    """The shared value of a list (e.g. <r> Omega of every run), or None if they differ."""
    if values and all(math.isclose(v, values[0], rel_tol=1e-9) for v in values):
        return values[0]
    return None


def time_panel(ax, entries, series, label, secondary=None, log=None):
    """One quantity of every run against time, with equilibrium windows and means."""
    everything = []
    for run, eq, style in entries:
        orbits, values = run.timeseries["orbits"], series(run)
        ax.plot(orbits[1:], values[1:], color=style["color"], linestyle=style["linestyle"],
                linewidth=1.0, label=eq["name"])
        everything.append(values[1:])
        shade_equilibrium(ax, eq, float(orbits[-1]), style)
        mean = window_mean(values, orbits, eq)
        if mean is not None:
            ax.axhline(mean[0], color=style["color"], linestyle="--", linewidth=0.8)
    is_log = set_readable_axis(ax, "y", np.concatenate(everything), log=log)
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
    if secondary is not None:
        scale, sec_label = secondary
        secondary_scaled_axis(ax, "y", scale, sec_label, is_log)
    return is_log


def timeseries_figure(entries, title: str):
    """c [mm/s], H [m], collision rate [1/orbit] and filling factor against time [orbits]."""
    plt = pyplot()
    fig, axes = plt.subplots(4, 1, figsize=(9, 10.5), sharex=True)
    r_omega = _common_scale([eq["mean_radius"] * run.scenario.orbital_frequency
                             for run, eq, _ in entries])
    r_mean = _common_scale([eq["mean_radius"] for _run, eq, _ in entries])
    time_panel(axes[0], entries, lambda run: run.timeseries["velocity_dispersion"] / SPEED_SCALE,
           axis_label("velocity_dispersion"),
           None if r_omega is None else (r_omega / SPEED_SCALE, "c / (⟨r⟩Ω) [dimensionless]"))
    time_panel(axes[1], entries, lambda run: run.timeseries["thickness"], axis_label("thickness"),
           None if r_mean is None else (r_mean, "H / ⟨r⟩ [dimensionless]"))
    time_panel(axes[2], entries, collision_rate, "collision rate\n[per particle per orbit]")
    time_panel(axes[3], entries, lambda run: run.timeseries["filling_factor"],
           axis_label("filling_factor", "\n"), log=False)
    orbits = np.concatenate([run.timeseries["orbits"] for run, _eq, _s in entries])
    set_readable_axis(axes[3], "x", orbits, log=False, pad=0.0, include_zero=True, max_ticks=8)
    axes[3].set_xlabel("time [orbits]")
    axes[0].legend(fontsize=label_fontsize(len(entries)), loc="best")
    fig.suptitle(wrapped(f"{title}\nshaded: equilibrium window, dashed: its mean  "
                         f"({equilibrium_note([eq for _r, eq, _s in entries])})"), fontsize=9)
    return fig


def ellipsoid_figure(entries):
    """Axis ratios and tilt of the velocity ellipsoid against time, with equilibrium means."""
    plt = pyplot()
    fig, (ax_r, ax_t) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    ratios, tilts = [], []
    for run, eq, style in entries:
        ts = run.timeseries
        orbits = ts["orbits"]
        shape = velocity_ellipsoid(ts["sigma_xx"], ts["sigma_yy"], ts["sigma_zz"],
                                   ts["sigma_xy"])
        tilt_deg = np.degrees(shape["tilt"])
        for ax, key, values, linestyle, what in (
                (ax_r, "minor", shape["minor_over_major"], "-", "minor/major (x-y plane)"),
                (ax_r, "vertical", shape["vertical_over_major"], ":", "vertical/major"),
                (ax_t, "tilt", tilt_deg, "-", "tilt")):
            mean = window_mean(values, orbits, eq)
            text = "" if mean is None else f" = {mean[0]:.3f} ± {mean[1]:.2g}"
            if key == "tilt" and mean is not None:
                text = f" = {mean[0]:.1f} ± {mean[1]:.1g}°"
            ax.plot(orbits[1:], values[1:], color=style["color"], linestyle=linestyle,
                    linewidth=1.0, label=f"{eq['name']}: {what}{text}")
            if mean is not None:
                ax.axhline(mean[0], color=style["color"], linestyle="--", linewidth=0.8)
        for ax in (ax_r, ax_t):
            shade_equilibrium(ax, eq, float(orbits[-1]), style)
        ratios.append(np.concatenate([shape["minor_over_major"][1:],
                                      shape["vertical_over_major"][1:]]))
        tilts.append(tilt_deg[1:])
    set_readable_axis(ax_r, "y", np.concatenate(ratios + [[0.0, 1.0]]), log=False, pad=0.03)
    set_readable_axis(ax_t, "y", np.concatenate(tilts + [[0.0]]), log=False)
    set_readable_axis(ax_t, "x", np.concatenate([r.timeseries["orbits"] for r, _e, _s in
                                                 entries]), log=False, pad=0.0,
                      include_zero=True, max_ticks=8)
    ax_r.set_ylabel("axis ratio of the velocity\nellipsoid [dimensionless]")
    ax_t.set_ylabel("tilt of the major axis\nfrom radial (x) [deg]")
    ax_t.set_xlabel("time [orbits]")
    for ax in (ax_r, ax_t):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=label_fontsize(3 * len(entries)), loc="best")
    fig.suptitle(wrapped("Velocity ellipsoid: principal rms speeds in the x-y plane and "
                         "vertical; tilt = ½ atan2(2σxy, σxx − σyy)\n(means ± standard errors "
                         "over the equilibrium window; "
                         f"{equilibrium_note([eq for _r, eq, _s in entries])})", width=105),
                 fontsize=9)
    return fig


def size_label(r_low: float, r_high: float, radii: np.ndarray | None) -> str:
    """Legend text of a size bin: the species' radius for a single radius, else the range."""
    if radii is not None and radii.size and np.ptp(radii) <= 1e-9 * radii.max():
        return f"r = {radii[0]:.3g} m"
    return f"r = {r_low:.3g}–{r_high:.3g} m"


def size_bin_radii(radius: np.ndarray, edges: np.ndarray) -> list[np.ndarray]:
    """The radii [m] of the particles in each size bin (edges [m]; last bin closed)."""
    idx = np.clip(np.searchsorted(edges, radius, side="right") - 1, 0, edges.size - 2)
    return [radius[idx == k] for k in range(edges.size - 1)]


def per_size_timeseries_figure(run, eq: dict):
    """c and H of each size bin against time (one colour per bin)."""
    plt = pyplot()
    ts = run.timeseries
    orbits, edges = ts["orbits"], ts["size_bin_edges"]
    radii = size_bin_radii(run.snapshot(0)["radius"], edges)
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, edges.size - 1))
    fig, (ax_c, ax_h) = plt.subplots(2, 1, figsize=(11, 7.5), sharex=True)
    for ax, key, scale in ((ax_c, "size_bin_velocity_dispersion", SPEED_SCALE),
                           (ax_h, "size_bin_thickness", 1.0)):
        values = ts[key] / scale
        for k in range(edges.size - 1):
            ax.plot(orbits[1:], values[1:, k], color=colours[k], linewidth=1.0,
                    label=f"{size_label(edges[k], edges[k + 1], radii[k])} "
                          f"(n = {radii[k].size})")
        shade_equilibrium(ax, eq, float(orbits[-1]), {"color": "0.3", "hatch": "//"})
        set_readable_axis(ax, "y", values[1:])
        ax.grid(alpha=0.3)
    ax_c.set_ylabel(axis_label("velocity_dispersion"))
    ax_h.set_ylabel(axis_label("thickness"))
    set_readable_axis(ax_h, "x", orbits, log=False, pad=0.0, include_zero=True, max_ticks=8)
    ax_h.set_xlabel("time [orbits]")
    ax_c.legend(fontsize=label_fontsize(edges.size - 1), loc="upper left",
                bbox_to_anchor=(1.01, 1.0), title="size bin")
    fig.suptitle(wrapped(f"{eq['name']}: per size bin ({equilibrium_note([eq])})"), fontsize=9)
    return fig
