"""What a study's summaries keep when the study asks (``keep``, ``ringsim.study.kept``):
the energy budget and the aggregation of a run, their seed means per case, references on
them, and summaries of studies that keep nothing unchanged."""

from __future__ import annotations

import json
import math

import pytest
import yaml

from ringsim.config.schema import ScenarioError, Section
from ringsim.config.study_references import KEPT_QUANTITIES, read_keep, read_references
from ringsim.study.command import run_study
from ringsim.study.kept import case_kept, kept_summary, lacks_kept
from ringsim.study.references import reference_entry


def value(mean: float, stderr: float, units: str = "W/m^2") -> dict:
    return {"mean": mean, "stderr": stderr, "units": units}


def equilibrium(ratio: float, bound: float = 0.0) -> dict:
    """An equilibrium with an energy budget of heating/dissipation ``ratio`` and an
    aggregation with ``bound`` of the mass in Hill groups at most, half that on average
    (the verdict's mean)."""
    budget = {key: value(1.0, 0.1) for key in KEPT_QUANTITIES["energy_budget"]}
    budget["ratio"] = value(ratio, 0.01, "dimensionless")
    aggregation = {"rows": 20, "overlap_rows": 1, "max_overlapping_pairs": 2,
                   "multi_encounter_share": 0.01, "bound_fraction_mean": 0.5 * bound,
                   "bound_fraction_max": bound,
                   "bound_fraction_last": bound, "contact_fraction_last": 0.5 * bound,
                   "aggregating": 0.5 * bound >= 0.1, "snapshots": [{}],
                   "units": {"rows": "count", "bound_fraction_max": "fraction of the mass"}}
    return {"energy_budget": budget, "aggregation": aggregation}


def test_a_summary_keeps_only_what_is_named():
    eq = equilibrium(0.99, bound=0.3)
    assert kept_summary(eq, ()) == {}
    kept = kept_summary(eq, ("energy_budget",))
    assert set(kept) == {"energy_budget"}
    assert kept["energy_budget"]["ratio"] == value(0.99, 0.01, "dimensionless")
    agg = kept_summary(eq, ("aggregation",))["aggregation"]
    assert agg["bound_fraction_max"] == {"mean": 0.3, "stderr": 0.0,
                                         "units": "fraction of the mass"}
    assert agg["aggregating"] is True and "snapshots" not in agg
    assert kept_summary({"energy_budget": None}, ("energy_budget",)) == {"energy_budget": None}


def test_a_summary_lacking_a_key_of_a_kept_entry_is_remade():
    """A summary kept by an older ringsim, whose aggregation lacks a key of today's (the
    verdict's window mean), is remade; a null energy budget (a run without the dissipation)
    lacks nothing."""
    kept = kept_summary(equilibrium(1.0, bound=0.3), ("energy_budget", "aggregation"))
    assert not lacks_kept(kept, ("energy_budget", "aggregation"))
    older = {**kept, "aggregation": {key: entry for key, entry in kept["aggregation"].items()
                                     if key != "bound_fraction_mean"}}
    assert lacks_kept(older, ("aggregation",))
    assert not lacks_kept(older, ("energy_budget",))
    assert not lacks_kept({"energy_budget": None}, ("energy_budget",))
    assert lacks_kept({}, ("energy_budget",))
    case = case_kept([kept, older], ("aggregation",))["aggregation"]
    assert "bound_fraction_mean" not in case
    assert case["bound_fraction_max"]["mean"] == pytest.approx(0.3)


def test_a_case_holds_seed_means_only_of_entries_every_run_has():
    """Ratios 0.98 and 1.02 (stderr 0.01 each): mean 1.00, error the seed-to-seed standard
    error of the mean, 0.02; a run without the budget (null) drops it from the case."""
    runs = [kept_summary(equilibrium(r, b), ("energy_budget", "aggregation"))
            for r, b in ((0.98, 0.0), (1.02, 0.2))]
    case = case_kept(runs, ("energy_budget", "aggregation"))
    assert case["energy_budget"]["ratio"]["mean"] == pytest.approx(1.0)
    assert case["energy_budget"]["ratio"]["stderr"] == pytest.approx(0.02)
    assert case["aggregation"]["bound_fraction_max"]["mean"] == pytest.approx(0.1)
    assert case["aggregation"]["aggregating_runs"] == 1
    assert "energy_budget" not in case_kept([*runs, {"energy_budget": None}],
                                            ("energy_budget",))


def test_a_reference_on_a_kept_quantity_reads_the_case_and_keep_is_checked():
    top = Section("<test>", "", {"references": {"c": {"energy_budget.ratio": {
        "value": 1.0, "tolerance": 0.01, "source": "energy conservation"}}}})
    (ref,) = read_references(top, ["c"], quantities=["velocity_dispersion"])
    good = {"kept": case_kept([kept_summary(equilibrium(1.015), ("energy_budget",))],
                              ("energy_budget",))}
    bad = {"kept": case_kept([kept_summary(equilibrium(1.10), ("energy_budget",))],
                             ("energy_budget",))}
    assert reference_entry(ref, {"c": good})["agrees"]
    assert not reference_entry(ref, {"c": bad})["agrees"]
    assert math.isnan(reference_entry(ref, {"c": {"equilibrium": {}}})["mean"])
    assert read_keep(Section("<test>", "", {"keep": ["aggregation"]})) == ("aggregation",)
    assert read_keep(Section("<test>", "", {})) == ()
    for wrong in (["energy_budgt"], "aggregation", ["aggregation", "aggregation"]):
        with pytest.raises(ScenarioError, match="keep"):
            read_keep(Section("<test>", "", {"keep": wrong}))


STUDY = """\
name: kept
base: ring.yaml
seeds: [1]
cases:
  c: {{}}
{keep}"""


def test_a_study_keeps_the_budget_only_when_asked(tmp_path, scenario_dict):
    """The same tiny run summarised by a study without ``keep`` and by one with it: the
    first summary holds no energy budget, the second the same summary with it (the run
    file is reused and the summary completed from it)."""
    (tmp_path / "ring.yaml").write_text(yaml.safe_dump(scenario_dict(
        "ring", {"integration.orbits": 0.1, "output.snapshot_every": 0.1})))
    study = tmp_path / "kept.yaml"
    study.write_text(STUDY.format(keep=""))
    run_study(study, workers=1, echo=None)
    (summary,) = (tmp_path / "summaries").glob("*.json")
    plain = json.loads(summary.read_text())
    assert "energy_budget" not in plain and "aggregation" not in plain
    study.write_text(STUDY.format(keep="keep: [energy_budget]\n"))
    run_study(study, workers=1, echo=None)
    kept = json.loads(summary.read_text())
    budget = kept.pop("energy_budget")
    assert kept == plain
    assert budget["ratio"]["units"] == "dimensionless" and budget["heating"]["mean"] > 0
    report = json.loads((tmp_path / "kept.report" / "report.json").read_text())
    assert report["cases"]["c"]["kept"]["energy_budget"]["ratio"]["mean"] == \
        pytest.approx(budget["ratio"]["mean"])
