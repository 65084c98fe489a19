"""The sheet detector resolves the contacts of a step in time order.

What is checked, and to what tolerance:

* three bodies in one step: B at rest, A strikes it at 20% of the step, and B's recoil
  carries it into C at 60% - a contact that does not exist on the paths before the first
  collision - or C is on course for B anyway but B's recoil changes where and when they
  meet.  One step of dt gives the state of ten steps of dt/10 (where each step holds at
  most one collision per particle).  In a force-free box the paths are exact straight
  lines, so the two runs differ only by the round-off of the contact times and of the
  drifts (measured below 1e-15 of the scale): tolerance 1e-10 of the scale (speed x dt for
  positions, speed for velocities), far below the 0.1 to 1 that a contact resolved out of
  order or missed costs.  In a shearing sheet at 1e-3 orbit, across the radial boundary,
  the detector's straight paths approximate the epicycles to first order in Omega dt:
  tolerance 5 Omega dt of the scale (measured 0.63 Omega dt in positions and 1.93 Omega dt
  in velocities, proportional to dt from 2.5e-4 to 1e-3 orbit);
* on a hot random sheet (several contacts per particle and step), after one step no pair
  overlaps by more than round-off (1e-12 of the sum of the radii), momentum is conserved
  to 1e-12 of sum(m |v|), the resolution is deterministic, and no particle reaches the
  contact cap;
* multi_encounters counts the collisions after a deflection in the same step (time order);
* eps = 0 chains (inelastic collapse: infinitely many collisions at one instant) are cut by
  the contact cap and end at the common velocity to round-off, momentum conserved.
"""

from __future__ import annotations

import ctypes
import importlib.util
import math

import numpy as np
import pytest
import rebound

from ringsim.engine.resolver import install_resolver

OMEGA = 2e-4                       # [1/s]
ORBIT = 2.0 * math.pi / OMEGA      # [s]
EPS_HALF = {"model": "constant", "epsilon": 0.5}

# Local ctypes declarations of the detector's C functions (not declared in ringsim/resolver.py).
_LIB = ctypes.CDLL(importlib.util.find_spec("ringsim._resolver").origin)
_LIB.rs_sheet_step.restype = None
_LIB.rs_sheet_step.argtypes = [ctypes.c_void_p]


def phase_space(sim: rebound.Simulation) -> np.ndarray:
    """(N, 6) array of x, y, z [m], vx, vy, vz [m/s]."""
    xyz = np.zeros((sim.N, 3))
    vxyz = np.zeros((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vxyz)
    return np.hstack([xyz, vxyz])


def empty_box(box: float, dt: float, Omega: float = 0.0, t: float = 0.0) -> rebound.Simulation:
    """A box without gravity: periodic and force-free (leapfrog: exact straight lines), or
    a shearing sheet (SEI) at time t [s] if Omega [1/s] > 0."""
    sim = rebound.Simulation()
    if Omega > 0.0:
        sim.OMEGA = Omega
        sim.integrator = "sei"
        sim.boundary = "shear"
    else:
        sim.integrator = "leapfrog"
        sim.boundary = "periodic"
    sim.gravity = "none"
    sim.collision = "none"
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.N_ghost_z = 0
    sim.dt = dt
    sim.t = t
    return sim


# --- three bodies in one step ----------------------------------------------------------------

RADII = (0.8, 1.0, 0.6)            # [m] A, B, C
MASSES = (600.0, 1000.0, 400.0)    # [kg]


def three_body_state(dt: float, speed: float, c_on_course: bool) -> tuple[np.ndarray, ...]:
    """Positions and velocities (3, 3) of A, B, C at the start of a step of length dt [s],
    relative to B (at rest at the origin).

    A moves at ``speed`` [m/s] and touches B obliquely at 0.2 dt.  B recoils (eps = 0.5) and
    touches C at 0.6 dt.  If ``c_on_course`` is False, C drifts slowly and would pass B at
    more than 0.6 m without A's push; if True, it is on course for B (contact at about
    0.8 dt on the first paths) and A's push makes them meet earlier and elsewhere.
    """
    ra, rb, rc = RADII
    ma, mb, _ = MASSES
    t1, t2 = 0.2 * dt, 0.6 * dt
    va = speed * np.array([1.0, 0.0, 0.08])
    n_ab = np.array([-0.9, -0.3, 0.2])
    n_ab /= np.linalg.norm(n_ab)                       # from B to A at the contact
    xa = (ra + rb) * n_ab - va * t1
    impulse = 1.5 * np.dot(va, -n_ab) * ma * mb / (ma + mb)
    vb = impulse / mb * (-n_ab)                        # B after A's push
    if c_on_course:
        vc = speed * np.array([-0.9, -0.35, 0.1])
        u = vb / np.linalg.norm(vb) + np.array([0.0, -0.3, 0.25])
    else:
        vc = speed * np.array([-0.08, -0.24, 0.0])
        u = vb / np.linalg.norm(vb) + np.array([0.0, 0.45, -0.2])
    u /= np.linalg.norm(u)                             # from B to C at the contact
    xc = vb * (t2 - t1) + (rb + rc) * u - vc * t2
    return np.array([xa, np.zeros(3), xc]), np.array([va, np.zeros(3), vc])


def three_body_sim(dt_run: float, dt_step: float, speed: float, c_on_course: bool,
                   sheared: bool) -> rebound.Simulation:
    """The three bodies in a force-free periodic box, or in a shearing sheet with B at rest
    in the shear frame just inside the radial boundary (A and C across it, as images)."""
    x, v = three_body_state(dt_step, speed, c_on_course)
    if sheared:
        box = 40.0
        sim = empty_box(box, dt_run, OMEGA, t=2.37 * ORBIT)
        slide = math.fmod(1.5 * OMEGA * box * sim.t, box)
        origin = np.array([0.5 * box - 1.5, 3.0, 0.0])
        x = x + origin
        v = v.copy()
        v[:, 1] += -1.5 * OMEGA * x[:, 0]              # the shear flow at each position
        outside = x[:, 0] > 0.5 * box                  # put them into the box, as images
        x[outside] += np.array([-box, slide, 0.0])
        v[outside, 1] += 1.5 * OMEGA * box
        x[:, 1] -= box * np.round(x[:, 1] / box)
        assert outside.any(), "the test needs a pair across the radial boundary"
    else:
        sim = empty_box(200.0, dt_run)
    for k in range(3):
        sim.add(m=MASSES[k], r=RADII[k], x=x[k, 0], y=x[k, 1], z=x[k, 2], vx=v[k, 0],
                vy=v[k, 1], vz=v[k, 2])
    # Unused by the time-ordered detector; fixed so that the test is reproducible also with
    # the former shuffled resolution, which with this seed resolves B-C before A-B.
    sim.rand_seed = 4
    return sim


@pytest.mark.parametrize("sheared", [False, True], ids=["free-box", "shearing-sheet"])
@pytest.mark.parametrize("c_on_course", [False, True], ids=["deflected-into-C", "C-on-course"])
def test_three_body_step_equals_ten_short_steps(c_on_course, sheared):
    dt = 1e-3 * ORBIT if sheared else 100.0            # [s]
    speed = 5.0 / dt                                   # [m/s]: 5 m per step, 2 diameters
    one = three_body_sim(dt, dt, speed, c_on_course, sheared)
    ten = three_body_sim(dt / 10, dt, speed, c_on_course, sheared)
    handles = [install_resolver(s, EPS_HALF, collision_detection="line") for s in (one, ten)]
    start = phase_space(one)
    one.steps(1)
    ten.steps(10)
    assert one.t == pytest.approx(ten.t, rel=1e-14)

    stats_one, stats_ten = handles[0].stats(), handles[1].stats()
    assert stats_ten["count"] == 2 and stats_ten["multi_encounters"] == 0, \
        "the reference: two collisions, in different short steps"
    assert stats_one["count"] == 2, "both collisions in the one long step"
    assert stats_one["multi_encounters"] == 1, "B was deflected before it met C"

    got, ref = phase_space(one), phase_space(ten)
    if sheared:
        box = 40.0
        shift = np.round((got[:, 0] - ref[:, 0]) / box)    # wrapped differently: same image
        slide = math.fmod(1.5 * OMEGA * box * one.t, box)
        got[:, 0] -= shift * box
        got[:, 1] += shift * slide
        got[:, 4] += shift * 1.5 * OMEGA * box
        got[:, 1] -= box * np.round((got[:, 1] - ref[:, 1]) / box)
        tolerance = 5.0 * OMEGA * dt                   # straight paths for epicycles
    else:
        tolerance = 1e-10                              # round-off only
    np.testing.assert_allclose(got[:, :3], ref[:, :3], rtol=0, atol=tolerance * speed * dt,
                               err_msg="positions after one step vs ten short steps")
    np.testing.assert_allclose(got[:, 3:], ref[:, 3:], rtol=0, atol=tolerance * speed,
                               err_msg="velocities after one step vs ten short steps")
    momentum = np.asarray(MASSES) @ start[:, 3:]
    if not sheared:
        np.testing.assert_allclose(np.asarray(MASSES) @ got[:, 3:], momentum, rtol=0,
                                   atol=1e-13 * sum(MASSES) * speed)
    counters = handles[0].order_stats()
    assert counters["resolved"] == 2 and counters["rescheduled"] == 1
    assert counters["saturated"] == 0 and counters["span_limited"] == 0


# --- a hot random sheet ----------------------------------------------------------------------

def hot_sheet(seed: int, n: int = 400, box: float = 50.0) -> rebound.Simulation:
    """A sheared box at t = 1.3 orbits, radii 0.5-2 m, random speeds of 0.1 m/s relative to
    the shear flow: at 1e-3 orbit a particle moves about 3 m, several contacts per particle
    and step.  No overlaps at the start of the step (the state is taken as its start)."""
    rng = np.random.default_rng(seed)
    sim = empty_box(box, 1e-3 * ORBIT, OMEGA, t=1.3 * ORBIT)
    slide = math.fmod(1.5 * OMEGA * box * sim.t, box)
    positions = np.zeros((0, 3))
    radii = np.zeros(0)
    while radii.size < n:
        p = np.array([rng.uniform(-box / 2, box / 2), rng.uniform(-box / 2, box / 2),
                      rng.normal(0.0, 1.5)])
        radius = rng.uniform(0.5, 2.0)
        if np.all(np.linalg.norm(_nearest(p - positions, box, slide), axis=1) > radius + radii):
            positions = np.vstack([positions, p])
            radii = np.append(radii, radius)
    for p, radius in zip(positions, radii, strict=True):
        v = rng.normal(0.0, 0.1, 3)
        sim.add(m=900.0 * radius**3, r=radius, x=p[0], y=p[1], z=p[2], vx=v[0],
                vy=-1.5 * OMEGA * p[0] + v[1], vz=v[2])
    return sim


def _nearest(d: np.ndarray, box: float, slide: float) -> np.ndarray:
    """Nearest images of separations d (k, 3) [m] in a shear-periodic box: x - box goes
    with y + slide (REBOUND's ghost boxes), then periodic in y."""
    d = d.copy()
    m = np.round(d[:, 0] / box)
    d[:, 0] -= m * box
    d[:, 1] += m * slide
    d[:, 1] -= box * np.round(d[:, 1] / box)
    return d


def resolve_one_step(sim: rebound.Simulation, handle) -> None:
    """The collisions of one step of dt = sim.dt that has brought the particles where they
    are (the state at the end of the step), resolved by the sheet detector directly: no
    integrator, so that momentum changes by the collisions only."""
    sim.dt_last_done = sim.dt
    _LIB.rs_sheet_step(ctypes.addressof(sim))
    assert handle.detector_stats()["error"] == "none"


def test_hot_sheet_step_leaves_no_overlap_and_conserves_momentum():
    sim = hot_sheet(seed=7)
    handle = install_resolver(sim, EPS_HALF, collision_detection="line")
    masses = np.array([p.m for p in sim.particles])
    radii = np.array([p.r for p in sim.particles])
    # Move the particles on by one step along straight lines: the state is then the end of
    # a step whose start had no overlaps, and the detector sees crossings, not overlaps.
    state = phase_space(sim)
    end = state.copy()
    end[:, :3] += sim.dt * state[:, 3:]
    sim.set_serialized_particle_data(xyz=np.ascontiguousarray(end[:, :3]))
    sim.dt_last_done = sim.dt
    pairs, _ = handle.detect_pairs()
    assert len(pairs) > 0.5 * sim.N, "too few contacts to test anything"
    momentum = masses @ end[:, 3:]

    resolve_one_step(sim, handle)
    after = phase_space(sim)
    stats = handle.stats()
    assert stats["count"] >= len(pairs) // 2
    assert stats["multi_encounters"] > 0.1 * stats["count"], "a hot step: many multiples"

    scale = masses @ np.abs(end[:, 3:]).sum(axis=1)    # sum m |v| [kg m/s]
    np.testing.assert_allclose(masses @ after[:, 3:], momentum, rtol=0, atol=1e-12 * scale,
                               err_msg="momentum conserved by the collisions")

    # Every pair overlapping at the end of the step would be found by the detector.
    pairs, offsets = handle.detect_pairs()
    d = after[pairs[:, 0], :3] + offsets[:, :3] - after[pairs[:, 1], :3]
    distance = np.sqrt(np.sum(d * d, axis=1))
    contact = radii[pairs[:, 0]] + radii[pairs[:, 1]]
    depth = (contact - distance) / contact
    assert depth.max() <= 1e-12, \
        f"pair {pairs[np.argmax(depth)]} overlaps by {depth.max():.3g} of the sum of radii"

    # Deterministic: the same state resolved again gives the same bits.
    again = hot_sheet(seed=7)
    handle_again = install_resolver(again, EPS_HALF, collision_detection="line")
    again.set_serialized_particle_data(xyz=np.ascontiguousarray(end[:, :3]))
    resolve_one_step(again, handle_again)
    np.testing.assert_array_equal(phase_space(again), after)

    counters = handle.order_stats()
    assert counters["rescheduled"] > 0, "contacts found on paths changed within the step"
    assert counters["saturated"] == 0 and counters["span_limited"] == 0


# --- eps = 0 ---------------------------------------------------------------------------------

def test_perfectly_inelastic_chain_is_cut_and_conserves_momentum():
    """eps = 0, A strikes B, which touches C: every collision leaves the next pair touching
    and approaching (A-B, B-C, A-B, ... each after a third body's push, so each is allowed),
    an infinite sequence at one instant (inelastic collapse).  The contact cap ends the step;
    the next step goes on from where it stopped until the approach speeds fall below
    round-off, and all three end with the common velocity v/3, momentum conserved."""
    speed = 0.05                                         # [m/s]
    sim = empty_box(200.0, 100.0)
    sim.add(m=1e3, r=1.0, x=-2.0 - 0.5 * speed * 100.0, vx=speed)
    sim.add(m=1e3, r=1.0, x=0.0)
    sim.add(m=1e3, r=1.0, x=2.0)                         # touching B, at rest
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.0},
                              collision_detection="line")
    sim.steps(1)
    count = handle.stats()["count"]
    assert 8 < count <= 64, f"{count} collisions: a chain, cut"
    sim.steps(3)
    state = phase_space(sim)
    np.testing.assert_allclose(state[:, 3], speed / 3.0, rtol=1e-12)
    np.testing.assert_allclose(1e3 * state[:, 3].sum(), 1e3 * speed, rtol=1e-14)
    assert np.all(np.diff(state[:, 0]) >= 2.0 - 1e-9), "in order, not overlapping"
    assert handle.order_stats()["saturated"] == 1, "B reached the contact cap (once)"


# --- a large particle among grains -----------------------------------------------------------

def test_large_particle_meets_more_grains_than_the_cap_in_one_step():
    """A 2 m boulder crosses a lattice of 1 cm grains at rest and meets about a hundred of
    them in one step.  The contact cap counts only the contacts that deflect a particle
    (a partner of at least a tenth of the pair's mass): the boulder, hardly turned by any
    grain, keeps meeting them, and after the step no grain is left inside it (overlap at
    most round-off, 1e-12 of the sum of the radii), momentum conserved to 1e-12 of
    sum(m |v|).  Counting every contact, the boulder would stop at the cap and the grains
    after it would pass into it."""
    dt, speed = 100.0, 0.1                     # [s], [m/s]: the boulder moves 10 m
    sim = empty_box(60.0, dt)
    sim.add(m=1e7, r=2.0, x=-8.0, vx=speed)    # [kg], [m] ~ porous ice
    grid = np.arange(-1.75, 1.76, 0.5)         # [m] grains across the boulder's path
    for x in np.arange(-5.5, 7.0, 0.5):
        for y in grid:
            for z in grid:
                sim.add(m=2e-3, r=0.01, x=x, y=y, z=z)
    handle = install_resolver(sim, EPS_HALF, collision_detection="line")
    state = phase_space(sim)
    end = state.copy()
    end[:, :3] += dt * state[:, 3:]            # the end of a step that started apart
    sim.set_serialized_particle_data(xyz=np.ascontiguousarray(end[:, :3]))
    masses = np.array([p.m for p in sim.particles])
    radii = np.array([p.r for p in sim.particles])
    momentum = masses @ end[:, 3:]

    resolve_one_step(sim, handle)
    after = phase_space(sim)
    assert handle.stats()["count"] > 3 * 32, "more grains met than the cap"
    scale = masses @ np.abs(end[:, 3:]).sum(axis=1)
    np.testing.assert_allclose(masses @ after[:, 3:], momentum, rtol=0, atol=1e-12 * scale)
    d = after[1:, :3] - after[0, :3]
    depth = (radii[1:] + radii[0] - np.sqrt(np.sum(d * d, axis=1))) / (radii[1:] + radii[0])
    assert depth.max() <= 1e-12, f"{np.sum(depth > 1e-12)} grains inside the boulder"
    assert handle.order_stats()["saturated"] == 0
