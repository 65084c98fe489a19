"""Per-size-bin diagnostics of a broad size distribution: each bin's velocity ellipsoid, the
small- and large-particle layers beside the thickness by weighting, and the law's eps per
pair of size bins (``analysis.size_bins``, ``physics.pair_bins``)."""

import json
import math

import numpy as np
import pytest

import ringsim
from ringsim.analysis import window
from ringsim.analysis.equilibrium import NO_WINDOW_SNAPSHOT, equilibrium_table
from ringsim.analysis.law_range import law_range
from ringsim.cli import main
from ringsim.engine.statistics import UNCOUNTED
from ringsim.physics import restitution as rs
from ringsim.physics.pair_bins import pair_bin_sums, pair_radii

ICE = 900.0   # [kg/m^3]


def _mass(r):
    return ICE * 4.0 / 3.0 * math.pi * np.asarray(r, float) ** 3


@pytest.fixture(scope="module")
def broad_run(tmp_path_factory, ring_scenario):
    """A ring of 0.1-2 m ice particles (q = 3, a factor 20 in radius), 300 particles, half
    an orbit with every collision of an interval logged (up to 2000)."""
    sc = ring_scenario(name="broad", **{
        "particles.size_distribution.r_min": 0.1, "particles.size_distribution.r_max": 2.0,
        "sheet.n_particles": 300, "integration.orbits": 0.5, "output.log_collisions": 2000,
        "output.snapshot_every": 0.1})
    return ringsim.run(sc, output=tmp_path_factory.mktemp("bins") / "broad.h5",
                       progress=False)


def test_pair_radii_recover_both_radii():
    # the inversion is exact algebra: round-off only (rel 1e-9 allows a 1e-6 m radius on 10 m)
    r1 = np.array([0.01, 0.5, 0.025, 1e-3, 0.3])
    r2 = np.array([5.0, 0.5, 0.1, 10.0, 0.2])
    small, large = pair_radii(rs.reduced_radius(r1, r2),
                              rs.reduced_mass(_mass(r1), _mass(r2)), ICE)
    np.testing.assert_allclose(small, np.minimum(r1, r2), rtol=1e-9)
    np.testing.assert_allclose(large, np.maximum(r1, r2), rtol=1e-9)


def test_pair_bin_sums_sort_pairs_by_both_partners():
    edges = np.array([0.01, 0.1, 1.0, 10.0])
    r1 = np.array([0.05, 0.05, 5.0, 0.5])
    r2 = np.array([0.05, 5.0, 0.05, 0.5])
    eps = np.array([0.2, 0.4, 0.6, 0.8])
    counts, sums = pair_bin_sums(rs.reduced_radius(r1, r2),
                                 rs.reduced_mass(_mass(r1), _mass(r2)), eps, ICE, edges)
    expected = np.zeros((3, 3), int)
    expected[0, 0], expected[0, 2], expected[1, 1] = 1, 2, 1    # (small bin, large bin)
    np.testing.assert_array_equal(counts.reshape(3, 3), expected)
    assert sums.reshape(3, 3)[0, 2] == pytest.approx(1.0, rel=1e-15)
    # a pair lighter than any two ice spheres of its R_bar is left out, not misplaced
    counts, _ = pair_bin_sums([0.05], [1e-6], [0.5], ICE, edges)
    assert counts.sum() == 0


def test_the_ellipsoid_of_each_bin_makes_its_dispersion(broad_run):
    # c_bin^2 = (sigma_x^2 + sigma_y^2 + sigma_z^2) / 3 in every row (round-off only)
    ts = ringsim.open_run(broad_run).timeseries
    sq = sum(ts[f"size_bin_sigma_{a}"] ** 2 for a in "xyz") / 3.0
    good = np.isfinite(sq)
    assert good.sum() > 20
    np.testing.assert_allclose(np.sqrt(sq[good]), ts["size_bin_velocity_dispersion"][good],
                               rtol=1e-12)


def test_analyze_prints_per_bin_motions_layers_and_pair_eps(broad_run, tmp_path, capsys):
    out = tmp_path / "eq.json"
    assert main(["analyze", str(broad_run), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    eq = json.loads(out.read_text())
    bins = eq["per_size_bin"]
    assert len(bins) >= 3
    for b in bins:       # every row: its edges, c, H and the ellipsoid, with units
        assert f"{b['r_low']:7.3g} - {b['r_high']:<7.3g}".rstrip() in text
        for key in ("velocity_dispersion", "thickness", "sigma_x", "sigma_y", "sigma_z"):
            assert b[key]["units"] == ("m" if key == "thickness" else "m/s")
    assert "per size bin:   r [m]" in text and "velocity ellipsoid per size bin [mm/s]" in text
    # the small- and large-particle layers, recomputed from the snapshots of the window
    seg = eq["vertical_segregation"]
    run = ringsim.open_run(broad_run)
    t0 = eq["equilibrium_from_orbit"]["mean"] * 2 * math.pi / run.scenario.orbital_frequency
    snaps = [s for s in (run.snapshot(i) for i in range(run.n_snapshots))
             if s["t"] >= t0 - 1e-6 * abs(t0)] or [run.snapshot(-1)]
    r = snaps[0]["radius"]
    r_small = r.min() * (r.max() / r.min()) ** (1 / 3)
    H = np.mean([math.sqrt(np.mean((s["z"][r < r_small]
                                    - np.average(s["z"], weights=s["mass"])) ** 2))
                 for s in snaps])
    assert seg["small"]["thickness"]["mean"] == pytest.approx(H, rel=1e-12)
    assert seg["small"]["r_high"] == pytest.approx(r_small, rel=1e-12)
    assert seg["large"]["n"] == int(np.sum(r > r.min() * (r.max() / r.min()) ** (2 / 3)))
    assert "vertical segregation (Cuzzi et al. 1979)" in text
    # the snapshots averaged are the window's, and the equilibrium says how many
    assert seg["in_window"] is (eq["window_snapshots"] > 0)
    assert eq["window_snapshots"] == len([s for s in snaps if s["t"] >= t0 - 1e-6 * abs(t0)])
    assert eq["units"]["window_snapshots"] == "count"
    assert (NO_WINDOW_SNAPSHOT in text) is (eq["window_snapshots"] == 0)
    assert f"H = {seg['small']['thickness']['mean']:.4g}" in text
    assert "thickness H (rms z) by weighting [m]: number" in text
    assert "mass" in text.split("by weighting [m]:")[1].splitlines()[0]
    assert "cross section" in text.split("by weighting [m]:")[1].splitlines()[0]
    # the eps of pairs of bins: every sampled collision once, each mean a law value in [0, 1]
    pair = eq["pair_epsilon"]
    assert pair["status"] == "on"
    counts = np.array(pair["counts"])
    start = int(np.searchsorted(run.timeseries["orbits"], eq["equilibrium_from_orbit"]["mean"]))
    collisions = run.timeseries["collisions"][start:]
    assert collisions.max() < 2000      # every collision of an interval was logged
    assert counts.sum() == int(collisions.sum()) > 0
    assert np.all(np.tril(counts, -1) == 0)     # row: the smaller partner's bin
    mean = np.array(pair["mean_epsilon"], float)
    assert np.all((mean[counts > 0] > 0) & (mean[counts > 0] <= 1))
    assert "mean eps of the law (sampled collisions) per pair of size bins" in text


class _Snapshots:
    """A stand-in run: time series rows at ``rows`` and snapshots at ``times`` [s]."""

    def __init__(self, rows, times):
        self.timeseries = {"t": np.asarray(rows, float)}
        self.snapshot_times = np.asarray(times, float)
        self.n_snapshots = self.snapshot_times.size


def test_window_snapshots_say_when_none_lies_in_the_window(broad_run):
    rows = np.arange(11) * 10.0
    # snapshots at 0, 40, 80 s: a window from row 5 (50 s) holds the one at 80 s
    assert window.window_snapshot_indices(_Snapshots(rows, [0.0, 40.0, 80.0]), 5) == ([2], True)
    # a window from row 9 (90 s) holds none: the last snapshot, flagged
    assert window.window_snapshot_indices(_Snapshots(rows, [0.0, 40.0, 80.0]), 9) == ([2], False)
    # a start past the last row is the last row
    assert window.window_snapshot_indices(_Snapshots(rows, [0.0, 100.0]), 99) == ([1], True)
    # analyze prints one line for it, and the equilibrium's table only then
    eq = ringsim.equilibrium(ringsim.open_run(broad_run))
    eq["window_snapshots"] = 0
    assert NO_WINDOW_SNAPSHOT in equilibrium_table(eq).splitlines()


def test_pair_eps_says_when_the_log_is_off(tmp_path, ring_scenario, capsys):
    sc = ring_scenario(name="nolog", **{"integration.orbits": 0.1})
    path = ringsim.run(sc, output=tmp_path / "nolog.h5", progress=False)
    out = tmp_path / "eq.json"
    assert main(["analyze", str(path), "--json", str(out)]) == 0
    pair = json.loads(out.read_text())["pair_epsilon"]
    assert pair == {"status": "off",
                    "reason": "output.log_collisions is 0: no collisions were sampled"}
    assert "eps of pairs of size bins: not available (output.log_collisions is 0" in \
        capsys.readouterr().out


def test_analyze_splits_the_law_range_below_and_above(broad_run, tmp_path, capsys):
    # Dilley's law: 2.5-20 cm reduced radii and 60-600 g reduced masses measured; these
    # pairs of 0.1-2 m ice spheres have R_bar >= 5 cm and M_bar >= 1.9 kg: every impact is
    # above the masses, none below; the shares are the window's counts over its impacts
    out = tmp_path / "eq.json"
    assert main(["analyze", str(broad_run), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    eq = json.loads(out.read_text())
    rng = eq["law_range"]
    ts = ringsim.open_run(broad_run).timeseries
    start = int(np.searchsorted(ts["orbits"], eq["equilibrium_from_orbit"]["mean"]))
    impacts = ts["collisions"][start:].sum()
    for what in ("speeds", "sizes", "masses"):
        for side in ("below", "above"):
            assert rng[f"{what}_{side}"] == pytest.approx(
                ts[f"law_{what}_{side}"][start:].sum() / impacts, rel=1e-12)
        assert rng[f"outside_{what}"] == pytest.approx(
            rng[f"{what}_below"] + rng[f"{what}_above"], rel=1e-12)
    assert rng["masses_above"] == 1.0 and rng["masses_below"] == 0.0
    assert rng["masses"] == [0.060, 0.600] and rng["units"]["masses"] == "kg"
    assert rng["critically_damped_count"] == int(ts["law_critically_damped"][start:].sum())
    assert ("100.0 % of impacts outside the reduced masses the dilley law was measured over "
            "(60-600 g): 0.0 % below, 100.0 % above") in text
    assert "of impacts critically damped (xi >= 1, eps = 0)" in text
    # every impact is above the masses, so none lies inside all three ranges at once
    assert ts["law_inside_all"][start:].sum() == 0 and rng["inside_all"] == 0.0
    assert "0.0 % of impacts inside all three measured ranges at once" in text


def test_the_joint_share_leaves_out_rows_written_before_its_counter():
    # rows 0-1 were written before the counter existed (-1), row 2 ends the interval
    # resumed from a checkpoint without it (UNCOUNTED plus what it counted); the window's
    # share counts only the impacts of the rows that hold a count: (30 + 10) / (100 + 60)
    ts = {"collisions": np.array([50, 70, 80, 100, 60]),
          "law_inside_all": np.array([-1, -1, UNCOUNTED + 20, 30, 10]),
          "law_outside_speeds": np.zeros(5, int)}
    assert law_range(ts, 0, "dilley")["inside_all"] == pytest.approx(40 / 160, rel=1e-15)
    ts["law_inside_all"][:] = -1
    assert math.isnan(law_range(ts, 0, "dilley")["inside_all"])
    # a law that states no range has no joint share, whatever the counter says
    ts["law_inside_all"][:] = 5
    assert math.isnan(law_range(ts, 0, "constant")["inside_all"])


@pytest.mark.slow
def test_compare_divides_each_size_bin(broad_run, tmp_path, ring_scenario, capsys):
    # a second ring of the same bins with a more dissipative law: per bin, the printed and
    # written ratio is c(other) / c(broad) of the two equilibria, with the propagated error
    sc = ring_scenario(name="broad-k", restitution={"model": "constant", "epsilon": 0.3},
                       **{"particles.size_distribution.r_min": 0.1,
                          "particles.size_distribution.r_max": 2.0,
                          "sheet.n_particles": 300, "integration.orbits": 0.5,
                          "output.snapshot_every": 0.1})
    other = ringsim.run(sc, output=tmp_path / "other.h5", progress=False)
    out = tmp_path / "cmp.json"
    assert main(["compare", str(broad_run), str(other), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    comp = json.loads(out.read_text())
    a, b = (ringsim.equilibrium(ringsim.open_run(p)) for p in (broad_run, other))
    rows = comp["ratios"][0]["per_size_bin"]
    assert len(rows) == len(a["per_size_bin"]) >= 3
    for row, x, y in zip(rows, b["per_size_bin"], a["per_size_bin"], strict=True):
        assert (row["r_low"], row["r_high"]) == (x["r_low"], x["r_high"])
        for key in ("velocity_dispersion", "thickness", "sigma_z"):
            if math.isfinite(row[key]["mean"]):
                assert row[key]["mean"] == pytest.approx(x[key]["mean"] / y[key]["mean"],
                                                         rel=1e-12)
    assert "per size bin, ratio ± stat:" in text


def test_a_layer_from_one_snapshot_has_no_error():
    from ringsim.analysis import size_bins

    snap = {"z": np.array([-1.0, 1.0, 3.0, -3.0]), "mass": np.ones(4)}
    members = np.array([True, True, False, False])
    mean, stderr = size_bins._group_thickness([snap], members)
    assert mean == 1.0 and math.isnan(stderr)
    # two snapshots: the standard error of their two values, |1 - 3| / 2
    other = {"z": np.array([-3.0, 3.0, 0.0, 0.0]), "mass": np.ones(4)}
    assert size_bins._group_thickness([snap, other], members) == (2.0, 1.0)
    assert size_bins._fmt({"mean": 1.0, "stderr": math.nan}) == "1 (one sample: no error)"
