"""P3M's mesh every k steps (``sheet.p3m_mesh_interval``, docs/gravity.md "The mesh every k
steps"): the long-range mesh force as an impulse of k steps on the middle step of every k,
the pair sum and the mean vertical field every step.  The impulse's size and schedule, the
trajectory against the mesh every step, the scenario key and a bit-exact resume."""

import math

import numpy as np
import pytest

from ringsim import testing
from ringsim.gravity import p3m

T_REF = 2345.6    # s: a non-trivial shear offset


def _state(sim):
    return np.array([[p.x, p.y, p.z, p.vx, p.vy, p.vz] for p in sim.particles])


def test_impulse_is_k_times_the_mesh_force_on_the_middle_step_only():
    """At one state (same t, same shear offset), with k = 5: on a step whose index
    floor(t / dt) is 2 modulo 5 the accelerations are those of the mesh every step plus
    4 times the mesh's part; on the other steps the mesh's part is absent; the mesh's part
    (the whole force minus the force without it) is a sizeable share of the force, so a
    missing or doubled impulse fails."""
    s = testing.random_sheet(600, seed=4)
    every = testing.accelerations(testing.p3m_simulation(s, t=T_REF))
    sim = testing.p3m_simulation(s, t=T_REF, mesh_interval=5)
    step = math.floor(T_REF / 10.0)             # dt = 10 s: the step index of T_REF
    results = {}
    for shift in range(5):
        sim.dt = T_REF / (step + shift + 0.5)   # t is mid-step of step index step + shift
        results[(step + shift) % 5] = testing.accelerations(sim)
    without = results[0]
    mesh = every - without
    assert np.sqrt(np.mean(np.sum(mesh**2, axis=1))) > 0.1 * np.sqrt(
        np.mean(np.sum(every**2, axis=1)))
    for index in (0, 1, 3, 4):
        assert np.array_equal(results[index], without)
    scale = np.abs(every).max()
    assert np.abs(results[2] - (without + 5.0 * mesh)).max() < 1e-12 * scale


@pytest.mark.parametrize("k, bound", [(3, 2.0e-3), (9, 1.0e-2)])
def test_trajectory_with_the_mesh_every_k_steps_stays_near_every_step(k, bound):
    """400 particles without collisions, 45 steps of 1e-3 orbit (5 and 15 whole intervals
    of 3 and 9 steps): the rms difference of positions and velocities against the mesh
    every step is below ``bound`` times the mesh's own effect (the difference when the
    mesh is left out).  The centred impulse's error grows as k^2 (measured 0.07 % and
    0.64 % of positions; an impulse on the first step of each interval instead of the
    middle one gives 6.5 % at k = 4)."""
    s = testing.random_sheet(400, seed=5, dispersion=2e-3)
    dt = 1e-3 * 2.0 * math.pi / s["geometry"].Omega

    def run(interval):
        sim = testing.p3m_simulation(s, mesh_interval=interval)
        sim.dt = dt
        sim.steps(45)
        return _state(sim)

    # 99: the steps 0 ... 44 hold no middle step (49) of an interval, so no mesh at all
    every, without, sparse = run(1), run(99), run(k)

    def rms(a, b):
        return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))

    for part in (slice(0, 3), slice(3, 6)):
        effect = rms(without[:, part], every[:, part])
        assert effect > 0.0
        assert rms(sparse[:, part], every[:, part]) < bound * effect


def test_scenario_key_run_file_and_bit_exact_resume(tmp_path, gravitating_scenario):
    """``sheet.p3m_mesh_interval`` defaults to 1, left out of the resolved scenario and the
    solver's keywords there (earlier runs keep their identity); an even or fractional value
    is refused naming the key; a run with 7 (0.04 orbit, dt = 5e-4 orbit) stopped inside an
    interval (after step 40: index 40 is 5 modulo 7, past the middle step 3) and resumed is
    the run in one go, bit for bit, and its file records the interval."""
    from ringsim.config.schema import ScenarioError

    plain = gravitating_scenario({"integration.orbits": 0.01}, source="<t>")
    assert plain.sheet.p3m_mesh_interval == 1.0
    assert "p3m_mesh_interval" not in p3m.arguments(plain)
    assert "p3m_mesh_interval" not in plain.to_dict()["sheet"]
    for bad in (2, 2.5, 0, 101):
        with pytest.raises(ScenarioError, match="p3m_mesh_interval"):
            gravitating_scenario({"sheet.p3m_mesh_interval": bad}, source="<t>")
    sc = gravitating_scenario({"sheet.p3m_mesh_interval": 7, "integration.orbits": 0.04,
                               "output.snapshot_every": 0.02,
                               "output.timeseries_every": 0.01}, source="<t>")
    assert sc.to_dict()["sheet"]["p3m_mesh_interval"] == 7
    assert p3m.arguments(sc)["p3m_mesh_interval"] == 7
    a, _ = testing.assert_resumes_bit_for_bit(sc, tmp_path, stop_orbits=0.02)
    assert a.attrs["p3m_mesh_interval"] == 7
