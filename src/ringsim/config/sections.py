"""The sections of a scenario as frozen dataclasses: planet, particles, sheet, restitution,
friction, integration, output.

They hold validated values only (SI, durations in orbits); `ringsim.config.scenario_keys`
(and, for ``integration``, `ringsim.config.scenario`) reads and checks the YAML into them,
and `ringsim.config.scenario` assembles the `Scenario`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

from ringsim.config.initial_state import InitialStateFile, sheet_dict_with_file
from ringsim.physics.friction import SOLID_SPHERE_INERTIA
from ringsim.physics.gravity_solvers import SOLVER_PARAMETERS
from ringsim.physics.restitution import RESTITUTION
from ringsim.physics.sizes import SizeDistribution

# --- the frozen scenario ----------------------------------------------------------------------

@dataclass(frozen=True)
class Planet:
    """Where the patch orbits: give ``Omega``, or ``GM`` and ``a`` (the other stays None).

    Attributes
    ----------
    Omega : float or None [1/s]
        Orbital (Keplerian) angular frequency of the patch.
    GM : float or None [m^3/s^2]
        Gravitational parameter of the planet.
    a : float or None [m]
        Orbital radius of the patch.
    """

    Omega: float | None
    GM: float | None
    a: float | None

    @property
    def orbital_frequency(self) -> float:
        """Omega [1/s]: as given, or sqrt(GM / a^3)."""
        if self.Omega is not None:
            return self.Omega
        GM, a = self._gm_and_a()
        return math.sqrt(GM / a**3)

    def _gm_and_a(self) -> tuple[float, float]:
        """GM and a of a planet given without Omega; ValueError if either is missing."""
        if self.GM is None or self.a is None:
            raise ValueError("planet: give Omega, or both GM and a")
        return self.GM, self.a

    @property
    def orbital_period(self) -> float:
        """One orbit, 2 pi / Omega [s]."""
        return 2.0 * math.pi / self.orbital_frequency

    def to_dict(self) -> dict[str, float]:
        if self.Omega is not None:
            return {"Omega": self.Omega}
        GM, a = self._gm_and_a()
        return {"GM": GM, "a": a}


@dataclass(frozen=True)
class Particles:
    """The ring particles: solid spheres of one bulk density.

    Attributes
    ----------
    density : float [kg/m^3]
        Bulk density of every particle (900 for solid ice; lower for porous aggregates).
    size_distribution : Monodisperse | PowerLaw | PowerLawCutoff | Mixture
    inertia_factor : float [dimensionless]
        k in the moment of inertia I = k m R^2 (2/5: solid sphere); used with a
        ``friction`` section only (`ringsim.physics.friction.INERTIA_FACTOR`).
    """

    density: float
    size_distribution: SizeDistribution
    inertia_factor: float = SOLID_SPHERE_INERTIA

    @property
    def mean_mass(self) -> float:
        """Number-weighted mean particle mass, density * 4/3 pi <R^3> [kg]."""
        return self.density * 4.0 / 3.0 * math.pi * self.size_distribution.moment(3.0)

    def to_dict(self) -> dict[str, Any]:
        d = {"density": self.density, "size_distribution": self.size_distribution.to_dict()}
        if self.inertia_factor != SOLID_SPHERE_INERTIA:   # only written with friction
            d["inertia_factor"] = self.inertia_factor
        return d


@dataclass(frozen=True)
class SheetConfig:
    """The shearing-sheet patch.

    Attributes
    ----------
    optical_depth : float [dimensionless]
        Dynamical optical depth, sum(pi R^2) / (Lx Ly).
    n_particles : int
        Number of particles; the box area is sized to hold them at that optical depth.
    aspect : float [dimensionless]
        Ly / Lx (y along the orbit, x radial).
    gravity : bool
        Self-gravity (solver: ``gravity_solver``).
    gravity_solver : "tree", "p3m", "slab" or None
        REBOUND's tree plus the field beyond its ghost boxes, or ringsim's P3M solver
        (physics.gravity_solvers.GRAVITY_SOLVERS); None without gravity.
    softening : float [m] or "auto" or None
        Gravitational softening length; "auto" = 0.1 x smallest radius; None without gravity.
    opening_angle : float [rad] or None
        Barnes-Hut opening angle of the tree (REBOUND's opening_angle2 is its square);
        None without the tree.
    initial_dispersion : float [mean radius x Omega]
        Initial 1-D velocity dispersion relative to the shear flow.
    initial_toomre_q : float [-] or None
        With self-gravity: the initial 1-D velocity dispersion instead as Toomre's Q of the
        sheet, c = Q 3.36 G Sigma / Omega (replaces initial_dispersion); None: not used.
    p3m_split : float [m] or "auto" or None
        Split scale of the P3M solver; "auto" follows the layer's height span; None
        without P3M.
    p3m_pair_min_radius : float [m] or None
        P3M's field-only particles are those smaller than this (0: none); None without P3M.
    p3m_tail_fraction : float [-] or None
        Fraction of the particles P3M's mesh may leave beyond its layers (0: none); None
        without P3M.
    p3m_mesh_interval : float [steps] or None
        Steps per evaluation of P3M's mesh (a whole number; 1: every step); None without
        P3M.
    p3m_core_min_radius : float [m] or None
        With a tail fraction, the particles whose heights set P3M's mesh core are those of
        at least this radius (0: all); None without P3M.
    z_box : float [mean radii] or "auto"
        Initial vertical height of the box.
    initial_state : InitialStateFile or None
        Particles (radii, masses, positions, velocities) from a file instead of drawn.
    """

    optical_depth: float
    n_particles: int
    aspect: float
    gravity: bool
    softening: float | str | None
    opening_angle: float | None
    initial_dispersion: float
    z_box: float | str
    initial_state: InitialStateFile | None = None
    initial_toomre_q: float | None = None
    gravity_solver: str | None = None
    p3m_split: float | str | None = None
    p3m_pair_min_radius: float | None = None
    p3m_tail_fraction: float | None = None
    p3m_mesh_interval: float | None = None
    p3m_core_min_radius: float | None = None

    def gravity_dict(self) -> dict[str, Any]:
        """The self-gravity keys as a scenario gives them ({} without gravity; no softening
        for the slab, which has no pairs, and an opening angle for the tree only)."""
        if not self.gravity:
            return {}
        d: dict[str, Any] = {"gravity_solver": self.gravity_solver}
        for key, par in SOLVER_PARAMETERS.items():   # the solvers' keys, None where not used
            value = getattr(self, key)
            if value is not None and not par.implied(value):
                d[key] = value
        return d

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"optical_depth": self.optical_depth,
                             "n_particles": self.n_particles, "aspect": self.aspect,
                             "gravity": self.gravity}
        if self.initial_state is not None:
            return sheet_dict_with_file(self, d)
        d.update(self.gravity_dict())
        if self.initial_toomre_q is not None:
            d["initial_toomre_q"] = self.initial_toomre_q
        else:
            d["initial_dispersion"] = self.initial_dispersion
        d["z_box"] = self.z_box
        return d


@dataclass(frozen=True)
class Restitution:
    """Coefficient-of-restitution law: a model name and its parameters (defaults filled).

    The parameters are also attributes: ``sc.restitution.kappa``; see
    `ringsim.physics.restitution.RESTITUTION` for the names of each model.

    Attributes
    ----------
    model : str
        dilley | bridges | constant | andrews | tabor.
    parameters : tuple of (name, value) pairs
        xi0 [-], p [-], kappa [-] | v_c [m/s], exponent [-] | epsilon [-] | v_c [m/s] |
        v_c [m/s], q [-].
    """

    model: str
    parameters: tuple[tuple[str, float], ...]

    def __getattr__(self, name: str) -> float:
        # Only reached when normal lookup fails: expose the model's parameters by name.
        if not name.startswith("_"):
            for key, value in self.__dict__.get("parameters", ()):
                if key == name:
                    return value
        raise AttributeError(f"{type(self).__name__} of model "
                             f"{self.__dict__.get('model')!r} has no attribute {name!r}")

    def to_dict(self) -> dict[str, Any]:
        """{"model": ..., parameter: value, ...} as the resolver and epsilon_for_pair take
        (parameters declared ``implicit_at_default`` left out at their default)."""
        return {"model": self.model,
                **RESTITUTION[self.model].explicit(dict(self.parameters))}


@dataclass(frozen=True)
class Friction:
    """Surface friction of the particles: a model of `ringsim.physics.friction.FRICTION`
    and its parameters (defaults filled).  No section: smooth spheres, no spins.

    Attributes
    ----------
    model : str
        constant | coulomb.
    parameters : tuple of (name, value) pairs
        beta [-] | mu [-], beta0 [-].
    """

    model: str
    parameters: tuple[tuple[str, float], ...]

    def to_dict(self) -> dict[str, Any]:
        """{"model": ..., parameter: value, ...} as the resolver takes it."""
        return {"model": self.model, **dict(self.parameters)}


@dataclass(frozen=True)
class Integration:
    """How long and how finely to integrate.

    Attributes
    ----------
    orbits : float [orbits]
        Duration.
    dt : float [orbits] or "auto"
        Fixed time step, or chosen by the run from ``dt_safety``.
    dt_safety : float [dimensionless]
        For dt: auto, the largest relative displacement of two particles in one step, as a
        fraction of the smallest radius.
    collision_detection : str
        tree (overlaps at the ends of steps) | line (swept paths within the step).
    until_equilibrium : bool
        Stop once the equilibrium finder calls c and H stationary (``orbits`` is then the
        maximum).
    threads : int >= 1 or "auto"
        OpenMP threads of line detection's search; "auto": the cores this process may run
        on (``available_cores``).  Results do not depend on it (same seed, same bits).
    resolver : str
        ringsim (ringsim's C resolver) | rebound_hardsphere (REBOUND's built-in hard-sphere
        resolver, for comparisons; written by `to_dict` only when not the default, so that
        the identity of every other run is unchanged).
    """

    orbits: float
    dt: float | str
    dt_safety: float
    collision_detection: str
    until_equilibrium: bool = False
    threads: int | str = "auto"
    resolver: str = "ringsim"

    def to_dict(self) -> dict[str, Any]:
        d = {"orbits": self.orbits, "dt": self.dt, "dt_safety": self.dt_safety,
             "collision_detection": self.collision_detection,
             "until_equilibrium": self.until_equilibrium, "threads": self.threads}
        if self.resolver != "ringsim":
            d["resolver"] = self.resolver
        return d

    def thread_count(self) -> int:
        """The number of threads ``threads`` asks for (``auto`` resolved now)."""
        return available_cores() if self.threads == "auto" else int(self.threads)


def read_threads(sec, default: Any) -> int | str:
    """``integration.threads`` of a scenario section (``config.schema.Section``): "auto" or
    an integer >= 1; ScenarioError otherwise."""
    from ringsim.config.schema import ScenarioError

    if sec.mapping.get("threads", default) == "auto":
        return "auto"
    try:
        return sec.integer("threads", default, ge=1)
    except ScenarioError as exc:
        raise sec.error("threads", exc.problem, "auto, or an integer >= 1") from None


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity; os.cpu_count where unknown)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # no sched_getaffinity on this platform (macOS, Windows)
        return max(1, os.cpu_count() or 1)


@dataclass(frozen=True)
class Output:
    """What to write and how often (intervals in orbits).

    Attributes
    ----------
    path : str
        Run file (HDF5); the command line's ``-o`` wins.
    timeseries_every, snapshot_every, checkpoint_every : float [orbits]
    log_collisions : int
        Capacity of the sampled collision log (0: no log).
    """

    path: str
    timeseries_every: float
    snapshot_every: float
    checkpoint_every: float
    log_collisions: int

    def to_dict(self) -> dict[str, Any]:
        return {"path": self.path, "timeseries_every": self.timeseries_every,
                "snapshot_every": self.snapshot_every,
                "checkpoint_every": self.checkpoint_every,
                "log_collisions": self.log_collisions}
