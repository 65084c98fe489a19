"""The self-gravity keys of the ``sheet`` section: which solver, and its parameters.

``sheet.gravity_solver`` (default ``config.scenario_keys.DEFAULTS["sheet.gravity_solver"]``)
and the solvers' own keys (``sheet.softening``, the tree's ``sheet.opening_angle``, P3M's
``sheet.p3m_split``): read and validated here, for the sheet reader of
``config.scenario_keys``, from the solvers' declarations
(``physics.gravity_solvers``: names, parameters with unit, default, range and ``auto``,
the keys each solver refuses, the box each needs).  Nothing here names a solver.
"""

from __future__ import annotations

from typing import Any

from ringsim.config.schema import Section
from ringsim.physics.gravity_solvers import (
    ACTS_ONLY_WITH,
    GRAVITY_SOLVERS,
    P3M,
    SOLVER_PARAMETERS,
)
from ringsim.physics.laws import DIMENSIONLESS, Parameter
from ringsim.physics.p3m_scales import p3m_first_split

#: The solvers' keys of the ``sheet`` section, in the order a scenario writes them.
SOLVER_KEYS = tuple(SOLVER_PARAMETERS)
#: Keys that only a gravitating sheet may set.
GRAVITY_ONLY_KEYS = ("gravity_solver", *SOLVER_KEYS)


def _users(key: str) -> list[str]:
    """The solvers that use ``key``, in declaration order."""
    return [s.name for s in GRAVITY_SOLVERS.values() if key in s.names]


def _default_solver(sec: Section, d: dict[str, Any]) -> str:
    """The solver of a section without ``gravity_solver``: the one a key given implies
    (its declaration's ``implied_by``: ``opening_angle`` means the tree), else the
    default."""
    if not sec.has("gravity_solver"):
        for declaration in GRAVITY_SOLVERS.values():
            if any(sec.has(key) for key in declaration.implied_by):
                return declaration.name
    return d["sheet.gravity_solver"]


def _refuse_unused_keys(sec: Section, solver: str) -> None:
    """A key the chosen solver does not use is an error naming the solvers that use it;
    keys of a single solver are named before keys that several share."""
    declaration = GRAVITY_SOLVERS[solver]
    unused = sorted((key for key in SOLVER_KEYS if key not in declaration.names),
                    key=lambda key: len(_users(key)))
    for key in (k for k in unused if sec.has(k)):
        users = _users(key)
        problem = (f"only used with gravity_solver: {users[0]}" if len(users) == 1 else
                   f"not used with gravity_solver: {solver}"
                   + (f" ({declaration.lacks})" if declaration.lacks else ""))
        raise sec.error(key, problem,
                        f"remove the key, or set sheet.gravity_solver: {' or '.join(users)}")


def _read_parameter(sec: Section, par: Parameter) -> float | str:
    """A solver's key as its declaration allows: a number in range, or "auto"."""
    unit = "" if par.unit == DIMENSIONLESS else par.unit
    if par.auto:
        return sec.number_or_auto(par.name, par.default, unit=unit, **par.limits())
    return sec.number(par.name, par.default, unit=unit, **par.limits())


def read_gravity_keys(sec: Section, d: dict[str, Any]) -> dict[str, Any]:
    """``gravity``, ``gravity_solver`` and every solver key of `SOLVER_KEYS` (numbers in
    their units, or "auto"; None where the solver does not use it) of a sheet section,
    with defaults ``d`` for ``gravity`` and ``gravity_solver``."""
    gravity = sec.boolean("gravity", d["sheet.gravity"])
    if not gravity:
        for name in GRAVITY_ONLY_KEYS:
            if sec.has(name):
                raise sec.error(name, "only used with self-gravity",
                                "set sheet.gravity: true, or remove the key")
        return {"gravity": False, "gravity_solver": None, **dict.fromkeys(SOLVER_KEYS)}
    solver = sec.string("gravity_solver", _default_solver(sec, d),
                        choices=tuple(GRAVITY_SOLVERS))
    _refuse_unused_keys(sec, solver)
    values: dict[str, Any] = dict.fromkeys(SOLVER_KEYS)
    for par in GRAVITY_SOLVERS[solver].parameters:
        values[par.name] = _read_parameter(sec, par)
    for key, needed in ACTS_ONLY_WITH.items():
        if sec.has(key) and values[key] != SOLVER_PARAMETERS[key].default \
                and not values[needed]:
            raise sec.error(key, f"acts only with sheet.{needed} above 0",
                            f"set sheet.{needed} (the Saturn presets: 0.08), or remove the key")
    return {"gravity": True, "gravity_solver": solver, **values}


def p3m_setting(sheet, mean_radius: float) -> tuple[float, bool] | None:
    """(split [m], auto) of a sheet's P3M solver: ``sheet.p3m_split`` given as a number, or
    "auto" from P3M_SPLIT_RADII times the larger of the mean radius and
    ``sheet.p3m_pair_min_radius`` up (the particles of the pair sum set the split); None
    without P3M.

    Parameters
    ----------
    sheet : SheetConfig
    mean_radius : float [m]
    """
    if sheet.gravity_solver != P3M.name:
        return None
    base = max(mean_radius, sheet.p3m_pair_min_radius or 0.0)
    return p3m_first_split(sheet.p3m_split, base), sheet.p3m_split == "auto"


def check_gravity_box(top: Section, sheet, mean_radius: float, lx: float, ly: float) -> None:
    """The box must suit the sheet's solver (its declaration's ``check_box``: P3M's pair
    sum needs a box wider than its cutoff).

    Parameters
    ----------
    sheet : SheetConfig
    mean_radius : float [m]
    lx, ly : float [m]
        The box the scenario makes.
    """
    declaration = GRAVITY_SOLVERS.get(sheet.gravity_solver)    # None without gravity
    if declaration is None or declaration.check_box is None:
        return
    values = {key: getattr(sheet, key) for key in declaration.names}
    refused = declaration.check_box(values, mean_radius, sheet.n_particles, lx, ly)
    if refused is not None:
        raise top.error("sheet.gravity_solver", *refused)
