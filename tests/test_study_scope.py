"""A study's case ``seeds`` and variant ``cases`` (``config.study_scope``): the runs they
ask for, the report they give, and bad values as bad input.

The study is tests/test_study.py's tiny sheet (200 particles, 0.3 orbit in line mode, a
few seconds a run)."""

import json
import os
import subprocess
import sys

import pytest

from ringsim.cli import main
from ringsim.config.study import load_study
from ringsim.study import run_study
from ringsim.study.runs import collect, run_id
from tests.test_study import SCENARIO, assert_refused, write_study

SCOPED = """\
name: tiny-scoped
base: tiny.yaml
seeds: [1, 2]
cases:
  k0: {}
  k01: {restitution.kappa: 0.1}
  k02: {restitution.kappa: 0.2, seeds: [1]}
ratios: [[k01, k0], [k02, k0]]
variants:
  ref_600g: {restitution.reference_mass: 0.6, cases: [k01, k02]}
length: {orbits: 0.6}
quick:
  sheet.n_particles: 200
  length: {orbits: 0.3}
"""


def test_case_seeds_and_variant_cases_plan_only_the_runs_that_differ(tmp_path):
    study = load_study(write_study(tmp_path, SCOPED))
    specs = study.specs(quick=True)
    labels = [spec.label for spec in specs]
    # seed by seed; k02 only with seed 1; the variant on every case of the ratios
    assert labels == ["k0 seed 1", "k01 seed 1", "k02 seed 1", "k0 seed 2", "k01 seed 2",
                      "k0 [ref_600g] seed 1", "k01 [ref_600g] seed 1",
                      "k02 [ref_600g] seed 1"]
    runs, ids = collect(specs)
    by_label = dict(zip(labels, ids, strict=True))
    # k0 keeps its own run in the variant; the variant changes k01's and k02's
    assert by_label["k0 [ref_600g] seed 1"] == by_label["k0 seed 1"]
    assert by_label["k01 [ref_600g] seed 1"] != by_label["k01 seed 1"]
    assert by_label["k02 [ref_600g] seed 1"] != by_label["k02 seed 1"]
    assert len(runs) == 7
    moved = next(s for s in specs if s.label == "k01 [ref_600g] seed 1").scenario
    assert moved.restitution.reference_mass == 0.6
    assert run_id(next(s for s in specs if s.label == "k0 [ref_600g] seed 1").scenario) \
        == by_label["k0 seed 1"]

#: SCOPED with its reference-mass variant a model parameter's range.
RANGED = SCOPED.replace("cases: [k01, k02]}", "cases: [k01, k02], budget: range}")
assert RANGED != SCOPED


@pytest.fixture(scope="module")
def scoped(tmp_path_factory):
    """The scoped study's quick form, run once: its folder."""
    folder = tmp_path_factory.mktemp("scoped")
    path = write_study(folder, SCOPED)
    run_study(path, quick=True, workers=2, echo=None, command="ringsim study x --quick")
    return folder


def test_scoped_study_report_holds_the_seeds_and_cases_it_ran(scoped):
    tmp_path = scoped
    report = json.loads((tmp_path / "study.quick.report" / "report.json").read_text())
    assert report["cases"]["k02"]["seeds"] == [1]
    assert "seeds" not in report["cases"]["k0"]
    assert [r["seed"] for r in report["cases"]["k02"]["runs"]] == [1]
    assert report["variants"]["ref_600g"]["cases"] == ["k01", "k02"]
    variant_k0 = report["variants"]["ref_600g"]["runs"]["k0"]
    assert [r["run"] for r in variant_k0] == [report["cases"]["k0"]["runs"][0]["run"]]
    k02 = next(e for e in report["ratios"]
               if e["numerator"] == "k02" and e["quantity"] == "velocity_dispersion")
    assert k02["seed_scatter"] is None   # one common seed: no seed-to-seed scatter
    text = (tmp_path / "study.quick.report" / "report.md").read_text()
    assert "(seeds [1] only)" in text and "changes the runs of `k01`, `k02` only" in text


def test_a_range_variant_is_given_beside_the_ratio_not_added_to_its_error(scoped):
    """``budget: range`` changes no run: from the same summaries the ratio with the variant
    is the one ``budget: systematic`` gives, shown beside the ratio (``range_parts``, the
    table) instead of in its systematic error, which without other variants is null.  A
    partial report without the variant's runs leaves the range out."""
    (scoped / "ranged.yaml").write_text(RANGED)
    run_study(scoped / "ranged.yaml", quick=True, report_only=True, echo=None,
              command="ringsim study x --quick --report-only")
    before = json.loads((scoped / "study.quick.report" / "report.json").read_text())
    after = json.loads((scoped / "ranged.quick.report" / "report.json").read_text())
    pick = {(e["numerator"], e["quantity"]): e for e in after["ratios"]}
    for old in before["ratios"]:
        new = pick[(old["numerator"], old["quantity"])]
        assert new["mean"] == old["mean"] and new["stat"] == old["stat"]
        assert old["syst"] is not None and new["syst"] is None and new["syst_parts"] == {}
        assert new["range_parts"] == old["syst_parts"]
    assert "budget is range" in after["systematics"]
    assert "budget is range" not in before["systematics"]
    c = pick[("k01", "velocity_dispersion")]["range_parts"]["ref_600g"]
    shown = f"{c['ratio_without']:.4g} → {c['ratio']:.4g} with ref_600g (range; seeds [1])"
    md = (scoped / "ranged.quick.report" / "report.md").read_text()
    assert shown in md and "| ref_600g (range) |" in md
    assert "with ref_600g (range" not in (scoped / "study.quick.report" / "report.md"
                                         ).read_text()
    moved = after["variants"]["ref_600g"]["runs"]["k01"][0]["run"]
    (scoped / "summaries" / f"{moved}.json").rename(scoped / f"{moved}.json")
    try:
        run_study(scoped / "ranged.yaml", quick=True, report_only=True, partial=True,
                  echo=None, command="ringsim study x --quick --report-only --partial")
    finally:
        (scoped / f"{moved}.json").rename(scoped / "summaries" / f"{moved}.json")
    part = json.loads((scoped / "ranged.quick.partial.report" / "report.json").read_text())
    assert "variants ref_600g" in part["partial"] and part["ratios"]
    assert all("range_parts" not in e for e in part["ratios"])
    assert "budget is range" not in part["systematics"]


BAD = [
    ("  k02: {restitution.kappa: 0.2, seeds: [3]}\n", "cases.k02.seeds", "3 is not allowed"),
    ("  k02: {restitution.kappa: 0.2, seeds: []}\n", "cases.k02.seeds", "got []"),
    ("  k02: {restitution.kappa: 0.2, seeds: [2]}\n", "cases.k02.seeds",
     "lacks the full form's variant seeds [1]"),
    ("  ref_600g: {restitution.reference_mass: 0.6, cases: [k9]}\n", "variants.ref_600g.cases",
     "'k9' is not a case of the ratios"),
    ("  ref_600g: {cases: [k01]}\n", "variants.ref_600g", "is empty"),
    ("  ref_600g: {restitution.reference_mass: 0.6, budget: model}\n",
     "variants.ref_600g.budget", "got 'model'"),
]


@pytest.mark.parametrize("line, key, words", BAD, ids=[b[1] + str(i) for i, b in
                                                     enumerate(BAD)])
def test_bad_case_seeds_and_variant_cases_are_bad_input(tmp_path, capsys, line, key, words):
    name = line.split(":")[0]
    text = "".join(line if row.startswith(name + ":") else row + "\n"
                   for row in SCOPED.splitlines())
    assert text != SCOPED + "\n"
    assert_refused(write_study(tmp_path, text, SCENARIO), capsys, key, words)


def test_partial_report_leaves_out_what_is_not_summarised_and_says_so(scoped, tmp_path,
                                                                     capsys):
    """``--report-only --partial``: with every summary it is the full report (in its own
    folder); without k02's and the variant's k01 summaries it holds k0 and k01, their
    ratio without the variant, and a note naming what is missing."""
    path = scoped / "study.yaml"
    whole = run_study(path, quick=True, report_only=True, partial=True, echo=None,
                      command="ringsim study x --quick")
    assert whole.out == scoped / "study.quick.partial.report"
    assert (whole.out / "report.json").read_bytes() == \
        (scoped / "study.quick.report" / "report.json").read_bytes()
    report = json.loads((scoped / "study.quick.report" / "report.json").read_text())
    gone = [report["cases"]["k02"]["runs"][0]["run"],
            report["variants"]["ref_600g"]["runs"]["k01"][0]["run"]]
    for rid in gone:
        (scoped / "summaries" / f"{rid}.json").rename(tmp_path / f"{rid}.json")
    try:
        assert main(["study", str(path), "--quick", "--report-only"]) == 2
        capsys.readouterr()
        out = tmp_path / "partial"
        run_study(path, out=out, quick=True, report_only=True, partial=True, echo=None,
                  command="ringsim study x --quick --report-only --partial")
    finally:
        for rid in gone:
            (tmp_path / f"{rid}.json").rename(scoped / "summaries" / f"{rid}.json")
    part = json.loads((out / "report.json").read_text())
    assert list(part["cases"]) == ["k0", "k01"]
    assert part["cases"]["k0"] == report["cases"]["k0"]
    assert [(e["numerator"], e["denominator"]) for e in part["ratios"]][:1] == [("k01", "k0")]
    assert part["variants"] == {}
    assert all(e["syst"] is None for e in part["ratios"])
    assert part["partial"].startswith("PARTIAL REPORT: 5 of 7 runs have summaries")
    assert "cases k02" in part["partial"] and "variants ref_600g" in part["partial"]
    assert f"**{part['partial']}**" in (out / "report.md").read_text()
    # the variant's summarised k02 run is named with its numbers; its base run is gone
    waiting = part["partial"].split("waiting for the ratios they measure: ")[1]
    k02 = report["variants"]["ref_600g"]["runs"]["k02"][0]["run"]
    c = json.loads((scoped / "summaries" / f"{k02}.json").read_text())["equilibrium"][
        "velocity_dispersion"]["mean"]
    assert waiting.startswith(f"ref_600g (k02 seed 1: c {1e3 * c:.4g} mm/s, H ")
    assert "without it" not in waiting


def test_partial_without_report_only_is_bad_input(scoped, capsys):
    assert main(["study", str(scoped / "study.yaml"), "--quick", "--partial"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--partial" in err[0] and "--report-only" in err[0]


def test_partial_report_keeps_a_case_with_some_of_its_seeds(scoped, tmp_path):
    """Without k01's seed-2 summary the partial report holds k01 from seed 1 alone and
    says so; its ratio to k0 is over the seed both have, seed 1's over k0's seed 1 (k0's
    seed 2 is another realisation, which would enter one side only)."""
    path = scoped / "study.yaml"
    report = json.loads((scoped / "study.quick.report" / "report.json").read_text())
    gone = next(r["run"] for r in report["cases"]["k01"]["runs"] if r["seed"] == 2)
    (scoped / "summaries" / f"{gone}.json").rename(tmp_path / f"{gone}.json")
    try:
        out = tmp_path / "partial"
        run_study(path, out=out, quick=True, report_only=True, partial=True, echo=None,
                  command="ringsim study x --quick --report-only --partial")
    finally:
        (tmp_path / f"{gone}.json").rename(scoped / "summaries" / f"{gone}.json")
    part = json.loads((out / "report.json").read_text())
    assert [r["seed"] for r in part["cases"]["k01"]["runs"]] == [1]
    assert part["cases"]["k01"]["seeds"] == [1]
    assert part["cases"]["k0"] == report["cases"]["k0"]
    assert "fewer seeds than asked: k01 (seeds [1] of [1, 2])" in part["partial"]
    one = part["cases"]["k01"]["runs"][0]["run"]
    summary = json.loads((scoped / "summaries" / f"{one}.json").read_text())
    c01 = summary["equilibrium"]["velocity_dispersion"]["mean"]
    k0_one = next(r["run"] for r in report["cases"]["k0"]["runs"] if r["seed"] == 1)
    c0 = json.loads((scoped / "summaries" / f"{k0_one}.json").read_text()
                    )["equilibrium"]["velocity_dispersion"]["mean"]
    ratio = next(e for e in part["ratios"] if e["numerator"] == "k01"
                 and e["quantity"] == "velocity_dispersion")
    assert ratio["seeds"] == [1]
    assert ratio["mean"] == pytest.approx(c01 / c0, rel=1e-12)
    assert list(part["variants"]) == ["ref_600g"]     # its seed-1 runs are all there


def test_partial_report_is_the_same_bits_whatever_the_hash_seed(scoped, tmp_path):
    """Without k0's and k01's seed-2 summaries the note names both in the study's order,
    and the report's bytes do not depend on the order of Python's sets (the hash seed of
    the process that writes it)."""
    report = json.loads((scoped / "study.quick.report" / "report.json").read_text())
    gone = [next(r["run"] for r in report["cases"][case]["runs"] if r["seed"] == 2)
            for case in ("k0", "k01")]
    for rid in gone:
        (scoped / "summaries" / f"{rid}.json").rename(tmp_path / f"{rid}.json")
    texts = []
    try:
        for hash_seed in ("1", "2", "3", "4"):
            out = tmp_path / f"partial{hash_seed}"
            code = ("from ringsim.cli import main; raise SystemExit(main(['study', "
                    f"{str(scoped / 'study.yaml')!r}, '--quick', '--report-only', "
                    f"'--partial', '--out', {str(out)!r}]))")
            subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                           env={**os.environ, "PYTHONHASHSEED": hash_seed})
            both = (out / "report.md").read_text() + (out / "report.json").read_text()
            texts.append(both.replace(str(out), "OUT"))     # the command line names it
    finally:
        for rid in gone:
            (tmp_path / f"{rid}.json").rename(scoped / "summaries" / f"{rid}.json")
    assert all(text == texts[0] for text in texts)
    note = json.loads((tmp_path / "partial1" / "report.json").read_text())["partial"]
    assert "fewer seeds than asked: k0 (seeds [1] of [1, 2]), k01 (seeds [1] of [1, 2])" \
        in note


LENGTHS = SCOPED.replace("  k02: {restitution.kappa: 0.2, seeds: [1]}\n",
                         "  k02: {restitution.kappa: 0.2, seeds: [1],\n"
                         "        length: {until_equilibrium: true, max_orbits: 0.9}}\n")


def test_a_case_length_replaces_the_studys_in_the_full_form_only(tmp_path):
    """A case's ``length`` sets its runs' length (its variants' runs too) in the full form;
    the other cases keep the study's; the quick form's length applies to every case; the
    full report's set-up names it."""
    study = load_study(write_study(tmp_path, LENGTHS))
    full = {spec.label: spec.scenario.integration for spec in study.specs(False)}
    assert (full["k02 seed 1"].orbits, full["k02 seed 1"].until_equilibrium) == (0.9, True)
    assert (full["k02 [ref_600g] seed 1"].orbits,
            full["k02 [ref_600g] seed 1"].until_equilibrium) == (0.9, True)
    for label in ("k0 seed 1", "k01 seed 2", "k01 [ref_600g] seed 1"):
        assert (full[label].orbits, full[label].until_equilibrium) == (0.6, False)
    quick = {spec.label: spec.scenario.integration for spec in study.specs(True)}
    assert {(q.orbits, q.until_equilibrium) for q in quick.values()} == {(0.3, False)}
    # the same runs as before for the cases without a length of their own
    plain = load_study(write_study(tmp_path / "plain", SCOPED))
    assert collect(plain.specs(True))[1] == collect(study.specs(True))[1]
    assert collect(plain.specs(False))[1][:2] == collect(study.specs(False))[1][:2]
    assert collect(plain.specs(False))[1][2] != collect(study.specs(False))[1][2]


def test_a_bad_case_length_is_bad_input(tmp_path, capsys):
    text = LENGTHS.replace("length: {until_equilibrium: true, max_orbits: 0.9}",
                           "length: {until_equilibrium: true, orbits: 0.9}")
    assert_refused(write_study(tmp_path, text, SCENARIO), capsys, "cases.k02.length.orbits",
                   "not with until_equilibrium: true")


def test_only_runs_the_runs_asked_and_writes_no_report(tmp_path, capsys):
    """``--only k02 'k01 seed 2'``: k02's one run and k01's seed-2 run get summaries, no
    other run is made and no report is written; the summaries are those of the whole
    study's runs (the same ids)."""
    path = write_study(tmp_path, SCOPED)
    study = load_study(path)
    specs = study.specs(quick=True)
    _, ids = collect(specs)
    by_label = dict(zip([s.label for s in specs], ids, strict=True))
    assert main(["study", str(path), "--quick", "--workers", "1", "--only", "k02",
                 "k01 seed 2"]) == 0
    made = sorted(p.stem for p in (tmp_path / "summaries").glob("*.json"))
    assert made == sorted({by_label["k02 seed 1"], by_label["k01 seed 2"],
                           by_label["k02 [ref_600g] seed 1"]})
    assert not (tmp_path / "study.quick.report" / "report.json").exists()
    assert "--only" in capsys.readouterr().out


@pytest.mark.parametrize("args, words", [
    (["--only", "k9"], "'k9' is neither a case nor a run's label"),
    (["--only", "k0", "--report-only"], "given with --report-only")])
def test_only_with_an_unknown_run_or_with_report_only_is_bad_input(tmp_path, capsys, args,
                                                                   words):
    path = write_study(tmp_path, SCOPED)
    assert main(["study", str(path), "--quick", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]
    assert not (tmp_path / "summaries").exists() or not any((tmp_path / "summaries").iterdir())
