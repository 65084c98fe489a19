"""Scenario files: a YAML description of one ring-patch simulation -> a frozen `Scenario`.

A scenario names everything a run needs: where the patch orbits (``planet``), what the
particles are (``particles``: bulk density and size distribution), how large the patch is
(``sheet``), how collisions lose energy (``restitution``), how long and how finely to
integrate (``integration``) and what to write (``output``).  Every key, its unit, default
and allowed range is listed in ``docs/scenario.md``; the tables ``_SECTION_KEYS`` and the
``_read_*`` functions below are the single place where they are enforced.

All values are SI inside (m, kg, s) except where the key says otherwise: durations and
intervals are in orbits (2 pi / Omega), ``sheet.initial_dispersion`` is in units of the mean
particle radius times Omega, ``sheet.z_box`` in mean particle radii.

Errors are raised as `ScenarioError` with the file, the dotted key
(``particles.size_distribution.r_min``) and a one-line message
``"<file>: <dotted.key>: <what is wrong> (<allowed range or type>)"``.  Pseudo-keys:
``<file>`` (the file cannot be read), ``<yaml>`` (YAML syntax error, or the document is not
a mapping).

Example
-------
>>> sc = scenario_from_text("name: demo\\nseed: 1\\nplanet: {Omega: 2.0e-4}\\n"
...                         "particles: {size_distribution: {kind: monodisperse, radius: 1.0}}")
>>> sc.restitution_dict()
{'model': 'dilley', 'xi0': 0.16, 'p': 0.65, 'kappa': 0.0}
>>> with_overrides(sc, {"restitution.kappa": 0.1}).restitution.kappa
0.1
"""

from __future__ import annotations

import copy
import difflib
import itertools
import math
import numbers
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import yaml

from ringsim.errors import InputError
from ringsim.restitution import MODEL_PARAMETERS

__all__ = [
    "Integration",
    "Mixture",
    "MixtureComponent",
    "Monodisperse",
    "Output",
    "Particles",
    "Planet",
    "PowerLaw",
    "Restitution",
    "Scenario",
    "ScenarioError",
    "Sheet",
    "SizeDistribution",
    "Sweep",
    "load_scenario",
    "load_sweep",
    "scenario_from_dict",
    "scenario_from_text",
    "with_overrides",
]

#: Largest seed accepted: REBOUND's collision-shuffle seed ``rand_seed`` is an unsigned int.
MAX_SEED = 2**32 - 1
#: Largest dynamical optical depth accepted (denser patches are beyond a monolayer's reach).
MAX_OPTICAL_DEPTH = 3.0
#: Largest step accepted [orbits]: collisions need dt << 1/Omega.
MAX_DT_ORBITS = 0.1
#: Tolerance on the sum of a mixture's number fractions.
FRACTION_SUM_TOLERANCE = 1e-9
#: Softening used by ``softening: auto``, as a fraction of the smallest particle radius
#: (REBOUND's shearing-sheet example: 0.1 m for 1 m particles).
AUTO_SOFTENING_FRACTION = 0.1

# Keys of each section, in the order they are written by Scenario.to_dict().
_SECTION_KEYS: dict[str, tuple[str, ...]] = {
    "": ("name", "seed", "description", "planet", "particles", "sheet", "restitution",
         "integration", "output"),
    "planet": ("Omega", "GM", "a"),
    "particles": ("density", "size_distribution"),
    "sheet": ("optical_depth", "n_particles", "aspect", "gravity", "softening",
              "opening_angle", "initial_dispersion", "z_box"),
    "integration": ("orbits", "dt", "dt_safety", "collision_detection"),
    "output": ("path", "timeseries_every", "snapshot_every", "checkpoint_every",
               "log_collisions"),
}
_SIZE_KINDS: dict[str, tuple[str, ...]] = {
    "monodisperse": ("radius",),
    "powerlaw": ("q", "r_min", "r_max"),
    "mixture": ("components",),
}
_GRAVITY_ONLY_KEYS = ("softening", "opening_angle")
_COLLISION_DETECTIONS = ("tree", "line")

#: Defaults of the optional keys (restitution defaults come from ringsim.restitution).
DEFAULTS: dict[str, Any] = {
    "description": "",
    "particles.density": 900.0,
    "sheet.optical_depth": 0.25,
    "sheet.n_particles": 1000,
    "sheet.aspect": 1.0,
    "sheet.gravity": False,
    "sheet.softening": "auto",
    "sheet.opening_angle": 0.5,
    "sheet.initial_dispersion": 2.0,
    "sheet.z_box": "auto",
    "restitution.model": "dilley",
    "integration.orbits": 10.0,
    "integration.dt": "auto",
    "integration.dt_safety": 0.1,
    "integration.collision_detection": "tree",
    "output.timeseries_every": 0.1,
    "output.snapshot_every": 5.0,
    "output.log_collisions": 0,
}

_REQUIRED = object()


# --- errors -----------------------------------------------------------------------------------

class ScenarioError(InputError):
    """A scenario or sweep file is unreadable or invalid.

    Attributes
    ----------
    file : str
        The file (or the ``source`` name given to `scenario_from_text`).
    key : str
        Dotted key of the offending value (``"particles.size_distribution.r_min"``), or
        ``"<file>"`` (cannot read the file) or ``"<yaml>"`` (syntax error, not a mapping).
    problem : str
        What is wrong.
    allowed : str
        The allowed range or type.

    ``str(error)`` is the single line ``"<file>: <key>: <problem> (<allowed>)"``.
    """

    def __init__(self, file: str, key: str, problem: str, allowed: str):
        problem = " ".join(str(problem).split())
        allowed = " ".join(str(allowed).split())
        super().__init__(str(file), str(key), f"{problem} ({allowed})")
        self.problem = problem
        self.allowed = allowed

    def __reduce__(self):
        # Exceptions are pickled via their args; ours has four (sweeps run in processes).
        return (type(self), (self.file, self.key, self.problem, self.allowed))


def _show(value: Any) -> str:
    """A short one-line rendering of a user's value for an error message."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_real(value: Any) -> bool:
    """True for int/float (and numpy numbers), False for bool, str, None."""
    return (isinstance(value, numbers.Real)
            and not isinstance(value, (bool, np.bool_)))


def _is_integer(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


class _Section:
    """One mapping of the scenario being validated, with its dotted-key prefix."""

    def __init__(self, file: str, prefix: str, mapping: Mapping):
        self.file = file
        self.prefix = prefix
        self.mapping = mapping

    def key(self, name: str) -> str:
        return f"{self.prefix}.{name}" if self.prefix else name

    def error(self, name: str, problem: str, allowed: str) -> ScenarioError:
        return ScenarioError(self.file, self.key(name), problem, allowed)

    def check_keys(self, allowed: Sequence[str], context: str = "") -> None:
        """Reject keys not in ``allowed``, suggesting the closest valid one; ``context``
        ("the dilley model") says whose keys they are."""
        for raw_key in self.mapping:
            name = str(raw_key)
            if raw_key in allowed:
                continue
            close = difflib.get_close_matches(name, allowed, n=1, cutoff=0.6)
            if not close:  # case slips, e.g. "omega" for "Omega"
                lower = {a.lower(): a for a in allowed}
                close = [lower[name.lower()]] if name.lower() in lower else []
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise self.error(name, f"unknown key {name!r}" + (f" for {context}" if context
                                                                else ""),
                             f"{hint}allowed here: {', '.join(allowed)}")

    def has(self, name: str) -> bool:
        return name in self.mapping

    def get(self, name: str, default: Any, allowed: str) -> Any:
        """The raw value, ``default`` if absent; raise if required or given empty."""
        if name not in self.mapping:
            if default is _REQUIRED:
                raise self.error(name, f"missing required key {name!r}", allowed)
            return default
        value = self.mapping[name]
        if value is None:
            raise self.error(name, "no value given", allowed)
        return value

    def number(self, name: str, default: Any = _REQUIRED, *, unit: str = "",
               gt: float | None = None, ge: float | None = None,
               lt: float | None = None, le: float | None = None) -> float:
        """A finite real number in the given interval (bool and strings are not numbers)."""
        allowed = _range_text("a finite real number", unit, gt, ge, lt, le)
        value = self.get(name, default, allowed)
        if isinstance(value, (bool, np.bool_)):
            raise self.error(name, f"got a boolean ({value}), not a number", allowed)
        if isinstance(value, str):
            raise self.error(name, f"got the string {_show(value)}, not a number"
                             + _string_number_hint(value), allowed)
        if not _is_real(value):
            raise self.error(name, f"got {type(value).__name__} {_show(value)}, not a number",
                             allowed)
        x = float(value)
        if not math.isfinite(x):
            raise self.error(name, f"{x} is not finite", allowed)
        if ((gt is not None and not x > gt) or (ge is not None and not x >= ge)
                or (lt is not None and not x < lt) or (le is not None and not x <= le)):
            raise self.error(name, f"{x:g}{' ' + unit if unit else ''} is out of range",
                             allowed)
        return x

    def integer(self, name: str, default: Any = _REQUIRED, *, ge: int | None = None,
                le: int | None = None) -> int:
        allowed = _range_text("an integer", "", None, ge, None, le)
        value = self.get(name, default, allowed)
        if not _is_integer(value):
            kind = ("a boolean" if isinstance(value, (bool, np.bool_))
                    else f"{type(value).__name__} {_show(value)}")
            raise self.error(name, f"got {kind}, not an integer", allowed)
        n = int(value)
        if (ge is not None and n < ge) or (le is not None and n > le):
            raise self.error(name, f"{n} is out of range", allowed)
        return n

    def boolean(self, name: str, default: Any = _REQUIRED) -> bool:
        allowed = "true or false"
        value = self.get(name, default, allowed)
        if not isinstance(value, (bool, np.bool_)):
            raise self.error(name, f"got {type(value).__name__} {_show(value)}", allowed)
        return bool(value)

    def string(self, name: str, default: Any = _REQUIRED,
               choices: Sequence[str] | None = None, what: str = "a non-empty string",
               allow_empty: bool = False) -> str:
        allowed = f"one of: {', '.join(choices)}" if choices else what
        value = self.get(name, default, allowed)
        if not isinstance(value, str):
            raise self.error(name, f"got {type(value).__name__} {_show(value)}, not a string",
                             allowed)
        if choices is not None and value not in choices:
            close = difflib.get_close_matches(value, choices, n=1, cutoff=0.6)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise self.error(name, f"unknown value {_show(value)}", hint + allowed)
        if not allow_empty and not value.strip():
            raise self.error(name, "is empty", allowed)
        return value

    def number_or_auto(self, name: str, default: Any, **limits) -> float | str:
        """The string ``"auto"`` or a number obeying ``limits`` (see `number`)."""
        if self.mapping.get(name, default) == "auto":
            return "auto"
        try:
            return self.number(name, default, **limits)
        except ScenarioError as exc:
            raise self.error(name, exc.problem, f"auto, or {exc.allowed}") from None

    def section(self, name: str, required: bool = False, allowed: str | None = None
                ) -> _Section:
        """A nested mapping (empty if absent and not required)."""
        keys = _SECTION_KEYS.get(name)
        if allowed is None:
            allowed = f"a mapping with keys: {', '.join(keys)}" if keys else "a mapping"
        value = self.get(name, _REQUIRED if required else {}, allowed)
        if not isinstance(value, Mapping):
            raise self.error(name, f"got {type(value).__name__} {_show(value)}, "
                             "not a mapping", allowed)
        return _Section(self.file, self.key(name), value)


def _string_number_hint(text: str) -> str:
    """Why a number-looking string was read as text, and the fix."""
    try:
        x = float(text)
    except ValueError:
        return ""
    if not math.isfinite(x):
        return ""
    if "e" in text.lower() and "." not in text:
        mantissa, _, exponent = text.lower().partition("e")
        return (f"; YAML reads exponent notation without a decimal point as text: "
                f"write {mantissa}.0e{exponent}")
    return "; remove the quotes"


def _range_text(kind: str, unit: str, gt, ge, lt, le) -> str:
    """'a finite real number > 0 [m]', 'an integer >= 2', 'a finite real number in (0, 3]'."""
    def fmt(x) -> str:
        return str(x) if isinstance(x, int) else f"{x:g}"

    low = (f"({fmt(gt)}", gt) if gt is not None else (f"[{fmt(ge)}", ge) if ge is not None \
        else None
    high = (f"{fmt(lt)})", lt) if lt is not None else (f"{fmt(le)}]", le) if le is not None \
        else None
    if low and high:
        text = f"{kind} in {low[0]}, {high[0]}"
    elif low:
        text = f"{kind} {'>' if gt is not None else '>='} {fmt(low[1])}"
    elif high:
        text = f"{kind} {'<' if lt is not None else '<='} {fmt(high[1])}"
    else:
        text = kind
    return f"{text} [{unit}]" if unit else text


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
        return math.sqrt(self.GM / self.a**3)

    @property
    def orbital_period(self) -> float:
        """One orbit, 2 pi / Omega [s]."""
        return 2.0 * math.pi / self.orbital_frequency

    def to_dict(self) -> dict[str, float]:
        if self.Omega is not None:
            return {"Omega": self.Omega}
        return {"GM": self.GM, "a": self.a}


class SizeDistribution:
    """Number distribution of particle radii; subclasses give `moment` and `draw_radii`."""

    kind: ClassVar[str] = ""

    def moment(self, k: float) -> float:
        """Number-weighted mean of radius**k [m^k]."""
        raise NotImplementedError

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` radii [m] drawn from the distribution with the generator ``rng``."""
        raise NotImplementedError

    @property
    def smallest_radius(self) -> float:
        """Smallest radius the distribution can produce [m]."""
        raise NotImplementedError

    @property
    def largest_radius(self) -> float:
        """Largest radius the distribution can produce [m]."""
        raise NotImplementedError

    @property
    def mean_radius(self) -> float:
        """Number-weighted mean radius <R> [m]."""
        return self.moment(1.0)

    def to_dict(self) -> dict[str, Any]:
        raise NotImplementedError


@dataclass(frozen=True)
class Monodisperse(SizeDistribution):
    """All particles alike.

    Attributes
    ----------
    radius : float [m]
    """

    radius: float
    kind: ClassVar[str] = "monodisperse"

    def moment(self, k: float) -> float:
        return self.radius**k

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return np.full(n, self.radius)

    @property
    def smallest_radius(self) -> float:
        return self.radius

    @property
    def largest_radius(self) -> float:
        return self.radius

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "radius": self.radius}


def _integral_of_power(s: float, r_min: float, r_max: float) -> float:
    """Integral of R**s dR from r_min to r_max [m^(s+1)], accurate near s = -1."""
    t = s + 1.0
    log_ratio = math.log(r_max / r_min)
    if t == 0.0:
        return log_ratio
    return r_min**t * math.expm1(t * log_ratio) / t


@dataclass(frozen=True)
class PowerLaw(SizeDistribution):
    """Power law dN/dR proportional to R^-q between r_min and r_max.

    Attributes
    ----------
    q : float [dimensionless]
        Slope; q = 3 is the classic value for Saturn's rings (equal optical depth per
        logarithmic radius interval); any finite real is allowed.
    r_min, r_max : float [m]
        Radius limits, 0 < r_min <= r_max.
    """

    q: float
    r_min: float
    r_max: float
    kind: ClassVar[str] = "powerlaw"

    def moment(self, k: float) -> float:
        if self.r_min == self.r_max:
            return self.r_min**k
        return (_integral_of_power(k - self.q, self.r_min, self.r_max)
                / _integral_of_power(-self.q, self.r_min, self.r_max))

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Inverse-transform sampling of the truncated power law."""
        u = rng.random(n)
        if self.r_min == self.r_max:
            return np.full(n, self.r_min)
        t = 1.0 - self.q
        log_ratio = math.log(self.r_max / self.r_min)
        if t == 0.0:
            radii = self.r_min * np.exp(u * log_ratio)
        else:
            radii = self.r_min * (1.0 + u * math.expm1(t * log_ratio)) ** (1.0 / t)
        return np.clip(radii, self.r_min, self.r_max)

    @property
    def smallest_radius(self) -> float:
        return self.r_min

    @property
    def largest_radius(self) -> float:
        return self.r_max

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "q": self.q, "r_min": self.r_min, "r_max": self.r_max}


@dataclass(frozen=True)
class MixtureComponent:
    """One species of a mixture.

    Attributes
    ----------
    radius : float [m]
    number_fraction : float [dimensionless]
        Fraction of the particles (by number) of this radius, > 0.
    """

    radius: float
    number_fraction: float

    def to_dict(self) -> dict[str, float]:
        return {"radius": self.radius, "number_fraction": self.number_fraction}


@dataclass(frozen=True)
class Mixture(SizeDistribution):
    """A few discrete radii with given number fractions (summing to 1)."""

    components: tuple[MixtureComponent, ...]
    kind: ClassVar[str] = "mixture"

    def moment(self, k: float) -> float:
        radii = np.array([c.radius for c in self.components])
        fractions = np.array([c.number_fraction for c in self.components])
        return float(np.sum(fractions * radii**k) / np.sum(fractions))

    def counts(self, n: int) -> np.ndarray:
        """Particles of each component among ``n``: n * fraction rounded by largest remainder,
        so that they sum to exactly n."""
        fractions = np.array([c.number_fraction for c in self.components])
        exact = n * fractions / fractions.sum()
        counts = np.floor(exact).astype(int)
        short = n - int(counts.sum())
        order = np.argsort(-(exact - counts), kind="stable")
        counts[order[:short]] += 1
        return counts

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Exactly `counts` (n) particles of each radius, in random order."""
        radii = np.repeat([c.radius for c in self.components], self.counts(n))
        return rng.permutation(radii)

    @property
    def smallest_radius(self) -> float:
        return min(c.radius for c in self.components)

    @property
    def largest_radius(self) -> float:
        return max(c.radius for c in self.components)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "components": [c.to_dict() for c in self.components]}


@dataclass(frozen=True)
class Particles:
    """The ring particles: solid spheres of one bulk density.

    Attributes
    ----------
    density : float [kg/m^3]
        Bulk density of every particle (900 for solid ice; lower for porous aggregates).
    size_distribution : Monodisperse | PowerLaw | Mixture
    """

    density: float
    size_distribution: SizeDistribution

    @property
    def mean_mass(self) -> float:
        """Number-weighted mean particle mass, density * 4/3 pi <R^3> [kg]."""
        return self.density * 4.0 / 3.0 * math.pi * self.size_distribution.moment(3.0)

    def to_dict(self) -> dict[str, Any]:
        return {"density": self.density, "size_distribution": self.size_distribution.to_dict()}


@dataclass(frozen=True)
class Sheet:
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
        Self-gravity with REBOUND's tree code.
    softening : float [m] or "auto" or None
        Gravitational softening length; "auto" = 0.1 x smallest radius; None without gravity.
    opening_angle : float [rad] or None
        Barnes-Hut opening angle of the tree (REBOUND's opening_angle2 is its square);
        None without gravity.
    initial_dispersion : float [mean radius x Omega]
        Initial 1-D velocity dispersion relative to the shear flow.
    z_box : float [mean radii] or "auto"
        Initial vertical height of the box.
    """

    optical_depth: float
    n_particles: int
    aspect: float
    gravity: bool
    softening: float | str | None
    opening_angle: float | None
    initial_dispersion: float
    z_box: float | str

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"optical_depth": self.optical_depth,
                             "n_particles": self.n_particles, "aspect": self.aspect,
                             "gravity": self.gravity}
        if self.gravity:
            d["softening"] = self.softening
            d["opening_angle"] = self.opening_angle
        d["initial_dispersion"] = self.initial_dispersion
        d["z_box"] = self.z_box
        return d


@dataclass(frozen=True)
class Restitution:
    """Coefficient-of-restitution law: a model name and its parameters (defaults filled).

    The parameters are also attributes: ``sc.restitution.kappa``; see
    `ringsim.restitution.MODEL_PARAMETERS` for the names of each model.

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
        """{"model": ..., parameter: value, ...} as the resolver and epsilon_for_pair take."""
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
    """

    orbits: float
    dt: float | str
    dt_safety: float
    collision_detection: str

    def to_dict(self) -> dict[str, Any]:
        return {"orbits": self.orbits, "dt": self.dt, "dt_safety": self.dt_safety,
                "collision_detection": self.collision_detection}


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


@dataclass(frozen=True)
class Scenario:
    """One validated scenario.  Build it with `load_scenario`, `scenario_from_text` or
    `scenario_from_dict`; change it with `with_overrides`.

    Equality compares the physics and settings only, not ``source`` or ``source_text``.

    Attributes
    ----------
    name : str
    seed : int
        Seeds every random choice of the run (initial conditions, REBOUND's collision order).
    description : str
    planet, particles, sheet, restitution, integration, output : the sections.
    source : str
        The file it was read from (or the ``source`` name given).
    source_text : str or None
        The original YAML text, when read from text or a file (comments kept).
    """

    name: str
    seed: int
    description: str
    planet: Planet
    particles: Particles
    sheet: Sheet
    restitution: Restitution
    integration: Integration
    output: Output
    source: str = field(default="<dict>", compare=False, repr=False)
    source_text: str | None = field(default=None, compare=False, repr=False)
    # The mapping as the user wrote it (before defaults), for with_overrides.
    _given: Mapping = field(default_factory=dict, compare=False, repr=False)

    # -- derived quantities --
    @property
    def orbital_frequency(self) -> float:
        """Omega [1/s]."""
        return self.planet.orbital_frequency

    @property
    def orbital_period(self) -> float:
        """2 pi / Omega [s]."""
        return self.planet.orbital_period

    @property
    def mean_radius(self) -> float:
        """Number-weighted mean particle radius [m]."""
        return self.particles.size_distribution.mean_radius

    @property
    def softening_length(self) -> float | None:
        """Gravitational softening [m] ("auto" resolved); None without self-gravity."""
        if not self.sheet.gravity:
            return None
        if self.sheet.softening == "auto":
            return AUTO_SOFTENING_FRACTION * self.particles.size_distribution.smallest_radius
        return float(self.sheet.softening)

    def expected_box_size(self) -> tuple[float, float]:
        """(Lx, Ly) [m] holding n_particles of mean area pi <R^2> at the optical depth.

        Lx Ly = N pi <R^2> / tau and Ly = aspect Lx.  A run may size its box from the
        radii actually drawn instead; this is the expectation.
        """
        area = (self.sheet.n_particles * math.pi * self.particles.size_distribution.moment(2.0)
                / self.sheet.optical_depth)
        lx = math.sqrt(area / self.sheet.aspect)
        return lx, self.sheet.aspect * lx

    # -- serialization --
    def restitution_dict(self) -> dict[str, Any]:
        """{"model": ..., params...} for `ringsim.install_resolver` and `epsilon_for_pair`."""
        return self.restitution.to_dict()

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict with every default filled in (SI / orbits as in the file)."""
        return {
            "name": self.name,
            "seed": self.seed,
            "description": self.description,
            "planet": self.planet.to_dict(),
            "particles": self.particles.to_dict(),
            "sheet": self.sheet.to_dict(),
            "restitution": self.restitution.to_dict(),
            "integration": self.integration.to_dict(),
            "output": self.output.to_dict(),
        }

    def to_yaml(self) -> str:
        """YAML text of `to_dict`; ``scenario_from_text(sc.to_yaml()) == sc``."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=False,
                              allow_unicode=True)

    @property
    def yaml_text(self) -> str:
        """The text to embed in a run file: the original text if any, else `to_yaml`."""
        return self.source_text if self.source_text is not None else self.to_yaml()


# --- validation -------------------------------------------------------------------------------

def _read_name(top: _Section) -> str:
    allowed = "a non-empty string without '/', '\\' or surrounding spaces"
    name = top.string("name", what=allowed)
    if name != name.strip() or any(c in name for c in "/\\\n\r\t\0"):
        raise top.error("name", f"{_show(name)} cannot be used in a file name", allowed)
    return name


def _read_planet(top: _Section) -> Planet:
    allowed = "a mapping: Omega [1/s], or GM [m^3/s^2] and a [m]"
    if not top.has("planet"):
        raise top.error("planet", "missing required key 'planet'", allowed)
    sec = top.section("planet", required=True)
    sec.check_keys(_SECTION_KEYS["planet"])
    if sec.has("Omega"):
        for other in ("GM", "a"):
            if sec.has(other):
                raise sec.error(other, "give either Omega or GM and a, not both",
                                "Omega [1/s], or GM [m^3/s^2] and a [m]")
        return Planet(Omega=sec.number("Omega", unit="1/s", gt=0.0), GM=None, a=None)
    if not (sec.has("GM") or sec.has("a")):
        raise sec.error("Omega", "missing required key 'Omega'",
                        "Omega [1/s], or GM [m^3/s^2] and a [m]")
    gm = sec.number("GM", unit="m^3/s^2", gt=0.0)
    a = sec.number("a", unit="m", gt=0.0)
    return Planet(Omega=None, GM=gm, a=a)


def _read_size_distribution(particles: _Section) -> SizeDistribution:
    sec = particles.section("size_distribution", required=True,
                            allowed="a mapping: kind monodisperse {radius}, powerlaw "
                            "{q, r_min, r_max} or mixture {components}")
    kind = sec.string("kind", choices=tuple(_SIZE_KINDS))
    sec.check_keys(("kind",) + _SIZE_KINDS[kind], context=f"kind {kind}")
    if kind == "monodisperse":
        return Monodisperse(radius=sec.number("radius", unit="m", gt=0.0))
    if kind == "powerlaw":
        q = sec.number("q")
        r_min = sec.number("r_min", unit="m", gt=0.0)
        r_max = sec.number("r_max", unit="m", gt=0.0)
        if r_min > r_max:
            raise sec.error("r_min", f"r_min = {r_min:g} m is larger than r_max = {r_max:g} m",
                            "0 < r_min <= r_max")
        return PowerLaw(q=q, r_min=r_min, r_max=r_max)
    allowed = "a non-empty list of {radius [m], number_fraction} mappings"
    components = sec.get("components", _REQUIRED, allowed)
    if not isinstance(components, (list, tuple)) or not components:
        raise sec.error("components", f"got {_show(components)}", allowed)
    parsed = []
    for i, item in enumerate(components):
        if not isinstance(item, Mapping):
            raise sec.error(f"components.{i}", f"got {_show(item)}, not a mapping", allowed)
        comp = _Section(sec.file, sec.key(f"components.{i}"), item)
        comp.check_keys(("radius", "number_fraction"))
        parsed.append(MixtureComponent(radius=comp.number("radius", unit="m", gt=0.0),
                                       number_fraction=comp.number("number_fraction", gt=0.0,
                                                                   le=1.0)))
    total = math.fsum(c.number_fraction for c in parsed)
    if abs(total - 1.0) > FRACTION_SUM_TOLERANCE:
        raise sec.error("components", f"number fractions sum to {total:.12g}",
                        f"they must sum to 1 within {FRACTION_SUM_TOLERANCE:g}")
    return Mixture(components=tuple(parsed))


def _read_particles(top: _Section) -> Particles:
    sec = top.section("particles", required=True)
    sec.check_keys(_SECTION_KEYS["particles"])
    density = sec.number("density", DEFAULTS["particles.density"], unit="kg/m^3", gt=0.0)
    return Particles(density=density, size_distribution=_read_size_distribution(sec))


def _read_sheet(top: _Section) -> Sheet:
    sec = top.section("sheet")
    sec.check_keys(_SECTION_KEYS["sheet"])
    d = DEFAULTS
    gravity = sec.boolean("gravity", d["sheet.gravity"])
    if not gravity:
        for name in _GRAVITY_ONLY_KEYS:
            if sec.has(name):
                raise sec.error(name, "only used with self-gravity",
                                "set sheet.gravity: true, or remove the key")
    return Sheet(
        optical_depth=sec.number("optical_depth", d["sheet.optical_depth"], gt=0.0,
                                 le=MAX_OPTICAL_DEPTH),
        n_particles=sec.integer("n_particles", d["sheet.n_particles"], ge=2),
        aspect=sec.number("aspect", d["sheet.aspect"], gt=0.0),
        gravity=gravity,
        softening=(sec.number_or_auto("softening", d["sheet.softening"], unit="m", ge=0.0)
                   if gravity else None),
        opening_angle=(sec.number("opening_angle", d["sheet.opening_angle"], unit="rad",
                                  gt=0.0, le=1.0) if gravity else None),
        initial_dispersion=sec.number("initial_dispersion", d["sheet.initial_dispersion"],
                                      unit="mean radius x Omega", ge=0.0),
        z_box=sec.number_or_auto("z_box", d["sheet.z_box"], unit="mean radii", gt=0.0),
    )


# Allowed ranges of the restitution parameters: (unit, gt, ge, lt, le).  Parameters not
# listed here (a model added to ringsim.restitution later) need only be finite reals.
_RESTITUTION_RANGES: dict[tuple[str, str], tuple[str, float | None, float | None,
                                                 float | None, float | None]] = {
    ("dilley", "xi0"): ("", 0.0, None, None, None),
    ("dilley", "p"): ("", None, 0.0, None, None),
    ("dilley", "kappa"): ("", None, None, None, None),
    ("bridges", "v_c"): ("m/s", 0.0, None, None, None),
    ("bridges", "exponent"): ("", 0.0, None, None, None),
    ("constant", "epsilon"): ("", None, 0.0, None, 1.0),
    ("andrews", "v_c"): ("m/s", 0.0, None, None, None),
    ("tabor", "v_c"): ("m/s", 0.0, None, None, None),
    ("tabor", "q"): ("", 0.0, None, 0.5, None),
}


def _read_restitution(top: _Section) -> Restitution:
    sec = top.section("restitution")
    model = sec.string("model", DEFAULTS["restitution.model"], choices=tuple(MODEL_PARAMETERS))
    names = tuple(MODEL_PARAMETERS[model])
    sec.check_keys(("model",) + names, context=f"the {model} model")
    params = []
    for name in names:
        default = MODEL_PARAMETERS[model][name]
        unit, gt, ge, lt, le = _RESTITUTION_RANGES.get((model, name),
                                                       ("", None, None, None, None))
        value = sec.number(name, _REQUIRED if default is None else default, unit=unit,
                           gt=gt, ge=ge, lt=lt, le=le)
        params.append((name, value))
    return Restitution(model=model, parameters=tuple(params))


def _read_integration(top: _Section) -> Integration:
    sec = top.section("integration")
    sec.check_keys(_SECTION_KEYS["integration"])
    d = DEFAULTS
    orbits = sec.number("orbits", d["integration.orbits"], unit="orbits", gt=0.0)
    dt = sec.number_or_auto("dt", d["integration.dt"], unit="orbits", gt=0.0,
                            le=MAX_DT_ORBITS)
    if dt != "auto" and dt > orbits:
        raise sec.error("dt", f"dt = {dt:g} orbits is longer than the run ({orbits:g} orbits)",
                        "dt <= integration.orbits")
    return Integration(
        orbits=orbits,
        dt=dt,
        dt_safety=sec.number("dt_safety", d["integration.dt_safety"], gt=0.0, le=1.0),
        collision_detection=sec.string("collision_detection",
                                       d["integration.collision_detection"],
                                       choices=_COLLISION_DETECTIONS),
    )


def _read_output(top: _Section, name: str) -> Output:
    sec = top.section("output")
    sec.check_keys(_SECTION_KEYS["output"])
    d = DEFAULTS
    snapshot_every = sec.number("snapshot_every", d["output.snapshot_every"], unit="orbits",
                                gt=0.0)
    return Output(
        path=sec.string("path", f"runs/{name}.h5", what="a non-empty file path"),
        timeseries_every=sec.number("timeseries_every", d["output.timeseries_every"],
                                    unit="orbits", gt=0.0),
        snapshot_every=snapshot_every,
        checkpoint_every=sec.number("checkpoint_every", snapshot_every, unit="orbits",
                                    gt=0.0),
        log_collisions=sec.integer("log_collisions", d["output.log_collisions"], ge=0),
    )


def _check_geometry(top: _Section, particles: Particles, sheet: Sheet,
                    probe: Scenario) -> None:
    """The box must be wider and (if given) taller than the largest particle."""
    r_max = particles.size_distribution.largest_radius
    lx, ly = probe.expected_box_size()
    if min(lx, ly) <= 2.0 * r_max:
        raise top.error("sheet.n_particles",
                        f"{sheet.n_particles} particles make a {lx:.3g} m x {ly:.3g} m box, "
                        f"not wider than the largest particle (diameter {2 * r_max:g} m)",
                        "more particles, a lower optical depth or an aspect nearer 1")
    if sheet.z_box != "auto":
        r_mean = particles.size_distribution.mean_radius
        if sheet.z_box * r_mean <= 2.0 * r_max:
            raise top.error("sheet.z_box",
                            f"{sheet.z_box:g} mean radii ({sheet.z_box * r_mean:.3g} m) is "
                            f"not taller than the largest particle (diameter {2 * r_max:g} m)",
                            f"auto, or > {2.0 * r_max / r_mean:.4g} mean radii")


def _plain(value: Any) -> Any:
    """A deep copy with every mapping a dict and every list/tuple a list."""
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return copy.deepcopy(value)


def _build(data: Any, source: str, source_text: str | None) -> Scenario:
    source = str(source)
    if not isinstance(data, Mapping):
        got = ("an empty document" if data is None
               else {"str": "a string", "list": "a list", "int": "a number",
                     "float": "a number"}.get(type(data).__name__, f"a {type(data).__name__}"))
        raise ScenarioError(source, "<yaml>", f"the top level is {got}, not a mapping",
                            "a YAML mapping with at least the keys name, seed, planet, "
                            "particles")
    top = _Section(source, "", data)
    top.check_keys(_SECTION_KEYS[""])
    name = _read_name(top)
    seed = top.integer("seed", ge=0, le=MAX_SEED)
    description = top.string("description", DEFAULTS["description"], what="a string",
                             allow_empty=True)
    planet = _read_planet(top)
    particles = _read_particles(top)
    sheet = _read_sheet(top)
    restitution = _read_restitution(top)
    integration = _read_integration(top)
    output = _read_output(top, name)
    scenario = Scenario(name=name, seed=seed, description=description, planet=planet,
                        particles=particles, sheet=sheet, restitution=restitution,
                        integration=integration, output=output, source=source,
                        source_text=source_text, _given=_plain(data))
    _check_geometry(top, particles, sheet, scenario)
    return scenario


# --- public constructors ----------------------------------------------------------------------

def _read_text(path: str | PathLike) -> str:
    """The file's text, or ScenarioError with key "<file>"."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(str(path), "<file>", f"not UTF-8 text ({exc.reason})",
                            "a UTF-8 YAML text file") from None
    except OSError as exc:
        raise ScenarioError(str(path), "<file>", f"cannot read: {exc.strerror or exc}",
                            "an existing, readable YAML file") from None


def _parse_yaml(text: str, source: str) -> Any:
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ScenarioError(source, "<yaml>", f"invalid YAML{where}: {problem}",
                            "YAML syntax: 'key: value' lines, nesting by indentation") from None


def scenario_from_dict(d: Mapping, source: str = "<dict>") -> Scenario:
    """Validate a nested mapping (as YAML would load it) into a `Scenario`.

    Parameters
    ----------
    d : mapping
        The scenario keys; see docs/scenario.md.
    source : str
        Name used as the file in error messages.
    """
    return _build(d, source, None)


def scenario_from_text(text: str, source: str = "<string>") -> Scenario:
    """Parse YAML text (``yaml.safe_load``) and validate it; keeps the text in
    ``source_text``."""
    return _build(_parse_yaml(text, source), source, text)


def load_scenario(path: str | PathLike) -> Scenario:
    """Read and validate a scenario file; raises `ScenarioError` naming the file and key."""
    text = _read_text(path)
    return scenario_from_text(text, source=str(path))


def _set_dotted(given: dict, dotted: str, value: Any, source: str) -> None:
    """Set ``given[a][b][c] = value`` for ``dotted = "a.b.c"``, creating missing mappings;
    list items are addressed by index ("particles.size_distribution.components.0.radius")."""
    allowed = "a dotted scenario key such as 'restitution.kappa'"
    if not isinstance(dotted, str) or not dotted or any(not p for p in dotted.split(".")):
        raise ScenarioError(source, str(dotted), "not a valid dotted key", allowed)
    parts = dotted.split(".")
    node: Any = given
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        here = ".".join(parts[:depth + 1])
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ScenarioError(source, here, f"no list item {part!r}",
                                    f"an index 0..{len(node) - 1}")
            index: Any = int(part)
        elif isinstance(node, dict):
            index = part
            if not last and not isinstance(node.get(part), (dict, list)):
                if part in node and node[part] is not None:
                    raise ScenarioError(source, here, f"is a value ({_show(node[part])}), "
                                        f"so {dotted!r} cannot be set", allowed)
                node[part] = {}
        else:
            raise ScenarioError(source, here, "cannot be set inside a value", allowed)
        if last:
            node[index] = copy.deepcopy(value)
        else:
            node = node[index]


def with_overrides(sc: Scenario, overrides: Mapping[str, Any]) -> Scenario:
    """A new Scenario with dotted keys replaced, validated again.

    Overrides apply to the scenario as its author wrote it, so defaults that follow other
    keys follow the new values (``output.path`` follows ``name``, ``checkpoint_every`` follows
    ``snapshot_every`` unless they were written out).  The result has no ``source_text``.

    Parameters
    ----------
    sc : Scenario
    overrides : mapping
        ``{"restitution.kappa": 0.1, "seed": 2}``; values in the units of the file.
    """
    given = _plain(sc._given)
    try:
        consistent = _build(given, sc.source, None) == sc
    except ScenarioError:
        consistent = False
    if not consistent:  # made by dataclasses.replace or by hand: start from what it is now
        given = sc.to_dict()
    for dotted, value in overrides.items():
        _set_dotted(given, dotted, value, sc.source)
    return _build(given, sc.source, None)


# --- sweeps -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sweep:
    """A grid of scenarios: a base scenario and dotted keys -> lists of values.

    Attributes
    ----------
    base : Scenario
    base_path : str
        The base scenario's file (resolved relative to the sweep file).
    grid : tuple of (dotted key, tuple of values)
        In file order; the last key varies fastest.
    source : str
        The sweep file.
    """

    base: Scenario
    base_path: str
    grid: tuple[tuple[str, tuple[Any, ...]], ...]
    source: str
    source_text: str | None = field(default=None, compare=False, repr=False)

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(key for key, _ in self.grid)

    def __len__(self) -> int:
        return math.prod(len(values) for _, values in self.grid)

    def parameter_sets(self) -> Iterator[dict[str, Any]]:
        """The grid points as {dotted key: value}, Cartesian product, last key fastest."""
        for combo in itertools.product(*(values for _, values in self.grid)):
            yield dict(zip(self.keys, combo, strict=True))

    def points(self) -> Iterator[tuple[dict[str, Any], Scenario]]:
        """(parameters, scenario) for every grid point, in `parameter_sets` order."""
        for params in self.parameter_sets():
            try:
                yield params, with_overrides(self.base, params)
            except ScenarioError as exc:
                point = ", ".join(f"{k}={v!r}" for k, v in params.items())
                raise ScenarioError(self.source, "grid",
                                    f"point {point}: {exc.key}: {exc.problem}",
                                    exc.allowed) from None


def load_sweep(path: str | PathLike) -> Sweep:
    """Read a sweep file (``base``: scenario path relative to it; ``grid``: dotted key ->
    list) and check every value and every grid point against the base scenario."""
    source = str(path)
    text = _read_text(path)
    data = _parse_yaml(text, source)
    if not isinstance(data, Mapping):
        raise ScenarioError(source, "<yaml>", "the top level is not a mapping",
                            "a YAML mapping with keys base and grid")
    top = _Section(source, "", data)
    top.check_keys(("base", "grid"))
    base_name = top.string("base", what="a scenario file path, relative to the sweep file")
    base_path = Path(source).parent / base_name
    base = load_scenario(base_path)
    grid_sec = top.section("grid", required=True)
    allowed = "a non-empty list of values"
    if not grid_sec.mapping:
        raise top.error("grid", "is empty", "dotted scenario keys -> lists of values")
    grid = []
    for key, values in grid_sec.mapping.items():
        if not isinstance(values, list) or not values:
            raise grid_sec.error(str(key), f"got {_show(values)}", allowed)
        for value in values:
            try:
                with_overrides(base, {key: value})
            except ScenarioError as exc:
                raise grid_sec.error(str(key), f"value {_show(value)} is invalid for "
                                     f"{exc.file}: {exc.key}: {exc.problem}",
                                     exc.allowed) from None
        grid.append((str(key), tuple(values)))
    sweep = Sweep(base=base, base_path=str(base_path), grid=tuple(grid), source=source,
                  source_text=text)
    for _ in sweep.points():  # combinations can clash even if each value is fine alone
        pass
    return sweep
