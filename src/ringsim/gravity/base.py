"""The interface of a self-gravity solver, and the C fields REBOUND calls.

A solver is a `GravitySolver`: its declaration (``physics.gravity_solvers``: name and
scenario keys) and five functions, what the engine asks of every solver.  The engine sets
``sim.G`` and ``sim.softening`` and then calls the solver's ``install``; REBOUND does not
save function pointers, so the run loop installs it again after loading a checkpoint, with
the same keywords (``arguments`` of the scenario).  ``recognise`` finds the solver in a
simulation (a box enlarged mid-run is a new simulation that gets the same solver again).

The C fields of ``csrc/rs_gravity.c`` (the tree's field beyond its ghost boxes, the slab's
field) are REBOUND ``additional_forces``: `install_c_field` sets one by its symbol name.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import rebound

from ringsim.engine.native import _LIB, _POST_TIMESTEP
from ringsim.physics.gravity_solvers import SolverDeclaration

if TYPE_CHECKING:
    from ringsim.config.scenario import Scenario
    from ringsim.engine.box import SheetGeometry


def _nothing(*_args) -> None:
    """The hook of a solver that has nothing to do there."""


@dataclass(frozen=True)
class GravitySolver:
    """A self-gravity solver installed in a REBOUND shearing sheet.

    ``keywords`` below are the solver's own keywords of `registry.install_gravity`
    (``opening_angle``, ``p3m_setting``; none for the slab), without ``softening``.

    Attributes
    ----------
    declaration : SolverDeclaration
        Name and scenario keys (``physics.gravity_solvers``).
    install : callable
        ``install(sim, **keywords)``: switch the solver on in a configured sheet whose
        ``sim.G`` and ``sim.softening`` [m] are set (before or after adding particles;
        again after loading a simulation from a file).
    arguments : callable
        ``arguments(scenario) -> keywords`` of a scenario that chose this solver.
    recognise : callable
        ``recognise(sim) -> keywords`` that install this solver again in another
        simulation, or None if it is not the one installed in ``sim``.
    attributes : callable
        ``attributes(keywords, geometry) -> dict``: root attributes of the run file naming
        the solver and its parameters, each with ``units_<name>`` beside it; here
        ``keywords`` include ``softening`` [m].
    set_threads : callable
        ``set_threads(sim, threads)``: the solver's own threads, if installed (no result
        may depend on them).
    raise_pending : callable
        ``raise_pending(sim)``: re-raise an error that a Python callback of the solver
        caught during the last steps (ctypes cannot pass it through REBOUND).
    """

    declaration: SolverDeclaration
    install: Callable[..., None]
    arguments: Callable[[Scenario], dict[str, Any]]
    recognise: Callable[[rebound.Simulation], dict[str, Any] | None]
    attributes: Callable[[dict[str, Any], SheetGeometry], dict[str, Any]]
    set_threads: Callable[[rebound.Simulation, int], None] = _nothing
    raise_pending: Callable[[rebound.Simulation], None] = _nothing

    @property
    def name(self) -> str:
        """Value of ``sheet.gravity_solver``."""
        return self.declaration.name


def c_field_pointer(name: str):
    """A ctypes function pointer to the C field ``name`` of ``rs_gravity.c`` (REBOUND's
    additional_forces type)."""
    if not hasattr(_LIB, name):
        raise ImportError("ringsim._resolver was built without rs_gravity.c; rebuild the "
                          "extension (`python setup.py build_ext --inplace`)")
    address = ctypes.cast(getattr(_LIB, name), ctypes.c_void_p).value
    if address is None:    # a function of a loaded library always has an address
        raise ImportError(f"ringsim._resolver: {name} has no address")
    return _POST_TIMESTEP(address)


def has_c_field(sim: rebound.Simulation, name: str) -> bool:
    """True if ``sim.additional_forces`` is the C field ``name``."""
    current = ctypes.cast(sim._additional_forces, ctypes.c_void_p).value
    return current is not None and current == ctypes.cast(c_field_pointer(name),
                                                           ctypes.c_void_p).value


def install_c_field(sim: rebound.Simulation, name: str) -> None:
    """Make the C field ``name`` REBOUND's ``additional_forces`` of ``sim``."""
    fp = c_field_pointer(name)
    sim._additional_forces = fp
    sim._afp = fp    # REBOUND's slot that keeps the ctypes object alive with the simulation
