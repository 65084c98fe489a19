"""Spins between collisions: a torque-free spin is constant in inertial space.

In the rotating frame's axes its x, y components turn at -Omega (w_z is unchanged: the
frame's own rotation is along z).  The resolver keeps x, y in the axes the frame had at
t = 0 and turns them by Omega t at each collision (the contact time) and at each read.

* A particle spun about x (and one about y and z) with no collisions shows
  w_x + i w_y = w_0 exp(-i Omega t) at every output, w_z unchanged.
* A collision after a time gap T: the C result is the numpy reference rule applied to the
  spins rotated by hand by -Omega T, velocities bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import rebound
import test_friction as tf
from test_resolver import ORBIT

from ringsim.engine.resolver import collision_records, install_resolver
from ringsim.physics import friction as fr

RESTITUTION = {"model": "constant", "epsilon": 0.5}
ROUGH = {"model": "constant", "beta": 0.0}


def _rotated(w: np.ndarray, theta: float) -> np.ndarray:
    """w turned by -theta about z (by hand: the rotating frame's axes at angle theta)."""
    c, s = math.cos(theta), math.sin(theta)
    return np.stack([c * w[:, 0] + s * w[:, 1], c * w[:, 1] - s * w[:, 0], w[:, 2]], axis=1)


def test_free_spins_precess_at_minus_omega_in_the_rotating_frame():
    sim = rebound.Simulation()
    sim.OMEGA = sim.OMEGAZ = tf.OMEGA
    sim.integrator = "sei"
    sim.dt = 1e-3 * ORBIT
    for x in (-100.0, 100.0):         # far apart, on circular orbits: never collide
        sim.add(m=1.0, r=1.0, x=x, vy=-1.5 * tf.OMEGA * x)
    handle = install_resolver(sim, RESTITUTION, ROUGH)
    w0 = np.array([[3e-4, 0.0, 0.0], [0.0, 2e-4, -5e-4]])      # [rad/s]
    handle.set_spins(w0)
    for orbits in (0.1, 0.25, 0.6, 1.0, 2.35):
        sim.integrate(orbits * ORBIT)
        phase = tf.OMEGA * sim.t
        expected = np.stack([w0[:, 0] * math.cos(phase) + w0[:, 1] * math.sin(phase),
                             w0[:, 1] * math.cos(phase) - w0[:, 0] * math.sin(phase),
                             w0[:, 2]], axis=1)
        w = handle.spins()
        # tolerance: the rounding of the angle Omega t (< 16 rad here) and of two products
        assert np.allclose(w, expected, rtol=0.0, atol=1e-14 * 3e-4), orbits
        assert np.array_equal(w[:, 2], w0[:, 2]), "w_z unchanged"
        assert np.allclose(np.hypot(w[:, 0], w[:, 1]), np.hypot(w0[:, 0], w0[:, 1]),
                           rtol=1e-15, atol=0.0), "in-plane spin magnitude kept"
    assert handle.stats()["count"] == 0
    # a quarter orbit turns the x spin to -y in the rotating frame's axes
    assert math.sin(tf.OMEGA * sim.t) > 0.5 and w[0, 1] < -0.5 * 3e-4


def test_inertial_frame_spins_do_not_precess():
    sim = rebound.Simulation()          # OMEGA = 0: an inertial box
    sim.add(m=1.0, r=1.0, x=-10.0)
    sim.add(m=1.0, r=1.0, x=10.0)
    handle = install_resolver(sim, RESTITUTION, ROUGH)
    w0 = np.array([[3e-4, 1e-4, 0.0], [0.0, 2e-4, -5e-4]])
    handle.set_spins(w0)
    sim.integrate(1e4)
    assert np.array_equal(handle.spins(), w0)


def test_collision_after_a_time_gap_uses_the_precessed_spins():
    c = tf.RoughCollisionChecks.collisions(tf.RoughCollisionChecks(), 7)
    gap = 0.37 * ORBIT          # [s]
    theta = tf.OMEGA * gap
    # The pairs in one simulation, spins set at t = 0, the clock moved on by ``gap`` (no
    # motion: only the frame turns), then every pair resolved once.
    n = c["R1"].size
    w0 = np.empty((2 * n, 3))
    w0[0::2], w0[1::2] = c["w1"], c["w2"]
    sim2 = rebound.Simulation()
    sim2.OMEGA = tf.OMEGA
    for i in range(n):
        for x, v, m, r in ((c["x1"][i], c["v1"][i], c["M1"][i], c["R1"][i]),
                           (c["x2"][i], c["v2"][i], c["M2"][i], c["R2"][i])):
            sim2.add(m=m, r=r, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
    handle2 = install_resolver(sim2, RESTITUTION, ROUGH)
    handle2.set_spins(w0)                          # at t = 0: stored as given
    assert np.array_equal(handle2.spin_state(), w0)
    sim2.t = gap
    before = np.array([[p.vx, p.vy, p.vz] for p in sim2.particles])
    pairs = np.stack([np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)], axis=1)
    assert handle2.resolve_batch(collision_records(pairs, tf.NO_GHOST)) == n
    after = np.array([[p.vx, p.vy, p.vz] for p in sim2.particles])

    dr = c["x1"] - c["x2"]
    dv = c["v1"] - c["v2"]
    w1, w2 = _rotated(c["w1"], theta), _rotated(c["w2"], theta)
    imp = fr.collision_impulse(dr, dv, w1, w2, c["R1"], c["R2"], c["M1"], c["M2"], 0.5, ROUGH)
    assert np.array_equal(after[0::2], before[0::2] + imp.dv1), "v1 == reference(rotated)"
    assert np.array_equal(after[1::2], before[1::2] + imp.dv2), "v2 == reference(rotated)"
    stale = fr.collision_impulse(dr, dv, c["w1"], c["w2"], c["R1"], c["R2"], c["M1"],
                                 c["M2"], 0.5, ROUGH)
    assert not np.allclose(imp.dv1, stale.dv1, rtol=1e-6), "the gap matters"
    # Stored back in the axes at t = 0, exactly as the inverse rotation by hand ...
    new = np.empty((2 * n, 3))
    new[0::2], new[1::2] = w1 + imp.dw1, w2 + imp.dw2
    cs, sn = math.cos(theta), math.sin(theta)
    stored = np.stack([cs * new[:, 0] - sn * new[:, 1], cs * new[:, 1] + sn * new[:, 0],
                       new[:, 2]], axis=1)
    assert np.array_equal(handle2.spin_state(), stored)
    # ... and read at t = gap as the reference's new spins (one rotation there and back:
    # a few units of round-off of the largest spin component)
    scale = np.abs(new).max(axis=1, keepdims=True)
    assert np.all(np.abs(handle2.spins() - new) <= 4 * np.finfo(float).eps * scale)
