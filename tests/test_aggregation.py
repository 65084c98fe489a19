"""Bound Hill-sphere groups, contact groups, overlap events and the aggregating verdict of a
run (analysis/aggregation.py), on synthetic sheets."""

import json
import math
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

import ringsim
from ringsim.analysis import aggregation as agg
from ringsim.cli import main
from ringsim.physics import gravity as patch
from ringsim.physics.constants import G_SI

GM = 3.7931e16          # [m^3/s^2] Saturn
DENSITY = 900.0         # [kg/m^3]
LX = LY = 80.0          # [m]
MASS = DENSITY * 4.0 / 3.0 * np.pi  # [kg] a 1 m sphere


def omega_for(r_h):
    """Orbital frequency [1/s] at which a pair of 1 m ice spheres has Hill parameter r_h."""
    a = 1.0e8 * r_h / float(patch.hill_parameter(1.0, 1.0, DENSITY, GM, 1.0e8))
    return math.sqrt(GM / a**3)


def clump_points():
    """18 touching 1 m spheres on a 3 x 3 x 2 cubic lattice of spacing 2 m, centred at
    (10, 5, 0): its farthest member reaches 4 m from the centre (3 m plus its radius)."""
    grid = np.array([(x, y, z) for x in (-2.0, 0.0, 2.0) for y in (-2.0, 0.0, 2.0)
                     for z in (-1.0, 1.0)])
    return grid + [10.0, 5.0, 0.0]


def sheet(Omega, clump_velocity=0.0, seed=4):
    """The clump of `clump_points` moving with the shear flow (its members with random
    velocities of rms ``clump_velocity`` [m/s] about it) among 60 single particles on a
    6 m grid clear of it, each with 1 mm/s rms random velocity about the shear flow."""
    rng = np.random.default_rng(seed)
    clump = clump_points()
    grid = np.array([(x, y, 0.0) for x in np.arange(-36.0, 0.0, 6.0)
                     for y in np.arange(-36.0, 24.0, 6.0)])
    pos = np.vstack([clump, grid])
    n = len(pos)
    v = np.zeros((n, 3))
    v[:18] = rng.normal(0.0, clump_velocity / math.sqrt(3), (18, 3))
    v[18:] = rng.normal(0.0, 1e-3, (n - 18, 3))
    v[:18, 1] += -1.5 * Omega * 10.0          # the clump's centre moves with the flow
    v[18:, 1] += -1.5 * Omega * pos[18:, 0]
    return {"x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2], "vx": v[:, 0], "vy": v[:, 1],
            "vz": v[:, 2], "radius": np.ones(n), "mass": np.full(n, MASS), "t": 0.0}


def test_a_bound_clump_at_r_h_1_3_is_all_bound():
    """18 touching spheres at rest about their centre at r_h = 1.3: the block (4 m to its
    farthest surface) lies inside its Hill sphere (r_H = 9^(1/3) x 2.6 m = 5.4 m, 2.6 m
    being the pair's) and every member is below the Lagrange points' energy (the corner
    member at -0.8 Omega^2 r_H^2 at rest): all 18 of 78 are bound."""
    Omega = omega_for(1.3)
    stats = agg.snapshot_aggregation(sheet(Omega), LX, LY, Omega)
    assert stats["bound_fraction"] == pytest.approx(18 / 78, rel=1e-12)
    assert stats["bound_groups"] == 1 and stats["largest_bound_group"] == 18
    assert stats["contact_fraction"] == pytest.approx(18 / 78, rel=1e-12)


def test_the_same_clump_at_r_h_0_6_is_not_bound():
    """At r_h = 0.6 the tide wins: r_H = 9^(1/3) x 1.2 m = 2.5 m is less than the block's
    4 m, so no member is bound, though the contact group is the same."""
    Omega = omega_for(0.6)
    stats = agg.snapshot_aggregation(sheet(Omega), LX, LY, Omega)
    assert stats["bound_fraction"] == 0.0 and stats["bound_groups"] == 0
    assert stats["contact_fraction"] == pytest.approx(18 / 78, rel=1e-12)


def test_a_clump_flying_apart_is_not_bound():
    """The clump's members at 20 cm/s rms about its centre, far above its escape speed
    (sqrt(2 G M / 3 m) = 1.7 mm/s): a passing contact, not an aggregate."""
    Omega = omega_for(1.3)
    stats = agg.snapshot_aggregation(sheet(Omega, clump_velocity=0.2), LX, LY, Omega)
    assert stats["bound_fraction"] == 0.0


def test_jacobi_energy_is_zero_at_the_lagrange_point():
    """A test particle at rest at L1 (r = r_H along x) has E_J = 0; just inside, at rest on
    the y axis, it is below (bound) only if r < (2/3) r_H (-G M / r + 4.5 Omega^2 r_H^2)."""
    Omega, M = 2e-4, 1e7
    r_hill = float(agg.hill_radius(M, Omega))
    assert r_hill == pytest.approx((G_SI * M / (3 * Omega**2)) ** (1 / 3), rel=1e-12)
    e = agg.jacobi_energy([[r_hill, 0, 0]], [[0, 0, 0]], [M], Omega)
    assert abs(e[0]) < 1e-12 * Omega**2 * r_hill**2
    inside = agg.jacobi_energy([[0, 0.66 * r_hill, 0], [0, 0.68 * r_hill, 0]],
                               np.zeros((2, 3)), [M, M], Omega)
    assert inside[0] < 0.0 < inside[1]


def fake_run(snap, Omega, gravity=True):
    """The parts of a Run that run_aggregation reads: one snapshot (or a list of them, one
    orbit apart) and a window of 4 rows, two of them with deep overlaps."""
    snaps = snap if isinstance(snap, list) else [snap]
    period = 2 * np.pi / Omega
    snaps = [{**one, "t": i * period} for i, one in enumerate(snaps)]
    ts = {"t": np.arange(4.0), "orbits": np.array([0.0, 0.1, 0.2, 0.3]),
          "overlapping_pairs": np.array([0, 0, 2, 5]), "multi_encounters": np.array([0, 1, 3, 6]),
          "collisions": np.array([0, 10, 10, 20])}
    sheet_section = SimpleNamespace(gravity=gravity)
    scenario = SimpleNamespace(sheet=sheet_section, orbital_frequency=Omega,
                               orbital_period=2 * np.pi / Omega)
    return SimpleNamespace(timeseries=ts, scenario=scenario, attrs={"Lx": LX, "Ly": LY},
                           n_snapshots=len(snaps), snapshot=lambda i: snaps[i],
                           snapshot_times=np.array([one["t"] for one in snaps]))


@pytest.mark.parametrize("r_h, flagged", [(1.3, True), (0.6, False)])
def test_a_sheet_with_a_bound_clump_is_flagged_as_aggregating(r_h, flagged):
    """A run whose snapshot holds the bound clump (23 % of the mass, above
    AGGREGATING_FRACTION = 10 %) is aggregating, and its collision statistics are
    withheld (NaN, the fluid averages kept apart); at r_h = 0.6 it is not.  The overlap
    events are counted from the window's rows: 2 of 3 rows, at most 5 pairs, 10 of 40
    collisions multi-encounters.  The one snapshot (orbit 0) lies before the window (from
    orbit 0.1), and the result and the printed line say so."""
    Omega = omega_for(r_h)
    result = agg.run_aggregation(fake_run(sheet(Omega), Omega), start=1)
    assert result["aggregating"] is flagged
    assert (result["rows"], result["overlap_rows"], result["max_overlapping_pairs"]) == (3, 2, 5)
    assert result["multi_encounter_share"] == pytest.approx(0.25, rel=1e-12)
    assert result["snapshots_in_window"] is False
    eq = {"name": "clump",
          **{key: {"mean": 1.0, "stderr": 0.1, "units": "u"} for key in agg.COLLISION_KEYS}}
    agg.withhold_collision_statistics(eq, result)
    assert eq["aggregating"] is flagged
    for key in agg.COLLISION_KEYS:
        assert math.isnan(eq[key]["mean"]) is flagged
    if flagged:
        assert result["as_fluid"]["collision_frequency"]["mean"] == 1.0
        printed = "\n".join(agg.aggregation_lines(eq))
        assert "WARNING: clump aggregates (23 % of the mass in bound" in printed
        assert "23.1 % of the mass in bound Hill groups on average over 1 snapshot," in printed
        assert "aggregation (last snapshot, before window)" in printed
        assert "window snapshots" not in printed


@pytest.mark.parametrize("bound_snapshots, flagged", [(1, False), (2, True), (4, True)])
def test_the_verdict_is_the_window_mean_of_the_bound_share(bound_snapshots, flagged):
    """Four window snapshots at r_h = 1.3, the clump bound (18 of 78 particles: 23 % of the
    mass) in ``bound_snapshots`` of them and flying apart (0 %) in the rest: the window mean
    is 5.8, 11.5 and 23 % against the verdict's 10 %, while the largest share is 23 % in
    each.  One snapshot's transient group does not make a run aggregating."""
    Omega = omega_for(1.3)
    snaps = ([sheet(Omega)] * bound_snapshots
             + [sheet(Omega, clump_velocity=0.2)] * (4 - bound_snapshots))
    result = agg.run_aggregation(fake_run(snaps, Omega), start=0)
    assert len(result["snapshots"]) == 4
    assert result["bound_fraction_max"] == pytest.approx(18 / 78, rel=1e-12)
    assert result["bound_fraction_mean"] == pytest.approx(bound_snapshots / 4 * 18 / 78,
                                                          rel=1e-12)
    assert result["aggregating"] is flagged
    eq = {"name": "clump",
          **{key: {"mean": 1.0, "stderr": 0.1, "units": "u"} for key in agg.COLLISION_KEYS}}
    agg.withhold_collision_statistics(eq, result)
    printed = "\n".join(agg.aggregation_lines(eq))
    mean = 100 * result["bound_fraction_mean"]
    assert (f"WARNING: clump aggregates ({mean:.0f} % of the mass" in printed) is flagged
    assert f"{mean:.1f} % of the mass in bound Hill groups on average over 4 snapshots" in printed
    assert result["snapshots_in_window"] is True
    assert "aggregation (window snapshots)" in printed


def test_a_run_without_self_gravity_is_never_aggregating():
    Omega = omega_for(1.3)
    result = agg.run_aggregation(fake_run(sheet(Omega), Omega, gravity=False))
    assert result["aggregating"] is False and "snapshots" not in result


def test_analyze_and_compare_flag_an_aggregating_run(tmp_path, gravitating_scenario, capsys):
    """A real run that aggregates (400 identical 1 m spheres, tau = 0.25, r_h = 1.3, one
    orbit: the runs of docs/validation.md hold 20-85 % of their mass bound from orbit 0.5 on,
    against the 10 % of the verdict): `analyze` says so and withholds its collision
    statistics (JSON NaN, the fluid averages in aggregation.as_fluid, printed "withheld"),
    and `compare` warns and gives no ratio for them."""
    a = 1.0e8 * 1.3 / float(patch.hill_parameter(1.0, 1.0, DENSITY, GM, 1.0e8))
    sc = gravitating_scenario(name="clumping", seed=1, **{
        "planet.a": a, "sheet.optical_depth": 0.25, "sheet.n_particles": 400,
        "integration.orbits": 1.0, "integration.dt": 5e-4, "integration.dt_safety": 0.2,
        "output.path": "runs/r.h5", "output.timeseries_every": 0.05,
        "output.snapshot_every": 0.25})
    path = ringsim.run(sc, output=tmp_path / "c.h5", progress=False)
    capsys.readouterr()
    assert main(["analyze", str(path), "--json", str(tmp_path / "eq.json")]) == 0
    printed = capsys.readouterr().out
    eq = json.loads((tmp_path / "eq.json").read_text())
    assert eq["aggregating"] is True and eq["aggregation"]["bound_fraction_max"] >= 0.1
    assert math.isnan(eq["collision_frequency"]["mean"])
    assert eq["aggregation"]["as_fluid"]["collision_frequency"]["mean"] > 0.0
    assert "clumping aggregates" in printed and "withheld: the ring aggregates" in printed
    mean = 100 * eq["aggregation"]["bound_fraction_mean"]
    assert mean >= 10.0 and f"{mean:.1f} % of the mass in bound Hill groups on average" in printed
    shutil.copy(path, tmp_path / "d.h5")
    assert main(["compare", str(path), str(tmp_path / "d.h5"), "--json",
                 str(tmp_path / "cmp.json")]) == 0
    captured = capsys.readouterr()   # each run's warning once, with the table (two runs)
    assert captured.out.count("WARNING: clumping aggregates") == 2, captured.out
    comp = json.loads((tmp_path / "cmp.json").read_text())
    assert all(r["aggregating"] for r in comp["runs"])
    assert math.isnan(comp["ratios"][0]["collision_frequency"]["mean"])
