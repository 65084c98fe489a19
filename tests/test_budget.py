"""Error budget of equilibrium ratios: replicas, systematics, warnings, units, size ratios."""

import json
import math

import pytest

from ringsim.analysis import budget
from ringsim.analysis.compare import comparison, comparison_table
from ringsim.analysis.equilibrium import TABLE_ROWS, size_dispersion_ratio
from ringsim.cli import main
from ringsim.errors import InputError


def _eq(name, seed, c, err=0.01, kappa=0.0, in_eq=True):
    """A synthetic equilibrium: every table quantity = c +- err."""
    eq = {"name": name, "in_equilibrium": in_eq, "reason": "stationary" if in_eq else
          "too short", "scenario": {"name": name, "seed": seed, "restitution":
                                    {"model": "dilley", "kappa": kappa},
                                    "output": {"path": f"runs/{name}.h5"}}}
    for key in TABLE_ROWS:
        eq[key] = {"mean": c, "stderr": err, "units": "m/s"}
    return eq


def test_replicas_are_combined_with_the_larger_of_propagated_and_seed_scatter():
    eqs = [_eq("a1", 1, 1.00), _eq("a2", 2, 1.10), _eq("a3", 3, 0.90),
           _eq("b1", 1, 2.0, kappa=0.1), _eq("b2", 2, 2.0, kappa=0.1)]
    comp = comparison(eqs)
    assert [r["name"] for r in comp["runs"]] == ["a1+a2+a3", "b1+b2"]
    a = comp["runs"][0]["velocity_dispersion"]
    assert a["mean"] == pytest.approx(1.0, rel=1e-12)
    # seed scatter: std(1.0, 1.1, 0.9, ddof=1) / sqrt(3) = 0.1 / sqrt(3) > 0.01 / sqrt(3)
    assert a["stderr"] == pytest.approx(0.1 / math.sqrt(3), rel=1e-12)
    b = comp["runs"][1]["velocity_dispersion"]
    assert b["stderr"] == pytest.approx(math.sqrt(2) * 0.01 / 2, rel=1e-12), \
        "identical replicas: the propagated error remains"
    r = comp["ratios"][0]["velocity_dispersion"]
    assert r["mean"] == pytest.approx(2.0, rel=1e-12)
    assert r["statistical"] == r["stderr"]
    assert math.isnan(r["systematic"]), "no budget: the systematic part is not invented"


def test_systematic_budget_adds_in_quadrature(tmp_path):
    path = tmp_path / "budget.json"
    path.write_text(json.dumps({"description": "test", "relative": {
        "velocity_dispersion": {"collision_detection": 0.03, "dt": 0.04}}}))
    comp = comparison([_eq("a", 1, 1.0), _eq("b", 1, 3.0, kappa=0.1)],
                      budget.load_budget(path))
    r = comp["ratios"][0]["velocity_dispersion"]
    assert r["systematic"] == pytest.approx(3.0 * 0.05, rel=1e-12)
    assert r["total"] == pytest.approx(math.hypot(r["statistical"], 0.15), rel=1e-12)
    assert math.isnan(comp["ratios"][0]["thickness"]["systematic"])
    assert "(syst)" in comparison_table(comp)


@pytest.mark.parametrize("content, key", [
    ("not json", "--systematics"),
    ('{"relative": {"velocity_dispersion": {"moon_phase": 0.1}}}',
     "relative.velocity_dispersion.moon_phase"),
    ('{"relative": {"velocity_dispersion": {"dt": -0.1}}}', "relative.velocity_dispersion.dt"),
    ('{"nothing": 1}', "relative"),
])
def test_bad_budget_names_the_key(tmp_path, content, key):
    path = tmp_path / "b.json"
    path.write_text(content)
    with pytest.raises(InputError) as info:
        budget.load_budget(path)
    assert info.value.key == key


def test_compare_warns_when_a_run_is_not_in_equilibrium():
    comp = comparison([_eq("a", 1, 1.0), _eq("b", 1, 2.0, kappa=0.1, in_eq=False)])
    assert not comp["all_in_equilibrium"] and len(comp["warnings"]) == 1
    assert "b never reached equilibrium" in comp["warnings"][0]
    table = comparison_table(comp)
    assert table.startswith("WARNING") and "NOT IN EQUILIBRIUM" in table


def test_size_ratio_uses_the_same_bins_for_equipartition():
    def b(lo, hi, c, m, n=50):
        return {"r_low": lo, "r_high": hi, "n": n,
                "velocity_dispersion": {"mean": c, "stderr": 0.0, "units": "m/s"},
                "mean_mass": {"mean": m, "stderr": 0.0, "units": "kg"}}
    bins = [b(0.5, 1.0, 4.0, 1.0), b(1.0, 2.0, 3.0, 8.0), b(2.0, 4.0, 1.0, 64.0),
            b(4.0, 5.0, 0.1, 500.0, n=3)]
    ratio = size_dispersion_ratio(bins)
    assert ratio["ratio"]["mean"] == pytest.approx(4.0), "smallest over largest POPULATED bin"
    assert ratio["large_bin_m"] == [2.0, 4.0]
    assert ratio["equipartition"] == pytest.approx(8.0), "sqrt(64 / 1) for these bins"


def test_cli_compare_refuses_a_bad_budget(tmp_path, capsys):
    bad = tmp_path / "b.json"
    bad.write_text("[]")
    assert main(["compare", str(tmp_path / "x.h5"), "--systematics", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "b.json" in err[0]


def test_replicas_of_a_single_case_are_compared_with_each_other():
    comp = comparison([_eq("s1", 1, 1.0), _eq("s2", 2, 1.1)])
    assert [r["name"] for r in comp["runs"]] == ["s1", "s2"]
    assert comp["ratios"][0]["velocity_dispersion"]["mean"] == pytest.approx(1.1)
