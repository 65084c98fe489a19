"""`compare`'s size-resolved parts: the small- and large-particle layers and the law's eps
per pair of size bins, divided (layers) and subtracted (eps) between runs, and pooled over
replicas."""

from __future__ import annotations

import math

import pytest

from ringsim.analysis import compare


def _value(mean, stderr, units="m"):
    return {"mean": mean, "stderr": stderr, "units": units}


def _layers(small, large):
    return {"small": {"r_low": 0.05, "r_high": 0.25, "n": 100, "thickness": _value(*small)},
            "large": {"r_low": 1.0, "r_high": 5.0, "n": 10, "thickness": _value(*large)},
            "ratio": _value(small[0] / large[0], 0.01, "dimensionless"),
            "definition": "rms z"}


def _pairs(mean, counts):
    return {"status": "on", "edges": [0.05, 0.5, 5.0], "counts": counts,
            "mean_epsilon": mean, "layout": "row: smaller", "sample": "all",
            "units": {}}


def test_layer_ratios_carry_their_propagated_errors():
    a = {"vertical_segregation": _layers((6.0, 0.3), (3.0, 0.15))}
    b = {"vertical_segregation": _layers((4.0, 0.2), (3.0, 0.15))}
    r = compare.layer_ratios(a, b)
    assert r["small"]["mean"] == pytest.approx(1.5, rel=1e-15)
    # relative errors 5 % and 5 % in quadrature
    assert r["small"]["stderr"] == pytest.approx(1.5 * math.hypot(0.05, 0.05), rel=1e-12)
    assert r["large"]["mean"] == pytest.approx(1.0, rel=1e-15)
    assert compare.layer_ratios(a, {}) is None
    text = compare._layer_lines(r)[0]
    assert "H_small 1.5 ±" in text and "H_small / H_large 1.5 ±" in text


def test_the_eps_difference_is_per_pair_and_blank_where_either_run_sampled_none():
    a = {"pair_epsilon": _pairs([[0.5, 0.7], [math.nan, 0.9]], [[10, 5], [0, 2]])}
    b = {"pair_epsilon": _pairs([[0.6, math.nan], [math.nan, 0.8]], [[20, 0], [0, 4]])}
    d = compare.pair_epsilon_difference(a, b)
    assert d["difference"][0][0] == pytest.approx(-0.1, abs=1e-15)
    assert d["difference"][1][1] == pytest.approx(0.1, abs=1e-15)
    assert math.isnan(d["difference"][0][1]) and math.isnan(d["difference"][1][0])
    lines = compare._pair_difference_lines(d)
    assert lines[2].split()[1:] == ["-0.100", "-"]
    # other bins, or a run without the table: no difference
    other = {"pair_epsilon": {**_pairs([[0.5]], [[1]]), "edges": [0.05, 5.0]}}
    assert compare.pair_epsilon_difference(a, other) is None
    assert compare.pair_epsilon_difference(a, {"pair_epsilon": {"status": "off"}}) is None


def test_replicas_pool_their_sampled_collisions():
    a = {"pair_epsilon": _pairs([[0.5, 0.7], [math.nan, 0.9]], [[10, 5], [0, 2]])}
    b = {"pair_epsilon": _pairs([[0.8, math.nan], [math.nan, 0.6]], [[30, 0], [0, 2]])}
    pooled = compare._combined_pairs([a, b])
    assert pooled["counts"] == [[40, 5], [0, 4]]
    # (10 x 0.5 + 30 x 0.8) / 40
    assert pooled["mean_epsilon"][0][0] == pytest.approx(29.0 / 40.0, rel=1e-15)
    assert pooled["mean_epsilon"][0][1] == pytest.approx(0.7, rel=1e-15)
    assert pooled["mean_epsilon"][1][1] == pytest.approx(0.75, rel=1e-15)
    assert math.isnan(pooled["mean_epsilon"][1][0])
    layers = compare._combined_layers([{"vertical_segregation": _layers((6.0, 0.3), (3, 0.1))},
                                       {"vertical_segregation": _layers((4.0, 0.3), (3, 0.1))}])
    assert layers["small"]["thickness"]["mean"] == pytest.approx(5.0, rel=1e-15)
    # two seeds 2 m apart: the seed scatter (1 m) exceeds the propagated error
    assert layers["small"]["thickness"]["stderr"] == pytest.approx(1.0, rel=1e-12)
    assert compare._combined_layers([{"vertical_segregation": None}, {}]) is None


def test_replicas_of_one_snapshot_layers_take_their_error_from_the_scatter():
    # each replica's layer from one snapshot has no error (NaN); two replicas 2 m apart
    # have a seed-to-seed standard error of 1 m, one alone has none
    one = [{"vertical_segregation": _layers((6.0, math.nan), (3.0, math.nan))},
           {"vertical_segregation": _layers((4.0, math.nan), (3.4, math.nan))}]
    layers = compare._combined_layers(one)
    assert layers["small"]["thickness"]["stderr"] == pytest.approx(1.0, rel=1e-12)
    assert layers["large"]["thickness"]["stderr"] == pytest.approx(0.2, rel=1e-12)
    assert "the mean over 2 replicas" in layers["definition"]
    alone = compare._combined_layers(one[:1])
    assert math.isnan(alone["small"]["thickness"]["stderr"])
    ratios = compare.layer_ratios({"vertical_segregation": alone},
                                  {"vertical_segregation": _layers((4.0, 0.2), (3.0, 0.1))})
    assert "H_small 1.5 (one sample: no error)" in compare._layer_lines(ratios)[0]


def test_replicas_with_and_without_the_pair_table_have_none():
    a = {"pair_epsilon": _pairs([[0.5]], [[1]])}
    assert compare._combined_pairs([a, {"pair_epsilon": {"status": "off"}}])["status"] == "off"
