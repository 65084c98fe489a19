"""Spin diagnostics and the energy budget with friction.

* The resolver's dissipation counters close the energy exactly: in a periodic box without
  shear or gravity, kinetic energy (translation + rotation) lost = normal + tangential
  dissipation counted, to round-off, for constant beta and Coulomb friction.
* The time-series rows of a run with friction (rotational energy, E_rot/E_tr, mean w_z and
  rms spin in units of Omega) are the snapshot's numbers at the snapshot's time, with units.
* ``analyze --json`` of a run with friction has ``rotational_energy_fraction``, ``spin``
  and ``energy_budget``; the table prints them.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import rebound

import ringsim
from ringsim.cli import main
from ringsim.engine.resolver import install_resolver
from ringsim.physics import friction as fr


def _kinetic(sim, spins, k):
    m = np.array([p.m for p in sim.particles])
    r = np.array([p.r for p in sim.particles])
    v = np.array([[p.vx, p.vy, p.vz] for p in sim.particles])
    return 0.5 * np.sum(m[:, None] * v * v) + np.sum(fr.rotational_energy(m, r, spins, k))


@pytest.mark.parametrize("friction", [{"model": "constant", "beta": 0.3},
                                      {"model": "coulomb", "mu": 0.2},
                                      None], ids=["beta0.3", "mu0.2", "smooth"])
def test_dissipation_counters_close_the_energy_of_a_box(friction):
    rng = np.random.default_rng(11)
    sim = rebound.Simulation()
    sim.integrator = "leapfrog"
    sim.boundary = "periodic"
    sim.gravity = "none"
    sim.collision = "tree"
    sim.root_size = 30.0
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = sim.N_ghost_z = 1
    sim.dt = 0.05
    n, placed = 120, []
    while len(placed) < n:
        trial = rng.uniform(-15.0, 15.0, 3)
        if all(np.linalg.norm(trial - q) > 2.2 for q in placed):
            placed.append(trial)
    for x in placed:
        radius = rng.uniform(0.5, 1.0)
        v = rng.normal(0.0, 0.3, 3)
        sim.add(m=900.0 * 4.19 * radius**3, r=radius, x=x[0], y=x[1], z=x[2], vx=v[0],
                vy=v[1], vz=v[2])
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.7}, friction, 0.35)
    if friction:
        handle.set_spins(rng.normal(0.0, 0.3, (n, 3)))
    before = _kinetic(sim, handle.spins(), 0.35)
    sim.integrate(200.0)
    stats = handle.stats()
    after = _kinetic(sim, handle.spins(), 0.35)
    assert stats["count"] > 100
    lost = stats["normal_dissipation"] + stats["tangential_dissipation"]
    assert lost > 0.1 * before
    # tolerance: round-off of the summed energies, about count x 1e-16 of the energy
    assert abs((before - after) - lost) <= 1e-12 * before, (before - after, lost)
    if friction is None:
        assert stats["tangential_dissipation"] == 0.0
    else:
        assert stats["tangential_dissipation"] > 0.05 * lost


@pytest.fixture(scope="module")
def rough_run(tmp_path_factory, rough_scenario):
    path = tmp_path_factory.mktemp("rough") / "rough.h5"
    # 0.8 orbit: the last snapshot, written with the final checkpoint, is 288 degrees on
    sc = rough_scenario({"model": "constant", "beta": 0.0}, **{"integration.orbits": 0.8})
    return ringsim.run(sc, output=path, progress=False)


def test_spin_rows_are_the_snapshot_numbers(rough_run):
    run = ringsim.open_run(rough_run)
    ts, units = run.timeseries, run.units
    assert units["rotational_energy"] == "J" and units["mean_spin_z"] == "Omega"
    assert units["rms_spin"] == "Omega" and units["rotational_energy_ratio"] == "dimensionless"
    assert units["normal_dissipation"] == "J" and units["tangential_dissipation"] == "J"
    Omega = run.scenario.orbital_frequency
    k = run.scenario.particles.inertia_factor
    checked = 0
    for i in range(1, run.n_snapshots):
        s = run.snapshot(i)
        row = int(np.argmin(np.abs(ts["t"] - s["t"])))
        assert ts["t"][row] == s["t"]
        w = np.stack([s["wx"], s["wy"], s["wz"]], axis=1)
        e_rot = float(np.sum(fr.rotational_energy(s["mass"], s["radius"], w, k)))
        assert ts["rotational_energy"][row] == pytest.approx(e_rot, rel=1e-12)
        u2 = s["vx"] ** 2 + (s["vy"] + 1.5 * Omega * s["x"]) ** 2 + s["vz"] ** 2
        e_tr = 0.5 * np.sum(s["mass"] * u2)
        # E_tr of the row subtracts the (tiny) mean drift: equal to a part in 1e3 here
        assert ts["rotational_energy_ratio"][row] == pytest.approx(e_rot / e_tr, rel=1e-3)
        assert ts["mean_spin_z"][row] == pytest.approx(np.mean(s["wz"]) / Omega, rel=1e-12)
        assert ts["rms_spin"][row] == pytest.approx(
            np.sqrt(np.mean(np.sum(w * w, axis=1))) / Omega, rel=1e-12)
        checked += 1
    assert checked >= 2 and np.all(ts["rotational_energy"][1:] > 0)
    assert np.all(ts["tangential_dissipation"][1:] > 0) and np.all(ts["sliding_collisions"] == 0)


def test_size_bin_spin_rows_add_up_to_the_ring_and_are_the_snapshot_numbers(rough_run):
    run = ringsim.open_run(rough_run)
    ts, units = run.timeseries, run.units
    assert units["size_bin_rotational_energy"] == "J"
    assert units["size_bin_rotational_energy_ratio"] == "dimensionless"
    edges = ts["size_bin_edges"]
    Omega = run.scenario.orbital_frequency
    k = run.scenario.particles.inertia_factor
    # every particle lies in a bin: the bins' energies add up to the ring's, to round-off
    np.testing.assert_allclose(np.nansum(ts["size_bin_rotational_energy"], axis=1),
                               ts["rotational_energy"], rtol=1e-12)
    s = run.snapshot(-1)
    row = int(np.argmin(np.abs(ts["t"] - s["t"])))
    assert ts["t"][row] == s["t"]
    w = np.stack([s["wx"], s["wy"], s["wz"]], axis=1)
    v = np.stack([s["vx"], s["vy"] + 1.5 * Omega * s["x"], s["vz"]])
    dv = v - (v @ s["mass"] / s["mass"].sum())[:, None]
    e_rot = fr.rotational_energy(s["mass"], s["radius"], w, k)
    e_tr = 0.5 * s["mass"] * np.sum(dv * dv, axis=0)
    index = np.clip(np.searchsorted(edges, s["radius"], side="right") - 1, 0, edges.size - 2)
    filled = 0
    for b in range(edges.size - 1):
        members = index == b
        if not members.any():
            assert np.isnan(ts["size_bin_rotational_energy_ratio"][row, b])
            continue
        filled += 1
        assert ts["size_bin_rotational_energy"][row, b] == pytest.approx(
            e_rot[members].sum(), rel=1e-12)
        assert ts["size_bin_rotational_energy_ratio"][row, b] == pytest.approx(
            e_rot[members].sum() / e_tr[members].sum(), rel=1e-12)
    assert filled >= 2


def test_analyze_reports_spins_and_the_energy_budget(rough_run, tmp_path, capsys):
    out = tmp_path / "eq.json"
    assert main(["analyze", str(rough_run), "--json", str(out), "--plots",
                 str(tmp_path / "plots")]) == 0
    assert (tmp_path / "plots" / "spins.png").stat().st_size > 10_000
    text = capsys.readouterr().out
    assert "E_rot / E_tr" in text and "mean w_z / Omega" in text and "shear heating" in text
    eq = json.loads(out.read_text())
    frac = eq["rotational_energy_fraction"]
    assert set(frac) == {"mean", "stderr", "units"} and frac["units"] == "dimensionless"
    assert 0.0 < frac["mean"] < 1.0
    spin = eq["spin"]
    assert spin["mean_spin_z"]["units"] == spin["rms_spin"]["units"] == "Omega"
    assert spin["collisional_spin_ratio"] == pytest.approx(2.0 / 9.0, rel=1e-15)
    assert "rotating frame" in spin["convention"]
    bins = spin["per_size_bin"]
    assert bins and all(b["rotational_energy"] > 0 and b["translational_energy"] > 0
                        for b in bins)
    # the per-bin window means of the run file's series, beside the velocity ellipsoid
    rows = [b for b in eq["per_size_bin"] if b["n"] > 0]
    assert rows and all(0.0 < b["rotational_energy_ratio"]["mean"] < 1.0 for b in rows)
    assert rows[0]["rotational_energy_ratio"]["units"] == "dimensionless"
    assert "E_rot / E_tr (by mass)" in text
    budget = eq["energy_budget"]
    for key in ("heating", "normal_dissipation", "tangential_dissipation"):
        assert budget[key]["units"] == "W/m^2" and budget[key]["mean"] > 0


def test_snapshot_spins_are_the_checkpoint_state_turned_by_the_frame_angle(rough_run):
    """The run file's two views of the spins at the last output: the checkpoint keeps the
    stored state (x, y in the frame's axes at t = 0), the snapshot the spins in the
    frame's axes at t: w_x + i w_y = (s_x + i s_y) exp(-i Omega t), bit for bit (the C's
    operations, no FMA), w_z equal."""
    import math

    from ringsim.store import runfile

    run = ringsim.open_run(rough_run)
    checkpoint = runfile.read_checkpoint(rough_run)
    t = float(checkpoint.state["t"])
    snap = run.snapshot(-1)
    assert snap["t"] == t
    theta = run.scenario.orbital_frequency * t
    assert abs(math.sin(theta)) > 0.5, "a rotation the test can see"
    c, s = math.cos(theta), math.sin(theta)
    stored = checkpoint.spins
    assert np.any(stored[:, :2] != 0.0)
    assert np.array_equal(snap["wx"], c * stored[:, 0] + s * stored[:, 1])
    assert np.array_equal(snap["wy"], c * stored[:, 1] - s * stored[:, 0])
    assert np.array_equal(snap["wz"], stored[:, 2])
