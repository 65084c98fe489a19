"""The self-gravity keys of the ``sheet`` section: which solver, and its parameters.

``sheet.gravity_solver`` (tree | p3m | slab, default DEFAULTS["sheet.gravity_solver"]),
``sheet.softening``, the tree's ``sheet.opening_angle`` and P3M's ``sheet.p3m_split``: read
and validated here, for ``config.scenario``; the solvers' own parameters are declared in
``physics.selfgravity`` and ``physics.p3m_scales``.
"""

from __future__ import annotations

from typing import Any

from ringsim.config.schema import Section
from ringsim.physics.p3m_scales import P3M_CUTOFF_SPLITS, P3M_SPLIT_RADII
from ringsim.physics.selfgravity import GRAVITY_SOLVERS

#: Keys that only a gravitating sheet may set.
GRAVITY_ONLY_KEYS = ("gravity_solver", "softening", "opening_angle", "p3m_split")


def read_gravity_keys(sec: Section, d: dict[str, Any]) -> dict[str, Any]:
    """``gravity``, ``gravity_solver``, ``softening`` [m or "auto"], ``opening_angle``
    [rad] and ``p3m_split`` [m or "auto"] of a sheet section (None where not used), with
    defaults ``d``."""
    gravity = sec.boolean("gravity", d["sheet.gravity"])
    if not gravity:
        for name in GRAVITY_ONLY_KEYS:
            if sec.has(name):
                raise sec.error(name, "only used with self-gravity",
                                "set sheet.gravity: true, or remove the key")
        return {"gravity": False, "gravity_solver": None, "softening": None,
                "opening_angle": None, "p3m_split": None}
    # a scenario that sets the tree's opening angle and no solver keeps the tree (scenarios
    # written before the P3M solver existed run as they did)
    default_solver = ("tree" if sec.has("opening_angle") and not sec.has("gravity_solver")
                      else d["sheet.gravity_solver"])
    solver = sec.string("gravity_solver", default_solver, choices=GRAVITY_SOLVERS)
    if solver != "tree" and sec.has("opening_angle"):
        raise sec.error("opening_angle", "only used with gravity_solver: tree",
                        "remove the key, or set sheet.gravity_solver: tree")
    if solver != "p3m" and sec.has("p3m_split"):
        raise sec.error("p3m_split", "only used with gravity_solver: p3m",
                        "remove the key, or set sheet.gravity_solver: p3m")
    if solver == "slab" and sec.has("softening"):
        raise sec.error("softening", "not used with gravity_solver: slab (no pair forces)",
                        "remove the key, or set sheet.gravity_solver: tree or p3m")
    return {"gravity": True, "gravity_solver": solver,
            "softening": (sec.number_or_auto("softening", d["sheet.softening"], unit="m",
                                              ge=0.0) if solver != "slab" else None),
            "opening_angle": (sec.number("opening_angle", d["sheet.opening_angle"],
                                         unit="rad", gt=0.0, le=1.0)
                              if solver == "tree" else None),
            "p3m_split": (sec.number_or_auto("p3m_split", d["sheet.p3m_split"], unit="m",
                                             gt=0.0) if solver == "p3m" else None)}


def p3m_first_split(p3m_split: float | str, mean_radius: float) -> float:
    """The (first) split scale r_s [m] of ``sheet.p3m_split``: the number given, or, for
    "auto", P3M_SPLIT_RADII mean radii, the smallest split auto chooses.

    Parameters
    ----------
    p3m_split : float [m] or "auto"
    mean_radius : float [m]
    """
    return P3M_SPLIT_RADII * mean_radius if p3m_split == "auto" else float(p3m_split)


def p3m_setting(sheet, mean_radius: float) -> tuple[float, bool] | None:
    """(split [m], auto) of a sheet's P3M solver: ``sheet.p3m_split`` given as a number, or
    "auto" from P3M_SPLIT_RADII mean radii up; None without P3M.

    Parameters
    ----------
    sheet : SheetConfig
    mean_radius : float [m]
    """
    if sheet.gravity_solver != "p3m":
        return None
    return p3m_first_split(sheet.p3m_split, mean_radius), sheet.p3m_split == "auto"


def check_p3m_box(top: Section, sheet, mean_radius: float, lx: float, ly: float) -> None:
    """The P3M pair sum needs a box wider than its cutoff (``rs_p3m.c``) at the first split
    scale (``auto`` never chooses a cutoff the box cannot hold).

    Parameters
    ----------
    sheet : SheetConfig
    mean_radius : float [m]
    lx, ly : float [m]
        The box the scenario makes.
    """
    if sheet.gravity_solver != "p3m":
        return
    cutoff = P3M_CUTOFF_SPLITS * p3m_first_split(sheet.p3m_split, mean_radius)
    if min(lx, ly) <= cutoff:
        raise top.error("sheet.gravity_solver",
                        f"p3m needs a box wider than its pair-sum cutoff ({cutoff:.3g} m); "
                        f"{sheet.n_particles} particles make {lx:.3g} m x {ly:.3g} m",
                        "tree, a smaller sheet.p3m_split, or more particles")
