"""Line mode: swept-path collision detection with contact-time resolution.

What is checked, and to what tolerance:

* no tunnelling: two spheres that cross both radii within one step bounce at their first
  contact (state after the step equal to the analytic one to 1e-12 relative, eps of the
  Dilley law at the contact speed, momentum conserved to 1e-13), with ringsim's sheet
  detector and with REBOUND's linetree; REBOUND's tree search at the same step lets them
  pass through each other (the negative control);
* a collision through the shear-periodic radial boundary, with a particle that left the box
  during the step, gives the same state with the sheet detector as with REBOUND's linetree
  (1e-9 relative), once, with the same collisions_log_n and collisions_plog;
* the sheet detector finds exactly the pairs of REBOUND's brute-force swept-path search
  (``line``) in sheared boxes at t != 0, also when particles are not yet wrapped;
* multi_encounters counts a particle deflected twice in one step, not a boulder struck by
  grains; measured and predicted (``ringsim.analysis.encounters``, tested on its own in
  tests/test_encounters.py) fractions in a dense ring agree to a factor 2, and
  ``dt: auto`` keeps the predicted fraction below 1% (1e-3 orbit for a hot ring);
* a line-mode run resumed from a REBOUND binary is bit-identical to an uninterrupted one;
* a cold dense ring (eps = 0.5, tau = 1) reaches the same c and H in line mode at 1e-3
  orbit as in tree mode with dt: auto, within 3 combined standard errors.
"""

from __future__ import annotations

import ctypes
import math
import warnings

import numpy as np
import pytest
import rebound

from ringsim.analysis import snapshot, timeseries
from ringsim.analysis.encounters import MULTI_ENCOUNTER_WINDOW_STEPS, multi_encounter_rate
from ringsim.config.scenario import with_overrides
from ringsim.engine import sheet
from ringsim.engine.box import SheetGeometry
from ringsim.engine.resolver import install_resolver
from ringsim.engine.timestep import MULTI_ENCOUNTER_MASS_SHARE
from ringsim.physics import restitution as rs

OMEGA = 2e-4                       # [1/s]
ORBIT = 2.0 * math.pi / OMEGA      # [s]
DILLEY_KAPPA01 = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}
CONSTANT_HALF = {"model": "constant", "epsilon": 0.5}


def phase_space(sim: rebound.Simulation) -> np.ndarray:
    """(N, 6) array of x, y, z [m], vx, vy, vz [m/s]."""
    xyz = np.zeros((sim.N, 3))
    vxyz = np.zeros((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vxyz)
    return np.hstack([xyz, vxyz])


def free_box(collision: str, box: float = 200.0, dt: float = 100.0) -> rebound.Simulation:
    """A periodic box without forces (leapfrog: straight lines exactly), step dt [s]."""
    sim = rebound.Simulation()
    sim.integrator = "leapfrog"
    sim.gravity = "none"
    sim.boundary = "periodic"
    sim.collision = collision
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.N_ghost_z = 0
    sim.dt = dt
    return sim


def sheared_box(collision: str, box: float, dt_orbits: float, t: float) -> rebound.Simulation:
    """An empty shearing sheet (SEI, shear boundaries) of side box [m] at time t [s]."""
    sim = rebound.Simulation()
    sim.OMEGA = OMEGA
    sim.integrator = "sei"
    sim.boundary = "shear"
    sim.gravity = "none"
    sim.collision = collision
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.N_ghost_z = 0
    sim.dt = dt_orbits * ORBIT
    sim.t = t
    return sim


def attach(sim: rebound.Simulation, detection: str, restitution: dict, **kwargs):
    """ringsim's resolver with the sheet detector ("sheet") or REBOUND's search."""
    if detection == "sheet":
        return install_resolver(sim, restitution, collision_detection="line", **kwargs)
    sim.collision = detection
    return install_resolver(sim, restitution, **kwargs)


# --- no tunnelling ------------------------------------------------------------------------

R1, R2 = 1.0, 0.5                      # [m]
M1, M2 = 4.0e3, 5.0e2                  # [kg]
DT = 100.0                             # [s]
SPEED = 3.0 * (R1 + R2) / DT           # [m/s]: crosses both diameters in one step
CONTACT = 0.4 * DT                     # [s] after the start of the step
IMPACT = 0.6 * (R1 + R2)               # [m] impact parameter


def fast_pair(collision: str) -> rebound.Simulation:
    """Particle 0 overtakes particle 1 along -x; they touch CONTACT after the step starts
    and would be 1.5 diameters past each other at its end without a collision."""
    sim = free_box(collision)
    v2 = np.array([0.01, -0.004, 0.002])
    r_contact = np.array([math.sqrt((R1 + R2) ** 2 - IMPACT**2), IMPACT, 0.0])
    u = np.array([-SPEED, 0.0, 0.0])
    x2 = np.array([3.0, -7.0, 0.5])
    x1 = x2 + r_contact - CONTACT * u
    v1 = v2 + u
    sim.add(m=M1, r=R1, x=x1[0], y=x1[1], z=x1[2], vx=v1[0], vy=v1[1], vz=v1[2])
    sim.add(m=M2, r=R2, x=x2[0], y=x2[1], z=x2[2], vx=v2[0], vy=v2[1], vz=v2[2])
    return sim


def expected_bounce(sim_start: np.ndarray, epsilon: float) -> np.ndarray:
    """State after one step: free flight to the contact, the impulse of eps, free flight."""
    x1, v1, x2, v2 = sim_start[0, :3], sim_start[0, 3:], sim_start[1, :3], sim_start[1, 3:]
    x1c, x2c = x1 + CONTACT * v1, x2 + CONTACT * v2
    normal = (x1c - x2c) / np.linalg.norm(x1c - x2c)
    v_n = np.dot(v1 - v2, normal)
    M_bar = M1 * M2 / (M1 + M2)
    impulse = -(1.0 + epsilon) * v_n * M_bar * normal       # on particle 0 [kg m/s]
    v1n, v2n = v1 + impulse / M1, v2 - impulse / M2
    rest = DT - CONTACT
    return np.array([np.concatenate([x1c + rest * v1n, v1n]),
                     np.concatenate([x2c + rest * v2n, v2n])])


@pytest.mark.parametrize("detection", ["sheet", "linetree"])
def test_fast_pair_bounces_at_first_contact_instead_of_tunnelling(detection):
    sim = fast_pair("none")
    handle = attach(sim, detection, DILLEY_KAPPA01, log_capacity=4)
    start = phase_space(sim)
    momentum = M1 * start[0, 3:] + M2 * start[1, 3:]
    sim.steps(1)

    stats = handle.stats()
    assert stats["count"] == 1 and sim.collisions_log_n == 1, "one collision, resolved once"
    normal_speed = SPEED * math.sqrt(1.0 - (IMPACT / (R1 + R2)) ** 2)
    R_bar, M_bar = rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2)
    epsilon = float(rs.dilley_epsilon(normal_speed, R_bar, M_bar, kappa=0.1))
    assert 0.3 < epsilon < 0.95, "a real bounce, neither elastic nor sticking"
    log = stats["log"][0]
    assert log["v_n"] == pytest.approx(normal_speed, rel=1e-12), "impact speed at contact"
    assert log["epsilon"] == pytest.approx(epsilon, rel=1e-12), "eps of the law at contact"

    got = phase_space(sim)
    expected = expected_bounce(start, epsilon)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * 10.0,
                               err_msg="state after the step: bounce at the first contact")
    np.testing.assert_allclose(M1 * got[0, 3:] + M2 * got[1, 3:], momentum, rtol=0,
                               atol=1e-13 * M1 * SPEED, err_msg="momentum conserved")
    assert np.linalg.norm(got[0, :3] - got[1, :3]) > R1 + R2, "apart at the end of the step"
    assert got[0, 0] > got[1, 0], "particle 0 bounced back: it is still on the +x side"


def test_fast_pair_tunnels_through_with_end_of_step_overlap_search():
    """The negative control: at this step the tree search never sees an overlap."""
    sim = fast_pair("tree")
    handle = install_resolver(sim, DILLEY_KAPPA01)
    sim.steps(1)
    got = phase_space(sim)
    assert handle.stats()["count"] == 0
    assert got[0, 0] < got[1, 0], "passed through each other unresolved"
    assert np.linalg.norm(got[0, :3] - got[1, :3]) > R1 + R2, "and no overlap to find"


def boundary_pair(collision: str) -> rebound.Simulation:
    """A fast pair meeting through the radial boundary of a sheared box at t = 3.3 orbits:
    particle 0 leaves the box at +x during the step, particle 1 sits near -x at the image
    position (x - L, y + a, vy + 1.5 Omega L) of a partner just outside +L/2."""
    box = 50.0
    t = 3.3 * ORBIT
    sim = sheared_box(collision, box, 1e-3, t)
    slide = math.fmod(1.5 * OMEGA * box * t, box)
    dt = 1e-3 * ORBIT
    speed = 3.0 * (R1 + R2) / dt
    x1 = np.array([0.5 * box - 0.3, 4.0, 0.2])
    partner = x1 + np.array([0.5 * speed * dt + 0.2 * (R1 + R2), 0.3, -0.1])
    v_partner = np.array([-0.5 * speed, -1.5 * OMEGA * partner[0], 0.0])
    v1 = np.array([0.5 * speed, -1.5 * OMEGA * x1[0], 0.0])
    x2 = partner + np.array([-box, slide, 0.0])
    v2 = v_partner + np.array([0.0, 1.5 * OMEGA * box, 0.0])
    sim.add(m=M1, r=R1, x=x1[0], y=x1[1], z=x1[2], vx=v1[0], vy=v1[1], vz=v1[2])
    sim.add(m=M2, r=R2, x=x2[0], y=x2[1] - box * round(x2[1] / box), z=x2[2], vx=v2[0],
            vy=v2[1], vz=v2[2])
    return sim


def test_collision_through_the_shear_boundary_matches_linetree():
    sims, handles = [], []
    for detection in ("sheet", "linetree"):
        sim = boundary_pair("none")
        handles.append(attach(sim, detection, CONSTANT_HALF, log_capacity=4))
        sim.steps(1)
        sims.append(sim)
    sheet_state, linetree_state = phase_space(sims[0]), phase_space(sims[1])
    assert handles[0].stats()["count"] == handles[1].stats()["count"] == 1
    assert sims[0].collisions_log_n == sims[1].collisions_log_n == 1
    assert sims[0].collisions_plog == pytest.approx(sims[1].collisions_plog, rel=1e-9)
    scale = np.max(np.abs(linetree_state), axis=0)
    assert np.all(np.abs(sheet_state - linetree_state) <= 1e-9 * scale), \
        "sheet detector and linetree disagree"
    log = handles[0].stats()["log"][0]
    assert log["epsilon"] == 0.5 and log["v_n"] > 0.5 * 3.0 * (R1 + R2) / (1e-3 * ORBIT)


# --- the detector against REBOUND's brute-force swept-path search ---------------------------

def random_sheet(collision: str, seed: int, n: int = 300, box: float = 60.0):
    """A sheared box at t = 1.97 orbits with fast random motions, 5e-3 orbit steps."""
    rng = np.random.default_rng(seed)
    sim = sheared_box(collision, box, 5e-3, 1.97 * ORBIT)
    for _ in range(n):
        x, y = rng.uniform(-box / 2, box / 2, 2)
        radius = rng.uniform(0.5, 2.0)
        sim.add(m=900.0 * radius**3, r=radius, x=x, y=y, z=rng.normal(0.0, 3.0),
                vx=rng.normal(0.0, 0.05), vy=-1.5 * OMEGA * x + rng.normal(0.0, 0.05),
                vz=rng.normal(0.0, 0.05))
    return sim


# A box of 60 m is narrower than two spans of the search (cells of 16 m): every pair is
# looked at from its particle of lower index; one of 200 m is wider, and pairs inside the
# primary box are looked at from one side of the grid only (rs_sheet_detect.c, Method 3's
# half shell).  Both must find exactly REBOUND's pairs, each once.
@pytest.mark.parametrize("seed, n, box, half_shell",
                         [(3, 300, 60.0, False), (4, 300, 60.0, False),
                          (3, 3300, 200.0, True), (4, 3300, 200.0, True)])
def test_detector_finds_exactly_the_pairs_of_rebound_line_search(seed, n, box, half_shell):
    reported = []

    def record(sim_pointer, collision):
        reported.append((min(collision.p1, collision.p2), max(collision.p1, collision.p2)))
        return 0

    brute = random_sheet("line", seed, n, box)
    brute.collision_resolve = record
    brute.steps(1)
    assert len(reported) > 200, "too few swept contacts to test anything"

    sim = random_sheet("none", seed, n, box)
    handle = install_resolver(sim, CONSTANT_HALF)       # detection only below
    sim.steps(1)
    np.testing.assert_array_equal(phase_space(sim), phase_space(brute))
    pairs, offsets = handle.detect_pairs()
    assert handle.detector_stats()["half_shell"] is half_shell
    assert len(pairs) == len({tuple(p) for p in pairs}), "each pair reported once"
    assert {tuple(p) for p in pairs} == set(reported)

    # The same particles, some of them not yet wrapped (shifted to an image box, as the
    # detector sees them before REBOUND's boundary check): same pairs, same separations.
    state = phase_space(sim)
    slide = math.fmod(1.5 * OMEGA * box * sim.t, box)
    moved = state.copy()
    outside = np.arange(0, sim.N, 3)
    moved[outside, 0] += box
    moved[outside, 1] -= slide
    moved[outside, 4] -= 1.5 * OMEGA * box
    sim.set_serialized_particle_data(xyz=np.ascontiguousarray(moved[:, :3]),
                                     vxvyvz=np.ascontiguousarray(moved[:, 3:]))
    pairs2, offsets2 = handle.detect_pairs()
    assert {tuple(p) for p in pairs2} == set(reported)
    order = {tuple(p): k for k, p in enumerate(pairs)}
    for (i, j), gb in zip(pairs2, offsets2, strict=True):
        k = order[(i, j)]
        d_wrapped = state[i, :3] + offsets[k, :3] - state[j, :3]
        d_moved = moved[i, :3] + gb[:3] - moved[j, :3]
        np.testing.assert_allclose(d_moved, d_wrapped, rtol=0, atol=1e-9)
        assert gb[4] + moved[i, 4] - moved[j, 4] == pytest.approx(
            offsets[k, 4] + state[i, 4] - state[j, 4], abs=1e-12)


# --- multiple encounters ---------------------------------------------------------------------

def three_bodies(side_mass: float) -> rebound.Simulation:
    """A sphere at rest (r = 2 m) struck within one step from -x and from +x by two spheres
    (r = 0.5 m) whose own paths stay 2.4 m apart."""
    sim = free_box("none")
    sim.rand_seed = 4
    speed = 0.04                                         # [m/s]
    sim.add(m=1e3, r=2.0, x=0.0, y=0.0, z=0.0)
    sim.add(m=side_mass, r=0.5, x=-2.0 - 0.3 * speed * DT, y=0.0, z=1.2, vx=speed)
    sim.add(m=side_mass, r=0.5, x=2.0 + 0.6 * speed * DT, y=0.0, z=-1.2, vx=-speed)
    return sim


# Equal masses: an exact event-driven integration of the three spheres has contacts at
# 25.2 s (A-B), 42.5 s (B-C) and 55.7 s (A-B again) inside the 100 s step; the time-ordered
# detector resolves all three, two of them on a path deflected earlier in the step.
@pytest.mark.parametrize("side_mass, count, multi", [(1e3, 3, 2), (10.0, 2, 0)],
                         ids=["equal-masses", "grains-on-a-boulder"])
def test_multi_encounters_count_particles_deflected_twice_in_a_step(side_mass, count, multi):
    sim = three_bodies(side_mass)
    handle = install_resolver(sim, CONSTANT_HALF, collision_detection="line")
    sim.steps(1)
    stats = handle.stats()
    assert stats["count"] == count, "every contact of the exact event sequence resolved"
    assert stats["multi_encounters"] == multi
    counters = handle.detector_stats()
    assert counters["steps"] == 1 and counters["reports"] == 2 and counters["error"] == "none"


def ring_arrays(n: int, tau: float, dispersion_rOmega: float, seed: int) -> tuple[dict, float]:
    """Particle arrays of a random 1 m ring (Gaussian layer, no overlaps) and its box [m]."""
    rng = np.random.default_rng(seed)
    radii = np.ones(n)
    box = math.sqrt(n * math.pi / tau)
    geometry = SheetGeometry(box, 1, 1, max(1, math.ceil(2000.0 / box)), OMEGA)
    state = sheet.initial_state(radii, geometry, dispersion_rOmega * OMEGA, rng)
    state.update(radius=radii, mass=900.0 * 4.0 / 3.0 * math.pi * radii**3)
    return state, box


def test_dense_ring_runs_at_the_orbit_limit_within_the_detectors_limits(cold_dense_scenario):
    """dt: auto gives line mode 1e-3 orbit even in a cold dense ring, where a particle often
    meets several partners in one step; the time-ordered resolution never reaches its
    limits there (contacts per particle and step, search span)."""
    _, sim, handle = integrate_sheet(cold_dense_scenario("line", "auto"), 1.0)
    assert sim.dt == pytest.approx(1e-3 * ORBIT, rel=1e-15)
    counters = handle.order_stats()
    assert counters["resolved"] > 1000 and counters["rescheduled"] > 0
    assert counters["saturated"] == 0 and counters["span_limited"] == 0, counters


@pytest.fixture(scope="module")
def cold_dense_scenario(line_scenario):
    """Factory ``cold_dense_scenario(detection, dt, n=300)``: 1 m ice, constant eps = 0.5,
    tau = 1: a cold, dense ring."""
    def make(detection: str, dt: float | str, n: int = 300):
        return line_scenario({"planet.Omega": OMEGA, "sheet.optical_depth": 1.0,
                              "sheet.n_particles": n, "output.timeseries_every": 0.1,
                              "output.snapshot_every": 1.0},
                             name="cold-dense", seed=3, restitution=CONSTANT_HALF,
                             integration={"orbits": 1.0, "dt": dt,
                                          "collision_detection": detection})
    return make


def integrate_sheet(sc, orbits: float, every: float = 0.1):
    """Build a sheet from a scenario (line mode: the sheet detector), integrate, and return
    c [m/s], H [m], collisions, multi_encounters and predicted fractions per output."""
    built = sheet.build_sheet(sc)
    sim, handle = built.sim, built.resolver
    if sc.integration.collision_detection == "line" and handle.collision_detection != "line":
        handle.close()
        handle = install_resolver(sim, sc.restitution_dict(), collision_detection="line")
    rows = []
    for k in range(1, int(round(orbits / every)) + 1):
        sim.integrate(k * every * ORBIT, exact_finish_time=0)
        a = sheet.particle_arrays(sim)
        stats = handle.stats()
        handle.reset_stats()
        rate = multi_encounter_rate(a, OMEGA, MULTI_ENCOUNTER_WINDOW_STEPS * 1e-3 * ORBIT,
                                    MULTI_ENCOUNTER_MASS_SHARE)
        rows.append((snapshot.velocity_dispersion(a["x"], a["vx"], a["vy"], a["vz"], OMEGA),
                     snapshot.thickness(a["z"]), stats["count"], stats["multi_encounters"],
                     rate * sim.dt))
    return np.array(rows), sim, handle


def test_straight_path_prediction_is_a_lower_bound_of_measured_multi_encounters(
        cold_dense_scenario):
    """The prediction sees only second contacts already on course at the start of a step;
    the time-ordered detector also resolves those a deflection causes, so the measured
    fraction is larger (1.7-3.6 times in docs/validation.md), and still rare at 1e-3 orbit."""
    rows, _, _ = integrate_sheet(cold_dense_scenario("line", 1e-3), 2.0)
    late = rows[10:]                                   # after one orbit of cooling
    measured = late[:, 3].sum() / late[:, 2].sum()
    predicted = late[:, 4].mean()
    assert late[:, 2].sum() > 2000
    assert predicted < measured < 0.05, f"measured {measured:.4f}, predicted {predicted:.4f}"


def test_cold_dense_equilibrium_agrees_with_tree_reference(cold_dense_scenario):
    """c and H after the transient, line mode at 1e-3 orbit against tree mode at dt: auto,
    each the mean of 4 seeds.  The uncertainty is the seeds' scatter: one run's
    autocorrelation-corrected standard error (~0.35 %) is 4-5 times smaller than the
    seed-to-seed scatter (~1.8 %) of 4-orbit windows, and would reject runs that agree.
    Within 10 % as well: the tree reference itself moves by 3 % with its dt_safety."""
    means = {}
    for detection, dt in (("line", 1e-3), ("tree", "auto")):
        per_seed = []
        for seed in (3, 4, 5, 6):
            sc = with_overrides(cold_dense_scenario(detection, dt), {"seed": seed})
            rows, _, _ = integrate_sheet(sc, 4.0)
            t = np.arange(1, rows.shape[0] + 1) * 0.1
            per_seed.append([timeseries.stationary_mean(t, rows[:, k]).mean for k in (0, 1)])
        means[detection] = np.array(per_seed)
    for k, name in enumerate(("velocity dispersion", "thickness")):
        line, tree = means["line"][:, k], means["tree"][:, k]
        error = math.hypot(line.std(ddof=1), tree.std(ddof=1)) / math.sqrt(line.size)
        z = (line.mean() - tree.mean()) / error
        assert abs(z) < 3.0, \
            f"{name}: line {line.mean():.4g} vs tree {tree.mean():.4g} ({z:+.1f} sigma)"
        assert abs(line.mean() / tree.mean() - 1.0) < 0.1, f"{name} within 10%"


# --- restart -------------------------------------------------------------------------------

def test_line_mode_resume_from_binary_is_bit_identical(tmp_path, cold_dense_scenario):
    sc = cold_dense_scenario("line", 1e-3, n=200)
    _, sim, handle = integrate_sheet(sc, 0.3)
    path = tmp_path / "checkpoint.bin"
    sim.save_to_file(str(path), delete_file=True)
    rand_seed = sim.rand_seed
    sim.integrate(0.6 * ORBIT, exact_finish_time=0)

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="You have to reset function pointers")
        resumed = rebound.Simulation(str(path))
    resumed.rand_seed = rand_seed
    install_resolver(resumed, sc.restitution_dict(), collision_detection="line")
    resumed.integrate(0.6 * ORBIT, exact_finish_time=0)
    assert resumed.t == sim.t and resumed.collisions_log_n == sim.collisions_log_n
    np.testing.assert_array_equal(phase_space(resumed), phase_space(sim))


# --- installation ----------------------------------------------------------------------------

def test_sheet_detector_installation_is_checked():
    with pytest.raises(ValueError, match="collision_detection"):
        install_resolver(free_box("none"), CONSTANT_HALF, collision_detection="octree")
    sim = free_box("none")
    sim.boundary = "open"
    with pytest.raises(ValueError, match="shear"):
        install_resolver(sim, CONSTANT_HALF, collision_detection="line")
    sim = free_box("tree")
    handle = install_resolver(sim, CONSTANT_HALF, collision_detection="line")
    assert sim.collision == "none", "REBOUND's own search is switched off"
    handle.close()
    assert sim.extras is None
    assert ctypes.cast(sim._post_timestep_modifications, ctypes.c_void_p).value is None
