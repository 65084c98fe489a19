"""Scenario files: a YAML description of one ring-patch simulation -> a frozen `Scenario`.

A scenario names everything a run needs: where the patch orbits (``planet``), what the
particles are (``particles``: bulk density and size distribution), how large the patch is
(``sheet``), how collisions lose energy (``restitution``), how long and how finely to
integrate (``integration``) and what to write (``output``).  Every key, its unit, default
and allowed range is listed in ``docs/scenario.md``; ``config.scenario_keys`` (the tables
``SECTION_KEYS`` and ``DEFAULTS`` and the section readers) and `_read_integration` below
are the single place where they are enforced.  This module assembles the sections into a
`Scenario`, checks what spans several sections (the box against the particles, a tiled
start against ``until_equilibrium``) and applies overrides (`with_overrides`).

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
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

import yaml

from ringsim.config.gravity_keys import check_gravity_box, p3m_setting
from ringsim.config.initial_state import check_tiled_stop
from ringsim.config.intervals import check_intervals
from ringsim.config.scenario_keys import (
    COLLISION_DETECTIONS,
    DEFAULTS,
    MAX_DT_ORBITS,
    MAX_SEED,
    RESOLVERS,
    SECTION_KEYS,
    read_friction,
    read_name,
    read_output,
    read_particles,
    read_planet,
    read_restitution,
    read_sheet,
)
from ringsim.config.schema import ScenarioError, Section, parse_yaml, plain, read_text, show
from ringsim.config.sections import (
    Friction,
    Integration,
    Output,
    Particles,
    Planet,
    Restitution,
    SheetConfig,
    read_threads,
)
from ringsim.errors import InputError
from ringsim.physics.gravity_solvers import AUTO_SOFTENING_FRACTION
from ringsim.physics.restitution import RESTITUTION
from ringsim.physics.sizes import (
    Mixture,
    MixtureComponent,
    Monodisperse,
    PowerLaw,
    SizeDistribution,
)

__all__ = [
    "Friction",
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
    "SheetConfig",
    "SizeDistribution",
    "load_scenario",
    "scenario_from_dict",
    "scenario_from_text",
    "with_overrides",
]


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
    friction : Friction or None
        The optional ``friction`` section (None: smooth spheres).
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
    sheet: SheetConfig
    restitution: Restitution
    integration: Integration
    output: Output
    friction: Friction | None = None
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
        if self.sheet.softening is None:    # the slab solver: no pair forces to soften
            return 0.0
        if self.sheet.softening == "auto":
            return AUTO_SOFTENING_FRACTION * self.particles.size_distribution.smallest_radius
        return float(self.sheet.softening)

    @property
    def p3m_setting(self) -> tuple[float, bool] | None:
        """(split [m], auto) of the P3M solver (``config.gravity_keys.p3m_setting``)."""
        return p3m_setting(self.sheet, self.mean_radius)

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

    def friction_dict(self) -> dict[str, Any] | None:
        """{"model": ..., params...} for `ringsim.install_resolver`; None without friction."""
        return None if self.friction is None else self.friction.to_dict()

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict with every default filled in (SI / orbits as in the file)."""
        d = {
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
        if self.friction is not None:
            d["friction"] = self.friction.to_dict()
        return d

    def to_yaml(self) -> str:
        """YAML text of `to_dict`; ``scenario_from_text(sc.to_yaml()) == sc``."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=False,
                              allow_unicode=True)

    @property
    def yaml_text(self) -> str:
        """The text to embed in a run file: the original text if any, else `to_yaml`."""
        return self.source_text if self.source_text is not None else self.to_yaml()


# --- validation -------------------------------------------------------------------------------

def _read_integration(top: Section, planet: Planet) -> Integration:
    """The ``integration`` section; its reader lives here, beside the step check of line
    detection that asks the C library (`_check_line_dt`)."""
    sec = top.section("integration", keys=SECTION_KEYS["integration"])
    sec.check_keys(SECTION_KEYS["integration"])
    d = DEFAULTS
    orbits = sec.number("orbits", d["integration.orbits"], unit="orbits", gt=0.0)
    detection = sec.string("collision_detection", d["integration.collision_detection"],
                           choices=COLLISION_DETECTIONS)
    dt = sec.number_or_auto("dt", d["integration.dt"], unit="orbits", gt=0.0,
                            le=MAX_DT_ORBITS)
    # a number unless it is a string (the only one allowed is "auto")
    if not isinstance(dt, str) and dt > orbits:
        raise sec.error("dt", f"dt = {dt:g} orbits is longer than the run ({orbits:g} orbits)",
                        "dt <= integration.orbits")
    if not isinstance(dt, str) and detection == "line":
        _check_line_dt(sec, dt, planet.orbital_frequency)
    return Integration(
        orbits=orbits,
        dt=dt,
        dt_safety=sec.number("dt_safety", d["integration.dt_safety"], gt=0.0, le=1.0),
        collision_detection=detection,
        until_equilibrium=sec.boolean("until_equilibrium", d["integration.until_equilibrium"]),
        threads=read_threads(sec, d["integration.threads"]),
        resolver=sec.string("resolver", d["integration.resolver"], choices=RESOLVERS),
    )


def _check_resolver(top: Section, integration: Integration, restitution: Restitution,
                    friction: Friction | None) -> None:
    """REBOUND's hard-sphere resolver finds its pairs with REBOUND's search (tree), asks
    its ``coefficient_of_restitution`` for eps of the normal impact speed alone and knows
    no spins: it takes the tree, a law that does not use the pair, and smooth spheres."""
    if integration.resolver != "rebound_hardsphere":
        return
    allowed = ("rebound_hardsphere with collision_detection: tree, a law of the impact "
               "speed alone (" + ", ".join(n for n in RESTITUTION.names
                                           if not RESTITUTION[n].uses_pair)
               + ") and no friction; or ringsim")
    if integration.collision_detection != "tree":
        problem = f"collision_detection: {integration.collision_detection}"
    elif RESTITUTION[restitution.model].uses_pair:
        problem = f"the {restitution.model} law depends on the pair's radius and mass"
    elif friction is not None:
        problem = "friction (REBOUND's resolver has no spins)"
    else:
        return
    raise top.error("integration.resolver", f"rebound_hardsphere cannot run {problem}",
                    allowed)


def _check_line_dt(sec: Section, dt: float, Omega: float) -> None:
    """Line detection: the sheet detector refuses steps with 1.5 Omega dt >= its limit.

    The limit belongs to the C detector (RS_MAX_SHEAR_STEP in rs_sheet_detect.c), so it is
    asked from the engine here rather than copied; the import is lazy because config sits
    upstream of the engine and only this check needs it.  The test mirrors the C's
    arithmetic on the step in seconds that the run will use (engine.timestep.choose_dt).
    """
    from ringsim.engine.native import max_shear_step

    limit = max_shear_step()
    dt_seconds = float(dt) * 2.0 * math.pi / Omega
    if not 1.5 * abs(Omega) * dt_seconds < limit:
        largest = limit / (3.0 * math.pi)
        raise sec.error("dt", f"dt = {dt:g} orbits is too long for collision_detection: line "
                        f"(1.5 Omega dt = {1.5 * abs(Omega) * dt_seconds:.4g} >= {limit:g})",
                        f"auto, or a step in (0, {largest:.6g}) orbits with line detection")


def _check_geometry(top: Section, particles: Particles, sheet: SheetConfig,
                    probe: Scenario) -> None:
    """The box must be wider and (if given) taller than the largest particle."""
    r_max = particles.size_distribution.largest_radius
    lx, ly = probe.expected_box_size()
    if min(lx, ly) <= 2.0 * r_max:
        raise top.error("sheet.n_particles",
                        f"{sheet.n_particles} particles make a {lx:.3g} m x {ly:.3g} m box, "
                        f"not wider than the largest particle (diameter {2 * r_max:g} m)",
                        "more particles, a lower optical depth or an aspect nearer 1")
    check_gravity_box(top, sheet, particles.size_distribution.mean_radius, lx, ly)
    if not isinstance(sheet.z_box, str):   # a number, not "auto"
        r_mean = particles.size_distribution.mean_radius
        if sheet.z_box * r_mean <= 2.0 * r_max:
            raise top.error("sheet.z_box",
                            f"{sheet.z_box:g} mean radii ({sheet.z_box * r_mean:.3g} m) is "
                            f"not taller than the largest particle (diameter {2 * r_max:g} m)",
                            f"auto, or > {2.0 * r_max / r_mean:.4g} mean radii")


def _build(data: Any, source: str, source_text: str | None) -> Scenario:
    source = str(source)
    if not isinstance(data, Mapping):
        got = ("an empty document" if data is None
               else {"str": "a string", "list": "a list", "int": "a number",
                     "float": "a number"}.get(type(data).__name__, f"a {type(data).__name__}"))
        raise ScenarioError(source, "<yaml>", f"the top level is {got}, not a mapping",
                            "a YAML mapping with at least the keys name, seed, planet, "
                            "particles")
    top = Section(source, "", data)
    top.check_keys(SECTION_KEYS[""])
    name = read_name(top)
    seed = top.integer("seed", ge=0, le=MAX_SEED)
    description = top.string("description", DEFAULTS["description"], what="a string",
                             allow_empty=True)
    planet = read_planet(top)
    particles = read_particles(top)
    sheet = read_sheet(top)
    restitution = read_restitution(top)
    friction = read_friction(top)
    integration = _read_integration(top, planet)
    _check_resolver(top, integration, restitution, friction)
    check_tiled_stop(top, sheet.initial_state, integration.until_equilibrium)
    output = read_output(top, name)
    check_intervals(top, integration, output)
    scenario = Scenario(name=name, seed=seed, description=description, planet=planet,
                        particles=particles, sheet=sheet, restitution=restitution,
                        integration=integration, output=output, friction=friction,
                        source=source,
                        source_text=source_text, _given=plain(data))
    if sheet.initial_state is None:  # else the file's particles are checked at set-up
        _check_geometry(top, particles, sheet, scenario)
    return scenario


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
    return _build(parse_yaml(text, source), source, text)


def load_scenario(path: str | PathLike) -> Scenario:
    """Read and validate a scenario file; raises `ScenarioError` naming the file and key."""
    text = read_text(path)
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
                    raise ScenarioError(source, here, f"is a value ({show(node[part])}), "
                                        f"so {dotted!r} cannot be set", allowed)
                node[part] = {}
        else:
            raise ScenarioError(source, here, "cannot be set inside a value", allowed)
        if last:
            node[index] = copy.deepcopy(value)
        else:
            node = node[index]


#: Scenario keys that change how fast a run goes, never its result: scenarios that differ
#: only in them make the same run.
SPEED_ONLY_KEYS = ("integration.threads",)


def without_keys(d: Mapping[str, Any], dotted: Iterable[str]) -> dict[str, Any]:
    """A deep copy of the nested dict ``d`` without the dotted keys (absent ones ignored)."""
    out = copy.deepcopy(dict(d))
    for key in dotted:
        *path, last = key.split(".")
        node = out
        for part in path:
            node = node.get(part, {})
        node.pop(last, None)
    return out


def result_dict(sc: Scenario, *, without_orbits: bool = False) -> dict[str, Any]:
    """What two scenarios must share to make the same run: ``sc.to_dict()`` without
    `SPEED_ONLY_KEYS`, and without ``integration.orbits`` where a run may be lengthened."""
    return without_keys(sc.to_dict(), SPEED_ONLY_KEYS
                        + (("integration.orbits",) if without_orbits else ()))


def check_threads(threads: int | None) -> None:
    """InputError naming ``--threads`` unless it is None or a whole number of at least 1."""
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int)
                                or threads < 1):
        raise InputError("<command line>", "--threads",
                         f"{threads} is not a positive number of threads")


def with_threads(sc: Scenario, threads: int | None) -> Scenario:
    """``sc`` with ``integration.threads`` from a command's ``--threads`` (None: unchanged;
    it changes the speed of a run, never its result); InputError as `check_threads`."""
    check_threads(threads)
    return sc if threads is None else with_overrides(sc, {"integration.threads": threads})


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
    given = plain(sc._given)
    try:
        consistent = _build(given, sc.source, None) == sc
    except ScenarioError:
        consistent = False
    if not consistent:  # made by dataclasses.replace or by hand: start from what it is now
        given = sc.to_dict()
    for dotted, value in overrides.items():
        _set_dotted(given, dotted, value, sc.source)
    return _build(given, sc.source, None)
