"""The ``references`` of a study file (docs/studies.md, "Reference values"): read and
checked, the verdict of each case against its reference (a value with its own uncertainty,
a one-sided range, a per-size-bin value, a ratio of two cases), the report's section, and
the validation ladder's case 1 as a study (``studies/validation-constant-eps``)."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest

from ringsim.analysis.equilibrium import QUANTITIES
from ringsim.cli import main
from ringsim.config.study import load_study
from ringsim.config.study_references import Reference
from ringsim.study.command import run_study
from ringsim.study.references import reference_entry, references_section

ROOT = Path(__file__).resolve().parent.parent
BUNDLED = ROOT / "studies" / "validation-constant-eps"

STUDY = """\
name: refs
base: scenario.yaml
seeds: [1]
overrides: {sheet.n_particles: 60}
cases:
  dense: {}
  dilute: {sheet.optical_depth: 0.1}
length: {orbits: 0.3}
ratios: [[dense, dilute]]
references:
  dense:
    mean_epsilon: {value: 0.5, tolerance: 1.0e-9, source: the constant law}
    velocity_dispersion_rOmega: {low: 100.0, high: 200.0, source: a deliberately wrong range}
  dense/dilute:
    filling_factor: {low: 2.0, source: five times the optical depth fills more}
"""


def write(folder: Path, text: str = STUDY) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(BUNDLED / "scenario.yaml", folder / "scenario.yaml")
    (folder / "study.yaml").write_text(text)
    return folder / "study.yaml"


def case(mean: float, stderr: float) -> dict:
    return {"c": {"equilibrium": {"thickness": {"mean": mean, "stderr": stderr,
                                                "units": "m"}}}}


@pytest.mark.parametrize("mean, stderr, distance, agrees", [
    (15.0, 1.0, 0.0, True),        # inside the interval
    (22.0, 1.0, 2.0, True),        # 2 standard errors above its top: within 3
    (6.0, 1.0, 4.0, False),        # 4 below its bottom
    (25.0, 0.0, math.inf, False),  # outside with no error at all
    (math.nan, 1.0, math.nan, False),
])
def test_a_case_agrees_within_three_standard_errors_of_the_interval(mean, stderr, distance,
                                                                    agrees):
    ref = Reference("c", "thickness", 10.0, 20.0, None, "a range")
    entry = reference_entry(ref, case(mean, stderr))
    assert entry["agrees"] is agrees
    assert entry["distance"] == pytest.approx(distance, nan_ok=True)
    assert (entry["low"], entry["high"], entry["units"]) == (10.0, 20.0, "m")


BAD = [
    ("  dnse: {mean_epsilon: {value: 0.5, tolerance: 0.1, source: s}}\n",
     "references.dnse", "did you mean 'dense'"),
    ("  dense: {mean_epsilon: {value: 0.5, tolerance: 0.1, low: 0.1, source: s}}\n",
     "references.dense.mean_epsilon.low", "not with value"),
    ("  dense: {mean_epsilon: {tolerance: 0.1, source: s}}\n",
     "references.dense.mean_epsilon.tolerance", "without value"),
    ("  dense: {mean_epsilon: {value: 0.5, tolerance: -1, source: s}}\n",
     "references.dense.mean_epsilon.tolerance", "out of range"),
    ("  dense: {mean_epsilon: {value: 0.5, tolerance: 0.1}}\n",
     "references.dense.mean_epsilon.source", "missing"),
    ("  dense: {mean_epsilonn: {value: 0.5, tolerance: 0.1, source: s}}\n",
     "references.dense.mean_epsilonn", "did you mean 'mean_epsilon'"),
    ("  dense: {mean_epsilon: {low: 2, high: 1, source: s}}\n",
     "references.dense.mean_epsilon.high", "out of range"),
    ("  dense: {mean_epsilon: {value: 0.5, source: s}}\n",
     "references.dense.mean_epsilon.tolerance", "missing"),
    ("  dense: {mean_epsilon: {sigma: 0.1, low: 0.1, source: s}}\n",
     "references.dense.mean_epsilon.sigma", "without value"),
    ("  dense: {mean_epsilon: {value: 0.5, sigma: -0.1, source: s}}\n",
     "references.dense.mean_epsilon.sigma", "out of range"),
    ("  dense: {mean_epsilon: {source: s}}\n",
     "references.dense.mean_epsilon.low", "missing"),
    ("  dense: {mean_epsilon: {bin: 0, low: 0.1, source: s}}\n",
     "references.dense.mean_epsilon.bin", "not with"),
    ("  dense: {by_size.thickness: {low: 0.1, source: s}}\n",
     "references.dense.by_size.thickness.bin", "missing"),
    ("  dense: {by_size.thickness: {bin: 0.5, low: 0.1, source: s}}\n",
     "references.dense.by_size.thickness.bin", "integer"),
    ("  dense: {mean_epsilon: [{low: 0.1, source: s}, 3]}\n",
     "references.dense.mean_epsilon[1]", "not a mapping"),
    ("  dense: {mean_epsilon: [{low: 0.1, source: s}, {low: 0.1}]}\n",
     "references.dense.mean_epsilon[1].source", "missing"),
    ("  dilute/dense: {thickness: {low: 0.1, source: s}}\n",
     "references.dilute/dense", "the study's ratios: dense/dilute"),
    ("  dense/dilute: {by_size.thickness: {bin: 0, low: 0.1, source: s}}\n",
     "references.dense/dilute.by_size.thickness", "unknown quantity"),
]


@pytest.mark.parametrize("line, key, words", BAD)
def test_bad_reference_is_bad_input_naming_its_key(tmp_path, capsys, line, key, words):
    text = STUDY.split("references:")[0] + "references:\n" + line
    path = write(tmp_path / "bad", text)
    assert main(["study", str(path), "--report-only"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f": {key}:" in err[0] and words in err[0], err
    assert not (tmp_path / "bad" / "study.report").exists()


def test_study_reports_each_reference_with_its_verdict(tmp_path):
    """A tiny study: the constant law's epsilon agrees to 1e-9, a range far from the ring's
    c is reported as a disagreement, and a case without references gets none."""
    path = write(tmp_path / "refs")
    run_study(path, workers=1, echo=None, command="ringsim study study.yaml")
    out = tmp_path / "refs" / "study.report"
    report = json.loads((out / "report.json").read_text())
    entries = {e["quantity"]: e for e in report["references"]}
    assert [e["case"] for e in report["references"]] == ["dense", "dense", "dense/dilute"]
    ratio = entries["filling_factor"]
    listed = next(r for r in report["ratios"] if r["quantity"] == "filling_factor")
    assert ratio["ratio"] == ["dense", "dilute"] and ratio["agrees"]
    assert ratio["mean"] == listed["mean"] > 2.0 and ratio["high"] is None
    assert entries["mean_epsilon"]["agrees"] and entries["mean_epsilon"]["mean"] == \
        pytest.approx(0.5, abs=1e-9)
    wrong = entries["velocity_dispersion_rOmega"]
    assert not wrong["agrees"] and wrong["distance"] > 3.0 and wrong["mean"] < 100.0
    assert "3 standard errors" in report["references_rule"]
    text = (out / "report.md").read_text()
    assert "## Against the references" in text and "**disagrees**" in text


def test_bundled_case1_study_declares_the_ladders_references():
    study = load_study(BUNDLED / "study.yaml", quantities=tuple(QUANTITIES))
    taus = {name: s.scenario.sheet.optical_depth for name, s in
            ((spec.case, spec) for spec in study.specs())}
    assert sorted(taus.values()) == [0.1, 0.25, 0.5, 0.75, 1.0, 1.5]
    floors = [r for r in study.references if r.quantity == "velocity_dispersion_rOmega"]
    assert {r.case for r in floors} == set(taus)
    assert all((r.low, r.high) == (0.5, 5.0) for r in floors)


@pytest.mark.slow
def test_bundled_case1_study_quick_form_agrees_and_reproduces_its_summaries(tmp_path):
    """The quick form (six runs of 200 particles, 10 orbits; about 1.5 CPU-minutes) run
    afresh: every case is inside the finite-size floor and applies eps = 0.5, and its
    summaries equal the committed ones but for their cost (docs/studies.md)."""
    folder = tmp_path / "validation-constant-eps"
    shutil.copytree(BUNDLED, folder, ignore=shutil.ignore_patterns("summaries", "*.report"))
    run_study(folder / "study.yaml", quick=True, workers=2, echo=None,
              command="ringsim study studies/validation-constant-eps/study.yaml --quick")
    report = json.loads((folder / "study.quick.report" / "report.json").read_text())
    assert len(report["references"]) == 12 and all(e["agrees"] for e in report["references"])
    for new in sorted((folder / "summaries").glob("*.json")):
        old = json.loads((BUNDLED / "summaries" / new.name).read_text())
        fresh = json.loads(new.read_text())
        old.pop("cost"), fresh.pop("cost")
        assert fresh == old, new.name


def test_a_reference_with_its_own_uncertainty_is_checked_in_combined_units():
    """value ± sigma: the distance is |mean - value| / sqrt(stderr^2 + sigma^2), agreement
    within 3 of those (the ladder's Comparison rows)."""
    ref = Reference("c", "thickness", 10.0, 10.0, 10.0, "a value", sigma=4.0)
    entry = reference_entry(ref, case(25.0, 3.0))
    assert entry["distance"] == pytest.approx(15.0 / 5.0) and entry["agrees"]
    assert entry["sigma"] == 4.0
    assert not reference_entry(ref, case(26.0, 3.0))["agrees"]        # 3.2 combined
    alone = Reference("c", "thickness", 10.0, 10.0, 10.0, "the same without sigma")
    assert reference_entry(alone, case(25.0, 3.0))["distance"] == pytest.approx(5.0)
    assert "sigma" not in reference_entry(alone, case(25.0, 3.0))


BY_SIZE = {"cases": {"c": {"bins": [
    {"r_low": 0.5, "r_high": 1.0, "velocity_dispersion": {"mean": 3.0, "stderr": 0.3,
                                                          "units": "m/s"}},
    {"r_low": 1.0, "r_high": 2.0, "velocity_dispersion": {"mean": 2.0, "stderr": 0.1,
                                                          "units": "m/s"}},
    {"r_low": 2.0, "r_high": 4.0, "velocity_dispersion": {"mean": 1.0, "stderr": 0.1,
                                                          "units": "m/s"}}]}}}


def test_a_per_size_bin_reference_reads_the_bin_or_the_ratio_of_two_bins():
    """``bin`` counts from the smallest (negative from the largest); ``over_bin`` divides
    by another bin with first-order error propagation: 3.0 ± 0.3 over 1.0 ± 0.1 is
    3.0 ± 3 sqrt(0.1^2 + 0.1^2)."""
    one = Reference("c", "by_size.velocity_dispersion", 1.5, 2.5, None, "s", bin=1)
    entry = reference_entry(one, {}, BY_SIZE)
    assert (entry["mean"], entry["stderr"], entry["units"]) == (2.0, 0.1, "m/s")
    assert entry["bin_radii"] == [1.0, 2.0] and entry["agrees"]
    two = Reference("c", "by_size.velocity_dispersion", -math.inf, 2.0, None, "s", bin=0,
                    over_bin=-1)
    entry = reference_entry(two, {}, BY_SIZE)
    assert entry["mean"] == pytest.approx(3.0)
    assert entry["stderr"] == pytest.approx(3.0 * math.hypot(0.1, 0.1))
    assert entry["distance"] == pytest.approx(1.0 / entry["stderr"]) and entry["agrees"]
    assert entry["over_bin_radii"] == [2.0, 4.0] and entry["units"] == "dimensionless"
    missing = Reference("c", "by_size.velocity_dispersion", 0.0, 1.0, None, "s", bin=5)
    assert not reference_entry(missing, {}, BY_SIZE)["agrees"]
    lines = "\n".join(references_section([entry], "rule"))
    assert "below 2" in lines and "0.5-1 m bin / 2-4 m bin" in lines


def test_a_ratio_reference_uses_the_ratios_statistical_and_systematic_errors():
    ratios = [{"numerator": "a", "denominator": "b", "quantity": "thickness", "mean": 2.0,
               "stat": 0.3, "syst": 0.4, "units": "dimensionless"},
              {"numerator": "a", "denominator": "b", "quantity": "filling_factor",
               "mean": 2.0, "stat": 0.3, "syst": None, "units": "dimensionless"}]
    ref = Reference("a/b", "thickness", 0.0, 1.0, None, "s", ratio=("a", "b"))
    entry = reference_entry(ref, {}, None, ratios)
    assert entry["stderr"] == pytest.approx(0.5) and entry["distance"] == pytest.approx(2.0)
    no_syst = Reference("a/b", "filling_factor", 0.0, 1.0, None, "s", ratio=("a", "b"))
    assert reference_entry(no_syst, {}, None, ratios)["stderr"] == 0.3


def test_references_of_one_quantity_may_be_a_list(tmp_path):
    text = STUDY.split("references:")[0] + (
        "references:\n  dense:\n    mean_epsilon:\n"
        "      - {low: 0.4, source: one}\n      - {value: 0.5, sigma: 0.1, source: two}\n")
    study = load_study(write(tmp_path / "list", text), quantities=tuple(QUANTITIES))
    assert [(r.source, r.low, r.high, r.sigma) for r in study.references] == [
        ("one", 0.4, math.inf, 0.0), ("two", 0.5, 0.5, 0.1)]
