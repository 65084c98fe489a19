"""The validation ladder's case 5 (validation/) at a small size.

The test runs REBOUND's shearing-sheet example with fewer particles and orbits than the
documented run (docs/validation.md, "Reference cases") and asserts the agreement the report
states, so a change that breaks the physics fails here: every statistic of ringsim's
resolver within 3 combined standard errors of REBOUND's built-in resolver from the same
seed; the two sheets equal to 1e-6 m after one step.

Cases 1 to 4 are study files (``studies/validation-constant-eps``,
``studies/validation-threshold``, ``studies/validation-bridges``,
``studies/validation-size-distribution``), tested in tests/test_study_references.py and
tests/test_validation_studies.py; case 6 (Dilley 1993 Figs. 1 and 5) is
tests/test_dilley_figures.py.

The case test is marked slow (about a minute): ``pytest -m slow tests/test_validation.py``.
A fast test checks the renderer of docs/validation.md: case results survive their JSON
round trip with the same Markdown.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from validation.case5_rebound_example import case5
from validation.common import QUICK, CaseResult, Comparison, load_results, save_result
from validation.render import section_markdown


def small(**changes):
    return dataclasses.replace(QUICK, **changes)


@pytest.mark.slow
def test_case5_ringsim_matches_rebound_builtin_resolver(tmp_path):
    sizes = small()
    result = case5(sizes, tmp_path, tmp_path / "fig")
    assert result.extra["lockstep_first_step_m"] < 1e-6, "same physics in the first step"
    assert not result.extra["guard_events"], "the ringsim run kept REBOUND's box"
    for c in result.comparisons:
        assert math.isfinite(c.sigma) and abs(c.sigma) <= 3.0, \
            f"{c.quantity}: ringsim {c.ringsim} vs REBOUND {c.ref_value} ({c.sigma:+.1f} sigma)"


def test_case_results_round_trip_through_json_to_the_same_markdown(tmp_path):
    rows = [Comparison("c/(rΩ), τ = 0.5", 1.716, 0.011, reference="a few: 1–5", source="s",
                       kind="range", ref_low=1.0, ref_high=5.0),
            Comparison("ratio", 2.4, 0.1, reference="6.3", source="equipartition",
                       ref_value=6.3, expected="disagree"),
            Comparison("ε_cr", 0.648, 0.004, reference="0.63", source="GT78",
                       ref_value=0.63, ref_err=0.005)]
    result = CaseResult(2, "title", "setup", rows, "discussion", figure="f.png",
                        cpu_seconds=12.0, sizes="quick", extra={"x": np.float64(1.5)})
    save_result(result, tmp_path)
    loaded = load_results(tmp_path)
    assert list(loaded) == [2]
    assert section_markdown(loaded, "fig") == section_markdown({2: result}, "fig")
    assert [c.sigma for c in loaded[2].comparisons] == [
        0.0, pytest.approx(-39.0), pytest.approx(18 / math.hypot(4, 5))]
    assert [c.as_expected for c in loaded[2].comparisons] == [True, True, True]
    assert loaded[2].passed
    assert "| ε_cr | 0.6480 ± 0.0040 | 0.63 | GT78 | +2.8σ | agrees |" in \
        section_markdown(loaded, "fig")
