"""Figures: epsilon(v) curves of the restitution laws, and run / comparison figures.

Matplotlib is used with the non-interactive Agg backend; every function writes PNG files
and returns their paths.  Axes carry labels with units.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringsim.physics import restitution as rs

CM = 0.01  # [m]
CM_S = 0.01  # [m/s]


@dataclass(frozen=True)
class Curve:
    """One epsilon(v) curve of a figure panel.

    Attributes
    ----------
    panel : str
        Panel key ("fig1", "fig5_kappa0", "fig5_kappa0.1", "plastic").
    label : str
        Legend text.
    v : array [m/s]
    epsilon : array [dimensionless]
    style : str
        Matplotlib line style.
    """

    panel: str
    label: str
    v: np.ndarray
    epsilon: np.ndarray
    style: str = "-"


PANEL_TITLES = {
    "fig1": "(a) Viscous model vs a massive brick (Dilley Fig. 1b-d): "
            r"$\xi_0=0.16$, $p=0.65$",
    "fig5_kappa0": r"(b) Equal-density spheres, $\kappa=0$ (Fig. 5a)",
    "fig5_kappa0.1": r"(c) Equal-density spheres, $\kappa=0.1$ (Fig. 5b)",
    "plastic": "(d) Critical-speed models, R = 2.5 cm (Figs. 1a, 3)",
}


def paper_curves(v: np.ndarray | None = None) -> list[Curve]:
    """The epsilon(v) curves of Dilley (1993) Figs. 1 and 5 and the plastic-deformation laws.

    Parameters
    ----------
    v : array [m/s], optional
        Impact speeds; default 200 log-spaced speeds from 0.01 to 2 cm/s.
    """
    if v is None:
        v = np.logspace(np.log10(0.01 * CM_S), np.log10(2.0 * CM_S), 200)
    curves: list[Curve] = []
    # Fig. 1b-d: the experiment's sphere against a brick; only the size enters (eq. 5.13).
    for radius_cm in (2.5, 5.0, 10.0, 20.0):
        eps = rs.dilley_epsilon(v, rs.reduced_radius(radius_cm * CM, np.inf), rs.M_REF)
        curves.append(Curve("fig1", f"R = {radius_cm:g} cm", v, eps))
    # Fig. 5: equal-density spheres, smaller radius R1, delta = 0 (brick) and 1 (twin).
    for kappa in (0.0, 0.1):
        for r1_cm, name in ((0.25, "0.25 cm"), (2.5, "2.5 cm"), (25.0, "25 cm"),
                            (250.0, "2.5 m")):
            for delta, style in ((0.0, "-"), (1.0, "--")):
                xi = rs.dilley_xi_equal_density(v, r1_cm * CM, delta, kappa=kappa)
                kind = "vs brick" if delta == 0 else "equal spheres"
                curves.append(Curve(f"fig5_kappa{kappa:g}",
                                    f"R1 = {name}, δ = {delta:g} ({kind})", v,
                                    np.asarray(rs.epsilon_from_xi(xi)), style))
    # Plastic-deformation models of section 4 against the viscous fit, R = 2.5 cm.
    curves += [
        Curve("plastic", "viscous (Dilley), R = 2.5 cm", v,
              rs.dilley_epsilon(v, rs.R_REF, rs.M_REF)),
        Curve("plastic", "Tabor, v_c = 0.0809 cm/s, q = 0.371 (curve c)", v,
              rs.tabor_epsilon(v, 0.0809 * CM_S, 0.371), "-."),
        Curve("plastic", "Tabor, v_c = 0.0314 cm/s, q = 0.42 (curve d)", v,
              rs.tabor_epsilon(v, 0.0314 * CM_S, 0.42), ":"),
        Curve("plastic", "Andrews, v_c = 0.0809 cm/s (eq. 4.3)", v,
              rs.andrews_epsilon(v, 0.0809 * CM_S), "--"),
        Curve("plastic", "Bridges et al. 1984, v_c = 0.0077 cm/s", v, rs.bridges_epsilon(v),
              (0, (5, 1, 1, 1))),
    ]
    return curves


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_epsilon_curves(curves: list[Curve], path: str | Path) -> Path:
    """Draw epsilon against impact speed, one panel per figure of the paper; write a PNG.

    Parameters
    ----------
    curves : list of Curve
    path : PNG file to write
    """
    plt = _pyplot()
    panels = list(dict.fromkeys(c.panel for c in curves))
    fig, axes = plt.subplots(2, 2, figsize=(12, 9), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, panel in zip(axes.flat, panels, strict=False):
        members = [c for c in curves if c.panel == panel]
        labels = list(dict.fromkeys(c.label.split(",")[0] for c in members))
        for curve in members:
            colour = colours[labels.index(curve.label.split(",")[0]) % len(colours)]
            ax.plot(curve.v / CM_S, curve.epsilon, linestyle=curve.style, color=colour,
                    label=curve.label)
        ax.set_xscale("log")
        ax.set_ylim(0.0, 1.02)
        ax.set_xlabel("normal impact speed v [cm/s]")
        ax.set_ylabel("coefficient of restitution ε")
        ax.set_title(PANEL_TITLES.get(panel, panel), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    fig.suptitle("Coefficient of restitution of icy spheres (Dilley 1993, Icarus 105, 225)")
    return save_figure(fig, path, dpi=120)


# --- run and comparison figures ----------------------------------------------------------------

def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it as a PNG (creating the folder) and close it."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _timeseries_axes(plt, runs, equilibria, title: str):
    fig, (ax_c, ax_h) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for run, eq in zip(runs, equilibria, strict=True):
        ts = run.timeseries
        r_omega = eq["mean_radius"] * run.scenario.orbital_frequency
        (line,) = ax_c.plot(ts["orbits"], ts["velocity_dispersion"] / r_omega, label=eq["name"])
        ax_h.plot(ts["orbits"], ts["thickness"] / eq["mean_radius"], color=line.get_color(),
                  label=eq["name"])
        start = eq["equilibrium_from_orbit"]["mean"]
        for ax, key, scale in ((ax_c, "velocity_dispersion", r_omega),
                               (ax_h, "thickness", eq["mean_radius"])):
            ax.axvspan(start, ts["orbits"][-1], color=line.get_color(), alpha=0.08)
            m = eq[key]["mean"] / scale
            ax.axhline(m, color=line.get_color(), linestyle="--", linewidth=0.8)
    ax_c.set_ylabel("velocity dispersion c / (<r> Ω)")
    ax_h.set_ylabel("thickness H / <r>  (rms z)")
    ax_h.set_xlabel("time [orbits]")
    ax_c.set_title(title + "  (shaded: equilibrium window; dashed: its mean)", fontsize=10)
    for ax in (ax_c, ax_h):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def _size_bin_figure(plt, equilibria):
    fig, (ax_c, ax_h) = plt.subplots(1, 2, figsize=(11, 4.5))
    for eq in equilibria:
        bins = eq["per_size_bin"]
        if not bins:
            continue
        r_mid = np.array([np.sqrt(b["r_low"] * b["r_high"]) for b in bins])
        for ax, key, scale in ((ax_c, "velocity_dispersion", 1e3), (ax_h, "thickness", 1.0)):
            mean = np.array([b[key]["mean"] for b in bins]) * scale
            err = np.array([b[key]["stderr"] for b in bins]) * scale
            ax.errorbar(r_mid, mean, yerr=err, marker="o", capsize=3, label=eq["name"])
    ax_c.set_ylabel("velocity dispersion c [mm/s]")
    ax_h.set_ylabel("thickness H (rms z) [m]")
    for ax in (ax_c, ax_h):
        ax.set_xscale("log")
        ax.set_xlabel("particle radius [m]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.suptitle("Equilibrium per size bin (error bars: standard errors)")
    return fig


def _epsilon_histogram_figure(plt, runs, equilibria):
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for run, eq in zip(runs, equilibria, strict=True):
        ts = run.timeseries
        if "one_minus_epsilon_histogram" not in ts:
            continue
        orbits = ts["orbits"]
        window = orbits >= eq["equilibrium_from_orbit"]["mean"]
        counts = ts["one_minus_epsilon_histogram"][window].sum(axis=0)
        edges = ts["one_minus_epsilon_bin_edges"]
        if counts.sum() == 0:
            continue
        # bins of 1 - eps, reversed so that epsilon increases along the axis
        ax.stairs(counts[::-1] / counts.sum(), (1.0 - edges)[::-1], label=eq["name"])
    ax.set_xlabel("applied coefficient of restitution ε")
    ax.set_ylabel("fraction of collisions in the equilibrium window")
    ax.set_title("Distribution of ε (bins logarithmic in 1 - ε; left bin: 1 - ε < 1e-4)",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def _snapshot_figure(plt, run, name: str):
    from matplotlib.collections import EllipseCollection

    snap = run.snapshot(-1)
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    fig, (ax_xy, ax_xz) = plt.subplots(2, 1, figsize=(8, 10),
                                       gridspec_kw={"height_ratios": [Ly, max(Ly / 3, 1.0)]})
    d = 2 * snap["radius"]
    for ax, horizontal, vertical in ((ax_xy, "x", "y"), (ax_xz, "x", "z")):
        coll = EllipseCollection(d, d, np.zeros_like(d), units="xy",
                                 offsets=np.column_stack([snap[horizontal], snap[vertical]]),
                                 offset_transform=ax.transData, facecolors="tab:blue",
                                 edgecolors="k", linewidths=0.2, alpha=0.7)
        ax.add_collection(coll)
        ax.set_aspect("equal")
        ax.set_xlim(-Lx / 2, Lx / 2)
        ax.set_xlabel("x (radial) [m]")
        ax.set_ylabel(f"{vertical} ({'azimuthal' if vertical == 'y' else 'vertical'}) [m]")
    ax_xy.set_ylim(-Ly / 2, Ly / 2)
    zmax = max(float(np.max(np.abs(snap["z"]) + snap["radius"])), 3 * float(d.max()))
    ax_xz.set_ylim(-zmax, zmax)
    ax_xy.set_title(f"{name}: last snapshot at {snap['t'] / run.scenario.orbital_period:.3g} "
                    "orbits, drawn to scale", fontsize=10)
    return fig


def plot_run(run, eq: dict, directory: str | Path) -> list[Path]:
    """Figures of one run (``ringsim analyze --plots DIR``); returns the PNG paths."""
    plt = _pyplot()
    directory = Path(directory)
    paths = [save_figure(_timeseries_axes(plt, [run], [eq], eq["name"]),
                   directory / "timeseries.png")]
    if eq["per_size_bin"]:
        paths.append(save_figure(_size_bin_figure(plt, [eq]), directory / "size_bins.png"))
    paths.append(save_figure(_epsilon_histogram_figure(plt, [run], [eq]),
                       directory / "epsilon_histogram.png"))
    paths.append(save_figure(_snapshot_figure(plt, run, eq["name"]), directory / "snapshot.png"))
    return paths


def plot_comparison(runs, equilibria: list[dict], directory: str | Path) -> list[Path]:
    """Overlay figures of several runs (``ringsim compare --plots DIR``)."""
    plt = _pyplot()
    directory = Path(directory)
    names = " vs ".join(eq["name"] for eq in equilibria)
    paths = [save_figure(_timeseries_axes(plt, runs, equilibria, names),
                   directory / "compare_timeseries.png")]
    if any(eq["per_size_bin"] for eq in equilibria):
        paths.append(save_figure(_size_bin_figure(plt, equilibria),
                                 directory / "compare_size_bins.png"))
    paths.append(save_figure(_epsilon_histogram_figure(plt, runs, equilibria),
                       directory / "compare_epsilon_histogram.png"))
    return paths
