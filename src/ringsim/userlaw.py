"""`ringsim epsilon --restitution ...`: epsilon(v) of a user's own law for given sizes.

The law is given as ``key=value`` pairs (``model=dilley,kappa=0.1``) or as a YAML file with
a ``restitution`` section (a scenario, or the file ``ringsim fit --write-restitution``
writes); it is checked by the scenario rules, so errors name ``restitution.<key>``.  Each
radius R [m] gives the curve of two identical spheres of that radius and bulk density
colliding: reduced radius R/2, reduced mass m/2 with m = density 4/3 pi R^3.  Without
``--radius`` a scenario file's smallest, mean and largest radii are used.  The printed
table gives speeds in cm/s, as the paper; the figure uses mm/s, as every ringsim figure.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ringsim.config.scenario import scenario_from_dict
from ringsim.config.schema import parse_yaml, read_text
from ringsim.errors import InputError, excerpt
from ringsim.physics import restitution as rs
from ringsim.plots.laws import Curve

#: One centimetre per second [m/s] (the paper's speed unit, used by the printed table).
CM_S = 0.01

#: Speeds [m/s] of the curves: 200 log-spaced from 0.01 to 2 cm/s, as the paper's figures.
SPEEDS = np.logspace(np.log10(0.01 * CM_S), np.log10(2.0 * CM_S), 200)
_PROBE = {"name": "epsilon", "seed": 0, "planet": {"Omega": 1e-4},
          "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}}}


def _from_pairs(spec: str) -> dict[str, Any]:
    section: dict[str, Any] = {}
    for item in spec.split(","):
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError("<command line>", "--restitution", f"{excerpt(item)} is not key=value "
                             "(e.g. model=dilley,kappa=0.1, or a YAML file)")
        section[key.strip()] = parse_yaml(value.strip(), "<command line>")
    return section


def read_law(spec: str, density: float | None, radii: Sequence[float] | None
             ) -> tuple[dict, float, list[float]]:
    """(restitution dict, density [kg/m^3], radii [m]) from the command line's values."""
    path = Path(spec)
    source = "<command line>"
    scenario_part: dict[str, Any] = {}
    if path.suffix.lower() in (".yaml", ".yml") or path.is_file():
        source = str(path)
        data = parse_yaml(read_text(path), source)
        if not isinstance(data, dict) or "restitution" not in data:
            raise InputError(source, "restitution", "the file has no 'restitution' section")
        section = data["restitution"]
        if "particles" in data and "planet" in data:
            scenario_part = data
    else:
        section = _from_pairs(spec)
    probe = scenario_from_dict({**_PROBE, "restitution": section}, source=source)
    scenario = scenario_from_dict(scenario_part, source=source) if scenario_part else None
    law = probe.restitution_dict()
    if density is None:
        density = scenario.particles.density if scenario else 900.0
    if not radii:
        if scenario is None:
            raise InputError("<command line>", "--radius", "give the particle radii [m] "
                             "(or a scenario file, whose sizes are then used)")
        sd = scenario.particles.size_distribution
        radii = sorted({sd.smallest_radius, sd.mean_radius, sd.largest_radius})
    for r in radii:
        if not (np.isfinite(r) and r > 0):
            raise InputError("<command line>", "--radius", f"{excerpt(r)} is not a radius > 0 [m]")
    if not (np.isfinite(density) and density > 0):
        raise InputError("<command line>", "--density", f"{excerpt(density)} is not > 0 [kg/m^3]")
    return law, float(density), [float(r) for r in radii]


def user_curves(law: dict, density: float, radii: Sequence[float]) -> list[Curve]:
    """epsilon(v) at `SPEEDS` for pairs of identical spheres of each radius [m]."""
    curves = []
    for radius in radii:
        mass = density * 4.0 / 3.0 * np.pi * radius**3
        eps = rs.epsilon_for_pair(law, SPEEDS, radius / 2.0, mass / 2.0)
        label = f"R = {radius:g} m (R̄ = {radius / 2:g} m, M̄ = {mass / 2:.3g} kg)"
        curves.append(Curve("user", label, SPEEDS, np.asarray(eps, dtype=float)))
    return curves


def law_title(law: dict, density: float) -> str:
    params = ", ".join(f"{k} = {v:g}" for k, v in law.items() if k != "model")
    return f"{law['model']} law ({params}), equal spheres of density {density:g} kg/m³"


def plot_user_curves(curves: Sequence[Curve], title: str, path: str | Path,
                     model: str | None = None) -> Path:
    """Write `user_curves_figure` as a PNG at ``path``; returns the path."""
    from ringsim.plots.common import save_figure

    return save_figure(user_curves_figure(curves, title, model), path, dpi=120)


def user_curves_figure(curves: Sequence[Curve], title: str, model: str | None = None):
    """One panel: epsilon against impact speed (in the figures' speed unit, mm/s), a line
    per radius, the speeds ``model`` was measured at shaded (a matplotlib Figure)."""
    from ringsim.plots.common import SPEED_SCALE, SPEED_UNIT, pyplot, set_readable_axis
    from ringsim.plots.laws import shade_measured_speeds

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for curve in curves:
        ax.plot(curve.v / SPEED_SCALE, curve.epsilon, label=curve.label)
    if model is not None:
        shade_measured_speeds(ax, model)
    set_readable_axis(ax, "x", np.concatenate([c.v for c in curves]) / SPEED_SCALE, log=True,
                      pad=0.0)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel(f"normal impact speed v [{SPEED_UNIT}]")
    ax.set_ylabel("coefficient of restitution ε [dimensionless]")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    return fig
