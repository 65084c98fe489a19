"""Scenario files: round trips, bundled scenarios, every kind of bad input, overrides, sweeps."""

from __future__ import annotations

import copy
import dataclasses
import math
import pickle
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import integrate

from ringsim.config.scenario import (
    Scenario,
    load_scenario,
    scenario_from_dict,
    scenario_from_text,
    with_overrides,
)
from ringsim.config.schema import ScenarioError
from ringsim.config.sweep import load_sweep
from ringsim.errors import InputError
from ringsim.physics import restitution as rs
from ringsim.physics.sizes import Mixture, MixtureComponent, Monodisperse, PowerLaw

SCENARIO_DIR = Path(__file__).resolve().parent.parent / "scenarios"
BUNDLED = sorted(p for p in SCENARIO_DIR.glob("*.yaml") if not p.name.startswith("sweep-"))
BUNDLED_SWEEPS = sorted(SCENARIO_DIR.glob("sweep-*.yaml"))

# A complete scenario as the contract shows it; tests mutate copies of it.
CONTRACT_EXAMPLE = {
    "name": "kappa0",
    "seed": 1,
    "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0,
                  "size_distribution": {"kind": "powerlaw", "q": 3.0, "r_min": 0.5,
                                        "r_max": 5.0}},
    "sheet": {"optical_depth": 0.25, "n_particles": 2000, "aspect": 1.0, "gravity": False},
    "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0},
    "integration": {"orbits": 50, "dt": "auto", "collision_detection": "tree"},
    "output": {"path": "runs/kappa0.h5", "timeseries_every": 0.1, "snapshot_every": 5.0},
}
MINIMAL = {
    "name": "minimal",
    "seed": 3,
    "planet": {"Omega": 2.0e-4},
    "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}},
}


def _write(tmp_path: Path, data, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
    return path


# --- round trips --------------------------------------------------------------------------

ROUND_TRIP_CASES = {
    "contract": CONTRACT_EXAMPLE,
    "minimal": MINIMAL,
    "GM_and_a": {**MINIMAL, "planet": {"GM": 3.7931187e16, "a": 1.3e8}},
    "mixture_gravity": {
        **MINIMAL,
        "particles": {"density": 450.0, "size_distribution": {"kind": "mixture", "components": [
            {"radius": 0.3, "number_fraction": 0.7}, {"radius": 1.7, "number_fraction": 0.3}]}},
        "sheet": {"gravity": True, "softening": "auto", "opening_angle": 0.7},
        "integration": {"dt": 1.0e-3, "collision_detection": "tree"},
        "output": {"log_collisions": 1000, "checkpoint_every": 0.5},
    },
    "odd_floats": {**MINIMAL, "planet": {"Omega": 0.1 + 0.2},
                   "restitution": {"model": "tabor", "v_c": 3.14e-4, "q": 1 / 3},
                   "description": "unicode: ε(v) ≤ 1"},
}


@pytest.mark.parametrize("case", sorted(ROUND_TRIP_CASES))
def test_yaml_round_trip_is_exact(case):
    sc = scenario_from_dict(ROUND_TRIP_CASES[case], source=case)
    again = scenario_from_text(sc.to_yaml())
    assert again == sc, "to_yaml -> scenario_from_text changed the scenario"
    assert again.to_yaml() == sc.to_yaml(), "to_yaml is not a fixed point"
    assert scenario_from_dict(sc.to_dict()) == sc, "to_dict -> scenario_from_dict changed it"
    assert hash(again) == hash(sc)


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: p.name)
def test_bundled_scenario_loads_and_round_trips(path):
    sc = load_scenario(path)
    assert sc.source == str(path)
    assert sc.source_text == path.read_text(), "the original text (with comments) is kept"
    assert sc.yaml_text == sc.source_text
    assert scenario_from_text(sc.to_yaml()) == sc
    assert sc.output.path == f"runs/{sc.name}.h5"
    # the restitution section is accepted by the restitution module as it stands
    eps = rs.epsilon_for_pair(sc.restitution_dict(), 0.01, 1.0, 1000.0)
    assert 0.0 <= eps <= 1.0


def test_bundled_files_are_the_ones_documented():
    names = {p.name for p in BUNDLED}
    assert {"quickstart.yaml", "kappa0.yaml", "kappa0.1.yaml", "bridges.yaml",
            "constant-eps-0.5.yaml"} <= names
    documented = (SCENARIO_DIR.parent / "docs" / "scenario.md").read_text()
    for name in names | {p.name for p in BUNDLED_SWEEPS}:
        assert f"`{name}`" in documented, f"{name} is not listed in docs/scenario.md"


def test_kappa_pair_differs_only_in_kappa_name_and_path():
    k0 = load_scenario(SCENARIO_DIR / "kappa0.yaml")
    k1 = load_scenario(SCENARIO_DIR / "kappa0.1.yaml")
    assert (k0.restitution.kappa, k1.restitution.kappa) == (0.0, 0.1)
    assert with_overrides(k0, {"restitution.kappa": 0.1, "name": "kappa0.1",
                               "output.path": "runs/kappa0.1.h5"}) == k1
    # the physics the brief asks for
    sd = k0.particles.size_distribution
    assert (sd.kind, sd.q, sd.r_min, sd.r_max) == ("powerlaw", 3.0, 0.5, 5.0)
    assert k0.particles.density == 900.0 and k0.orbital_frequency == 2.0e-4
    assert k0.sheet.optical_depth == 0.25 and not k0.sheet.gravity
    assert (k0.restitution.xi0, k0.restitution.p) == (0.16, 0.65)
    assert k0.integration.orbits >= 50 and k0.integration.dt == "auto"


def test_bridges_scenario_matches_rebound_shearing_sheet_example():
    sc = load_scenario(SCENARIO_DIR / "bridges.yaml")
    assert sc.restitution.model == "bridges"
    assert sc.orbital_frequency == 0.00013143527          # REBOUND's OMEGA [1/s]
    assert sc.particles.density == 400.0                  # REBOUND's particle_density
    sd = sc.particles.size_distribution
    assert (sd.q, sd.r_min, sd.r_max) == (3.0, 1.0, 4.0)  # slope -3, radii 1-4 m
    assert sc.sheet.gravity and sc.softening_length == 0.1
    assert sc.sheet.opening_angle**2 == pytest.approx(0.5, rel=1e-3)  # opening_angle2
    assert sc.integration.dt == "auto"                   # REBOUND's 1e-3 orbit is too long
    # the example itself, as studies/validation-rebound-example runs it (validation case 5)
    example = load_scenario(SCENARIO_DIR.parent / "studies" / "validation-rebound-example"
                            / "scenario.yaml")
    assert example.integration.dt == 1.0e-3              # REBOUND's dt [orbits]
    assert example.integration.collision_detection == "tree"
    assert example.sheet.gravity_solver == "tree" and example.softening_length == 0.1
    assert example.sheet.opening_angle**2 == pytest.approx(0.5, rel=1e-3)
    assert example.particles.size_distribution == sd and example.particles.density == 400.0
    assert example.restitution == sc.restitution
    # 400 kg/m^2 in 200 m x 200 m: dN/dR ~ R^-3 on [1, 4] m has <r^2> = 2 ln 4 / (15/16)
    # and <r^3> = 2 * 3 / (15/16) [m^2, m^3]
    r2, r3 = 2.0 * math.log(4.0) / (15 / 16), 6.0 / (15 / 16)
    mean_mass = 400.0 * 4.0 / 3.0 * math.pi * r3
    assert example.sheet.optical_depth == pytest.approx(400.0 * math.pi * r2 / mean_mass,
                                                        abs=5e-5)
    assert example.sheet.n_particles == round(400.0 * 200.0**2 / mean_mass)
    # REBOUND writes the law as eps = 0.32 (v / 1 cm/s)^-0.234; v_c = 1 cm/s * 0.32^(1/0.234)
    v_c_rebound = 0.01 * 0.32 ** (1.0 / 0.234)
    assert sc.restitution.v_c == pytest.approx(v_c_rebound, rel=5e-3)
    assert sc.restitution.exponent == 0.234


def test_quickstart_is_small():
    sc = load_scenario(SCENARIO_DIR / "quickstart.yaml")
    assert sc.sheet.n_particles <= 500 and sc.integration.orbits <= 10
    assert sc.output.path == "runs/quickstart.h5"


def test_constant_scenario():
    sc = load_scenario(SCENARIO_DIR / "constant-eps-0.5.yaml")
    assert sc.restitution_dict() == {"model": "constant", "epsilon": 0.5}
    assert sc.particles.size_distribution == Monodisperse(radius=1.0)
    assert sc.sheet.optical_depth == 0.25


# --- defaults and derived physics ---------------------------------------------------------

def test_defaults_are_filled_and_published_dilley_values():
    sc = scenario_from_dict(MINIMAL, source="minimal")
    d = sc.to_dict()
    assert d["restitution"] == {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0}
    assert d["particles"]["density"] == 900.0
    assert d["sheet"] == {"optical_depth": 0.25, "n_particles": 1000, "aspect": 1.0,
                          "gravity": False, "initial_dispersion": 2.0, "z_box": "auto"}
    assert d["integration"] == {"orbits": 10.0, "dt": "auto", "dt_safety": 0.1,
                                "collision_detection": "tree", "until_equilibrium": False,
                                "threads": "auto"}
    assert d["output"] == {"path": "runs/minimal.h5", "timeseries_every": 0.1,
                           "snapshot_every": 5.0, "checkpoint_every": 5.0, "log_collisions": 0}
    assert sc.softening_length is None and sc.source_text is None
    # Dilley's law at the reference pair and 1 cm/s: eps = exp(-pi xi0 / sqrt(1 - xi0^2))
    eps = rs.epsilon_for_pair(sc.restitution_dict(), 0.01, rs.R_REF, rs.M_REF)
    assert eps == pytest.approx(math.exp(-math.pi * 0.16 / math.sqrt(1 - 0.16**2)), rel=1e-12)


def test_planet_from_GM_and_a_gives_kepler_frequency():
    gm_saturn, a = 3.7931187e16, 1.30e8           # [m^3/s^2], [m]: Saturn's A ring
    sc = scenario_from_dict({**MINIMAL, "planet": {"GM": gm_saturn, "a": a}})
    assert sc.orbital_frequency == pytest.approx(math.sqrt(gm_saturn / a**3), rel=1e-15)
    # the bridges scenario's Omega is Saturn's at about 130 000 km (within 1%)
    assert sc.orbital_frequency == pytest.approx(0.00013143527, rel=1e-2)
    assert sc.orbital_period == pytest.approx(2 * math.pi / sc.orbital_frequency, rel=1e-15)


@pytest.mark.parametrize("q", [3.0, 1.0, 2.0, 3.5, 4.0])
def test_powerlaw_moments_match_quadrature(q):
    sd = PowerLaw(q=q, r_min=0.5, r_max=5.0)
    norm = integrate.quad(lambda r: r**-q, 0.5, 5.0, epsabs=0, epsrel=1e-13)[0]
    for k in (1.0, 2.0, 3.0, q - 1.0):       # k = q - 1 hits the logarithmic case
        num = integrate.quad(lambda r, k=k: r ** (k - q), 0.5, 5.0, epsabs=0, epsrel=1e-13)[0]
        assert sd.moment(k) == pytest.approx(num / norm, rel=1e-10), f"<r^{k}> for q={q}"


def test_powerlaw_draws_follow_the_distribution():
    sd = PowerLaw(q=3.0, r_min=0.5, r_max=5.0)
    rng = np.random.default_rng(20240601)
    n = 200_000
    radii = sd.draw_radii(n, rng)
    assert radii.min() >= 0.5 and radii.max() <= 5.0
    for k in (1, 2, 3):
        mean, stderr = np.mean(radii**k), np.std(radii**k) / math.sqrt(n)
        assert abs(mean - sd.moment(k)) < 5 * stderr, f"sample <r^{k}> off by > 5 sigma"
    # half the particles lie below the median R_med: R_med^-2 = (r_min^-2 + r_max^-2) / 2
    r_med = ((0.5**-2 + 5.0**-2) / 2) ** -0.5
    assert abs(np.mean(radii < r_med) - 0.5) < 5 * 0.5 / math.sqrt(n)


def test_mixture_draws_exact_counts():
    sd = Mixture((MixtureComponent(0.3, 0.7), MixtureComponent(1.7, 0.2),
                  MixtureComponent(2.0, 0.1)))
    radii = sd.draw_radii(1001, np.random.default_rng(5))
    counts = [int(np.sum(radii == r)) for r in (0.3, 1.7, 2.0)]
    assert sum(counts) == 1001 and counts == [701, 200, 100]
    assert sd.moment(2) == pytest.approx(0.7 * 0.09 + 0.2 * 2.89 + 0.1 * 4.0, rel=1e-14)
    assert (sd.smallest_radius, sd.largest_radius) == (0.3, 2.0)


def test_expected_box_holds_n_particles_at_the_optical_depth():
    sc = scenario_from_dict({**CONTRACT_EXAMPLE, "sheet": {"optical_depth": 0.4,
                                                          "n_particles": 3000, "aspect": 2.0}})
    lx, ly = sc.expected_box_size()
    sd = sc.particles.size_distribution
    assert ly == pytest.approx(2.0 * lx, rel=1e-15)
    assert 3000 * math.pi * sd.moment(2) / (lx * ly) == pytest.approx(0.4, rel=1e-13)


def test_scenario_is_frozen_hashable_and_picklable():
    sc = load_scenario(SCENARIO_DIR / "kappa0.yaml")
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.seed = 2
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.restitution.model = "bridges"
    again = pickle.loads(pickle.dumps(sc))
    assert again == sc and again.source_text == sc.source_text
    assert copy.deepcopy(sc) == sc
    assert scenario_from_dict(sc.to_dict()) == sc, "source_text is excluded from =="
    assert scenario_from_dict(sc.to_dict()).source_text is None
    assert len({sc, scenario_from_dict(sc.to_dict())}) == 1


# --- bad input ----------------------------------------------------------------------------

def _mutated(path_value_pairs=(), delete=()):
    """CONTRACT_EXAMPLE with dotted keys set/deleted."""
    d = copy.deepcopy(CONTRACT_EXAMPLE)
    for dotted in delete:
        *parents, last = dotted.split(".")
        node = d
        for p in parents:
            node = node[p]
        del node[last]
    for dotted, value in path_value_pairs:
        *parents, last = dotted.split(".")
        node = d
        for p in parents:
            node = node.setdefault(p, {})
        node[last] = value
    return d


SD = "particles.size_distribution"
BAD_INPUTS = {
    # name: (document, expected key, words in the message)
    "missing name": (_mutated(delete=["name"]), "name", "missing"),
    "missing seed": (_mutated(delete=["seed"]), "seed", "missing"),
    "missing planet": (_mutated(delete=["planet"]), "planet", "missing"),
    "missing size distribution": (_mutated(delete=[SD]), SD, "missing"),
    "unknown key at top": (_mutated([("colour", "red")]), "colour", "unknown key"),
    "typo at top suggests": (_mutated([("sede", 2)]), "sede", "did you mean 'seed'"),
    "unknown nested key": (_mutated([("sheet.optcal_depth", 0.3)]), "sheet.optcal_depth",
                           "did you mean 'optical_depth'"),
    "unknown deep key": (_mutated([(f"{SD}.r_mid", 1.0)]), f"{SD}.r_mid", "unknown key"),
    "negative radius": (_mutated([(SD, {"kind": "monodisperse", "radius": -1.0})]),
                        f"{SD}.radius", "out of range"),
    "negative r_min": (_mutated([(f"{SD}.r_min", -0.5)]), f"{SD}.r_min", "> 0"),
    "r_min > r_max": (_mutated([(f"{SD}.r_min", 6.0)]), f"{SD}.r_min", "larger than r_max"),
    "unknown kind": (_mutated([(f"{SD}.kind", "lognormal")]), f"{SD}.kind", "powerlaw"),
    "key of another kind": (_mutated([(f"{SD}.radius", 1.0)]), f"{SD}.radius",
                            "kind powerlaw"),
    "tau zero": (_mutated([("sheet.optical_depth", 0)]), "sheet.optical_depth", "(0, 3]"),
    "tau negative": (_mutated([("sheet.optical_depth", -0.1)]), "sheet.optical_depth",
                     "out of range"),
    "tau too large": (_mutated([("sheet.optical_depth", 5.0)]), "sheet.optical_depth",
                      "out of range"),
    "kappa abc": (_mutated([("restitution.kappa", "abc")]), "restitution.kappa",
                  "not a number"),
    "kappa true": (_mutated([("restitution.kappa", True)]), "restitution.kappa", "boolean"),
    "kappa quoted number": (_mutated([("restitution.kappa", "0.1")]), "restitution.kappa",
                            "remove the quotes"),
    "kappa infinite": (_mutated([("restitution.kappa", float("inf"))]), "restitution.kappa",
                       "not finite"),
    "kappa empty": (_mutated([("restitution.kappa", None)]), "restitution.kappa",
                    "no value"),
    "param of another model": (_mutated([("restitution", {"model": "bridges", "kappa": 0.1})]),
                               "restitution.kappa", "bridges model"),
    "unknown model": (_mutated([("restitution", {"model": "diley"})]), "restitution.model",
                      "did you mean 'dilley'"),
    "constant needs epsilon": (_mutated([("restitution", {"model": "constant"})]),
                               "restitution.epsilon", "missing"),
    "epsilon above 1": (_mutated([("restitution", {"model": "constant", "epsilon": 1.5})]),
                        "restitution.epsilon", "[0, 1]"),
    "tabor q 0.5": (_mutated([("restitution", {"model": "tabor", "v_c": 1e-3, "q": 0.5})]),
                    "restitution.q", "(0, 0.5)"),
    "mixture fractions": (_mutated([(SD, {"kind": "mixture", "components": [
        {"radius": 1.0, "number_fraction": 0.5}, {"radius": 2.0, "number_fraction": 0.4}]})]),
        f"{SD}.components", "sum to 0.9"),
    "mixture negative radius": (_mutated([(SD, {"kind": "mixture", "components": [
        {"radius": -1.0, "number_fraction": 1.0}]})]), f"{SD}.components.0.radius", "> 0"),
    "n_particles 1": (_mutated([("sheet.n_particles", 1)]), "sheet.n_particles", ">= 2"),
    "n_particles float": (_mutated([("sheet.n_particles", 2000.5)]), "sheet.n_particles",
                          "not an integer"),
    "box smaller than a particle": (_mutated([("sheet.n_particles", 2)]), "sheet.n_particles",
                                    "largest particle"),
    "seed negative": (_mutated([("seed", -1)]), "seed", "in [0, 4294967295]"),
    "seed non-integer": (_mutated([("seed", 1.5)]), "seed", "not an integer"),
    "seed boolean": (_mutated([("seed", True)]), "seed", "boolean"),
    "name with slash": (_mutated([("name", "a/b")]), "name", "file name"),
    "planet Omega and GM": (_mutated([("planet.GM", 3.79e16)]), "planet.GM", "not both"),
    "planet GM without a": (_mutated([("planet", {"GM": 3.79e16})]), "planet.a", "missing"),
    "planet Omega zero": (_mutated([("planet.Omega", 0.0)]), "planet.Omega", "> 0"),
    "density negative": (_mutated([("particles.density", -900.0)]), "particles.density", "> 0"),
    "softening without gravity": (_mutated([("sheet.softening", 0.1)]), "sheet.softening",
                                  "gravity"),
    "z_box thinner than a particle": (_mutated([("sheet.z_box", 5.0)]), "sheet.z_box",
                                      "largest particle"),
    "orbits zero": (_mutated([("integration.orbits", 0)]), "integration.orbits", "> 0"),
    "dt zero": (_mutated([("integration.dt", 0.0)]), "integration.dt", "auto, or"),
    "dt word": (_mutated([("integration.dt", "fast")]), "integration.dt", "auto, or"),
    "dt too long": (_mutated([("integration.dt", 0.5)]), "integration.dt", "(0, 0.1]"),
    "collision detection": (_mutated([("integration.collision_detection", "sweep")]),
                            "integration.collision_detection", "tree, line"),
    "timeseries_every zero": (_mutated([("output.timeseries_every", 0)]),
                              "output.timeseries_every", "> 0"),
    "snapshot_every negative": (_mutated([("output.snapshot_every", -5.0)]),
                                "output.snapshot_every", "> 0"),
    "checkpoint_every zero": (_mutated([("output.checkpoint_every", 0.0)]),
                              "output.checkpoint_every", "> 0"),
    "log_collisions negative": (_mutated([("output.log_collisions", -1)]),
                                "output.log_collisions", ">= 0"),
    "section not a mapping": (_mutated([("sheet", [1, 2])]), "sheet", "not a mapping"),
    "unreadable YAML": ("name: x\nseed: 1\n  bad: indent: here\n", "<yaml>", "line 3"),
    "unclosed bracket": ("name: x\nseed: 1\nplanet: [1, 2\n", "<yaml>", "line"),
    "top level a list": ("- name: x\n- seed: 1\n", "<yaml>", "not a mapping"),
    "top level a scalar": ("just some words\n", "<yaml>", "not a mapping"),
    "empty file": ("", "<yaml>", "empty document"),
    "python tag refused by safe_load": ("name: !!python/object:os.system x\n", "<yaml>",
                                        "line 1"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_names_file_and_key_in_one_line(case, tmp_path):
    document, key, words = BAD_INPUTS[case]
    path = _write(tmp_path, document)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    err = info.value
    assert err.key == key, f"{case}: wrong key {err.key!r}: {err}"
    assert err.file == str(path)
    message = str(err)
    assert "\n" not in message, "the message must be one line"
    assert message.startswith(f"{path}: {key}: "), message
    assert message.endswith(")"), "the message ends with the allowed range in parentheses"
    assert words in message, f"{case}: {words!r} not in {message!r}"
    assert isinstance(err, ValueError) and isinstance(err, InputError), "CLI exit status 2"


def test_missing_file(tmp_path):
    path = tmp_path / "nope.yaml"
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert (info.value.key, info.value.file) == ("<file>", str(path))
    assert str(info.value).startswith(f"{path}: <file>: ") and "\n" not in str(info.value)


def test_directory_and_binary_file_are_unreadable(tmp_path):
    with pytest.raises(ScenarioError) as info:
        load_scenario(tmp_path)
    assert info.value.key == "<file>"
    binary = tmp_path / "b.yaml"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ScenarioError) as info:
        load_scenario(binary)
    assert info.value.key == "<file>"


def test_errors_survive_pickling():
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(_mutated([("restitution.kappa", "abc")]), source="s.yaml")
    again = pickle.loads(pickle.dumps(info.value))
    assert (again.file, again.key, str(again)) == (info.value.file, info.value.key,
                                                   str(info.value))


def test_scenario_from_text_names_its_source():
    with pytest.raises(ScenarioError) as info:
        scenario_from_text("seed: 1\n")
    assert info.value.file == "<string>" and info.value.key == "name"


# --- overrides ----------------------------------------------------------------------------

def test_with_overrides_changes_only_the_named_keys():
    sc = scenario_from_dict(CONTRACT_EXAMPLE, source="k.yaml")
    new = with_overrides(sc, {"restitution.kappa": 0.1, "seed": 2})
    assert (new.restitution.kappa, new.seed) == (0.1, 2)
    assert (sc.restitution.kappa, sc.seed) == (0.0, 1), "the original is unchanged"
    assert dataclasses.replace(new, seed=1, restitution=sc.restitution) == sc
    assert new.source == "k.yaml" and new.source_text is None


def test_with_overrides_recomputes_dependent_defaults():
    sc = scenario_from_dict({**MINIMAL, "output": {"snapshot_every": 2.0}})
    assert sc.output.checkpoint_every == 2.0
    new = with_overrides(sc, {"name": "other", "output.snapshot_every": 0.5})
    assert new.output.path == "runs/other.h5"
    assert new.output.checkpoint_every == 0.5
    # an explicit path is kept
    explicit = with_overrides(scenario_from_dict(CONTRACT_EXAMPLE), {"name": "other"})
    assert explicit.output.path == "runs/kappa0.h5"


def test_with_overrides_creates_sections_and_indexes_lists():
    sc = scenario_from_dict(MINIMAL)
    bridges = with_overrides(sc, {"restitution.model": "bridges", "sheet.gravity": True,
                                  "sheet.softening": 0.05})
    assert bridges.restitution_dict() == {"model": "bridges", "v_c": rs.BRIDGES_V_C,
                                          "exponent": rs.BRIDGES_EXPONENT}
    assert bridges.softening_length == 0.05
    mix = with_overrides(sc, {"particles.size_distribution": {"kind": "mixture", "components": [
        {"radius": 1.0, "number_fraction": 0.5}, {"radius": 2.0, "number_fraction": 0.5}]}})
    bigger = with_overrides(mix, {"particles.size_distribution.components.1.radius": 3.0})
    assert bigger.particles.size_distribution.largest_radius == 3.0


def test_with_overrides_respects_dataclasses_replace():
    sc = scenario_from_dict(MINIMAL)
    replaced = dataclasses.replace(sc, seed=7)
    assert with_overrides(replaced, {"restitution.kappa": 0.2}).seed == 7, "stale author dict"


@pytest.mark.parametrize("overrides, key", [
    ({"restitution.kapa": 0.1}, "restitution.kapa"),
    ({"restitution.kappa": "abc"}, "restitution.kappa"),
    ({"seed": -1}, "seed"),
    ({"sheet.softening": 0.1}, "sheet.softening"),
    ({"seed.value": 1}, "seed"),
    ({"nonsense.deep.key": 1}, "nonsense"),
    ({"restitution..kappa": 1}, "restitution..kappa"),
])
def test_with_overrides_validates_again(overrides, key):
    sc = scenario_from_dict(CONTRACT_EXAMPLE, source="k.yaml")
    with pytest.raises(ScenarioError) as info:
        with_overrides(sc, overrides)
    assert (info.value.file, info.value.key) == ("k.yaml", key)
    assert "\n" not in str(info.value)


# --- sweeps -------------------------------------------------------------------------------

def _sweep_files(tmp_path: Path, grid, base="scen/base.yaml") -> Path:
    (tmp_path / "scen").mkdir(exist_ok=True)
    _write(tmp_path / "scen", CONTRACT_EXAMPLE, "base.yaml")
    return _write(tmp_path, {"base": base, "grid": grid}, "sweep.yaml")


def test_sweep_points_are_the_cartesian_product_in_order(tmp_path):
    path = _sweep_files(tmp_path, {"restitution.kappa": [0.0, 0.05, 0.1], "seed": [1, 2]})
    sweep = load_sweep(path)
    assert len(sweep) == 6 and sweep.keys == ("restitution.kappa", "seed")
    assert sweep.base == scenario_from_dict(CONTRACT_EXAMPLE)
    assert Path(sweep.base_path) == tmp_path / "scen" / "base.yaml"
    points = list(sweep.points())
    assert [p for p, _ in points] == [{"restitution.kappa": k, "seed": s}
                                      for k in (0.0, 0.05, 0.1) for s in (1, 2)]
    for params, sc in points:
        assert isinstance(sc, Scenario)
        assert (sc.restitution.kappa, sc.seed) == (params["restitution.kappa"], params["seed"])
    assert [p for p, _ in load_sweep(path).points()] == [p for p, _ in points], "deterministic"


@pytest.mark.parametrize("grid, key, words", [
    ({"restitution.kapa": [0.1]}, "grid.restitution.kapa", "did you mean 'kappa'"),
    ({"restitution.kappa": [0.1, "abc"]}, "grid.restitution.kappa", "'abc'"),
    ({"restitution.kappa": 0.1}, "grid.restitution.kappa", "list"),
    ({"restitution.kappa": []}, "grid.restitution.kappa", "list"),
    ({}, "grid", "empty"),
    ({"particles.size_distribution.r_min": [0.5, 4.0],
      "particles.size_distribution.r_max": [5.0, 3.0]}, "grid", "r_min"),
])
def test_bad_sweep(tmp_path, grid, key, words):
    path = _sweep_files(tmp_path, grid)
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert (info.value.file, info.value.key) == (str(path), key)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_sweep_with_missing_base_names_the_base_file(tmp_path):
    path = _sweep_files(tmp_path, {"seed": [1]}, base="scen/absent.yaml")
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert info.value.key == "<file>"
    assert Path(info.value.file) == tmp_path / "scen" / "absent.yaml"


def test_sweep_rejects_unknown_top_key(tmp_path):
    path = _write(tmp_path, {"base": "x.yaml", "grd": {}}, "sweep.yaml")
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert info.value.key == "grd" and "did you mean 'grid'" in str(info.value)


@pytest.mark.parametrize("path", BUNDLED_SWEEPS, ids=lambda p: p.name)
def test_bundled_sweep_loads(path):
    sweep = load_sweep(path)
    assert len(sweep) == len(list(sweep.points())) >= 2


def test_docstring_examples_run():
    import doctest

    import ringsim.config.scenario

    result = doctest.testmod(ringsim.config.scenario)
    assert result.attempted >= 3 and result.failed == 0
