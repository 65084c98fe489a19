"""The numbers of a self-gravitating sheet that ``ringsim run`` prints and stores.

:func:`sheet_gravity` gives r_h, the surface density, Toomre's critical wavelength and the
box in units of it (``physics.gravity``); :func:`scenario_gravity` adds the scenario's
solver and its parameters (``ringsim.gravity.registry.solver_attributes``).  The solvers
themselves are ``ringsim.gravity``; `install_gravity` is importable from here too, as the
code that ``ringsim export --rebound`` prints imports it (docs/export.md).
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.gravity.registry import (
    install_gravity,  # noqa: F401 (the printed code's import)
    solver_attributes,
)
from ringsim.physics import gravity as patch


def sheet_gravity(radii, masses, density: float, Lx: float, Ly: float, Omega: float,
                  GM: float | None = None, a: float | None = None) -> dict:
    """The dimensionless numbers of a self-gravitating sheet that ``ringsim run`` prints
    and stores (``physics.gravity``).

    Parameters
    ----------
    radii : array [m]
    masses : array [kg]
    density : float [kg/m^3]
    Lx, Ly : float [m]
    Omega : float [1/s]
    GM : float [m^3/s^2] or None
    a : float [m] or None
        The planet: r_h needs M_p = GM / G and a; with ``planet: {Omega}`` only it is
        unknown (None).

    Returns
    -------
    dict: ``r_h`` (mean pair, ``physics.gravity.mean_pair_hill_parameter``; None if
    unknown), ``Sigma`` [kg/m^2], ``lambda_cr`` [m], ``box`` (``wake_box_spans``),
    ``attributes`` (root attributes of the run file, each ``units_<name>`` beside it) and
    ``message`` (one line for stderr).
    """
    Sigma = patch.surface_density(float(np.sum(masses)), Lx, Ly)
    lambda_cr = float(patch.toomre_wavelength(Sigma, Omega))
    r_h = (None if GM is None or a is None
           else patch.mean_pair_hill_parameter(radii, density, GM, a))
    box = patch.wake_box_spans(Lx, Ly, lambda_cr)
    attributes = {"Sigma": Sigma, "units_Sigma": "kg/m^2",
                  "lambda_cr": lambda_cr, "units_lambda_cr": "m",
                  "box_lambda_cr": box["smallest"],
                  "units_box_lambda_cr": "lambda_cr (smaller of Lx, Ly)",
                  "r_h": math.nan if r_h is None else r_h,
                  "units_r_h": "dimensionless (mean pair; NaN: planet GM and a not given)"}
    rh_text = ("r_h unknown (planet given by Omega only; give GM and a)" if r_h is None
               else f"r_h = {r_h:.3g} (mean pair)")
    level = {"warn": "WARNING: ", "advise": "advice: ", "ok": ""}[box["level"]]
    message = (f"self-gravity: {rh_text}, Sigma = {Sigma:.4g} kg/m^2, lambda_cr = "
               f"{lambda_cr:.4g} m; {level}{box['message']}")
    return {"r_h": r_h, "Sigma": Sigma, "lambda_cr": lambda_cr, "box": box,
            "attributes": attributes, "message": message}


def scenario_gravity(scenario, radii, masses, geometry) -> dict:
    """:func:`sheet_gravity` of a scenario's sheet (its planet, density and box).

    Parameters
    ----------
    scenario : Scenario
    radii : array [m]
    masses : array [kg]
    geometry : SheetGeometry
    """
    planet = scenario.planet
    out = sheet_gravity(radii, masses, scenario.particles.density, geometry.Lx, geometry.Ly,
                        scenario.orbital_frequency, planet.GM, planet.a)
    out["attributes"].update(solver_attributes(scenario, geometry))
    out["message"] += f"; solver {scenario.sheet.gravity_solver or 'tree'}"
    r_pair = scenario.sheet.p3m_pair_min_radius or 0.0
    if r_pair > 0.0:
        small = np.asarray(radii) < r_pair
        share = float(np.sum(np.asarray(masses)[small]) / np.sum(masses))
        out["message"] += (f"; field-only below {r_pair:g} m: {small.mean():.1%} of the "
                           f"particles by number, {share:.2%} by mass")
    return out
