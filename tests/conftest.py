"""The tiny scenarios the tests build again and again, as factories of validated scenarios.

Four base sheets recur in the tests; each is declared once below as the mapping a scenario
file would hold.  A fixture of the same family builds a `Scenario` from it with dotted
overrides, through the package's own `scenario_from_dict` and `with_overrides`::

    def test_something(ring_scenario):
        sc = ring_scenario(name="k0", **{"restitution.kappa": 0.1, "sheet.n_particles": 60})

The factories take any number of override mappings, applied in turn (a test module's own
variant first, then the test's keys), then keyword overrides; a section given whole
(``restitution={"model": "constant", "epsilon": 0.5}``) replaces that section, so keys the
base gives and the variant does not want fall back to their defaults.  ``source`` names
the scenario in error messages (default ``"<test>"``).  Keys follow docs/scenario.md: SI
units, durations in orbits.

A base gives no ``output.path`` and no ``output.checkpoint_every``: left out, they follow
``name`` and ``output.snapshot_every`` through every override, as in a scenario file.

`small_scenario` and `rough_scenario` (the same with a friction section) build the variant
of the ring that the run, friction and spin tests share.  `scenario_dict` gives the bases'
mappings as plain dicts, unvalidated, for tests that write a scenario file or need a
document the validator refuses.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from functools import partial
from typing import Any

import pytest

from ringsim.config.scenario import Scenario, scenario_from_dict, with_overrides

#: A tiny ring without self-gravity: 200 ice particles of 1-3 m (power law q = 3) at
#: tau = 0.25, Omega = 2e-4 1/s, Dilley's law with kappa = 0, 0.3 orbit of tree detection
#: with dt: auto, a row every 0.02 orbit and a snapshot every 0.1.
RING: dict[str, Any] = {
    "name": "ring", "seed": 3, "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0, "size_distribution": {
        "kind": "powerlaw", "q": 3.0, "r_min": 1.0, "r_max": 3.0}},
    "sheet": {"optical_depth": 0.25, "n_particles": 200},
    "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0},
    "integration": {"orbits": 0.3},
    "output": {"timeseries_every": 0.02, "snapshot_every": 0.1},
}

#: A tiny self-gravitating sheet: 200 identical 1 m ice particles at tau = 0.5, 1e8 m from
#: Saturn (GM = 3.7931e16 m^3/s^2), the Bridges law of REBOUND's shearing-sheet example,
#: the default solver (P3M), 0.2 orbit, a row every 0.05 orbit and a snapshot every 0.1.
GRAVITATING: dict[str, Any] = {
    "name": "grav", "seed": 3, "planet": {"GM": 3.7931e16, "a": 1.0e8},
    "particles": {"density": 900.0, "size_distribution": {"kind": "monodisperse",
                                                          "radius": 1.0}},
    "sheet": {"optical_depth": 0.5, "n_particles": 200, "gravity": True},
    "restitution": {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234},
    "integration": {"orbits": 0.2},
    "output": {"timeseries_every": 0.05, "snapshot_every": 0.1},
}

#: A tiny line-mode sheet: 60 identical 1 m ice particles at tau = 0.2, Omega = 2e-4 1/s,
#: constant epsilon = 0.5, 0.3 orbit of line detection with dt: auto, a row every 0.05
#: orbit and a snapshot every 0.1.
LINE: dict[str, Any] = {
    "name": "line", "seed": 5, "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0, "size_distribution": {"kind": "monodisperse",
                                                          "radius": 1.0}},
    "sheet": {"optical_depth": 0.2, "n_particles": 60},
    "restitution": {"model": "constant", "epsilon": 0.5},
    "integration": {"orbits": 0.3, "collision_detection": "line"},
    "output": {"timeseries_every": 0.05, "snapshot_every": 0.1},
}

#: A sheet of a broad size distribution, for the set-up: 400 ice particles of 0.5-5 m
#: (power law q = 3, a factor 10 in radius) at tau = 0.4, Omega = 2e-4 1/s, Dilley's law
#: with kappa = 0.1; integration and output at their defaults.
BROAD: dict[str, Any] = {
    "name": "broad", "seed": 11, "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0, "size_distribution": {
        "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}},
    "sheet": {"optical_depth": 0.4, "n_particles": 400},
    "restitution": {"model": "dilley", "kappa": 0.1},
}

#: The run tests' variant of `RING` (test_run, test_friction_run, test_spin_diagnostics): 150
#: particles of 1-2 m, Dilley's law with kappa = 0.1, 0.6 orbit, a row every 0.05 orbit and a
#: snapshot every 0.2.
SMALL: dict[str, Any] = {
    "name": "small", "seed": 7, "particles.size_distribution.r_max": 2.0,
    "sheet.n_particles": 150, "restitution.kappa": 0.1, "integration.orbits": 0.6,
    "output.timeseries_every": 0.05, "output.snapshot_every": 0.2}

BASES: dict[str, dict[str, Any]] = {"ring": RING, "gravitating": GRAVITATING, "line": LINE,
                                    "broad": BROAD}


def _build_scenario(base: Mapping, *layers: Mapping[str, Any], source: str = "<test>",
                   **keys: Any) -> Scenario:
    """The validated scenario of ``base`` with each mapping of dotted overrides applied in
    turn by `with_overrides`, then ``keys`` (top-level keys or whole sections)."""
    sc = scenario_from_dict(base, source=source)
    for overrides in (*layers, keys):
        if overrides:
            sc = with_overrides(sc, overrides)
    return sc


def _build_dict(base: Mapping, *layers: Mapping[str, Any], **keys: Any) -> dict[str, Any]:
    """A deep copy of ``base`` with the dotted overrides set as `_build_scenario` sets
    them, not validated."""
    d = copy.deepcopy(dict(base))
    for overrides in (*layers, keys):
        for dotted, value in overrides.items():
            *parents, last = dotted.split(".")
            node = d
            for part in parents:
                node = node.setdefault(part, {})
            node[last] = copy.deepcopy(value)
    return d


@pytest.fixture(scope="session")
def ring_scenario() -> Callable[..., Scenario]:
    """Factory of `RING` scenarios: ``ring_scenario(*overrides, source=..., **keys)``."""
    return partial(_build_scenario, RING)


@pytest.fixture(scope="session")
def small_scenario(ring_scenario) -> Callable[..., Scenario]:
    """Factory of `SMALL` rings: ``small_scenario(**{key: value})``."""
    return lambda **overrides: ring_scenario(SMALL, overrides)


@pytest.fixture(scope="session")
def rough_scenario(small_scenario) -> Callable[..., Scenario]:
    """Factory of `SMALL` rings with a friction section (docs/friction.md):
    ``rough_scenario({"model": "coulomb", "mu": 0.5}, **{key: value})``."""
    return lambda friction, **overrides: with_overrides(small_scenario(**overrides),
                                                        {"friction": friction})


@pytest.fixture(scope="session")
def gravitating_scenario() -> Callable[..., Scenario]:
    """Factory of `GRAVITATING` scenarios: ``gravitating_scenario(*overrides, **keys)``."""
    return partial(_build_scenario, GRAVITATING)


@pytest.fixture(scope="session")
def line_scenario() -> Callable[..., Scenario]:
    """Factory of `LINE` scenarios: ``line_scenario(*overrides, source=..., **keys)``."""
    return partial(_build_scenario, LINE)


@pytest.fixture(scope="session")
def broad_scenario() -> Callable[..., Scenario]:
    """Factory of `BROAD` scenarios: ``broad_scenario(*overrides, source=..., **keys)``."""
    return partial(_build_scenario, BROAD)


@pytest.fixture(scope="session")
def scenario_dict() -> Callable[..., dict[str, Any]]:
    """Factory of plain scenario mappings: ``scenario_dict("gravitating", *overrides,
    **keys)`` with a family of `BASES` ("ring", "gravitating", "line" or "broad")."""
    def make(family: str, *layers: Mapping[str, Any], **keys: Any) -> dict[str, Any]:
        return _build_dict(BASES[family], *layers, **keys)
    return make
