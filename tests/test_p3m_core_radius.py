"""P3M's mesh core set by the large particles' heights (``sheet.p3m_core_min_radius``,
docs/gravity.md "The core of the pair-summed particles"): in a ring whose small particles
stand higher than its large ones, the layers span the large particles' core; forces
against the converged shear-periodic image sum, momentum, the same bits where the core is
unchanged, the choice as a function of the state, and the scenario key."""

import ctypes

import numpy as np
import pytest

from ringsim import testing
from ringsim.config.scenario import with_overrides
from ringsim.gravity import p3m
from ringsim.physics import p3m_scales as scales
from ringsim.physics import selfgravity as sg

T_REF = 2345.6    # s: a non-trivial shear offset
LARGE = 2.0       # [m] radius of the large particles (the small ones: 0.5 m)


def layered_sheet(n, sigma_small, sigma_large, large_fraction=0.1, seed=5):
    """A tau = 0.5 sheet of ``n`` particles, ``large_fraction`` of them of radius LARGE and
    8 times the mass of a 1 m sphere, the rest 0.5 m and 1/8 of it; the heights Gaussian of
    rms ``sigma_small`` and ``sigma_large`` [m]: the A-ring preset's equilibrium has its
    small particles at 19 m rms and its large ones at 8 m (docs/gravity.md).  Returns the
    sheet and the mask of the large particles."""
    s = testing.random_sheet(n, radius=1.0, dispersion=sigma_small * 2.0e-4, seed=seed)
    rng = np.random.default_rng(seed + 7)
    large = np.zeros(n, dtype=bool)
    large[rng.choice(n, int(large_fraction * n), replace=False)] = True
    s["radius"] = np.where(large, LARGE, 0.5)
    s["mass"] = s["mass"] * np.where(large, 8.0, 1.0 / 8.0)
    s["pos"][:, 2] = rng.normal(0.0, 1.0, n) * np.where(large, sigma_large, sigma_small)
    return s, large


def forces(s, core_min_radius, **kwargs):
    """(accelerations [m/s^2], P3M parameters) of ``s``: auto split, the Saturn presets' tail
    fraction, the core of the particles of at least ``core_min_radius`` [m] (``kwargs``:
    further arguments of ``P3MSolver``)."""
    sim = testing.p3m_simulation(s, t=T_REF, auto=True, tail_fraction=scales.P3M_TAIL_FRACTION,
                                 core_min_radius=core_min_radius, **kwargs)
    return testing.accelerations(sim), p3m.installed_solver(sim).params


def assert_core_of_every_particle(s, core_min_radius):
    """``s`` with the core radius has the layers and the forces (==) it has without."""
    every, par_every = forces(s, 0.0)
    core, par_core = forces(s, core_min_radius)
    assert (par_core.nz, par_core.zlo, par_core.zhi) == (par_every.nz, par_every.zlo,
                                                         par_every.zhi)
    assert np.array_equal(core, every)


def momentum_residual(s, acc):
    """|sum m a| over M rms|a| [dimensionless]: 0 where the forces cancel in pairs."""
    scale = np.sum(s["mass"]) * np.sqrt(np.mean(np.sum(acc ** 2, axis=1)))
    return np.abs(s["mass"] @ acc).max() / scale


def reference(s, targets):
    shift = sg.shear_offset(s["geometry"].Omega, s["Lx"], s["Ly"], T_REF)
    return sg.direct_accelerations(s["pos"], s["mass"], s["Lx"], s["Ly"], shift,
                                   0.1 * float(np.min(s["radius"])), n_rows=4,
                                   targets=targets, chunk=16)


def test_thick_ring_keeps_its_accuracy_with_a_third_of_the_layers():
    """Small particles at 45 m rms, large ones at 20 m (the A ring's ratio): the layers
    span the large particles' core (94 -> 39 layers), and the rms per-particle force error
    against the direct sum rises by at most 0.05 % (absolute) over the core of every
    particle, for small and large targets alike (measured: 0.365 -> 0.381 % and 0.699 ->
    0.700 %; the bound is tests/test_p3m_tail.py's for the tail apart against the full
    mesh); the forces sum to zero to round-off (|sum m a| below 1e-12 of M rms|a|, the
    scale of tests/test_p3m_tail.py's bound on the forces' sum)."""
    s, large = layered_sheet(3000, 45.0, 20.0)
    assert np.std(s["pos"][:, 2]) >= 40.0
    rng = np.random.default_rng(0)
    small_t = np.sort(rng.choice(np.flatnonzero(~large), 100, replace=False))
    large_t = np.sort(rng.choice(np.flatnonzero(large), 100, replace=False))
    ref_small, ref_large = reference(s, small_t), reference(s, large_t)
    every, par_every = forces(s, 0.0)
    core, par_core = forces(s, LARGE)
    assert (par_every.nz, par_core.nz) == (94, 39)
    assert par_core.split == par_every.split          # the split follows the whole span
    z = s["pos"][:, 2]
    beyond = ~large & ((z > par_core.zhi) | (z < par_core.zlo))
    assert np.sum(beyond) > 0.1 * np.sum(~large)      # 15 %
    for targets, ref in ((small_t, ref_small), (large_t, ref_large)):
        before = testing.force_errors(every[targets], ref)["rms_relative"]
        after = testing.force_errors(core[targets], ref)["rms_relative"]
        assert after - before < 5e-4, (before, after)
    assert momentum_residual(s, core) < 1e-12


def test_thin_ring_core_is_unchanged_bit_for_bit():
    """Where the large particles' core widened by its margin holds every particle, the mesh
    is the same and so is every force (==)."""
    assert_core_of_every_particle(layered_sheet(3000, 3.0, 1.5)[0], LARGE)


def test_core_is_a_function_of_the_state():
    """The particles in another order give the same layers (==) and the same forces (to
    1e-12: the sums run in another order): a resumed run chooses as the run it
    continues."""
    s, _ = layered_sheet(1500, 45.0, 20.0)
    order = np.random.default_rng(2).permutation(1500)
    t = {k: (v[order] if isinstance(v, np.ndarray) and len(v) == 1500 else v)
         for k, v in s.items()}
    acc, par = forces(s, LARGE)
    acc_t, par_t = forces(t, LARGE)
    assert (par.nz, par.zlo, par.zhi) == (par_t.nz, par_t.zlo, par_t.zhi)
    assert np.allclose(acc[order], acc_t, rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("large_fraction, radius", [
    (0.1, 10.0),       # no particle that large
    (0.002, LARGE),    # 3 of 1500: fewer than P3M_CORE_MIN_COUNT
    (0.1, 0.5),        # every particle: the core of every particle either way
])
def test_too_few_large_particles_leave_the_core_to_every_particle(large_fraction, radius):
    """Where the particles of at least the core radius are too few (or none) the core is
    every particle's, the same layers and forces (==) as without the key: with 3 large
    particles among 1500 a core of their heights left 63 % of the sheet beyond it and a
    6.5 % force error on the small particles."""
    assert_core_of_every_particle(
        layered_sheet(1500, 45.0, 20.0, large_fraction=large_fraction)[0], radius)


def test_large_particles_holding_little_mass_leave_the_core_to_every_particle():
    """Large particles that hold less than P3M_CORE_MIN_MASS_SHARE of the mass (here a
    tenth of the particles, made as light as the small ones) do not set the core."""
    s, large = layered_sheet(1500, 45.0, 20.0)
    s["mass"] = np.where(large, s["mass"] / 64.0, s["mass"])
    assert np.sum(s["mass"][large]) < scales.P3M_CORE_MIN_MASS_SHARE * np.sum(s["mass"])
    assert_core_of_every_particle(s, LARGE)


def test_with_field_only_particles_and_the_mesh_interval():
    """The intended use, the core radius equal to the field-only radius (the A-ring
    preset's 25 cm): fewer layers, momentum conserved to round-off, the error over the full
    mesh's within the thick-ring test's 0.05 %; and with the mesh every 5 steps the kick
    step's mesh force is 5 times the one of every step, the pair sum's the same (==)."""
    s, large = layered_sheet(3000, 45.0, 20.0)
    targets = np.sort(np.random.default_rng(1).choice(3000, 150, replace=False))
    ref = reference(s, targets)
    every, par_every = forces(s, 0.0, pair_min_radius=LARGE)
    core, par_core = forces(s, LARGE, pair_min_radius=LARGE)
    assert par_core.nz < par_every.nz
    assert momentum_residual(s, core) < 1e-12
    before = testing.force_errors(every[targets], ref)["rms_relative"]
    after = testing.force_errors(core[targets], ref)["rms_relative"]
    assert after - before < 5e-4, (before, after)
    sim = testing.p3m_simulation(s, t=T_REF, auto=True, tail_fraction=scales.P3M_TAIL_FRACTION,
                                 core_min_radius=LARGE, pair_min_radius=LARGE)
    solver = p3m.installed_solver(sim)
    address = ctypes.addressof(sim)
    parts = {}
    for steps in (0, 1, 5):
        for particle in sim.particles:
            particle.ax = particle.ay = particle.az = 0.0
        solver.apply(address, steps)
        parts[steps] = np.array([[q.ax, q.ay, q.az] for q in sim.particles])
    mesh_one, mesh_five = parts[1] - parts[0], parts[5] - parts[0]
    assert np.allclose(mesh_five, 5.0 * mesh_one, rtol=1e-12, atol=1e-12 * np.abs(
        mesh_one).max())


def test_scenario_key_reaches_the_solver_and_the_run_file(scenario_dict):
    """``sheet.p3m_core_min_radius`` is a P3M key: resolved, installed, recorded; at its
    default 0 it is left out (earlier runs keep their identity), and it is refused below 0
    or with another solver."""
    from ringsim.config.scenario import scenario_from_dict
    from ringsim.engine.sheet import build_sheet
    from ringsim.errors import InputError

    p3m_keys = {"sheet.gravity_solver": "p3m", "sheet.p3m_tail_fraction": 0.08}
    base = scenario_from_dict(scenario_dict("gravitating", p3m_keys))
    sc = with_overrides(base, {"sheet.p3m_core_min_radius": 0.5})
    assert "p3m_core_min_radius" not in base.to_dict()["sheet"]
    assert with_overrides(base, {"sheet.p3m_core_min_radius": 0.0}).to_dict() == base.to_dict()
    assert sc.to_dict()["sheet"]["p3m_core_min_radius"] == 0.5
    built = build_sheet(sc)
    assert p3m.installed_solver(built.sim).core_min_radius == 0.5
    assert p3m.recognise(built.sim)["p3m_core_min_radius"] == 0.5
    attrs = p3m.attributes({**p3m.arguments(sc), "softening": 0.1}, built.geometry)
    assert attrs["p3m_core_min_radius"] == 0.5 and attrs["units_p3m_core_min_radius"]
    assert "p3m_core_min_radius" not in p3m.attributes(
        {**p3m.arguments(base), "softening": 0.1}, built.geometry)
    with pytest.raises(InputError):
        with_overrides(base, {"sheet.p3m_core_min_radius": -1.0})
    with pytest.raises(InputError):
        scenario_from_dict(scenario_dict("gravitating", {"sheet.gravity_solver": "tree",
                                                         "sheet.p3m_core_min_radius": 0.5}))
    with pytest.raises(InputError, match="acts only with sheet.p3m_tail_fraction above 0"):
        scenario_from_dict(scenario_dict("gravitating", {"sheet.gravity_solver": "p3m",
                                                         "sheet.p3m_core_min_radius": 0.5}))
