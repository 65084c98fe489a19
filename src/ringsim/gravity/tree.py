"""REBOUND's tree gravity with the field of the sheet beyond its ghost boxes
(``sheet.gravity_solver: tree``).

REBOUND sums the box and one ring of ghost boxes (``sim.gravity = "tree"``,
``opening_angle2``, ``N_ghost_x/y``); its ghost-box sum has no uniform-background term, so
the sheet beyond them is missing, and its pull falls only as 1 / N_ghost (docs/gravity.md).
`install_ghost_field` adds that missing field: ``rs_ghost_field`` in
``ringsim/csrc/rs_gravity.c``, the C twin of
:func:`ringsim.physics.ghost_field.ghost_truncation_field`, as REBOUND's
``additional_forces``.  With it the tree's error is its own multipole error, set by the
opening angle.
"""

from __future__ import annotations

import math

import rebound

from ringsim.gravity.base import GravitySolver, has_c_field, install_c_field
from ringsim.physics.gravity_solvers import TREE

#: Ghost-box rings in x and y with the truncation field added (deeper rings change the
#: force error by < 0.1 %: it is the opening angle that sets it; docs/gravity.md).
DEFAULT_GHOST_BOXES = 1


def has_ghost_field(sim: rebound.Simulation) -> bool:
    """True if ``sim.additional_forces`` is ringsim's ghost-box truncation field."""
    return has_c_field(sim, "rs_ghost_field")


def install_ghost_field(sim: rebound.Simulation) -> None:
    """Add the field of the sheet beyond the ghost boxes to ``sim``'s tree gravity.

    Sets REBOUND's ``additional_forces`` to ``rs_ghost_field`` (``ringsim/csrc/rs_gravity.c``,
    the C twin of ``physics.ghost_field.ghost_truncation_field``): REBOUND calls it right
    after its tree gravity, at the same time ``sim.t`` (which sets the ghost rows' shear
    offsets), so the two together are the field of the infinite shear-periodic sheet to
    0.5-0.7 % rms at opening angle 0.3 (docs/gravity.md).  It reads everything from the
    simulation (G, Omega, box, N_ghost_x/y, boundary), so it stays right after the box is
    enlarged.  REBOUND does not save function pointers: call it again after loading a
    simulation from a file.

    Raises ValueError if ``additional_forces`` already holds another function.
    """
    if sim._additional_forces and not has_ghost_field(sim):
        raise ValueError("sim.additional_forces is already set; the ghost-box truncation "
                         "field needs it")
    install_c_field(sim, "rs_ghost_field")


def install(sim: rebound.Simulation, *, opening_angle: float) -> None:
    """REBOUND's tree at ``opening_angle`` [rad], `DEFAULT_GHOST_BOXES` rings of ghost boxes
    and the field of the sheet beyond them (`install_ghost_field`)."""
    sim.gravity = "tree"
    sim.opening_angle2 = opening_angle**2
    sim.N_ghost_x, sim.N_ghost_y = DEFAULT_GHOST_BOXES, DEFAULT_GHOST_BOXES
    install_ghost_field(sim)


def arguments(scenario) -> dict:
    """``opening_angle`` [rad] of a scenario's tree."""
    return {"opening_angle": scenario.sheet.opening_angle}


def recognise(sim: rebound.Simulation) -> dict | None:
    """``opening_angle`` [rad] of the tree installed in ``sim`` (None: no tree)."""
    if sim.gravity != "tree":
        return None
    return {"opening_angle": math.sqrt(sim.opening_angle2)}


def attributes(keywords: dict, geometry) -> dict:
    """The run file's attributes of the tree: opening angle [rad], ghost-box rings,
    softening [m]."""
    return {"gravity_solver": TREE.name,
            "tree_opening_angle": float(keywords["opening_angle"]),
            "units_tree_opening_angle": "rad",
            "tree_ghost_boxes": DEFAULT_GHOST_BOXES,
            "units_tree_ghost_boxes": "rings (x and y), plus the field beyond them",
            "softening": float(keywords["softening"]), "units_softening": "m"}


SOLVER = GravitySolver(TREE, install=install, arguments=arguments, recognise=recognise,
                       attributes=attributes)
