"""epsilon(v) curves of the restitution laws as in Dilley (1993) Figs. 1 and 5
(``ringsim epsilon --plot``).  Speeds in mm/s, as in every ringsim figure."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringsim.physics import dilley_spheres
from ringsim.physics import restitution as rs
from ringsim.plots.common import SPEED_SCALE, SPEED_UNIT, pyplot, save_figure, set_readable_axis

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
    style : str or (offset, dash sequence)
        Matplotlib line style.
    """

    panel: str
    label: str
    v: np.ndarray
    epsilon: np.ndarray
    style: str | tuple[int, tuple[int, ...]] = "-"


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
        Impact speeds; default 200 log-spaced speeds from 0.1 to 20 mm/s (0.01-2 cm/s).
    """
    if v is None:
        v = np.logspace(np.log10(0.01 * CM_S), np.log10(2.0 * CM_S), 200)
    curves: list[Curve] = []
    # Fig. 1b-d: the experiment's sphere against a brick; only the size enters (eq. 5.13).
    for radius_cm in (2.5, 5.0, 10.0, 20.0):
        eps = np.asarray(rs.dilley_epsilon(v, rs.reduced_radius(radius_cm * CM, np.inf),
                                           rs.M_REF))
        curves.append(Curve("fig1", f"R = {radius_cm:g} cm", v, eps))
    # Fig. 5: equal-density spheres, smaller radius R1, delta = 0 (brick) and 1 (twin).
    for kappa in (0.0, 0.1):
        for r1_cm, name in ((0.25, "0.25 cm"), (2.5, "2.5 cm"), (25.0, "25 cm"),
                            (250.0, "2.5 m")):
            for delta, style in ((0.0, "-"), (1.0, "--")):
                xi = dilley_spheres.dilley_xi_equal_density(v, r1_cm * CM, delta, kappa=kappa)
                kind = "vs brick" if delta == 0 else "equal spheres"
                curves.append(Curve(f"fig5_kappa{kappa:g}",
                                    f"R1 = {name}, δ = {delta:g} ({kind})", v,
                                    np.asarray(rs.epsilon_from_xi(xi)), style))
    # Plastic-deformation models of section 4 against the viscous fit, R = 2.5 cm.
    curves += [
        Curve("plastic", "viscous (Dilley), R = 2.5 cm", v,
              np.asarray(rs.dilley_epsilon(v, rs.R_REF, rs.M_REF))),
        Curve("plastic", "Tabor, v_c = 0.809 mm/s, q = 0.371 (curve c)", v,
              np.asarray(rs.tabor_epsilon(v, 0.0809 * CM_S, 0.371)), "-."),
        Curve("plastic", "Tabor, v_c = 0.314 mm/s, q = 0.42 (curve d)", v,
              np.asarray(rs.tabor_epsilon(v, 0.0314 * CM_S, 0.42)), ":"),
        Curve("plastic", "Andrews, v_c = 0.809 mm/s (eq. 4.3)", v,
              np.asarray(rs.andrews_epsilon(v, 0.0809 * CM_S)), "--"),
        Curve("plastic", "Bridges et al. 1984, v_c = 0.077 mm/s", v,
              np.asarray(rs.bridges_epsilon(v)), (0, (5, 1, 1, 1))),
    ]
    return curves


def shade_measured_speeds(ax, model: str) -> None:
    """Shade the impact speeds at which ``model``'s parameters were measured (declared with
    the law in ``physics.restitution``); nothing for a law without a measured range."""
    measured = rs.RESTITUTION[model].measured
    if measured.speeds is None:
        return
    lo, hi = (speed / SPEED_SCALE for speed in measured.speeds)
    ax.axvspan(lo, hi, facecolor="0.92", edgecolor="0.75", zorder=0,
               label=f"speeds the {model} law was measured at ({lo:g}-{hi:g} {SPEED_UNIT})")


def plot_epsilon_curves(curves: list[Curve], path: str | Path) -> Path:
    """Draw epsilon against impact speed, one panel per figure of the paper; write a PNG.

    Parameters
    ----------
    curves : list of Curve
    path : PNG file to write
    """
    return save_figure(epsilon_figure(curves), path, dpi=120)


def epsilon_figure(curves: list[Curve]):
    """The figure of `plot_epsilon_curves` (a matplotlib Figure, not yet written)."""
    plt = pyplot()
    panels = list(dict.fromkeys(c.panel for c in curves))
    fig, axes = plt.subplots(2, 2, figsize=(12, 9), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, panel in zip(axes.flat, panels, strict=False):
        members = [c for c in curves if c.panel == panel]
        labels = list(dict.fromkeys(c.label.split(",")[0] for c in members))
        for curve in members:
            colour = colours[labels.index(curve.label.split(",")[0]) % len(colours)]
            ax.plot(curve.v / SPEED_SCALE, curve.epsilon, linestyle=curve.style, color=colour,
                    label=curve.label)
        shade_measured_speeds(ax, "dilley")   # every panel compares with those data
        set_readable_axis(ax, "x", np.concatenate([c.v for c in members]) / SPEED_SCALE,
                          log=True, pad=0.0)
        ax.set_ylim(0.0, 1.02)
        ax.set_xlabel(f"normal impact speed v [{SPEED_UNIT}]")
        ax.set_ylabel("coefficient of restitution ε [dimensionless]")
        ax.set_title(PANEL_TITLES.get(panel, panel), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    fig.suptitle("Coefficient of restitution of icy spheres (Dilley 1993, Icarus 105, 225)")
    return fig
