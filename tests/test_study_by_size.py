"""The study's numbers by particle size: the summaries of runs of a size distribution keep
each size bin's c and H, the thickness under each weighting and the law-range shares; the
report divides them bin by bin between the cases of a ratio and says whether each ring is as
thin as Saturn's.  Uses the tiny two-case study of tests/test_study.py (0.5-5 m, q = 3)."""

import json
import math

import pytest
from test_study import reference  # noqa: F401  (the module's fixture)

from ringsim.analysis import budget
from ringsim.study.by_size import (
    FULL_PER_RMS,
    SATURN_FULL_THICKNESS,
    by_size_lines,
    by_size_report,
    case_by_size,
)


def _summaries(folder):
    return [json.loads(p.read_text()) for p in sorted((folder / "summaries").glob("*.json"))]


def _case(report, case):
    return [json.loads((report["folder"] / "summaries" / f"{r['run']}.json").read_text())
            for r in json.loads(report["json"])["cases"][case]["runs"]]


def test_a_size_distribution_run_keeps_its_size_bins_and_weightings(reference):  # noqa: F811
    for summary in _summaries(reference["folder"]):
        sizes = summary["by_size"]
        bins = sizes["bins"]
        assert len(bins) >= 2 and bins[0]["r_low"] == pytest.approx(0.5, rel=0.05)
        assert bins[-1]["r_high"] == pytest.approx(5.0, rel=0.05)
        assert all(a["r_high"] == b["r_low"] for a, b in zip(bins[:-1], bins[1:], strict=True))
        assert sum(b["n"] for b in bins) == summary["n_particles"]
        assert bins[0]["thickness"]["units"] == "m"
        assert set(sizes["thickness"]) == {"number", "mass", "optical_depth"}
        assert sizes["thickness"]["number"]["mean"] == summary["equilibrium"]["thickness"]["mean"]
        # every pair of 0.5-5 m ice spheres is heavier than Dilley's 60 g reference
        assert sizes["law_range"]["masses_below"] == 0.0
        assert sizes["law_range"]["sizes_above"] == pytest.approx(1.0)


def test_report_divides_c_and_h_bin_by_bin(reference):  # noqa: F811
    section = json.loads(reference["json"])["by_size"]
    (ratio,) = section["ratios"]
    assert (ratio["numerator"], ratio["denominator"]) == ("k01", "k0")
    k01, k0 = _case(reference, "k01"), _case(reference, "k0")
    for k, entry in enumerate(ratio["bins"]):
        for q in ("velocity_dispersion", "thickness"):
            # seeds whose bin is empty in the window (null) are left out of the bin's mean
            a = budget.replica_mean([v for s in k01 if (v := s["by_size"]["bins"][k][q])
                                     and v["mean"] is not None])
            b = budget.replica_mean([v for s in k0 if (v := s["by_size"]["bins"][k][q])
                                     and v["mean"] is not None])
            assert entry[q]["mean"] == pytest.approx(a["mean"] / b["mean"], rel=1e-12)
            rel = math.hypot(a["stderr"] / a["mean"], b["stderr"] / b["mean"])
            assert entry[q]["stat"] == pytest.approx(entry[q]["mean"] * rel, rel=1e-12)
    for case in ("k0", "k01"):
        e = section["cases"][case]
        full = FULL_PER_RMS * e["thickness"]["optical_depth"]["mean"]
        assert e["full_thickness_optical_depth"]["mean"] == pytest.approx(full)
        assert e["as_thin_as_saturn"] == (full <= SATURN_FULL_THICKNESS)
    md = reference["md"]
    assert "## By size" in md and "Ratio k01 / k0 in each size bin" in md
    assert "as thin as Saturn's" in md


def test_cases_without_sizes_or_with_other_bins_give_no_ratio(reference):  # noqa: F811
    k01, k0 = _case(reference, "k01"), _case(reference, "k0")
    assert case_by_size([{"equilibrium": {}}]) is None
    old = [{k: v for k, v in s.items() if k != "by_size"} for s in k0]
    assert by_size_report({"k01": k01, "k0": old}, [["k01", "k0"]])["ratios"] == []
    shifted = json.loads(json.dumps(k0))
    for s in shifted:
        s["by_size"]["bins"][0]["r_high"] *= 1.01
    assert by_size_report({"k01": k01, "k0": shifted}, [["k01", "k0"]])["ratios"] == []
    assert by_size_lines({}) == []
