"""The self-gravity solvers a scenario may choose, declared once: name and parameters.

Each solver of ``sheet.gravity_solver`` is a `SolverDeclaration`: its name, one line of
meaning, its keys of the ``sheet`` section as `ringsim.physics.laws.Parameter` (unit,
default, range, meaning, source, and what ``auto`` means where a key accepts it), and, where
it has one, its check of the box.  `GRAVITY_SOLVERS` collects them by name, in the order
the docs and the scenario's error messages list them.  The scenario's gravity keys
(``config.gravity_keys``) are validated from these declarations; the installation of each
solver in a REBOUND simulation is ``ringsim.gravity.<name>``, which names its declaration.

The declarations live here, not beside the installation, because the scenario reader
(config) may import physics but not the REBOUND machinery (``ringsim.gravity`` is at the
engine's level).  Pure Python: no numpy, no REBOUND.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ringsim.physics.laws import AUTO, DIMENSIONLESS, Parameter
from ringsim.physics.p3m_scales import (
    P3M_CUTOFF_SPLITS,
    P3M_SPLIT_RADII,
    P3M_TAIL_FRACTION,
    P3M_TAIL_MARGIN_SCALES,
    P3M_TAIL_MARGIN_SPLITS,
    p3m_first_split,
)

#: Softening used by ``sheet.softening: auto``, as a fraction of the smallest particle
#: radius (REBOUND's shearing-sheet example: 0.1 m for 1 m particles).
AUTO_SOFTENING_FRACTION = 0.1

SOFTENING = Parameter(
    "softening", "m", default=AUTO, lower=0.0, lower_closed=True, example=0.1,
    auto=f"{AUTO_SOFTENING_FRACTION:g} x the smallest particle radius",
    meaning="gravitational (Plummer) softening length of the pair forces",
    source="REBOUND's shearing-sheet example (0.1 m for 1 m particles)")
OPENING_ANGLE = Parameter(
    "opening_angle", "rad", default=0.3, lower=0.0, upper=1.0, upper_closed=True,
    meaning="Barnes-Hut opening angle of REBOUND's tree (its opening_angle2 is the square)",
    source="docs/gravity.md: < 1 % rms force error with the field beyond the ghost boxes, "
           "2 % at 0.5")
P3M_SPLIT = Parameter(
    "p3m_split", "m", default=AUTO, lower=0.0, example=3.0,
    auto=f"follows the layer's height span, from {P3M_SPLIT_RADII:g} mean radii up "
         "(physics.p3m_scales.p3m_auto_split)",
    meaning="split scale r_s of P3M's Gaussian force split (cutoff, mesh cells and layers "
            "are multiples of it)",
    source="docs/gravity.md, section 4b (benchmarks/gravity.py, benchmarks/p3m_split.py)")
P3M_PAIR_MIN_RADIUS = Parameter(
    "p3m_pair_min_radius", "m", default=0.0, lower=0.0, lower_closed=True, example=0.1,
    meaning="particles smaller than this radius are field-only: their mass is on P3M's mesh "
            "and the mesh field acts on them, but they are not in the short-range pair sum "
            "(neither as sources nor as targets); the automatic split then starts from "
            "P3M_SPLIT_RADII x the larger of the mean radius and this radius",
    source="docs/gravity.md, section \"Field-only small particles\" (the force error it "
           "introduces, measured against the full solver)")

P3M_TAIL = Parameter(
    "p3m_tail_fraction", DIMENSIONLESS, default=0.0, lower=0.0, upper=0.5,
    lower_closed=True, implicit_at_default=True,
    meaning="fraction of the particles P3M's mesh may leave beyond its layers (the sparse "
            "high tail of the heights, half above and half below; the layers then span the "
            f"rest widened by the larger of {P3M_TAIL_MARGIN_SPLITS:g} r_s and "
            f"{P3M_TAIL_MARGIN_SCALES:g} robust sigma of the heights on each side): a "
            "particle beyond is on the mesh at its top or bottom, its pair forces within "
            "the cutoff and the mean vertical field stay exact; 0: the layers span every "
            f"particle; {P3M_TAIL_FRACTION:g} saves a quarter of the step of a thick ring "
            "at the same force error (the Saturn presets)",
    source="docs/gravity.md, section 4b, \"The sparse high tail apart\" (force error "
           "against the direct sum; benchmarks/p3m_thick.py)")

P3M_MESH_INTERVAL = Parameter(
    "p3m_mesh_interval", DIMENSIONLESS, default=1.0, lower=1.0, upper=99.0,
    lower_closed=True, upper_closed=True, implicit_at_default=True,
    meaning="steps per evaluation of P3M's mesh (an odd whole number k): the long-range "
            "mesh force acts as an impulse of k steps on the middle step of every k "
            "(step index floor(t / dt) = (k - 1) / 2 modulo k) and not on the others, while "
            "the pair sum and the mean vertical field act every step (the impulse "
            "multiple-time-step scheme, RESPA); 1: the mesh every step; 5 left an "
            "equilibrium's c and H within the seeds' spread (-10 to +3 %), 15 heated it "
            "by about 10 %",
    source="Tuckerman, Berne & Martyna 1992, J. Chem. Phys. 97, 1990 (reversible "
           "multiple time scale molecular dynamics); docs/gravity.md, section \"The mesh "
           "every k steps\" (its error against k = 1; benchmarks/p3m_thick.py)")

P3M_CORE_MIN_RADIUS = Parameter(
    "p3m_core_min_radius", "m", default=0.0, lower=0.0, lower_closed=True,
    implicit_at_default=True, example=0.25,
    meaning="with p3m_tail_fraction: the heights of the particles of at least this radius "
            "set the core the mesh's layers span (their order statistics and robust "
            "sigma), so that a ring whose small particles (field-only, little of the mass) "
            "stand higher than its large ones keeps a mesh as tall as the layer that holds "
            "its mass; the particles beyond are on the mesh as the tail is; 0: every "
            "particle's height counts",
    source="docs/gravity.md, section \"The core of the pair-summed particles\" (the force "
           "error against the direct sum in the A-ring preset's equilibrium)")
#: Keys that act only where another key of the same solver is above 0: given away from its
#: default without that, the key would change a run's identity and nothing else.
ACTS_ONLY_WITH = {"p3m_core_min_radius": "p3m_tail_fraction"}


@dataclass(frozen=True)
class SolverDeclaration:
    """One self-gravity solver as a scenario chooses it.

    Attributes
    ----------
    name : str
        Value of ``sheet.gravity_solver``.
    meaning : str
        One line for the docs.
    parameters : tuple of Parameter
        Its keys of the ``sheet`` section (a key several solvers use is one `Parameter`,
        shared by their declarations).
    lacks : str
        What the solver does without: the reason given when a scenario sets a key that
        other solvers use ("no pair forces"); "": nothing to say.
    implied_by : tuple of str
        Keys that choose this solver when a scenario gives no ``gravity_solver``.
    check_box : callable or None
        ``check_box(values, mean_radius, n_particles, Lx, Ly)`` with the solver's
        parameter ``values`` (as given: numbers or "auto"), the mean radius and the box
        [m]: None if the box suits the solver, else (problem, what is allowed), the
        scenario error naming ``sheet.gravity_solver``.
    """

    name: str
    meaning: str
    parameters: tuple[Parameter, ...] = ()
    lacks: str = ""
    implied_by: tuple[str, ...] = ()
    check_box: Callable[..., tuple[str, str] | None] | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The solver's keys of the ``sheet`` section."""
        return tuple(p.name for p in self.parameters)


def _p3m_box(values: Mapping[str, Any], mean_radius: float, n_particles: int, Lx: float,
             Ly: float) -> tuple[str, str] | None:
    """P3M's pair sum needs a box wider than its cutoff (``rs_p3m.c``) at the first split
    scale (``auto`` never chooses a cutoff the box cannot hold).

    Parameters
    ----------
    values : P3M's keys (``p3m_split`` [m] or "auto", ``p3m_pair_min_radius`` [m],
        ``p3m_mesh_interval`` [steps], which must be odd and whole)
    mean_radius : float [m]
    n_particles : int
    Lx, Ly : float [m]
    """
    interval = float(values.get("p3m_mesh_interval") or 1.0)
    if interval != round(interval) or round(interval) % 2 == 0:
        return (f"p3m's sheet.p3m_mesh_interval must be an odd whole number of steps (the "
                f"mesh's impulse on the middle one), not {interval:g}",
                "an odd whole number from 1 to 99")
    base = max(mean_radius, float(values.get("p3m_pair_min_radius") or 0.0))
    cutoff = P3M_CUTOFF_SPLITS * p3m_first_split(values["p3m_split"], base)
    if min(Lx, Ly) > cutoff:
        return None
    return (f"p3m needs a box wider than its pair-sum cutoff ({cutoff:.3g} m); "
            f"{n_particles} particles make {Lx:.3g} m x {Ly:.3g} m",
            "tree, a smaller sheet.p3m_split, or more particles")


TREE = SolverDeclaration(
    "tree", "REBOUND's tree, one ring of ghost boxes and the field of the sheet beyond them",
    (SOFTENING, OPENING_ANGLE),
    # a scenario that sets the opening angle and no solver means the tree (the default is
    # P3M, which has no opening angle; docs/gravity.md, 8)
    implied_by=("opening_angle",))
P3M = SolverDeclaration(
    "p3m", "ringsim's shear-periodic P3M: a layered mesh with scipy.fft plus a pair sum in C",
    (SOFTENING, P3M_SPLIT, P3M_PAIR_MIN_RADIUS, P3M_TAIL, P3M_MESH_INTERVAL,
     P3M_CORE_MIN_RADIUS),
    check_box=_p3m_box)
SLAB = SolverDeclaration(
    "slab", "the vertical field of the horizontally averaged layer only (hot rings)",
    lacks="no pair forces")

#: The solvers by name, in the order the docs and the error messages list them.
GRAVITY_SOLVERS: dict[str, SolverDeclaration] = {s.name: s for s in (TREE, P3M, SLAB)}
#: Every solver parameter by key, once, in the order of the solvers' declarations.
SOLVER_PARAMETERS: dict[str, Parameter] = {
    p.name: p for s in GRAVITY_SOLVERS.values() for p in s.parameters}
