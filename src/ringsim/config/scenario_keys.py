"""The keys of a scenario file: each section's keys, defaults, units and allowed ranges,
and the readers that turn a section of YAML into its frozen object.

Every key, its unit, default and allowed range is listed in ``docs/scenario.md``; the
tables ``SECTION_KEYS`` and ``DEFAULTS`` and the ``read_*`` functions below are the single
place where they are enforced (the ``integration`` section is read in
``config.scenario``, beside its step check that asks the C library).  A reader raises
`ScenarioError` with the file, the dotted key and a one-line message.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ringsim.config.gravity_keys import SOLVER_KEYS, read_gravity_keys
from ringsim.config.initial_state import read_initial_state
from ringsim.config.schema import REQUIRED, Section, show
from ringsim.config.sections import (
    Friction,
    Output,
    Particles,
    Planet,
    Restitution,
    SheetConfig,
)
from ringsim.physics.friction import FRICTION, INERTIA_FACTOR
from ringsim.physics.gravity_solvers import SOLVER_PARAMETERS
from ringsim.physics.laws import DIMENSIONLESS
from ringsim.physics.restitution import RESTITUTION
from ringsim.physics.sizes import (
    CUTOFF_PARAMETERS,
    MIN_CUTOFF_ACCEPTANCE,
    Mixture,
    MixtureComponent,
    Monodisperse,
    PowerLaw,
    PowerLawCutoff,
    SizeDistribution,
)

#: Largest seed accepted: REBOUND's collision-shuffle seed ``rand_seed`` is an unsigned int.
MAX_SEED = 2**32 - 1
#: Largest dynamical optical depth accepted (denser patches are beyond a monolayer's reach).
MAX_OPTICAL_DEPTH = 3.0
#: Largest step accepted [orbits]: collisions need dt << 1/Omega.
MAX_DT_ORBITS = 0.1
#: Smallest and largest particle radius [m]: a micrometre grain to a 100 km moonlet, far
#: outside ring particles' centimetres to metres, inside what the box and masses hold in
#: floating point (r^3 and the power law's moments of r_min^-q).
MIN_RADIUS = 1e-6
MAX_RADIUS = 1e5
#: Longest scenario name [characters]: it names files (runs/<name>.h5 and the run file's
#: companions), which most file systems allow up to 255 bytes.
MAX_NAME_CHARS = 100
#: Tolerance on the sum of a mixture's number fractions.
FRACTION_SUM_TOLERANCE = 1e-9

#: Keys of each section, in the order ``Scenario.to_dict`` writes them.
SECTION_KEYS: dict[str, tuple[str, ...]] = {
    "": ("name", "seed", "description", "planet", "particles", "sheet", "restitution",
         "friction", "integration", "output"),
    "planet": ("Omega", "GM", "a"),
    "particles": ("density", "size_distribution", "inertia_factor"),
    "sheet": ("optical_depth", "n_particles", "aspect", "gravity", "gravity_solver",
              *SOLVER_KEYS, "initial_dispersion", "initial_toomre_q", "z_box", "initial_state"),
    "integration": ("orbits", "dt", "dt_safety", "collision_detection", "until_equilibrium",
                    "threads", "resolver"),
    "output": ("path", "timeseries_every", "snapshot_every", "checkpoint_every",
               "log_collisions"),
}
#: Keys of each kind of size distribution.
SIZE_KINDS: dict[str, tuple[str, ...]] = {
    "monodisperse": ("radius",),
    "powerlaw": ("q", "r_min", "r_max"),
    "powerlaw_cutoff": tuple(p.name for p in CUTOFF_PARAMETERS),
    "mixture": ("components",),
}
#: Words of ``integration.collision_detection``.
COLLISION_DETECTIONS = ("tree", "line")
#: Words of ``integration.resolver``: ringsim's C resolver, or REBOUND's built-in hard-sphere
#: resolver (``engine.hardsphere``; tree detection, a law of the impact speed alone).
RESOLVERS = ("ringsim", "rebound_hardsphere")

#: Defaults of the optional keys (restitution defaults: ringsim.physics.restitution.RESTITUTION).
DEFAULTS: dict[str, Any] = {
    "description": "",
    "particles.density": 900.0,
    "sheet.optical_depth": 0.25,
    "sheet.n_particles": 1000,
    "sheet.aspect": 1.0,
    "sheet.gravity": False,
    # chosen by benchmarks/gravity.py: equal force accuracy (< 1 % rms) at a fraction of
    # the tree's cost (docs/performance.md, "Self-gravity")
    "sheet.gravity_solver": "p3m",
    # the solvers' keys (softening, opening_angle, p3m_split): physics.gravity_solvers
    **{f"sheet.{p.name}": p.default for p in SOLVER_PARAMETERS.values()},
    "sheet.initial_dispersion": 2.0,
    "sheet.z_box": "auto",
    "integration.orbits": 10.0,
    "integration.dt": "auto",
    "integration.dt_safety": 0.1,
    "integration.collision_detection": "tree",
    "integration.until_equilibrium": False,
    "integration.threads": "auto",
    "integration.resolver": "ringsim",
    "output.timeseries_every": 0.1,
    "output.snapshot_every": 5.0,
    "output.log_collisions": 0,
}


def read_name(top: Section) -> str:
    allowed = (f"a non-empty string of at most {MAX_NAME_CHARS} characters without '/', "
               "'\\' or surrounding spaces")
    name = top.string("name", what=allowed)
    if len(name) > MAX_NAME_CHARS:   # it names files: runs/<name>.h5.parts/...
        raise top.error("name", f"{len(name)} characters ({show(name)})", allowed)
    if name != name.strip() or any(c in name for c in "/\\\n\r\t\0"):
        raise top.error("name", f"{show(name)} cannot be used in a file name", allowed)
    return name


def read_planet(top: Section) -> Planet:
    allowed = "a mapping: Omega [1/s], or GM [m^3/s^2] and a [m]"
    if not top.has("planet"):
        raise top.error("planet", "missing required key 'planet'", allowed)
    sec = top.section("planet", required=True, keys=SECTION_KEYS["planet"])
    sec.check_keys(SECTION_KEYS["planet"])
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


def _radius(sec: Section, name: str) -> float:
    """A particle radius [m] > 0, within [MIN_RADIUS, MAX_RADIUS]."""
    r = sec.number(name, unit="m", gt=0.0)
    if not MIN_RADIUS <= r <= MAX_RADIUS:
        raise sec.error(name, f"{r:g} m is out of range",
                        f"a finite real number > 0 [m], from {MIN_RADIUS:g} to {MAX_RADIUS:g}")
    return r


def read_size_distribution(particles: Section) -> SizeDistribution:
    sec = particles.section("size_distribution", required=True,
                            allowed="a mapping: kind monodisperse {radius}, powerlaw "
                            "{q, r_min, r_max}, powerlaw_cutoff {q, r_min, r_max, r_cut, "
                            "cutoff_exponent} or mixture {components}")
    kind = sec.string("kind", choices=tuple(SIZE_KINDS))
    sec.check_keys(("kind",) + SIZE_KINDS[kind], context=f"kind {kind}")
    if kind == "monodisperse":
        return Monodisperse(radius=_radius(sec, "radius"))
    if kind == "powerlaw":
        q = sec.number("q")
        r_min = _radius(sec, "r_min")
        r_max = _radius(sec, "r_max")
        if r_min > r_max:
            raise sec.error("r_min", f"r_min = {r_min:g} m is larger than r_max = {r_max:g} m",
                            "0 < r_min <= r_max")
        return PowerLaw(q=q, r_min=r_min, r_max=r_max)
    if kind == "powerlaw_cutoff":
        return read_cutoff(sec)
    allowed = "a non-empty list of {radius [m], number_fraction} mappings"
    components = sec.get("components", REQUIRED, allowed)
    if not isinstance(components, (list, tuple)) or not components:
        raise sec.error("components", f"got {show(components)}", allowed)
    parsed = []
    for i, item in enumerate(components):
        if not isinstance(item, Mapping):
            raise sec.error(f"components.{i}", f"got {show(item)}, not a mapping", allowed)
        comp = Section(sec.file, sec.key(f"components.{i}"), item)
        comp.check_keys(("radius", "number_fraction"))
        parsed.append(MixtureComponent(radius=_radius(comp, "radius"),
                                       number_fraction=comp.number("number_fraction", gt=0.0,
                                                                   le=1.0)))
    total = math.fsum(c.number_fraction for c in parsed)
    if abs(total - 1.0) > FRACTION_SUM_TOLERANCE:
        raise sec.error("components", f"number fractions sum to {total:.12g}",
                        f"they must sum to 1 within {FRACTION_SUM_TOLERANCE:g}")
    return Mixture(components=tuple(parsed))


def read_cutoff(sec: Section) -> PowerLawCutoff:
    """``kind: powerlaw_cutoff``, validated against its declaration `CUTOFF_PARAMETERS`."""
    values = {p.name: sec.number(p.name, REQUIRED if p.required else p.default,
                                 unit="" if p.unit == DIMENSIONLESS else p.unit, **p.limits())
              for p in CUTOFF_PARAMETERS}
    for name in ("r_min", "r_max"):
        if not MIN_RADIUS <= values[name] <= MAX_RADIUS:
            raise sec.error(name, f"{values[name]:g} m is out of range", "a finite real "
                            f"number > 0 [m], from {MIN_RADIUS:g} to {MAX_RADIUS:g}")
    if values["r_min"] > values["r_max"]:
        raise sec.error("r_min", f"r_min = {values['r_min']:g} m is larger than r_max = "
                        f"{values['r_max']:g} m", "0 < r_min <= r_max")
    sizes = PowerLawCutoff(**values)
    if sizes.acceptance() < MIN_CUTOFF_ACCEPTANCE:
        raise sec.error("r_cut", f"r_cut = {values['r_cut']:g} m leaves fewer than "
                        f"{MIN_CUTOFF_ACCEPTANCE:g} of the power law's particles",
                        "a cutoff radius nearer r_max")
    return sizes


def read_particles(top: Section) -> Particles:
    sec = top.section("particles", required=True, keys=SECTION_KEYS["particles"])
    sec.check_keys(SECTION_KEYS["particles"])
    density = sec.number("density", DEFAULTS["particles.density"], unit="kg/m^3", gt=0.0)
    if sec.has("inertia_factor") and not top.has("friction"):
        raise sec.error("inertia_factor", "only used with a friction section",
                        "add a friction section, or remove the key")
    inertia_factor = sec.number("inertia_factor", INERTIA_FACTOR.default,
                                **INERTIA_FACTOR.limits())
    return Particles(density=density, size_distribution=read_size_distribution(sec),
                     inertia_factor=inertia_factor)


def read_sheet(top: Section) -> SheetConfig:
    sec = top.section("sheet", keys=SECTION_KEYS["sheet"])
    sec.check_keys(SECTION_KEYS["sheet"])
    d = DEFAULTS
    grav = read_gravity_keys(sec, d)
    initial_state = read_initial_state(sec)
    initial_toomre_q = None
    if sec.has("initial_toomre_q"):
        if not grav["gravity"]:
            raise sec.error("initial_toomre_q", "only used with self-gravity",
                            "set sheet.gravity: true, or use sheet.initial_dispersion")
        if sec.has("initial_dispersion"):
            raise sec.error("initial_toomre_q", "given with sheet.initial_dispersion",
                            "one of initial_toomre_q and initial_dispersion")
        initial_toomre_q = sec.number("initial_toomre_q", unit="", gt=0.0)
    return SheetConfig(
        optical_depth=sec.number("optical_depth", d["sheet.optical_depth"], gt=0.0,
                                 le=MAX_OPTICAL_DEPTH),
        n_particles=sec.integer("n_particles", d["sheet.n_particles"], ge=2),
        aspect=sec.number("aspect", d["sheet.aspect"], gt=0.0),
        initial_dispersion=sec.number("initial_dispersion", d["sheet.initial_dispersion"],
                                      unit="mean radius x Omega", ge=0.0),
        initial_toomre_q=initial_toomre_q,
        z_box=sec.number_or_auto("z_box", d["sheet.z_box"], unit="mean radii", gt=0.0),
        initial_state=initial_state,
        **grav,
    )


def read_restitution(top: Section) -> Restitution:
    """The law and its parameters, validated against the declaration `RESTITUTION`."""
    sec = top.section("restitution")
    model = sec.string("model", RESTITUTION.default, choices=RESTITUTION.names)
    law = RESTITUTION[model]
    sec.check_keys(("model",) + law.names, context=f"the {model} model")
    params = []
    for par in law.parameters:
        unit = "" if par.unit == DIMENSIONLESS else par.unit
        value = sec.number(par.name, REQUIRED if par.required else par.default, unit=unit,
                           **par.limits())
        params.append((par.name, value))
    return Restitution(model=model, parameters=tuple(params))


def read_friction(top: Section) -> Friction | None:
    """The optional friction section, validated against the declaration `FRICTION`; absent
    or null (``friction: null``, how a study case removes a base's friction): smooth
    spheres."""
    if not top.has("friction") or top.mapping["friction"] is None:
        return None
    sec = top.section("friction")
    model = sec.string("model", choices=FRICTION.names)
    law = FRICTION[model]
    sec.check_keys(("model",) + law.names, context=f"the {model} model")
    params = tuple((par.name, sec.number(par.name, REQUIRED if par.required else par.default,
                                         **par.limits())) for par in law.parameters)
    return Friction(model=model, parameters=params)


def read_output(top: Section, name: str) -> Output:
    sec = top.section("output", keys=SECTION_KEYS["output"])
    sec.check_keys(SECTION_KEYS["output"])
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
