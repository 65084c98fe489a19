"""Scenario -> shearing sheet: box, size distribution, initial state, guards."""

import math

import numpy as np
import pytest

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine import box, native, sheet, timestep

#: The broad sheet, twice as long along the orbit (y) as across it (x).
LONG = {"name": "sheet-test", "sheet.aspect": 2.0}


@pytest.fixture(scope="module")
def built(broad_scenario):
    return sheet.build_sheet(broad_scenario(LONG))


def test_box_holds_the_optical_depth_exactly(built):
    g = built.geometry
    tau = np.sum(np.pi * built.radii**2) / (g.Lx * g.Ly)
    assert abs(tau - 0.4) < 1e-12
    assert g.Ly / g.Lx == 2.0
    sim = built.sim
    assert sim.root_size == g.root_size and (sim.N_root_x, sim.N_root_y) == (1, 2)


def test_simulation_settings(built):
    sim = built.sim
    assert sim.N == 400
    # REBOUND's SEI arithmetic on threads (tests/test_sei.py: the same bits as "sei")
    assert sim.integrator == native.THREADED_SEI
    assert sim.boundary == "shear" and sim.collision == "tree"
    assert sim.OMEGA == 2.0e-4 and sim.OMEGAZ == 2.0e-4
    assert sim.rand_seed == 11, "REBOUND's collision shuffle is seeded from the scenario"
    assert sim.gravity == "none" and (sim.N_ghost_x, sim.N_ghost_y, sim.N_ghost_z) == (1, 1, 0)
    arrays = sheet.particle_arrays(sim)
    np.testing.assert_allclose(arrays["mass"], 900.0 * 4 / 3 * np.pi * arrays["radius"]**3,
                               rtol=1e-15)


def test_initial_state(built):
    arrays = sheet.particle_arrays(built.sim)
    g = built.geometry
    assert box.count_overlaps(arrays, g, fraction=0.0) == 0, "no initial overlaps"
    assert np.all(np.abs(arrays["x"]) <= g.Lx / 2) and np.all(np.abs(arrays["y"]) <= g.Ly / 2)
    w_y = arrays["vy"] + 1.5 * 2e-4 * arrays["x"]
    c = 2.0 * np.mean(arrays["radius"]) * 2e-4  # initial_dispersion default: 2 <r> Omega
    assert abs(np.std(w_y) / c - 1) < 0.2, "random motion of the requested size"
    assert sheet.vertical_guard_ok(arrays, g)


def test_size_distribution_drawn_with_the_seed(broad_scenario):
    a = sheet.build_sheet(broad_scenario(LONG, source="<a>"))
    b = sheet.build_sheet(broad_scenario(LONG, source="<b>"))
    np.testing.assert_array_equal(a.radii, b.radii)
    assert a.radii.min() >= 0.5 and a.radii.max() <= 5.0
    c = sheet.build_sheet(broad_scenario(LONG, seed=12))
    assert not np.array_equal(a.radii, c.radii)
    np.testing.assert_array_equal(a.size_bin_edges, c.size_bin_edges)
    assert a.size_bin_edges[0] == 0.5 and 5.0 < a.size_bin_edges[-1] < 5.0 * (1 + 1e-8)


def test_gravity_sets_tree_gravity_one_ghost_ring_and_the_field_beyond(broad_scenario):
    # one ring plus the analytic field of the sheet beyond it (docs/gravity.md)
    from ringsim.gravity.tree import has_ghost_field

    sc = broad_scenario(LONG, {"sheet.gravity": True, "sheet.gravity_solver": "tree",
                               "sheet.n_particles": 50})
    sim = sheet.build_sheet(sc).sim
    assert sim.gravity == "tree" and sim.N_ghost_x == 1 and sim.N_ghost_y == 1
    assert has_ghost_field(sim)
    assert math.isclose(sim.G, 6.6743e-11)
    assert sim.softening == pytest.approx(0.05)


def _arrays(speed, r_min=0.5, n=100, seed=0):
    rng = np.random.default_rng(seed)
    r = np.full(n, r_min)
    return {"x": rng.uniform(-10, 10, n), "y": np.zeros(n), "z": np.zeros(n),
            "vx": rng.normal(0, speed, n), "vy": rng.normal(0, speed, n),
            "vz": rng.normal(0, speed, n), "radius": r, "mass": r**3}


@pytest.mark.parametrize("speed", [1e-5, 1e-3, 1e-1])
def test_auto_dt_bound(speed):
    Omega = 2e-4
    arrays = _arrays(speed)
    arrays["vy"] = arrays["vy"] - 1.5 * Omega * arrays["x"]
    dt = timestep.auto_dt(arrays, Omega, safety=0.1)
    assert dt <= 1e-3 * 2 * math.pi / Omega * (1 + 1e-15)
    assert timestep.relative_speed_bound(arrays, Omega) * dt <= 0.1 * 0.5 * (1 + 1e-12)
    assert timestep.dt_violation(arrays, Omega, dt, 0.1) <= 1 + 1e-12


def test_auto_dt_line_mode_is_the_orbit_limit():
    """Line mode ignores r/v and, since contacts are resolved in time order, multiple
    encounters too: a dilute hot ring and a crowded one both get 1e-3 orbit."""
    Omega = 2e-4
    dt_max = 1e-3 * 2 * math.pi / Omega
    rng = np.random.default_rng(3)
    n = 200
    dilute = {"x": rng.uniform(-500, 500, n), "y": rng.uniform(-500, 500, n),
              "z": rng.normal(0, 50, n), "vx": rng.normal(0, 0.01, n),
              "vy": rng.normal(0, 0.01, n), "vz": rng.normal(0, 0.01, n),
              "radius": np.full(n, 0.5), "mass": np.full(n, 470.0)}
    dilute["vy"] = dilute["vy"] - 1.5 * Omega * dilute["x"]
    assert timestep.auto_dt(dilute, Omega, 0.1, collision_detection="line") == dt_max
    crowded = _arrays(1e-3)
    assert timestep.auto_dt(crowded, Omega, 0.1, collision_detection="line") == dt_max
    assert timestep.auto_dt(crowded, Omega, 0.1) < dt_max, "tree mode: r/v bounds the step"


def test_auto_dt_grows_only_with_margin():
    Omega = 2e-4
    arrays = _arrays(1e-2)
    dt = timestep.auto_dt(arrays, Omega, 0.1)
    slower = dict(arrays, vx=arrays["vx"] / 1.9, vy=arrays["vy"] / 1.9, vz=arrays["vz"] / 1.9)
    # without history the bound would allow a doubled step; with it the step holds
    assert timestep.auto_dt(slower, Omega, 0.1) >= dt
    assert timestep.auto_dt(slower, Omega, 0.1, current=dt) == dt


def test_enlarged_copy_keeps_the_state(built):
    sim = built.sim
    sim.integrate(sim.t + 20 * sim.dt, exact_finish_time=0)
    new, geometry = sheet.enlarged_copy(sim, built.geometry, 3 * built.geometry.n_root_z)
    a, b = sheet.particle_arrays(sim), sheet.particle_arrays(new)
    for key in a:
        assert np.array_equal(a[key], b[key]), key
    assert new.t == sim.t and new.dt == sim.dt and new.rand_seed == sim.rand_seed
    assert new.collisions_log_n == sim.collisions_log_n
    assert new.N_root_z == 3 * built.geometry.n_root_z
    # root_size * (3 n) and 3 (root_size * n) may round differently in the last bit
    assert geometry.z_period == pytest.approx(3 * built.geometry.z_period, rel=1e-15)


@pytest.mark.parametrize("t_orbits", [0.0, 0.37, 5.2])
def test_overlaps_across_the_shearing_boundary(t_orbits):
    """A pair straddling the radial boundary overlaps only at the sheared image position."""
    g = box.SheetGeometry(100.0, 1, 1, 4, 2.0e-4)
    t = t_orbits * g.orbit
    shift = 1.5 * g.Omega * g.Lx * t
    y_image = (10.0 + shift + 50.0) % 100.0 - 50.0  # image of the particle at x = 49.5
    arrays = {"x": np.array([49.5, -49.6]), "y": np.array([10.0, y_image + 0.3]),
              "z": np.zeros(2), "vx": np.zeros(2), "vy": np.zeros(2), "vz": np.zeros(2),
              "radius": np.array([0.5, 0.5]), "mass": np.ones(2)}
    assert box.count_overlaps(arrays, g, t) == 1
    arrays["y"][1] = y_image + 3.0
    assert box.count_overlaps(arrays, g, t) == 0
    if t_orbits:
        # without the shear offset the ghost lands elsewhere
        arrays["y"][1] = 10.3
        assert box.count_overlaps(arrays, g, t) == 0


def test_centre_of_mass_starts_at_rest_in_the_shear_flow():
    """No undamped epicycle of the whole sheet: mass-weighted mean of (vx, vy + 1.5 Omega x,
    vz) and of z vanish to round-off at set-up (and the collisions conserve them)."""
    from ringsim.engine.sheet import build_sheet, particle_arrays

    sc = scenario_from_dict({"name": "com", "seed": 5, "planet": {"Omega": 2e-4},
                             "particles": {"size_distribution": {"kind": "powerlaw", "q": 3,
                                                                 "r_min": 0.5, "r_max": 5}},
                             "sheet": {"n_particles": 500, "initial_dispersion": 20.0}})
    built = build_sheet(sc)
    a = particle_arrays(built.sim)
    m = a["mass"] / a["mass"].sum()
    speed = np.sqrt(np.mean(a["vx"] ** 2))
    for values in (a["vx"], a["vy"] + 1.5 * 2e-4 * a["x"], a["vz"]):
        assert abs(np.dot(m, values)) < 1e-13 * speed
    assert abs(np.dot(m, a["z"])) < 1e-13 * np.sqrt(np.mean(a["z"] ** 2))
