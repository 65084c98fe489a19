"""`ringsim analyze` and `ringsim compare`: contract JSON keys, numbers that match the run."""

import json

import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.config.scenario import with_overrides

CONTRACT_KEYS = {"name", "velocity_dispersion", "velocity_dispersion_rOmega", "thickness",
                 "thickness_r", "filling_factor", "collision_frequency", "mean_epsilon",
                 "equilibrium_from_orbit", "per_size_bin"}


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory, ring_scenario):
    base = ring_scenario(name="k0", restitution={"model": "constant", "epsilon": 0.5}, **{
        "sheet.optical_depth": 0.3, "integration.orbits": 2.0, "output.snapshot_every": 1.0})
    other = with_overrides(base, {"name": "k1", "restitution.epsilon": 0.3})
    d = tmp_path_factory.mktemp("runs")
    return [ringsim.run(sc, output=d / f"{sc.name}.h5", progress=False) for sc in (base, other)]


def _is_number(v):
    """A JSON number of the interface: mean, standard error and its unit (docs/interface.md)."""
    return set(v) == {"mean", "stderr", "units"} and isinstance(v["units"], str) and v["units"]


def test_analyze_json_has_contract_keys(two_runs, tmp_path, capsys):
    out = tmp_path / "eq.json"
    assert main(["analyze", str(two_runs[0]), "--json", str(out), "--plots",
                 str(tmp_path / "plots")]) == 0
    eq = json.loads(out.read_text())
    assert CONTRACT_KEYS <= set(eq)
    for key in CONTRACT_KEYS - {"name", "per_size_bin"}:
        assert _is_number(eq[key]), key
    assert len(eq["per_size_bin"]) >= 2
    for b in eq["per_size_bin"]:
        assert {"r_low", "r_high", "velocity_dispersion", "thickness", "n"} <= set(b)
    assert sum(b["n"] for b in eq["per_size_bin"]) == 200
    for name in ("timeseries.png", "size_bins.png", "epsilon_histogram.png", "snapshot.png"):
        assert (tmp_path / "plots" / name).stat().st_size > 5000
    assert "velocity dispersion" in capsys.readouterr().out


def test_equilibrium_numbers_match_the_run(two_runs):
    run = ringsim.open_run(two_runs[0])
    eq = ringsim.equilibrium(run)
    ts = run.timeseries
    window = ts["orbits"] >= eq["equilibrium_from_orbit"]["mean"]
    c = ts["velocity_dispersion"][window]
    assert abs(eq["velocity_dispersion"]["mean"] - c.mean()) < 1e-12 * c.mean()
    assert eq["velocity_dispersion"]["stderr"] >= c.std() / np.sqrt(c.size) * 0.99, \
        "autocorrelated stderr is not below the naive one"
    r_mean = run.snapshot(0)["radius"].mean()
    assert abs(eq["velocity_dispersion_rOmega"]["mean"]
               - c.mean() / (r_mean * 2.0e-4)) < 1e-9
    assert eq["mean_epsilon"]["mean"] == pytest.approx(0.5, abs=1e-12), "constant eps"
    assert eq["collision_frequency"]["mean"] > 0


def test_compare_ratios(two_runs, tmp_path, capsys):
    out = tmp_path / "cmp.json"
    assert main(["compare", *map(str, two_runs), "--json", str(out), "--plots",
                 str(tmp_path / "p")]) == 0
    comp = json.loads(out.read_text())
    a, b = comp["runs"]
    r = comp["ratios"][0]["velocity_dispersion"]
    assert r["mean"] == pytest.approx(b["velocity_dispersion"]["mean"]
                                      / a["velocity_dispersion"]["mean"], rel=1e-12)
    assert r["stderr"] > 0
    assert comp["ratios"][0]["mean_epsilon"]["mean"] == pytest.approx(0.6, rel=1e-9)
    assert (tmp_path / "p" / "compare_timeseries.png").exists()
    printed = capsys.readouterr().out
    assert "ratio k1 / k0" in printed
    # every headline names its weighting, in the table and in the ratios
    assert "velocity dispersion c, number-weighted [mm/s]" in printed
    assert "  velocity dispersion c, number-weighted " in printed.split("ratio k1 / k0")[1]


def test_analyze_missing_file_is_bad_input(tmp_path, capsys):
    assert main(["analyze", str(tmp_path / "none.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none.h5" in err[0]


def test_run_file_written_before_the_package_split_still_opens(tmp_path, capsys):
    """tests/data/run_format_1_0.h5 was written by ringsim at commit f41c05e (no
    format_version attribute: format 1.0); analyze and compare must read it."""
    from pathlib import Path

    old = Path(__file__).parent / "data" / "run_format_1_0.h5"
    out = tmp_path / "eq.json"
    assert main(["analyze", str(old), "--json", str(out)]) == 0
    eq = json.loads(out.read_text())
    assert CONTRACT_KEYS <= set(eq) and eq["n_particles"] == 80
    assert main(["compare", str(old), str(old)]) == 0
    assert "velocity dispersion" in capsys.readouterr().out


def test_law_range_is_reported_with_the_laws_measured_ranges(two_runs):
    """Constant eps states no measured range: nothing to report; the Dilley law's sizes are
    2.5-20 cm, so metre-sized ring particles are all outside (a warning)."""
    from ringsim.analysis.equilibrium import LAW_RANGE_WARNING, law_range, law_range_lines

    run = ringsim.open_run(two_runs[0])
    eq = ringsim.equilibrium(run)
    assert eq["law_range"]["speeds"] is None and law_range_lines(eq) == []
    ts = dict(run.timeseries)
    ts["law_outside_sizes"] = ts["collisions"].copy()     # as a Dilley run of 1-3 m spheres
    ts["law_outside_speeds"] = ts["collisions"] // 20
    rng = law_range(ts, 1, "dilley")
    assert rng["outside_sizes"] == 1.0
    assert rng["outside_speeds"] == pytest.approx(ts["law_outside_speeds"][1:].sum()
                                                  / ts["collisions"][1:].sum(), rel=1e-12)
    assert 0.0 < rng["outside_speeds"] < LAW_RANGE_WARNING
    lines = law_range_lines({**eq, "law_range": rng, "restitution": {"model": "dilley"}})
    assert lines[1].startswith("WARNING") and not lines[0].startswith("WARNING")
