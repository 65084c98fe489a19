"""Figures of the ring's structure in equilibrium: per-size equilibria, the distribution of
applied epsilon, velocity distributions, the vertical density profile and a picture of the
particles.

Snapshots are pooled over the equilibrium window (`window_snapshots`); a run that is not in
equilibrium contributes its last snapshot only, and the figure says so.
"""

from __future__ import annotations

import numpy as np

from ringsim.analysis.snapshot import peculiar_velocity, thickness
from ringsim.analysis.window import snapshots_from
from ringsim.plots.common import (
    SPEED_SCALE,
    SPEED_UNIT,
    axis_label,
    equilibrium_start,
    label_fontsize,
    pyplot,
    set_readable_axis,
    wrapped,
)
from ringsim.plots.timeseries import size_bin_radii

#: Side-view vertical stretch (displayed over true) within which particles are drawn as
#: ellipses to scale on both axes; beyond it they are markers (their size not to scale).
_TO_SCALE_STRETCH = (1.0 / 3.0, 10.0)


def window_snapshots(run, eq: dict) -> tuple[list[dict], str]:
    """The snapshots inside the equilibrium window, or the last one when the run is not in
    equilibrium (or no snapshot falls inside the window); with a phrase saying which."""
    period = run.scenario.orbital_period
    start = equilibrium_start(eq)
    if start is not None:
        indices, in_window = snapshots_from(run, (start - 1e-9) * period)
        if in_window:
            inside = [run.snapshot(i) for i in indices]
            return inside, (f"{len(inside)} snapshot{'s' if len(inside) > 1 else ''} of the "
                            f"equilibrium window (orbits ≥ {start:.3g})")
    last = run.snapshot(-1)
    why = "not in equilibrium" if start is None else "no snapshot inside the window"
    return [last], f"last snapshot only, orbit {last['t'] / period:.3g} ({why})"


def _equipartition_line(ax, radii: np.ndarray, c: np.ndarray) -> None:
    """Equipartition of random kinetic energy, c ∝ m^-1/2 (∝ r^-3/2 at one density),
    drawn through the point of the largest radius across the radii shown.

    radii : array [m], increasing; c : array of the bins' dispersions [figure speed unit]
    """
    if radii.size < 2 or not np.isfinite(c[-1]):
        return
    r = np.geomspace(radii.min(), radii.max(), 50)
    ax.plot(r, c[-1] * (r / radii[-1]) ** -1.5, color="0.45", linestyle="--", linewidth=1.0,
            label="equipartition c ∝ m$^{-1/2}$ (through the largest size)")


def size_bin_figure(entries):
    """Equilibrium c and H of each size bin against the mean radius of its particles.

    A point sits at the mean radius of the particles in its bin (a mixture's species at
    their radii); horizontal bars show the bin's range for continuous distributions.
    """
    plt = pyplot()
    fig, (ax_c, ax_h) = plt.subplots(1, 2, figsize=(11, 4.8))
    xs, ys = [], {"c": [], "h": []}
    for run, eq, style in entries:
        bins = eq["per_size_bin"]
        if not bins:
            continue
        edges = np.array([bins[0]["r_low"]] + [b["r_high"] for b in bins])
        radii = size_bin_radii(run.snapshot(0)["radius"], edges)
        has = np.array([r.size > 0 for r in radii])
        r_at = np.array([r.mean() if r.size else np.nan for r in radii])
        continuous = run.scenario.particles.size_distribution.kind != "mixture"
        xerr = (np.vstack([r_at - edges[:-1], edges[1:] - r_at]) if continuous else None)
        for ax, key, scale, tag in ((ax_c, "velocity_dispersion", SPEED_SCALE, "c"),
                                    (ax_h, "thickness", 1.0, "h")):
            mean = np.array([b[key]["mean"] for b in bins]) / scale
            err = np.array([b[key]["stderr"] for b in bins]) / scale
            ax.errorbar(r_at[has], mean[has], yerr=err[has],
                        xerr=None if xerr is None else xerr[:, has], marker=style["marker"],
                        color=style["color"], linestyle="-", linewidth=0.8, capsize=3,
                        label=eq["name"] + ("" if eq["in_equilibrium"] else
                                            " (NOT in equilibrium)"))
            ys[tag].append(np.concatenate([mean - err, mean + err])[np.tile(has, 2)])
        xs.append(edges if continuous else r_at[has])
        if run is entries[0][0]:   # one reference line, through the first run's points
            c_bins = np.array([b["velocity_dispersion"]["mean"] for b in bins]) / SPEED_SCALE
            _equipartition_line(ax_c, r_at[has], c_bins[has])
    if xs:
        for ax, tag in ((ax_c, "c"), (ax_h, "h")):
            set_readable_axis(ax, "x", np.concatenate(xs))
            values = np.concatenate(ys[tag])
            set_readable_axis(ax, "y", values[values > 0] if np.any(values > 0) else values)
            ax.set_xlabel("particle radius r [m]")
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=label_fontsize(len(entries)))
    ax_c.set_ylabel(axis_label("velocity_dispersion"))
    ax_h.set_ylabel(axis_label("thickness"))
    fig.suptitle("Equilibrium per size bin: points at the mean radius of the bin's particles "
                 "(bars: bin range; error bars: standard errors)", fontsize=9)
    return fig


def epsilon_histogram_figure(entries):
    """Distribution of the applied coefficient of restitution over the equilibrium window
    (the whole run when not in equilibrium)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for run, eq, style in entries:
        ts = run.timeseries
        if "one_minus_epsilon_histogram" not in ts:
            continue
        start = equilibrium_start(eq)
        window = ts["orbits"] >= (start if start is not None else ts["orbits"][1])
        counts = ts["one_minus_epsilon_histogram"][window].sum(axis=0)
        edges = ts["one_minus_epsilon_bin_edges"]
        if counts.sum() == 0:
            continue
        where = "equilibrium window" if start is not None else "whole run, NOT in equilibrium"
        # bins of 1 - eps, reversed so that epsilon increases along the axis
        ax.stairs(counts[::-1] / counts.sum(), (1.0 - edges)[::-1], color=style["color"],
                  linestyle=style["linestyle"], label=f"{eq['name']} ({where})")
    ax.set_xlim(0.0, 1.0)
    set_readable_axis(ax, "x", [0.0, 1.0], log=False, pad=0.0)
    ax.set_xlabel("applied coefficient of restitution ε [dimensionless]")
    ax.set_ylabel("fraction of collisions [dimensionless]")
    ax.set_title("Distribution of ε (bins logarithmic in 1 − ε; last bin: 1 − ε < 1e-4)",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=label_fontsize(len(entries)))
    return fig


def _peculiar(snapshots: list[dict], Omega: float) -> np.ndarray:
    """Peculiar velocities (3, N) [m/s] of pooled snapshots, each centred on its own mean."""
    parts = []
    for s in snapshots:
        w = peculiar_velocity(s["x"], s["vx"], s["vy"], s["vz"], Omega)
        parts.append(w - w.mean(axis=1, keepdims=True))
    return np.concatenate(parts, axis=1)


def velocity_distribution_figure(entries):
    """Histograms of the three peculiar-velocity components, each against a Gaussian of the
    dispersion measured from the same samples (log density: tails show)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6))
    notes, floor, peak = [], [], []
    for run, eq, style in entries:
        snapshots, what = window_snapshots(run, eq)
        notes.append(f"{eq['name']}: {what}")
        w = _peculiar(snapshots, run.scenario.orbital_frequency) / SPEED_SCALE
        for ax, comp, name in zip(axes, w, ("radial $w_x$", "azimuthal $w_y$",
                                            "vertical $w_z$"), strict=True):
            sigma = float(np.sqrt(np.mean(comp ** 2)))
            edges = np.linspace(-5.0 * sigma, 5.0 * sigma, 51)
            density, _ = np.histogram(comp, bins=edges, density=False)
            density = density / (comp.size * np.diff(edges))
            floor.append(1.0 / (comp.size * np.diff(edges)[0]))  # one particle in a bin
            peak.append(max(float(density.max()), 1.0 / (sigma * np.sqrt(2 * np.pi))))
            outside = np.mean(np.abs(comp) > 5.0 * sigma)
            beyond = f"; {outside:.1%} beyond ±5σ" if outside > 0 else ""
            ax.stairs(np.where(density > 0, density, np.nan), edges, color=style["color"],
                      linewidth=1.2, label=f"{eq['name']}: σ = {sigma:.3g} {SPEED_UNIT}{beyond}")
            v = np.linspace(edges[0], edges[-1], 300)
            ax.plot(v, np.exp(-0.5 * (v / sigma) ** 2) / (sigma * np.sqrt(2 * np.pi)),
                    color=style["color"], linestyle=":", linewidth=1.0)
            ax.set_xlabel(f"{name} [{SPEED_UNIT}]")
    for ax in axes:
        lo, hi = ax.get_xlim()
        set_readable_axis(ax, "x", [lo, hi], log=False, pad=0.0)
        set_readable_axis(ax, "y", [0.3 * min(floor), 1.5 * max(peak)], log=True, pad=0.0)
        ax.set_ylabel(f"probability density [1/({SPEED_UNIT})]")
        ax.grid(alpha=0.3)
        # below the panel: the histograms fill the axes from the tails to the peak
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)
    fig.suptitle("Velocity distributions relative to the shear flow (dotted: Gaussian of the "
                 "measured dispersion σ)\n" + "; ".join(notes), fontsize=9)
    return fig


def vertical_profile_figure(entries):
    """Number- and mass-weighted vertical density profiles of the particle centres against
    Gaussians of the measured (rms) thickness."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(11, 5))
    notes, extent, floor, peak = [], [], [], []
    for run, eq, style in entries:
        snapshots, what = window_snapshots(run, eq)
        notes.append(f"{eq['name']}: {what}")
        z = np.concatenate([s["z"] - s["z"].mean() for s in snapshots])
        mass = np.concatenate([s["mass"] for s in snapshots])
        for weights, kind, linestyle in ((None, "number", "-"), (mass, "mass", "--")):
            h = thickness(z, weights)
            n_bins = int(np.clip(np.sqrt(z.size), 10, 60))
            edges = np.linspace(-4.0 * h, 4.0 * h, n_bins + 1)
            counts, _ = np.histogram(z, bins=edges, weights=weights)
            total = z.size if weights is None else float(np.sum(weights))
            profile = counts / (total * np.diff(edges))
            floor.append(float(np.min(profile[profile > 0], initial=np.inf)))
            peak.append(max(float(profile.max()), 1.0 / (h * np.sqrt(2 * np.pi))))
            ax.stairs(np.where(profile > 0, profile, np.nan), edges, color=style["color"],
                      linestyle=linestyle, linewidth=1.2,
                      label=f"{eq['name']}, {kind}-weighted: H = {h:.3g} m")
            zz = np.linspace(edges[0], edges[-1], 300)
            ax.plot(zz, np.exp(-0.5 * (zz / h) ** 2) / (h * np.sqrt(2 * np.pi)),
                    color=style["color"], linestyle=":", linewidth=0.9)
            extent.append(edges[[0, -1]])
    set_readable_axis(ax, "x", np.concatenate(extent), log=False, pad=0.0)
    # log density: a cold, thin profile and a hot, thick one both show, tails included
    set_readable_axis(ax, "y", [0.5 * min(floor), 2.0 * max(peak)], log=True, pad=0.0)
    ax.set_xlabel("height above the mean plane z [m]")
    ax.set_ylabel("density of particle centres [1/m]\n(normalised to 1)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=label_fontsize(2 * len(entries)), loc="upper left",
              bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.set_title(wrapped("Vertical profile (dotted: Gaussians of the measured rms thickness "
                         "H)\n" + "; ".join(notes), width=80), fontsize=9)
    return fig


def _side_view_stretch(z_extent: float, Lx: float) -> tuple[float, float]:
    """(panel height / width, vertical stretch) of the side view: a panel between 0.25 and
    0.7 of its width whatever the ring's thickness; stretch = displayed / true scale."""
    true_ratio = 2.0 * z_extent / Lx
    panel = float(np.clip(true_ratio, 0.25, 0.7))
    return panel, panel / true_ratio


def snapshot_figure(snap: dict, Lx: float, Ly: float, title: str):
    """Top (x-y, to scale) and side (x-z) views of one snapshot.

    The side view's height follows the ring's vertical extent, bounded so that a cold
    monolayer is not a sliver and a hot ring not a needle; when the vertical scale then
    differs from the horizontal one the title says by how much, and beyond a factor
    `_TO_SCALE_STRETCH` the particles are markers rather than circles to scale.

    Parameters
    ----------
    snap : dict with x, y, z [m], radius [m]
    Lx, Ly : float [m]
        Box size.
    title : str
    """
    from matplotlib.collections import EllipseCollection

    plt = pyplot()
    r = np.asarray(snap["radius"], dtype=float)
    z = np.asarray(snap["z"], dtype=float) - float(np.mean(snap["z"]))
    z_extent = 1.05 * float(np.max(np.abs(z) + r))
    side, stretch = _side_view_stretch(z_extent, Lx)
    top = float(np.clip(Ly / Lx, 0.3, 2.5))
    width = 8.0
    fig, (ax_xy, ax_xz) = plt.subplots(
        2, 1, figsize=(width, width * 0.78 * (top + side) + 1.6),
        gridspec_kw={"height_ratios": [top, side]})
    d = 2.0 * r
    ax_xy.add_collection(EllipseCollection(
        d, d, np.zeros_like(d), units="xy", offsets=np.column_stack([snap["x"], snap["y"]]),
        offset_transform=ax_xy.transData, facecolors="tab:blue", edgecolors="k",
        linewidths=0.2, alpha=0.7))
    ax_xy.set_aspect("equal")
    set_readable_axis(ax_xy, "x", [-Lx / 2, Lx / 2], log=False, pad=0.0)
    set_readable_axis(ax_xy, "y", [-Ly / 2, Ly / 2], log=False, pad=0.0)
    ax_xy.set_ylabel("y (azimuthal) [m]")
    ax_xy.set_xlabel("x (radial) [m]")
    to_scale = _TO_SCALE_STRETCH[0] <= stretch <= _TO_SCALE_STRETCH[1]
    if to_scale:
        ax_xz.add_collection(EllipseCollection(
            d, d, np.zeros_like(d), units="xy", offsets=np.column_stack([snap["x"], z]),
            offset_transform=ax_xz.transData, facecolors="tab:blue", edgecolors="k",
            linewidths=0.2, alpha=0.7))
    else:
        # marker diameter 2-7 points, growing with the radius
        ax_xz.scatter(snap["x"], z, s=(2.0 + 5.0 * r / r.max()) ** 2, color="tab:blue",
                      alpha=0.6, linewidths=0)
    ax_xz.set_aspect(stretch)
    set_readable_axis(ax_xz, "x", [-Lx / 2, Lx / 2], log=False, pad=0.0)
    set_readable_axis(ax_xz, "y", [-z_extent, z_extent], log=False, pad=0.0)
    ax_xz.set_xlabel("x (radial) [m]")
    ax_xz.set_ylabel("z (vertical) [m]")
    if abs(stretch - 1.0) < 0.01:
        scale = "drawn to scale"
    elif to_scale:
        scale = f"vertical scale ×{stretch:.3g} (particles: ellipses true to both axes)"
    else:
        scale = (f"vertical scale ×{stretch:.3g}; particles as markers, size not to scale")
    ax_xy.set_title(f"{title}\ntop view drawn to scale", fontsize=9)
    ax_xz.set_title(f"side view: {scale}; rms thickness {thickness(z):.3g} m", fontsize=9)
    return fig
