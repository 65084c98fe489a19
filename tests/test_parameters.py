"""The restitution laws are declared once (``restitution.RESTITUTION``); everything else must
agree with that declaration: the C library's own range check, scenario validation and the
command line, the resolver's packing, the fit's search bounds, sweep units and the docs.
Also: numpy and C solve the Tabor equation by one rule (to 2 ulp), and a fixed ``dt`` is
checked against the line detector's limit when the scenario is read."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import rebound
import yaml

from ringsim.analysis import fit
from ringsim.cli import main
from ringsim.config.scenario import scenario_from_dict
from ringsim.config.schema import ScenarioError
from ringsim.engine import native
from ringsim.engine.resolver import ResolverHandle, install_resolver
from ringsim.engine.sheet import build_sheet
from ringsim.physics import restitution as rs
from ringsim.physics.laws import DIMENSIONLESS, Law, LawTable, MeasuredRange, Parameter
from ringsim.physics.restitution import RESTITUTION
from ringsim.store import summary

DOCS = Path(__file__).resolve().parent.parent / "docs" / "scenario.md"
BEGIN = "<!-- generated from ringsim.physics.restitution.RESTITUTION"
END = "<!-- end of generated table -->"

SCENARIO = {
    "name": "bounds",
    "seed": 1,
    "planet": {"Omega": 2.0e-4},
    "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}},
    "sheet": {"n_particles": 50},
    "integration": {"orbits": 0.01},
}

PARAMETERS = [(law, par) for law in RESTITUTION for par in law.parameters]


def _id(item) -> str:
    law, par = item[:2]
    return f"{law.name}.{par.name}" + (f"={item[2]!r}" if len(item) > 2 else "")


def _typical(law: Law) -> dict[str, float]:
    return {p.name: p.typical for p in law.parameters}


def _probes(par: Parameter) -> list[float]:
    """Each finite bound, the nearest floats inside and outside it, and non-finite values."""
    values = [math.nan, math.inf, -math.inf]
    for bound, inward in ((par.lower, math.inf), (par.upper, -math.inf)):
        if math.isfinite(bound):
            values += [bound, math.nextafter(bound, inward), math.nextafter(bound, -inward)]
        else:   # unbounded side: the largest finite value is allowed
            values.append(math.copysign(np.finfo(float).max, bound))
    return values


def _outside(par: Parameter) -> list[float]:
    """Values a scenario must refuse: each open bound itself, the nearest float beyond
    each closed bound, and the non-finite values."""
    return [x for x in _probes(par) if not par.contains(x)]


# --- the declaration is well formed -----------------------------------------------------------

def test_declaration_complete():
    for law, par in PARAMETERS:
        assert par.unit and par.meaning and par.source, f"{law.name}.{par.name}"
        assert par.contains(par.typical), f"{law.name}.{par.name}: typical value in range"
        assert law.measured.source, law.name
    assert RESTITUTION.default == "dilley"
    assert RESTITUTION["dilley"].measured.speeds == (1e-4, 5e-2)


def test_codes_and_slots_are_derived_from_the_declaration():
    assert native.MODEL_CODES == {law.name: law.code for law in RESTITUTION}
    for law in RESTITUTION:
        order = native.PARAMETER_ORDER[law.name]
        assert [law[name].slot for name in order] == list(range(len(order)))


def test_a_friction_table_uses_the_same_machinery():
    """The coming friction section declares its laws the same way."""
    friction = LawTable("friction", n_slots=3, laws=[
        Law("constant", code=0, function=lambda v, beta: v, formula="β", source="test",
            measured=MeasuredRange(None, None, "not a measured law"),
            parameters=(Parameter("beta", DIMENSIONLESS, lower=-1.0, upper=1.0,
                                  lower_closed=True, upper_closed=True, default=0.0,
                                  meaning="tangential restitution", source="test"),)),
        Law("coulomb", code=1, function=lambda v, mu: v, formula="μ", source="test",
            measured=MeasuredRange(None, None, "not a measured law"),
            parameters=(Parameter("mu", DIMENSIONLESS, lower=0.0, lower_closed=True,
                                  example=0.5, meaning="friction coefficient",
                                  source="test"),)),
    ])
    assert friction.resolve({"model": "constant"})[1] == {"beta": 0.0}
    with pytest.raises(ValueError, match="^beta"):
        friction.resolve({"model": "constant", "beta": math.nextafter(1.0, 2.0)})
    with pytest.raises(ValueError, match="^mu: required"):
        friction.resolve({"model": "coulomb"})
    assert friction["coulomb"].pack({"mu": 0.25}, friction.n_slots) == (0.25, 0.0, 0.0)
    assert "| `coulomb` | `mu` | – | real | **required** | >= 0 |" in friction.markdown()


# --- C and Python agree at every bound ----------------------------------------------------------

def _c_accepts(law: Law, values: dict[str, float]) -> bool:
    """Whether the C library's own check (rs_parameters_valid) accepts the values."""
    packed = [0.0] * RESTITUTION.n_slots
    for par in law.parameters:
        packed[par.slot] = values[par.name]
    address = native._LIB.rs_resolver_create(law.code, *packed, 0, 1)
    if address:
        native._LIB.rs_resolver_free(address)
    return bool(address)


@pytest.mark.parametrize("law, par", PARAMETERS, ids=[_id(p) for p in PARAMETERS])
def test_c_accepts_exactly_the_declared_range(law, par):
    assert _c_accepts(law, _typical(law)), "typical values accepted"
    for x in _probes(par):
        declared = par.contains(x)
        assert _c_accepts(law, {**_typical(law), par.name: x}) == declared, \
            f"C and declaration disagree on {law.name}.{par.name} = {x!r} (declared: {declared})"
        values = {**_typical(law), par.name: x}
        if declared:
            assert law.checked(values)[par.name] == x
            with np.errstate(all="ignore"):   # extreme values over- or underflow inside
                eps = rs.epsilon_for_pair({"model": law.name, **values}, 1e-3, 1.0, 1.0)
            assert 0.0 <= eps <= 1.0, f"{law.name}.{par.name} = {x!r}: eps = {eps}"
        else:
            with pytest.raises(ValueError, match=f"^{par.name} "):
                law.checked(values)


@pytest.mark.parametrize("law, par", PARAMETERS, ids=[_id(p) for p in PARAMETERS])
def test_nearest_values_inside_pass_scenario_and_resolver(law, par):
    """What the scenario accepts, the resolver accepts: no exit 1 after validation."""
    inside = [x for x in _probes(par) if par.contains(x)]
    for x in inside:
        doc = copy.deepcopy(SCENARIO)
        doc["restitution"] = {"model": law.name, **_typical(law), par.name: x}
        sc = scenario_from_dict(doc)
        handle = ResolverHandle(sc.restitution_dict())
        assert handle.parameters[par.name] == x
        handle.close()


def test_resolver_packs_each_value_into_its_declared_slot():
    for law in RESTITUTION:
        values = {p.name: p.typical for p in law.parameters}
        with ResolverHandle({"model": law.name, **values}) as handle:
            struct = handle._struct
            assert struct.model == law.code
            for par in law.parameters:
                assert struct.param[par.slot] == values[par.name], f"{law.name}.{par.name}"


# --- scenario and command line -----------------------------------------------------------------

OUTSIDE = [(law, par, x) for law, par in PARAMETERS for x in _outside(par)]


@pytest.mark.parametrize("law, par, x", OUTSIDE, ids=[_id(o) for o in OUTSIDE])
def test_out_of_range_restitution_exits_2_naming_the_key(tmp_path, capsys, law, par, x):
    doc = copy.deepcopy(SCENARIO)
    doc["restitution"] = {"model": law.name, **_typical(law), par.name: x}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(doc, source=str(path))
    assert info.value.key == f"restitution.{par.name}"
    out = tmp_path / "never.h5"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert str(path) in lines[0] and f"restitution.{par.name}" in lines[0], lines[0]
    assert not out.exists(), "no output file for bad input"
    with pytest.raises(ValueError, match=par.name):
        install_resolver_probe(law, par, x)


def install_resolver_probe(law: Law, par: Parameter, x: float) -> None:
    install_resolver(rebound.Simulation(), {"model": law.name, **_typical(law), par.name: x})


def test_p_zero_exits_2_with_one_line(tmp_path, capsys):
    """Issue 10: p: 0 used to pass validation and then fail in the resolver (exit 1)."""
    doc = copy.deepcopy(SCENARIO)
    doc["restitution"] = {"model": "dilley", "p": 0}
    path = tmp_path / "p0.yaml"
    path.write_text(yaml.safe_dump(doc))
    out = tmp_path / "p0.h5"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and f"{path}: restitution.p: " in lines[0] and "> 0" in lines[0]
    assert not out.exists()


# --- integration.dt and the line detector --------------------------------------------------------

def _line(dt, detection="line", Omega=2.0e-4):
    doc = copy.deepcopy(SCENARIO)
    doc["planet"] = {"Omega": Omega}
    doc["integration"] = {"orbits": 1.0, "dt": dt, "collision_detection": detection}
    # outputs at least three of the longest step apart (config.intervals)
    doc["output"] = {**doc.get("output", {}), "timeseries_every": 0.5, "snapshot_every": 1.0}
    return doc


def test_line_dt_limit_comes_from_the_c_detector():
    assert native.max_shear_step() == 0.5
    largest = 0.5 / (3.0 * math.pi)   # 1.5 Omega dt < 0.5 with dt = 2 pi dt_orbits / Omega
    assert scenario_from_dict(_line(0.05)).integration.dt == 0.05
    assert scenario_from_dict(_line(0.06, "tree")).integration.dt == 0.06, "tree keeps (0, 0.1]"
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(_line(0.06))
    assert info.value.key == "integration.dt"
    assert f"{largest:.6g}" in str(info.value) and "orbits" in str(info.value)
    with pytest.raises(ScenarioError, match="integration.dt"):
        scenario_from_dict(_line(math.nextafter(largest, 1.0)))


def test_largest_accepted_line_dt_runs_a_step():
    """The largest dt the scenario accepts is accepted by the C detector (one step)."""
    dt = 0.5 / (3.0 * math.pi)
    while True:
        try:
            sc = scenario_from_dict(_line(dt))
            break
        except ScenarioError:
            dt = math.nextafter(dt, 0.0)
    with pytest.raises(ScenarioError):
        scenario_from_dict(_line(math.nextafter(dt, 1.0)))
    sheet = build_sheet(sc)
    sheet.sim.integrate(sheet.sim.dt)
    assert sheet.resolver.detector_stats()["error"] == "none"
    assert sheet.resolver.detector_stats()["steps"] == 1
    # the next longer step, which the scenario refuses, is refused by the C detector too
    refused = build_sheet(sc)
    refused.sim.dt = math.nextafter(dt, 1.0) * 2.0 * math.pi / sc.orbital_frequency
    with pytest.raises(rebound.GenericError):   # the detector stops the integration
        refused.sim.steps(1)
    assert refused.resolver.detector_stats()["error"].startswith("time step too long")


def test_line_dt_060_exits_2_and_writes_nothing(tmp_path, capsys):
    path = tmp_path / "line.yaml"
    path.write_text(yaml.safe_dump(_line(0.06)))
    out = tmp_path / "line.h5"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{path}: integration.dt: " in lines[0], lines
    assert not out.exists()


# --- fit, sweep units, docs --------------------------------------------------------------------

@pytest.mark.parametrize("law", list(RESTITUTION), ids=RESTITUTION.names)
def test_fit_search_bounds_lie_inside_the_declared_range(law):
    searched = fit._fit_parameters(law.name)
    # A reference scale held at its default (implicit_at_default) is degenerate with the
    # amplitude and not fitted; every other parameter is.
    fitted = [p for p in law.parameters if not p.implicit_at_default]
    assert [p.name for p in searched] == [p.name for p in fitted]
    for declared, par in zip(fitted, searched, strict=True):
        assert declared.contains(par.lower) and declared.contains(par.upper), par
        assert par.lower < declared.typical < par.upper, par
        assert par.unit == declared.unit
    for edge in ("lower", "upper"):   # the law evaluates at every corner of the search box
        values = {p.name: getattr(p, edge) for p in searched}
        eps = rs.epsilon_for_pair({"model": law.name, **values}, [1e-5, 1e-2], 1.0, 1.0)
        assert np.all((np.asarray(eps) >= 0) & (np.asarray(eps) <= 1))


def test_sweep_units_of_restitution_keys_are_declared():
    for _law, par in PARAMETERS:
        assert summary._parameter_units(f"restitution.{par.name}") == par.unit


def test_docs_table_is_generated_from_the_declaration():
    text = DOCS.read_text()
    start = text.index(BEGIN)
    table = text[text.index("\n", start) + 1:text.index(END)]
    assert table == RESTITUTION.markdown(), (
        "docs/scenario.md's restitution table differs from the declaration; paste "
        "ringsim.physics.restitution.RESTITUTION.markdown() between the markers")


# --- one Tabor solver ------------------------------------------------------------------------

def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance in units in the last place between positive floats."""
    return np.abs(a.view(np.int64) - b.view(np.int64))


def test_numpy_and_c_tabor_solvers_agree_to_two_ulp():
    u = np.geomspace(1.0 + 1e-12, 1e8, 1000)
    v_c = 1e-3
    worst = 0
    for q in np.linspace(1e-6, 0.5 - 1e-6, 51):
        with ResolverHandle({"model": "tabor", "v_c": v_c, "q": float(q)}) as handle:
            eps_c = handle.epsilon(u * v_c, 1.0, 1.0)
        eps_np = np.asarray(rs.tabor_epsilon(u * v_c, v_c, float(q)))
        ulps = _ulps(eps_np, eps_c)
        assert ulps.max() <= 2, f"q = {q}: numpy and C differ by {ulps.max()} ulp"
        worst = max(worst, int(ulps.max()))
    assert worst > 0, "the two solvers are independent evaluations (else compare differently)"


def test_twin_evaluates_the_law_in_c():
    from ringsim.testing import PythonReferenceResolver

    twin = PythonReferenceResolver({"model": "tabor", "v_c": 2e-4})
    with ResolverHandle({"model": "tabor", "v_c": 2e-4}) as handle:
        assert twin.epsilon(3e-3, 1.0, 1.0) == float(handle.epsilon(3e-3, 1.0, 1.0)[0])
