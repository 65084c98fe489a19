"""The seed-to-seed scatter of a study's ratio and the shift a variant gets by realisation
alone (``study.report.seed_scatter``, ``ratio_entry``'s ``seed_noise``)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ringsim.study.report import Runs, ratio_entry, seed_scatter


def _summary(c: float) -> dict:
    eq = {"velocity_dispersion": {"mean": c, "stderr": 0.01 * c, "units": "m/s"}}
    return {"equilibrium": eq, "in_equilibrium": True}


def _runs(values: dict[tuple[str, str | None, int], float]) -> Runs:
    specs = [SimpleNamespace(case=case, variant=variant, seed=seed)
             for case, variant, seed in values]
    ids = [f"{case}-{variant}-{seed}" for case, variant, seed in values]
    return Runs(specs, ids, {rid: _summary(v) for rid, v in zip(ids, values.values(),
                                                                strict=True)})


def test_seed_scatter_is_the_standard_deviation_of_each_seeds_ratio():
    num = {1: 5.2, 2: 5.0, 3: 5.3}
    den = {1: 1.0, 2: 1.1, 3: 0.9}
    values = {("a", None, s): v for s, v in num.items()}
    values.update({("b", None, s): v for s, v in den.items()})
    values.update({("a", "v", 1): 4.8, ("b", "v", 1): 1.0})
    runs = _runs(values)
    expected = float(np.std([num[s] / den[s] for s in (1, 2, 3)], ddof=1))
    assert seed_scatter(runs, "a", "b", "velocity_dispersion") == pytest.approx(expected,
                                                                                rel=1e-12)
    entry = ratio_entry(runs, ("a", "b"), "velocity_dispersion", ["v"], [1])
    assert entry["seed_scatter"] == pytest.approx(expected, rel=1e-12)
    part = entry["syst_parts"]["v"]
    # one variant seed: the difference of two single-seed ratios, sqrt(2) times the scatter
    assert part["seed_noise"] == pytest.approx(expected * math.sqrt(2.0), rel=1e-12)
    assert part["shift"] == pytest.approx(4.8 / 1.0 - 5.2 / 1.0, rel=1e-12)


def test_one_seed_has_no_scatter():
    runs = _runs({("a", None, 1): 2.0, ("b", None, 1): 1.0,
                  ("a", "v", 1): 2.1, ("b", "v", 1): 1.0})
    assert seed_scatter(runs, "a", "b", "velocity_dispersion") is None
    entry = ratio_entry(runs, ("a", "b"), "velocity_dispersion", ["v"], [1])
    assert entry["syst_parts"]["v"]["seed_noise"] is None


def test_the_paired_ratio_divides_out_what_a_realisation_gives_both_cases():
    """Each seed multiplies both cases by its own factor (its draw of the largest
    particles): the ratio of the seed means keeps that scatter, the seed-paired ratio is
    exact."""
    factor = {1: 0.9, 2: 1.0, 3: 1.15}
    values = {("a", None, s): 1.2 * f for s, f in factor.items()}
    values.update({("b", None, s): 1.0 * f for s, f in factor.items()})
    entry = ratio_entry(_runs(values), ("a", "b"), "velocity_dispersion", [], [1])
    paired = entry["paired"]
    assert paired["by_seed"] == {str(s): pytest.approx(1.2, rel=1e-14) for s in factor}
    assert paired["mean"] == pytest.approx(1.2, rel=1e-14)
    assert paired["stderr_seeds"] == pytest.approx(0.0, abs=1e-14)
    # what is left is each seed's window error: 1 % on each case, sqrt(2) % on a ratio
    assert paired["stderr"] == pytest.approx(1.2 * 0.01 * math.sqrt(2.0 / 3.0), rel=1e-12)
    assert entry["stat"] > 5 * paired["stderr"]   # the seed means keep the scatter


def test_the_paired_ratio_error_is_the_standard_error_of_the_seeds_ratios():
    num = {1: 5.2, 2: 5.0, 3: 5.3}
    den = {1: 1.0, 2: 1.1, 3: 0.9}
    values = {("a", None, s): v for s, v in num.items()}
    values.update({("b", None, s): v for s, v in den.items()})
    values[("a", None, 4)] = 7.0          # a seed the denominator did not run
    paired = ratio_entry(_runs(values), ("a", "b"), "velocity_dispersion", [], [1])["paired"]
    ratios = [num[s] / den[s] for s in (1, 2, 3)]
    assert set(paired["by_seed"]) == {"1", "2", "3"}
    assert paired["mean"] == pytest.approx(float(np.mean(ratios)), rel=1e-12)
    sem = float(np.std(ratios, ddof=1)) / math.sqrt(3)
    assert paired["stderr_seeds"] == pytest.approx(sem, rel=1e-12)
    assert paired["stderr"] == pytest.approx(sem, rel=1e-12)   # above the window errors
    assert paired["n_replicas"] == 3
    one = ratio_entry(_runs({("a", None, 1): 2.0, ("b", None, 1): 1.0}), ("a", "b"),
                      "velocity_dispersion", [], [1])
    assert one["paired"]["n_replicas"] == 1 and one["paired"]["by_seed"] == {"1": 2.0}
    assert one["paired"]["stderr"] == pytest.approx(one["stat"], rel=1e-12)


def test_a_ratio_of_cases_with_different_seeds_is_over_the_seeds_both_ran():
    """A case of one seed (the case key ``seeds``) against a case of three: the ratio of
    the seed means is taken over seed 1 alone, the realisation both ran, not that seed over
    the other case's mean of three draws; cases of the same seeds name none."""
    factor = {1: 0.8, 2: 1.0, 3: 1.2}
    values = {("b", None, s): 1.0 * f for s, f in factor.items()}
    values[("a", None, 1)] = 1.2 * factor[1]
    entry = ratio_entry(_runs(values), ("a", "b"), "velocity_dispersion", [], [1])
    assert entry["seeds"] == [1]
    assert entry["mean"] == pytest.approx(1.2, rel=1e-14)
    # seed 1's window errors alone: 1 % on each case
    assert entry["stat"] == pytest.approx(1.2 * 0.01 * math.sqrt(2.0), rel=1e-12)
    values[("a", None, 2)], values[("a", None, 3)] = 1.2, 1.2 * 1.2
    assert ratio_entry(_runs(values), ("a", "b"), "velocity_dispersion", [],
                       [1])["seeds"] is None


def test_the_report_says_which_ratios_are_over_the_seeds_both_cases_ran():
    """The line under the ratio table names the seeds of a ratio of cases that ran
    different seeds, and says so where they share none; ratios of the same seeds get no
    line."""
    from ringsim.study.markdown import ratios_section

    values = {("b", None, s): 1.0 for s in (1, 2, 3)}
    values.update({("a", None, 1): 1.2, ("c", None, 4): 0.9})
    runs = _runs(values)
    entries = [ratio_entry(runs, pair, "velocity_dispersion", [], [1])
               for pair in (("a", "b"), ("c", "b"))]
    assert [e["seeds"] for e in entries] == [[1], []]
    assert entries[1]["mean"] == pytest.approx(0.9, rel=1e-12)   # all seeds, as before
    report = {"ratios": entries, "quantities": ["velocity_dispersion"],
              "systematics": "none", "variant_seeds": [1]}
    text = "\n".join(ratios_section(report, None))
    assert "a / b: seeds [1]" in text
    assert "c / b: no seed in common, so of different realisations" in text
    report["ratios"] = [ratio_entry(_runs({("a", None, 1): 1.2, ("b", None, 1): 1.0}),
                                    ("a", "b"), "velocity_dispersion", [], [1])]
    assert "over the seeds both ran" not in "\n".join(ratios_section(report, None))
