"""YAML 1.2 as users write it: exponent floats are numbers, yes/no are text, 010 is ten."""

import pytest

from ringsim.config.scenario import load_scenario, scenario_from_text
from ringsim.config.schema import ScenarioError
from ringsim.config.sweep import load_sweep

HEAD = "name: y12\nseed: 1\n"
PARTICLES = "particles: {size_distribution: {kind: monodisperse, radius: 1.0}}\n"


def _text(planet: str = "planet: {Omega: 2.0e-4}\n", extra: str = "") -> str:
    return HEAD + planet + PARTICLES + extra


@pytest.mark.parametrize("gm, a", [("3.7931e16", "1e8"), ("3.7931e+16", "1.0e8"),
                                   ("37931e12", "100000000")])
def test_exponent_numbers_as_docs_write_them(gm, a):
    # docs/scenario.md writes Saturn's GM as 3.7931e16; YAML 1.1 read it as text
    sc = scenario_from_text(_text(planet=f"planet:\n  GM: {gm}\n  a: {a}\n"))
    assert sc.planet.GM == 3.7931e16 and sc.planet.a == 1e8
    assert sc.orbital_frequency == pytest.approx((3.7931e16 / 1e24) ** 0.5, rel=1e-15)


def test_quoted_number_says_remove_the_quotes(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(_text(planet="planet: {Omega: '2e-4'}\n"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(f"{path}: planet.Omega: got the string '2e-4'")
    assert "remove the quotes" in message and "write" not in message
    assert "\n" not in message


@pytest.mark.parametrize("word", ["yes", "no", "on", "off", "Yes", "OFF"])
def test_yes_no_on_off_are_text_and_rejected_for_booleans(word):
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(_text(extra=f"sheet: {{gravity: {word}}}\n"), source="s.yaml")
    e = info.value
    assert e.key == "sheet.gravity"
    assert f"got the text '{word}', not a boolean" in str(e) and "true or false" in str(e)


def test_true_false_are_booleans():
    assert scenario_from_text(_text(extra="sheet: {gravity: true}\n")).sheet.gravity is True
    assert scenario_from_text(_text(extra="sheet: {gravity: false}\n")).sheet.gravity is False


def test_leading_zero_is_decimal_and_0o_is_octal():
    # YAML 1.1 read seed: 010 as 8; YAML 1.2 reads ten
    assert scenario_from_text(_text().replace("seed: 1", "seed: 010")).seed == 10
    assert scenario_from_text(_text().replace("seed: 1", "seed: 0o10")).seed == 8


def test_duplicate_key_is_an_error_with_line_and_column():
    text = _text(extra="sheet: {n_particles: 10}\nsheet: {n_particles: 20}\n")
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(text, source="dup.yaml")
    message = str(info.value)
    assert message.startswith("dup.yaml: <yaml>: invalid YAML at line 6, column 1")
    assert 'duplicate key "sheet"' in message and "\n" not in message


def test_syntax_error_keeps_line_and_column():
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(_text(extra="sheet: [1, 2\nintegration: {}\n"), source="bad.yaml")
    assert str(info.value).startswith("bad.yaml: <yaml>: invalid YAML at line 6, column 12")


def test_python_tags_are_refused():
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(_text(extra="description: !!python/object/apply:os.system [ls]\n"))
    assert info.value.key == "<yaml>"


def test_round_trip_with_exponent_and_gm():
    sc = scenario_from_text(_text(planet="planet: {GM: 3.7931e16, a: 1e8}\n",
                                  extra="restitution: {model: bridges, v_c: 7.7e-5}\n"))
    assert scenario_from_text(sc.to_yaml()) == sc


def test_sweep_grid_reads_exponent_numbers(tmp_path):
    (tmp_path / "base.yaml").write_text(_text())
    (tmp_path / "sw.yaml").write_text("base: base.yaml\ngrid:\n  planet.Omega: [1e-4, 2e-4]\n")
    sweep = load_sweep(tmp_path / "sw.yaml")
    omegas = sorted(sc.planet.Omega for _, sc in sweep.points())
    assert omegas == [1e-4, 2e-4]
