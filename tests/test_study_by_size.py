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
from ringsim.study.variant_sizes import variant_by_size, variant_by_size_lines


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
        # so no impact lies inside all three measured ranges at once
        assert sizes["law_range"]["inside_all"] == 0.0


def test_the_joint_count_is_the_mean_over_the_seeds_that_counted_it():
    shares = {"speeds_below": 0.1, "inside_all": 0.4}
    with_it = _with_law_range(shares)
    other = _with_law_range({"speeds_below": 0.1, "inside_all": 0.5})
    without = _with_law_range({"speeds_below": 0.3})
    both = case_by_size([with_it, other])["law_range"]
    assert both["inside_all"] == pytest.approx(0.45) and both["speeds_below"] == 0.1
    assert (both["inside_all_seeds"], both["seeds"]) == (2, 2)
    # a summary made before the count: left out of that share only, and said so
    mixed = case_by_size([with_it, without])["law_range"]
    assert mixed["inside_all"] == pytest.approx(0.4) and mixed["speeds_below"] == pytest.approx(0.2)
    assert (mixed["inside_all_seeds"], mixed["seeds"]) == (1, 2)
    none = case_by_size([without, without])["law_range"]
    assert math.isnan(none["inside_all"]) and none["inside_all_seeds"] == 0
    lines = by_size_lines(by_size_report({"a": [with_it, other], "b": [with_it, without],
                                          "c": [without]}, []))
    assert any(line.startswith("| a |") and line.endswith("| 45.0 % |") for line in lines)
    assert any(line.startswith("| b |") and line.endswith("| 40.0 % (1 of 2 seeds) |")
               for line in lines)
    assert any(line.startswith("| c |") and line.endswith("| – |") for line in lines)


def _with_law_range(shares):
    summary = _constructed([[0.5, 0.5], [0.5, 0.5]], [[10, 10], [0, 10]])
    summary["by_size"]["law_range"] = shares
    return summary


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


def _constructed(eps, counts):
    """A summary's by_size of two size bins with the given pair eps and counts."""
    value = {"mean": 1.0, "stderr": 0.1, "units": "m"}
    return {"by_size": {
        "bins": [{"r_low": 0.025, "r_high": 0.1, "n": 90, "mean_mass": 0.01,
                  "velocity_dispersion": value, "thickness": value},
                 {"r_low": 0.1, "r_high": 1.0, "n": 10, "mean_mass": 1.0,
                  "velocity_dispersion": value, "thickness": value}],
        "thickness": {w: value for w in ("number", "mass", "optical_depth")},
        "layers": {"small": {"r_low": 0.025, "r_high": 0.1, "thickness": value},
                   "large": {"r_low": 0.3, "r_high": 1.0, "thickness": value}},
        "law_range": None, "law_masses": None,
        "pair_epsilon": {"mean": eps, "counts": counts}}}


def test_pair_eps_is_pooled_by_collisions_and_divided_where_both_sampled_enough():
    # seed 1: 0.5 over 100 collisions, seed 2: 0.8 over 300 -> (50 + 240) / 400 = 0.725
    k0 = [_constructed([[0.5, 0.6], [None, 0.9]], [[100, 30], [0, 40]]),
          _constructed([[0.8, 0.6], [None, 0.9]], [[300, 30], [0, 40]])]
    k01 = [_constructed([[0.29, 0.66], [None, 0.99]], [[200, 10], [0, 40]])]
    pooled = case_by_size(k0)["pair_epsilon"]
    assert pooled["mean"][0][0] == pytest.approx(0.725, rel=1e-12)
    assert pooled["counts"] == [[400, 60], [0, 80]]
    assert math.isnan(pooled["mean"][1][0])
    (ratio,) = by_size_report({"k01": k01, "k0": k0}, [["k01", "k0"]])["ratios"]
    table = ratio["pair_epsilon"]
    assert table[0][0] == pytest.approx(0.29 / 0.725, rel=1e-12)
    assert math.isnan(table[0][1]), "10 sampled collisions are too few"
    assert math.isnan(table[1][0]) and table[1][1] == pytest.approx(1.1, rel=1e-12)
    text = "\n".join(by_size_lines(by_size_report({"k01": k01, "k0": k0},
                                                  [["k01", "k0"]])))
    assert "| 0.025–0.1 | 0.400 | – |" in text


def _bins_of(c_small: float, c_large: float) -> dict:
    """A summary whose two size bins have the given c (and H = c, in other units)."""
    summary = _constructed([[0.5, 0.6], [None, 0.9]], [[100, 30], [0, 40]])
    for b, c in zip(summary["by_size"]["bins"], (c_small, c_large), strict=True):
        b["velocity_dispersion"] = b["thickness"] = {"mean": c, "stderr": 0.001 * c,
                                                     "units": "m"}
    return summary


def test_the_bins_seed_paired_ratio_divides_out_each_seeds_draw():
    """Each seed scales both cases' bins by its own factor: the ratio of the seed means
    keeps the scatter, the seed-paired ratio of each bin is exact."""
    factor = {1: 0.9, 2: 1.0, 3: 1.15}
    k0 = [_bins_of(2.0 * f, 1.0 * f) for f in factor.values()]
    k01 = [_bins_of(2.4 * f, 0.9 * f) for f in factor.values()]
    seeds = {"k01": list(factor), "k0": list(factor)}
    (ratio,) = by_size_report({"k01": k01, "k0": k0}, [["k01", "k0"]], seeds)["ratios"]
    small, large = ratio["bins"]
    for b, expected in ((small, 1.2), (large, 0.9)):
        for q in ("velocity_dispersion", "thickness"):
            assert b["paired"][q]["mean"] == pytest.approx(expected, rel=1e-14)
            assert b["paired"][q]["stderr_seeds"] == pytest.approx(0.0, abs=1e-14)
            # left: the window errors, 0.1 % per case: sqrt(2/3) 0.1 % on the mean ratio
            assert b["paired"][q]["stderr"] == pytest.approx(
                expected * 0.001 * math.sqrt(2.0 / 3.0), rel=1e-12)
            assert b["paired"][q]["n_replicas"] == 3
            assert b[q]["stat"] > 0.05 * expected    # the realisations' scatter
    text = "\n".join(by_size_lines(by_size_report({"k01": k01, "k0": k0},
                                                  [["k01", "k0"]], seeds)))
    assert "c ratio, seed-paired" in text and "| 1.2 ± 0.00098 | 1.2 ± 0.00098 |" in text
    # a seed only the numerator ran is not paired; without seeds there is no paired ratio
    seeds_off = {"k01": [1, 2, 4], "k0": [1, 2, 3]}
    (ratio,) = by_size_report({"k01": k01, "k0": k0}, [["k01", "k0"]], seeds_off)["ratios"]
    assert ratio["bins"][0]["paired"]["velocity_dispersion"]["n_replicas"] == 2
    (plain,) = by_size_report({"k01": k01, "k0": k0}, [["k01", "k0"]])["ratios"]
    assert "paired" not in plain["bins"][0]


def test_the_bins_ratio_of_cases_with_different_seeds_is_over_the_seeds_both_ran():
    """A numerator of one seed against three: each bin's ratio is of seed 1's runs alone
    (exact here, each seed scaling both cases alike), not of seed 1 over the mean of three
    draws, and the section says over which seeds."""
    factor = {1: 0.9, 2: 1.0, 3: 1.15}
    k0 = [_bins_of(2.0 * f, 1.0 * f) for f in factor.values()]
    k01 = [_bins_of(2.4 * factor[1], 0.9 * factor[1])]
    seeds = {"k01": [1], "k0": list(factor)}
    report = by_size_report({"k01": k01, "k0": k0}, [["k01", "k0"]], seeds)
    (ratio,) = report["ratios"]
    assert ratio["seeds"] == [1]
    small, large = ratio["bins"]
    assert small["velocity_dispersion"]["mean"] == pytest.approx(1.2, rel=1e-14)
    assert large["thickness"]["mean"] == pytest.approx(0.9, rel=1e-14)
    assert "over the seeds both cases ran, [1]" in "\n".join(by_size_lines(report))


def test_each_bins_share_of_the_mass_is_its_count_times_its_mean_mass():
    """Two bins: 90 particles of 10 g and 10 of 1 kg hold 0.9 and 10 kg."""
    one = _constructed([[0.5, 0.6], [None, 0.9]], [[100, 30], [0, 40]])
    other = _constructed([[0.5, 0.6], [None, 0.9]], [[100, 30], [0, 40]])
    other["by_size"]["bins"][1]["n"] = 12       # another seed draws two more large ones
    small, large = case_by_size([one, other])["bins"]
    assert large["n"] == 11.0 and small["n"] == 90.0
    shares = [(0.9 / 10.9, 0.9 / 12.9), (10 / 10.9, 12 / 12.9)]
    for b, (a, c) in zip((small, large), shares, strict=True):
        assert b["mass_share"]["mean"] == pytest.approx((a + c) / 2, rel=1e-12)
        assert b["mass_share"]["stderr"] == pytest.approx(abs(a - c) / 2, rel=1e-12)
    assert small["mass_share"]["mean"] + large["mass_share"]["mean"] == pytest.approx(1.0)
    text = "\n".join(by_size_lines(by_size_report({"a": [one, other]}, [])))
    assert "| a | 90 (7.62 ± 0.64 %) | 11 (92.4 ± 0.64 %) |" in text


def _weighted(summary: dict, by_mass: float, large: float) -> dict:
    """``summary`` with H by mass and the large layer's H set (errors 0.1 %)."""
    sizes = summary["by_size"]
    sizes["thickness"] = {**sizes["thickness"], "mass": {"mean": by_mass, "stderr": 1e-3 * by_mass,
                                                         "units": "m"}}
    sizes["layers"]["large"]["thickness"] = {"mean": large, "stderr": 1e-3 * large, "units": "m"}
    return summary


def test_a_variant_by_size_gives_each_weighting_and_bin_with_and_without_it():
    """A variant that halves the numerator's small bin (the particles that hold the number)
    and leaves its large bin, H by mass and the large layer: the ratio with it halves by
    number and in the small bin only; a ratio whose cases have other bins is left out."""
    k0 = [_weighted(_bins_of(2.0, 1.0), 3.0, 1.5)]
    k01 = [_weighted(_bins_of(2.4, 0.9), 3.6, 1.2)]
    k01_moved = [_weighted(_bins_of(1.2, 0.9), 3.6, 1.2)]
    (entry,) = variant_by_size({"ref": {"k01": k01_moved, "k0": k0}}, {"k01": k01, "k0": k0},
                               [["k01", "k0"]], [1])
    assert (entry["variant"], entry["numerator"], entry["seeds"]) == ("ref", "k01", [1])
    ratio = {key: [b["velocity_dispersion"]["mean"] for b in entry[key]["bins"]]
             for key in ("with", "without")}
    assert ratio["without"] == pytest.approx([1.2, 0.9], rel=1e-14)
    assert ratio["with"] == pytest.approx([0.6, 0.9], rel=1e-14)
    for key in ("with", "without"):
        assert entry[key]["thickness"]["mass"]["mean"] == pytest.approx(1.2, rel=1e-14)
        assert entry[key]["layers"]["large"]["mean"] == pytest.approx(0.8, rel=1e-14)
    text = "\n".join(variant_by_size_lines([entry]))
    assert "k01 / k0 with and without ref (seeds [1]):" in text
    assert "| c of 0.025–0.1 m | 1.2 ± 0.0017 | 0.6 ± 0.00085 |" in text
    assert "| H by mass | 1.2 ± 0.0017 | 1.2 ± 0.0017 |" in text
    other = _bins_of(2.0, 1.0)
    other["by_size"]["bins"][1]["r_high"] = 2.0
    assert variant_by_size({"ref": {"k01": k01_moved, "k0": [other]}},
                           {"k01": k01, "k0": k0}, [["k01", "k0"]], [1]) == []
    assert variant_by_size_lines([]) == []


def test_a_variant_that_changes_neither_case_of_a_ratio_has_no_table():
    """A variant whose ``cases`` are outside a ratio leaves both its runs as they were: no
    table of identical columns."""
    k0, k01 = [_bins_of(2.0, 1.0)], [_bins_of(2.4, 0.9)]
    runs = {"k01": k01, "k0": k0, "k02": [_bins_of(3.0, 1.0)]}
    ratios = [["k01", "k0"], ["k02", "k0"]]
    entries = variant_by_size({"ref": runs}, runs, ratios, [1], {"ref": ["k02"]})
    assert [(e["numerator"], e["denominator"]) for e in entries] == [("k02", "k0")]
    assert len(variant_by_size({"ref": runs}, runs, ratios, [1])) == 2
