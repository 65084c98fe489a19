"""The self-gravity solvers by name, and what the engine asks of them.

`SOLVERS` holds one `ringsim.gravity.base.GravitySolver` per name of
``physics.gravity_solvers.GRAVITY_SOLVERS``, in the same order.  `install_gravity` switches
one on (new sheets, box enlargements, after loading a checkpoint: REBOUND does not save
function pointers; the code ``ringsim export --rebound`` prints calls it too, as
``ringsim.engine.gravity.install_gravity``); `scenario_gravity_arguments` gives its keywords
for a scenario, `installed_gravity` those of the solver already installed in a
simulation, and `solver_attributes` the run file's description of the solver.
"""

from __future__ import annotations

from typing import Any

import rebound

from ringsim.gravity import p3m, slab, tree
from ringsim.gravity.base import GravitySolver
from ringsim.physics.constants import G_SI

#: The solvers by ``sheet.gravity_solver``, in the order of their declarations.
SOLVERS: dict[str, GravitySolver] = {s.name: s for s in (tree.SOLVER, p3m.SOLVER, slab.SOLVER)}


def install_gravity(sim: rebound.Simulation, solver: str, *, softening: float,
                    **keywords: Any) -> None:
    """Switch self-gravity on in a configured shearing sheet (before or after adding
    particles; again after loading one from a file).

    Parameters
    ----------
    solver : str
        A name of `SOLVERS`: "tree" (keyword ``opening_angle`` [rad]), "p3m" (keyword
        ``p3m_setting`` = (split scale [m], auto: the split follows the height span from
        there up)) or "slab" (no keywords).  Keywords given as None are left out.
    softening : float [m]
        Plummer softening (``sim.softening``; the slab has no close pairs to soften).
    """
    entry = SOLVERS.get(solver)
    if entry is None:
        raise ValueError(f"unknown gravity solver {solver!r}")
    sim.G = G_SI
    sim.softening = softening
    entry.install(sim, **{key: value for key, value in keywords.items() if value is not None})


def scenario_gravity_arguments(scenario) -> dict[str, Any]:
    """The arguments of `install_gravity` for a gravitating scenario: ``solver``,
    ``softening`` [m] and the solver's own keywords."""
    name = scenario.sheet.gravity_solver or "tree"
    return {"solver": name, "softening": scenario.softening_length,
            **SOLVERS[name].arguments(scenario)}


def install_scenario_gravity(sim: rebound.Simulation, scenario) -> None:
    """`install_gravity` with a scenario's solver and parameters (function pointers are not
    saved by REBOUND: the run loop calls this after loading a checkpoint)."""
    install_gravity(sim, **scenario_gravity_arguments(scenario))


def installed_gravity(sim: rebound.Simulation) -> dict[str, Any] | None:
    """The arguments of `install_gravity` that install the solver of ``sim`` in another
    simulation (``solver``, ``softening`` [m], its keywords), or None without one."""
    for name, entry in SOLVERS.items():
        keywords = entry.recognise(sim)
        if keywords is not None:
            return {"solver": name, "softening": sim.softening, **keywords}
    return None


def installed_solver_name(sim: rebound.Simulation) -> str | None:
    """The name of the self-gravity solver installed in ``sim``, or None."""
    installed = installed_gravity(sim)
    return None if installed is None else installed["solver"]


def solver_attributes(scenario, geometry) -> dict[str, Any]:
    """Root attributes of a run file naming the scenario's gravity solver and its
    parameters, each with ``units_<name>`` beside it.

    Parameters
    ----------
    scenario : Scenario
    geometry : SheetGeometry
    """
    keywords = scenario_gravity_arguments(scenario)
    return SOLVERS[keywords.pop("solver")].attributes(keywords, geometry)


def set_gravity_threads(sim: rebound.Simulation, threads: int) -> None:
    """The installed solver's own threads (no result depends on them)."""
    for entry in SOLVERS.values():
        entry.set_threads(sim, threads)


def raise_pending(sim: rebound.Simulation) -> None:
    """Re-raise an error a solver's Python callback caught during the last steps."""
    for entry in SOLVERS.values():
        entry.raise_pending(sim)
