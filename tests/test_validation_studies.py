"""Validation cases as study files (docs/validation.md): the ladder's cases 2, 3 and 4,
``studies/validation-threshold`` (the thermal-balance threshold of Goldreich & Tremaine
1978), ``studies/validation-bridges`` (the Bridges law, identical 1 m particles) and
``studies/validation-size-distribution`` (the Bridges law with a q = 3 size
distribution), ``studies/validation-line-mode`` (line-mode detection against the tree
reference), ``studies/validation-kinetic-theory`` (the dense-ring kinetic theory
of Latter & Ogilvie 2008), ``studies/validation-rebound-example`` (case 5: ringsim's
resolver against REBOUND's), ``studies/validation-energy-balance`` (case 1's energy
balance) and ``studies/validation-aggregation`` (where the rings start to aggregate).

The fast tests check what the study files declare against the physics they encode (the
critical epsilon they bracket, the size bins they read); the slow tests run each quick form
afresh and assert that every reference agrees and that the summaries equal the committed
ones but for their cost (docs/studies.md: a rerun on the same kind of machine reproduces
its summary).  The committed reports are checked against their summaries by
tests/test_study_reports.py.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from ringsim.analysis.equilibrium import QUANTITIES
from ringsim.config.study import load_study
from ringsim.physics import kinetic
from ringsim.physics.dense_kinetic import kinetic_steady_state
from ringsim.study.command import run_study

ROOT = Path(__file__).resolve().parent.parent
THRESHOLD = ROOT / "studies" / "validation-threshold"
SIZES = ROOT / "studies" / "validation-size-distribution"
BRIDGES = ROOT / "studies" / "validation-bridges"
LINE_MODE = ROOT / "studies" / "validation-line-mode"
KINETIC = ROOT / "studies" / "validation-kinetic-theory"
REBOUND_EXAMPLE = ROOT / "studies" / "validation-rebound-example"
ENERGY = ROOT / "studies" / "validation-energy-balance"
AGGREGATION = ROOT / "studies" / "validation-aggregation"


def _load(folder: Path):
    return load_study(folder / "study.yaml", quantities=tuple(QUANTITIES))


def test_threshold_study_brackets_the_critical_epsilon_with_cooling_and_heating_rings():
    """Every hot case below GT78's eps_cr at tau = 0.1 (0.631) must cool and every case
    above it heat: the references say so, on both sides, by the growth rate of ln c^2, and,
    away from the threshold, by c's window mean against its start (30 r Omega); next to
    it the window mean cannot tell (the study's prose)."""
    study = _load(THRESHOLD)
    eps_cr = kinetic.critical_epsilon(0.1)
    assert eps_cr == pytest.approx(0.631, abs=5e-4)
    specs = {spec.case: spec.scenario for spec in study.specs()}
    start = {case: sc.sheet.initial_dispersion for case, sc in specs.items()}
    eps = {case: dict(sc.restitution.parameters)["epsilon"] for case, sc in specs.items()}
    checks = {r.case: r for r in study.references
              if r.quantity == "velocity_dispersion_rOmega"}
    rates = {r.case: r for r in study.references
             if r.quantity == "thermal_balance.growth_rate"}
    hot = [case for case in specs if start[case] == 30.0]
    below = [case for case in hot if eps[case] < eps_cr]
    above = [case for case in hot if eps[case] > eps_cr]
    assert below and above and len(below) + len(above) == len(hot)
    assert all(rates[c].high == 0.0 and rates[c].low == float("-inf") for c in below)
    assert all(rates[c].low == 0.0 and rates[c].high == float("inf") for c in above)
    far = [case for case in hot if abs(eps[case] - eps_cr) > 0.03]
    assert len(far) == 6 and len(hot) == 8
    assert all(checks[c].high == 30.0 and checks[c].low == float("-inf")
               for c in below if c in far)
    assert all(checks[c].low == 30.0 and checks[c].high == float("inf")
               for c in above if c in far)
    cold = [case for case in specs if start[case] < 30.0]
    assert cold and all(eps[c] < eps_cr and checks[c].high <= 5.0 for c in cold)


def test_size_distribution_study_reads_the_smallest_over_the_largest_size_bin():
    study = _load(SIZES)
    bins = [r for r in study.references if r.quantity.startswith("by_size.")]
    assert bins and all((r.bin, r.over_bin) == (0, -1) for r in bins)
    c = [r for r in bins if r.quantity == "by_size.velocity_dispersion"]
    assert {(r.low, r.high) for r in c} == {(2.0, 5.0), (float("-inf"), 6.1)}


def test_kinetic_theory_study_quotes_the_theory_at_its_optical_depths():
    """Each case's references are the tabulated theory at the case's optical depth, to the
    4 digits written (c [r Omega]; viscosities [m^2/s] = [r^2 Omega] x r^2 Omega), with a
    tolerance of 3 % of the value."""
    study = _load(KINETIC)
    specs = {spec.case: spec.scenario for spec in study.specs()}
    keys = {"velocity_dispersion_rOmega": "c", "translational_viscosity": "nu_trans",
            "collisional_viscosity": "nu_coll"}
    assert {r.case for r in study.references} == set(specs)
    for ref in study.references:
        sc = specs[ref.case]
        unit = 1.0 if ref.quantity == "velocity_dispersion_rOmega" else \
            sc.orbital_frequency * 1.0 ** 2           # 1 m spheres
        theory = kinetic_steady_state(sc.sheet.optical_depth)[keys[ref.quantity]] * unit
        assert ref.value == pytest.approx(theory, rel=5e-4), (ref.case, ref.quantity)
        assert ref.high - ref.value == pytest.approx(0.03 * theory, rel=0.02)


def _quick_afresh(folder: Path, tmp_path: Path) -> dict:
    copy = tmp_path / folder.name
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns(
        "summaries", "*.report", "earlier_runs*"))
    run_study(copy / "study.yaml", quick=True, workers=2, echo=None,
              command=f"ringsim study studies/{folder.name}/study.yaml --quick")
    for new in sorted((copy / "summaries").glob("*.json")):
        old = json.loads((folder / "summaries" / new.name).read_text())
        fresh = json.loads(new.read_text())
        old.pop("cost"), fresh.pop("cost")
        assert fresh == old, new.name
    return json.loads((copy / "study.quick.report" / "report.json").read_text())


@pytest.mark.slow
def test_threshold_quick_form_cools_below_and_heats_above(tmp_path):
    """Nine runs of 400 particles, 15 orbits (about 10 CPU-seconds)."""
    report = _quick_afresh(THRESHOLD, tmp_path)
    assert len(report["references"]) == 21
    assert all(e["agrees"] for e in report["references"]), \
        [e for e in report["references"] if not e["agrees"]]
    c = {case: e["equilibrium"]["velocity_dispersion_rOmega"]["mean"]
         for case, e in report["cases"].items()}
    assert c["eps0.3"] < c["eps0.5"] < c["eps0.6"] < c["eps0.7"] < c["eps0.8"] < c["eps0.9"]


@pytest.mark.slow
def test_size_distribution_quick_form_is_far_from_equipartition(tmp_path):
    """One run of 600 particles, 15 orbits (about 5 CPU-seconds)."""
    report = _quick_afresh(SIZES, tmp_path)
    assert len(report["references"]) == 3 and all(e["agrees"] for e in report["references"])
    bins = report["by_size"]["cases"]["q3"]["bins"]
    c = [b["velocity_dispersion"]["mean"] for b in bins]
    assert all(a > b for a, b in zip(c, c[1:], strict=False)), "c falls with size"


@pytest.mark.slow
def test_bridges_quick_form_is_a_near_monolayer_held_up_by_finite_size(tmp_path):
    """Three runs of 300 particles, 15 orbits (about 35 CPU-seconds): c of a few r Omega
    (1 to 5, the ladder's reading of Wisdom & Tremaine 1988 and Salo 1991), H below 3 r,
    and the applied mean eps below GT78's eps_cr at each optical depth, so that only the
    particles' finite size holds the ring up; c falls as tau rises."""
    report = _quick_afresh(BRIDGES, tmp_path)
    assert len(report["references"]) == 9
    assert all(e["agrees"] for e in report["references"]), \
        [e for e in report["references"] if not e["agrees"]]
    for case, e in report["cases"].items():
        tau = float(case.removeprefix("tau"))
        eps = e["equilibrium"]["mean_epsilon"]["mean"]
        assert eps < kinetic.critical_epsilon(tau), (case, eps)
    c = {case: e["equilibrium"]["velocity_dispersion_rOmega"]["mean"]
         for case, e in report["cases"].items()}
    assert c["tau0.25"] > c["tau0.5"] > c["tau1"]


def test_line_mode_study_pairs_each_line_case_with_its_tree_reference():
    """Each ratio compares a line case at a fixed 1e-3 orbit with a tree case at dt: auto
    that differs from it by nothing else, and its references ask for 1 on c and H."""
    study = _load(LINE_MODE)
    cases = dict(study.cases)
    assert sorted(study.ratios) == [("mono-line", "mono-tree"),
                                    ("powerlaw-line", "powerlaw-tree")]
    for line, tree in study.ratios:
        a, b = dict(cases[line]), dict(cases[tree])
        assert (a.pop("integration.collision_detection"), a.pop("integration.dt")) == \
            ("line", 1.0e-3)
        assert (b.pop("integration.collision_detection"), b.pop("integration.dt")) == \
            ("tree", "auto")
        assert a == b, (line, tree)
    refs = [r for r in study.references if r.ratio is not None]
    assert {(r.ratio, r.quantity) for r in refs} == {
        (pair, q) for pair in study.ratios for q in ("velocity_dispersion", "thickness")}
    assert all(r.value == 1.0 and (r.low, r.high) == pytest.approx((0.97, 1.03)) for r in refs)


@pytest.mark.slow
def test_line_mode_quick_form_agrees_with_the_tree(tmp_path):
    """Twelve runs of 200 particles, 5 orbits (about 90 CPU-seconds): every line / tree
    ratio of c and H within 3 % of 1 widened by 3 standard errors, and the identical
    spheres' ratio of c within 3 % of 1 by itself (its standard error is below 1 %)."""
    report = _quick_afresh(LINE_MODE, tmp_path)
    assert len(report["references"]) == 4
    assert all(e["agrees"] for e in report["references"]), \
        [e for e in report["references"] if not e["agrees"]]
    mono = next(e for e in report["references"]
                if e["ratio"] == ["mono-line", "mono-tree"]
                and e["quantity"] == "velocity_dispersion")
    assert abs(mono["mean"] - 1.0) < 0.03 and mono["stderr"] < 0.01


def test_rebound_example_study_changes_only_the_resolver():
    """Case 5 compares two runs of the same scenario and seed that differ only in who
    resolves the collisions; every ratio REBOUND / ringsim is referenced to 1."""
    study = _load(REBOUND_EXAMPLE)
    assert dict(study.cases) == {"ringsim": {},
                                 "rebound": {"integration.resolver": "rebound_hardsphere"}}
    specs = {(spec.case, spec.seed): spec.scenario for spec in study.specs()}
    for seed in (1, 2, 3):
        ours, theirs = specs[("ringsim", seed)], specs[("rebound", seed)]
        assert theirs.integration.resolver == "rebound_hardsphere"
        assert ours.to_dict() == {**theirs.to_dict(), "integration": {
            k: v for k, v in theirs.to_dict()["integration"].items() if k != "resolver"}}
    refs = [r for r in study.references if r.ratio == ("rebound", "ringsim")]
    assert {r.quantity for r in refs} == set(study.quantities)
    assert all((r.low, r.high) == (1.0, 1.0) for r in refs)


def test_energy_balance_study_keeps_the_budget_and_asks_for_balance():
    study = _load(ENERGY)
    assert study.keep == ("energy_budget",)
    refs = {r.case: r for r in study.references}
    assert set(refs) == {case for case, _ in study.cases}
    assert all(r.quantity == "energy_budget.ratio" and (r.low, r.high) == (0.99, 1.01)
               for r in refs.values())


@pytest.mark.slow
def test_rebound_example_quick_form_agrees(tmp_path):
    """Six runs of 500 particles, 6 orbits (about 2 CPU-minutes): every ratio REBOUND /
    ringsim within 3 standard errors of 1, and c within 15 % of 1 by itself."""
    report = _quick_afresh(REBOUND_EXAMPLE, tmp_path)
    assert len(report["references"]) == 7
    assert all(e["agrees"] for e in report["references"]), \
        [e for e in report["references"] if not e["agrees"]]
    c = next(e for e in report["references"] if e["quantity"] == "velocity_dispersion")
    assert abs(c["mean"] - 1.0) < 0.15


@pytest.mark.slow
def test_energy_balance_quick_form_balances(tmp_path):
    """Six runs of 200 particles, 10 orbits (about 30 CPU-seconds): heating / dissipation
    within 1 % of 1 widened by 3 standard errors, and within 3 % by itself."""
    report = _quick_afresh(ENERGY, tmp_path)
    assert len(report["references"]) == 3
    assert all(e["agrees"] and abs(e["mean"] - 1.0) < 0.03 for e in report["references"])


def test_aggregation_study_sets_each_case_s_hill_parameter():
    """Each case's orbital radius gives the Hill parameter of two touching particles its
    name says (to 1e-6: the radii are written to 7 digits); the references bracket the
    touching pair's Hill-sphere condition r_h > 1 from both sides."""
    from ringsim.physics.gravity import hill_parameter

    study = _load(AGGREGATION)
    assert study.keep == ("aggregation",)
    for spec in study.specs():
        sc = spec.scenario
        r_h = float(hill_parameter(1.0, 1.0, sc.particles.density, sc.planet.GM, sc.planet.a))
        assert r_h == pytest.approx(float(spec.case.removeprefix("rh")), rel=1e-6)
    refs = {r.case: r for r in study.references}
    assert refs["rh0.9"].high == 0.1 and refs["rh1.3"].low == 0.1
    assert {r.quantity for r in refs.values()} == {"aggregation.bound_fraction_mean"}


@pytest.mark.slow
def test_aggregation_quick_form_aggregates_only_above_r_h_1(tmp_path):
    """Ten runs of 200 particles, 1 orbit (about 50 CPU-seconds): nothing bound at
    r_h = 0.9, aggregates at 1.3, and the bound share rising with r_h from 1.0 on."""
    report = _quick_afresh(AGGREGATION, tmp_path)
    assert all(e["agrees"] for e in report["references"])
    bound = [report["cases"][f"rh{x}"]["kept"]["aggregation"]["bound_fraction_mean"]["mean"]
             for x in ("1.0", "1.1", "1.2", "1.3")]
    assert bound == sorted(bound) and bound[-1] > 0.3


def test_threshold_full_form_puts_the_critical_epsilon_above_gt78():
    """The committed full form: the growth rate of ln c^2 changes sign between 0.6375 and
    0.65625, so ringsim's eps_cr lies above GT78's 0.631 (the ring at 0.6375 cools by more
    than three standard errors: the one reference that disagrees, and the prose says
    why), and the velocity ellipsoid there is GT78's within 10 %."""
    report = json.loads((THRESHOLD / "study.report" / "report.json").read_text())
    rate = {case: e["kept"]["thermal_balance"]["growth_rate"]
            for case, e in report["cases"].items()}
    assert rate["eps0.6375"]["mean"] + 3.0 * rate["eps0.6375"]["stderr"] < 0.0
    assert rate["eps0.65625"]["mean"] > 0.0
    wrong = [(e["case"], e["quantity"]) for e in report["references"] if not e["agrees"]]
    assert wrong == [("eps0.6375", "thermal_balance.growth_rate")]
