"""The scenario's optional ``friction`` section and ``particles.inertia_factor``.

Checked: both are validated against their one declaration (``FRICTION``,
``INERTIA_FACTOR``), with errors naming the dotted key; absent friction is no friction
(``friction_dict() is None``, ``to_dict`` unchanged); the scenario round-trips through
YAML; the docs table is the declaration's ``markdown()``; the sheet builder installs the
friction and inertia factor in the resolver.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from ringsim.config.scenario import ScenarioError, scenario_from_text, with_overrides
from ringsim.engine import sheet
from ringsim.physics.friction import FRICTION

DOCS = Path(__file__).resolve().parent.parent / "docs" / "scenario.md"
BEGIN = "<!-- generated from ringsim.physics.friction.FRICTION"
END = "<!-- end of generated friction table -->"
BASE = ("name: f\nseed: 1\nplanet: {Omega: 2.0e-4}\n"
        "sheet: {n_particles: 50}\n"
        "particles: {%s size_distribution: {kind: monodisperse, radius: 1.0}}\n")


def test_docs_table_is_generated_from_the_declaration():
    text = DOCS.read_text()
    start = text.index(BEGIN)
    table = text[text.index("\n", start) + 1:text.index(END)]
    assert table == FRICTION.markdown(), (
        "docs/scenario.md's friction table differs from the declaration; paste "
        "ringsim.physics.friction.FRICTION.markdown() between the markers")


def test_no_section_is_smooth_spheres():
    sc = scenario_from_text(BASE % "")
    assert sc.friction is None and sc.friction_dict() is None
    assert "friction" not in sc.to_dict()
    assert "inertia_factor" not in sc.to_dict()["particles"]
    assert sc.particles.inertia_factor == 0.4


def test_a_null_section_is_smooth_spheres_and_the_same_scenario():
    # how a study case removes the friction of its base (``friction: null``)
    plain = scenario_from_text(BASE % "")
    null = scenario_from_text(BASE % "" + "friction: null\n")
    rough = scenario_from_text(BASE % "" + "friction: {model: coulomb, mu: 0.5}\n")
    assert null.friction is None and null.to_dict() == plain.to_dict()
    assert with_overrides(rough, {"friction": None}).to_dict() == plain.to_dict()


def test_section_defaults_round_trip_and_reach_the_resolver():
    sc = scenario_from_text(BASE % "inertia_factor: 0.5," + "friction: {model: coulomb, "
                            "mu: 0.3}\n")
    assert sc.friction_dict() == {"model": "coulomb", "mu": 0.3, "beta0": 0.0}
    assert scenario_from_text(sc.to_yaml()) == sc
    built = sheet.build_sheet(sc)
    assert built.resolver.friction == sc.friction_dict()
    assert built.resolver.inertia_factor == 0.5
    assert built.resolver._struct.friction_model == FRICTION["coulomb"].code


@pytest.mark.parametrize("text, key", [
    ("friction: {beta: 0.0}", "friction.model"),
    ("friction: {model: sticky}", "friction.model"),
    ("friction: {model: constant}", "friction.beta"),
    ("friction: {model: constant, beta: 1.5}", "friction.beta"),
    ("friction: {model: constant, beta: 0.0, mu: 0.1}", "friction.mu"),
    ("friction: {model: coulomb, mu: -0.1}", "friction.mu"),
    ("friction: {model: coulomb, mu: 0.1, beta0: -1.01}", "friction.beta0"),
    ("friction: 3", "friction"),
])
def test_bad_section_names_the_key(text, key):
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(BASE % "" + text + "\n")
    assert info.value.key == key


@pytest.mark.parametrize("value, ok", [(0.0, False), (1e-9, True), (2.0 / 3.0, True),
                                       (0.667, False), (-0.1, False)])
def test_inertia_factor_range(value, ok):
    text = BASE % f"inertia_factor: {value!r}," + "friction: {model: constant, beta: 0.0}\n"
    if ok:
        assert scenario_from_text(text).particles.inertia_factor == value
    else:
        with pytest.raises(ScenarioError) as info:
            scenario_from_text(text)
        assert info.value.key == "particles.inertia_factor"


def test_inertia_factor_without_friction_refused():
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(BASE % "inertia_factor: 0.4,")
    assert info.value.key == "particles.inertia_factor"
