"""The self-gravity keys of the ``sheet`` section: which solver, and its parameters.

``sheet.gravity_solver`` (tree | p3m | slab, default DEFAULTS["sheet.gravity_solver"]),
``sheet.softening`` and the tree's ``sheet.opening_angle``: read and validated here, for
``config.scenario``; the solvers' own parameters are declared in ``physics.selfgravity``.
"""

from __future__ import annotations

from typing import Any

from ringsim.config.schema import Section
from ringsim.physics.selfgravity import GRAVITY_SOLVERS, P3M_CUTOFF_SPLITS, P3M_SPLIT_RADII

#: Keys that only a gravitating sheet may set.
GRAVITY_ONLY_KEYS = ("gravity_solver", "softening", "opening_angle")


def read_gravity_keys(sec: Section, d: dict[str, Any]) -> dict[str, Any]:
    """``gravity``, ``gravity_solver``, ``softening`` [m or "auto"] and ``opening_angle``
    [rad] of a sheet section (None where not used), with defaults ``d``."""
    gravity = sec.boolean("gravity", d["sheet.gravity"])
    if not gravity:
        for name in GRAVITY_ONLY_KEYS:
            if sec.has(name):
                raise sec.error(name, "only used with self-gravity",
                                "set sheet.gravity: true, or remove the key")
        return {"gravity": False, "gravity_solver": None, "softening": None,
                "opening_angle": None}
    # a scenario that sets the tree's opening angle and no solver keeps the tree (scenarios
    # written before the P3M solver existed run as they did)
    default_solver = ("tree" if sec.has("opening_angle") and not sec.has("gravity_solver")
                      else d["sheet.gravity_solver"])
    solver = sec.string("gravity_solver", default_solver, choices=GRAVITY_SOLVERS)
    if solver != "tree" and sec.has("opening_angle"):
        raise sec.error("opening_angle", "only used with gravity_solver: tree",
                        "remove the key, or set sheet.gravity_solver: tree")
    if solver == "slab" and sec.has("softening"):
        raise sec.error("softening", "not used with gravity_solver: slab (no pair forces)",
                        "remove the key, or set sheet.gravity_solver: tree or p3m")
    return {"gravity": True, "gravity_solver": solver,
            "softening": (sec.number_or_auto("softening", d["sheet.softening"], unit="m",
                                              ge=0.0) if solver != "slab" else None),
            "opening_angle": (sec.number("opening_angle", d["sheet.opening_angle"],
                                         unit="rad", gt=0.0, le=1.0)
                              if solver == "tree" else None)}


def check_p3m_box(top: Section, sheet, mean_radius: float, lx: float, ly: float) -> None:
    """The P3M pair sum needs a box wider than its cutoff (``rs_p3m.c``).

    Parameters
    ----------
    sheet : SheetConfig
    mean_radius : float [m]
    lx, ly : float [m]
        The box the scenario makes.
    """
    cutoff = P3M_CUTOFF_SPLITS * P3M_SPLIT_RADII * mean_radius
    if sheet.gravity_solver == "p3m" and min(lx, ly) <= cutoff:
        raise top.error("sheet.gravity_solver",
                        f"p3m needs a box wider than its pair-sum cutoff ({cutoff:.3g} m); "
                        f"{sheet.n_particles} particles make {lx:.3g} m x {ly:.3g} m",
                        "tree, or more particles")
