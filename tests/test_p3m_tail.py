"""P3M with the sparse high tail apart (``sheet.p3m_tail_fraction``, docs/gravity.md 4b):
the mesh's layers span the dense core of the heights, the few particles beyond are on the
mesh at its limits.  Forces against the converged shear-periodic image sum in thick rings
with a long tail and in a thin ring, momentum, the choice of the core as a function of the
state, the scenario key and a bit-exact resume with the tail apart."""

import numpy as np
import pytest

from ringsim import testing
from ringsim.gravity import p3m
from ringsim.physics import p3m_scales as scales
from ringsim.physics import selfgravity as sg
from ringsim.physics.p3m_mesh import core_heights

T_REF = 2345.6    # s: a non-trivial shear offset


def tailed_sheet(n, radius, sigma, tail=0.03, seed=3):
    """A random tau = 0.5 sheet of ``n`` particles of ``radius`` [m] whose heights are a
    Gaussian of rms ``sigma`` [m] with ``tail`` of the particles at 3-6 sigma (random
    sides): the shape of the production rings' heights (docs/performance.md, "Where the
    production step goes": rms 44 m, 99 % within 133 m, the highest at 268 m)."""
    s = testing.random_sheet(n, radius=radius, dispersion=sigma * 2.0e-4, seed=seed)
    rng = np.random.default_rng(seed + 100)
    z = s["pos"][:, 2]
    z = (z - z.mean()) / z.std() * sigma
    k = int(tail * n)
    idx = rng.choice(n, k, replace=False)
    z[idx] = rng.choice([-1.0, 1.0], k) * rng.uniform(3.0, 6.0, k) * sigma
    s["pos"][:, 2] = z
    return s


def errors_and_layers(s, tail_fraction, n_targets=200):
    """(force errors, P3M parameters, accelerations) of ``s`` with the auto split."""
    sim = testing.p3m_simulation(s, t=T_REF, auto=True, tail_fraction=tail_fraction)
    acc = testing.accelerations(sim)
    n = len(s["mass"])
    targets = np.sort(np.random.default_rng(0).choice(n, min(n, n_targets), replace=False))
    shift = sg.shear_offset(s["geometry"].Omega, s["Lx"], s["Ly"], T_REF)
    ref = sg.direct_accelerations(s["pos"], s["mass"], s["Lx"], s["Ly"], shift,
                                  0.1 * float(np.min(s["radius"])), n_rows=4,
                                  targets=targets, chunk=16)
    return testing.force_errors(acc[targets], ref), p3m.installed_solver(sim).params, acc


def test_core_heights_are_order_statistics_of_the_state():
    """At most the fraction lies beyond the core, half on each side; the result does not
    depend on the particles' order; a fraction below 2 / N keeps every particle."""
    z = np.random.default_rng(1).normal(0.0, 40.0, 1001)
    zlo, zhi = core_heights(z, 0.02)
    assert np.sum(z < zlo) == np.sum(z > zhi) == 10          # floor(0.02 x 1001 / 2)
    assert core_heights(z[::-1].copy(), 0.02) == (zlo, zhi)
    assert core_heights(z, 0.0019) == (z.min(), z.max())
    assert core_heights(z, 0.0) == (z.min(), z.max())


@pytest.mark.parametrize("n, radius, sigma, layers_before, layers_after", [
    (2000, 2.0, 44.0, 94, 60),
    (2400, 1.6, 183.0, 356, 182),
])
def test_thick_ring_with_a_long_tail_is_within_half_a_percent(n, radius, sigma,
                                                              layers_before, layers_after):
    """rms height 44 m (the kappa = 0 production ring) and 183 m (the hot kappa = 0.1 ring),
    each with 3 % of the particles at 3-6 sigma: at the default tail fraction the mesh has
    fewer layers and the rms per-particle force error against the direct sum stays within
    0.5 % (issue's bound; measured 0.396 % and 0.285 %, against 0.394 % and 0.285 % with the
    layers spanning every particle), no more than 0.05 % above the full mesh's; the forces
    sum to zero to round-off (measured 1e-15 of M rms|a|; bound as tests/test_p3m.py's
    thick ring)."""
    s = tailed_sheet(n, radius, sigma)
    assert np.std(s["pos"][:, 2]) >= 40.0
    before, par_before, _ = errors_and_layers(s, 0.0)
    after, par_after, acc = errors_and_layers(s, scales.P3M_TAIL_FRACTION)
    assert (par_before.nz, par_after.nz) == (layers_before, layers_after)
    assert par_after.split == par_before.split     # the split follows the whole span
    z = s["pos"][:, 2]
    assert np.sum((z > par_after.zhi) | (z < par_after.zlo)) > 0.005 * n   # a tail apart
    assert after["rms_relative"] < 0.005, after
    assert after["rms_relative"] < before["rms_relative"] + 0.0005, (before, after)
    force = s["mass"][:, None] * acc
    assert np.all(np.abs(force.sum(axis=0)) < 1e-12 * np.abs(force).sum(axis=0))


def test_thin_ring_keeps_the_full_mesh_bit_for_bit():
    """A thin Gaussian ring (rms height 3 m = r_s, highest particle at 3.6 sigma) lies
    within the core widened by P3M_TAIL_MARGIN_SPLITS r_s: the default gives the full
    mesh's forces (==).  Their error is the P3M defaults' (measured 0.63 %; bound 1 %,
    issue 12's accuracy of the defaults, tests/test_p3m.py)."""
    s = tailed_sheet(1000, 1.0, 3.0, tail=0.0)
    before, _, acc_before = errors_and_layers(s, 0.0)
    after, par, acc_after = errors_and_layers(s, scales.P3M_TAIL_FRACTION)
    z = s["pos"][:, 2]
    assert (par.zlo, par.zhi) == (z.min(), z.max())
    assert np.array_equal(acc_before, acc_after)
    assert after["rms_relative"] < 0.01, after


def test_far_tail_particle_conserves_momentum_and_gets_the_direct_force():
    """One particle 35 m above a thin sheet (rms height 2 m; far beyond the mesh, whose
    layers end near 17 m): the forces still sum to zero to round-off (its mesh stencil is
    the same both ways), and its force is the direct sum's within 1 % (mostly the exact mean
    vertical field; measured 0.14 %, 0.06 % with the layers spanning every particle, 1.7 %
without the damping of its mesh weights)."""
    s = testing.random_sheet(600, seed=8)
    s["pos"][0, 2] = 35.0
    sim = testing.p3m_simulation(s, t=T_REF, tail_fraction=0.01)
    acc = testing.accelerations(sim)
    par = p3m.installed_solver(sim).params
    assert par.zhi < 20.0                      # the particle is beyond the mesh
    force = s["mass"][:, None] * acc
    assert np.all(np.abs(force.sum(axis=0)) < 1e-12 * np.abs(force).sum(axis=0))
    shift = sg.shear_offset(s["geometry"].Omega, s["Lx"], s["Ly"], T_REF)
    ref = sg.direct_accelerations(s["pos"], s["mass"], s["Lx"], s["Ly"], shift, 0.1,
                                  n_rows=4, targets=np.array([0]))
    assert testing.force_errors(acc[:1], ref)["rms_relative"] < 0.01


def test_scenario_key_default_range_and_run_file(tmp_path, gravitating_scenario):
    """``sheet.p3m_tail_fraction`` defaults to 0 (the layers span every particle), left out
    of the resolved scenario there (earlier runs keep their identity), a value outside
    [0, 0.5) is refused naming the key, and the run file records it with its unit."""
    import ringsim
    from ringsim.config.schema import ScenarioError

    plain = gravitating_scenario({"integration.orbits": 0.01}, source="<t>")
    assert plain.sheet.p3m_tail_fraction == 0.0
    assert p3m.arguments(plain)["p3m_tail_fraction"] == 0.0
    assert "p3m_tail_fraction" not in plain.to_dict()["sheet"]
    sc = gravitating_scenario({"integration.orbits": 0.01,
                               "sheet.p3m_tail_fraction": scales.P3M_TAIL_FRACTION},
                              source="<t>")
    assert p3m.arguments(sc)["p3m_tail_fraction"] == scales.P3M_TAIL_FRACTION
    assert sc.to_dict()["sheet"]["p3m_tail_fraction"] == scales.P3M_TAIL_FRACTION
    for bad in (0.5, -0.1):
        with pytest.raises(ScenarioError, match="p3m_tail_fraction"):
            gravitating_scenario({"sheet.p3m_tail_fraction": bad}, source="<t>")
    attrs = ringsim.open_run(ringsim.run(sc, output=tmp_path / "g.h5",
                                         progress=False)).attrs
    assert attrs["p3m_tail_fraction"] == scales.P3M_TAIL_FRACTION
    assert attrs["units_p3m_tail_fraction"].startswith("1 ")


def test_hot_run_with_the_tail_apart_resumes_bit_for_bit(tmp_path, gravitating_scenario):
    """The core is a function of the state alone: a hot run whose mesh leaves a tail
    beyond its layers, stopped and resumed (its solver made anew), is the uninterrupted
    run, bit for bit."""
    from ringsim.engine import sheet

    sc = gravitating_scenario(source="<t>", **{"sheet.n_particles": 600,
                                               "sheet.initial_dispersion": 60.0,
                                               "sheet.p3m_tail_fraction":
                                                   scales.P3M_TAIL_FRACTION,
                                               "integration.collision_detection": "line"})
    built = sheet.build_sheet(sc)
    built.sim.steps(1)
    par = p3m.installed_solver(built.sim).params
    z = np.array([p.z for p in built.sim.particles])
    assert np.sum((z > par.zhi) | (z < par.zlo)) > 0             # a tail apart
    a, _ = testing.assert_resumes_bit_for_bit(sc, tmp_path, stop_orbits=0.1, snapshot=2)
    assert a.n_snapshots == 3


def test_tail_apart_gives_the_same_bits_on_one_and_two_threads():
    """The second pass of the pair sum (the pairs with a particle beyond the mesh) is a
    gather per target in a fixed order, as the first: the accelerations are identical (==)
    on 1 and 2 threads.  5000 particles (above the 2048 per thread at which a second thread
    starts, RS_P3M_PARTICLES_PER_THREAD), rms height 44 m with a 3 % tail."""
    s = tailed_sheet(5000, 1.0, 44.0)
    results = []
    for threads in (1, 2):
        sim = testing.p3m_simulation(s, t=T_REF, auto=True,
                                     tail_fraction=scales.P3M_TAIL_FRACTION)
        p3m.installed_solver(sim).set_threads(threads)
        results.append(testing.accelerations(sim))
        par = p3m.installed_solver(sim).params
        z = s["pos"][:, 2]
        assert np.sum((z > par.zhi) | (z < par.zlo)) > 0.005 * len(z)
    assert np.array_equal(results[0], results[1])
