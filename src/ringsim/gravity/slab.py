"""The slab solver (``sheet.gravity_solver: slab``): only the vertical field of the
horizontally averaged layer, ``rs_slab_field`` in ``ringsim/csrc/rs_gravity.c`` (the C
twin of ``physics.selfgravity.slab_field``) as REBOUND's ``additional_forces``, REBOUND's
own gravity off.  No pair forces, so no softening and no parameters (docs/gravity.md, 4c).
"""

from __future__ import annotations

import rebound

from ringsim.gravity.base import GravitySolver, has_c_field, install_c_field
from ringsim.physics.gravity_solvers import SLAB


def install(sim: rebound.Simulation) -> None:
    """REBOUND's gravity off, the averaged layer's vertical field on."""
    sim.gravity = "none"
    install_c_field(sim, "rs_slab_field")


def arguments(scenario) -> dict:
    """The slab has no keywords."""
    return {}


def recognise(sim: rebound.Simulation) -> dict | None:
    """{} if the slab field is installed in ``sim``, else None."""
    return {} if has_c_field(sim, "rs_slab_field") else None


def attributes(keywords: dict, geometry) -> dict:
    """The run file's attribute of the slab: its name."""
    return {"gravity_solver": SLAB.name}


SOLVER = GravitySolver(SLAB, install=install, arguments=arguments, recognise=recognise,
                       attributes=attributes)
