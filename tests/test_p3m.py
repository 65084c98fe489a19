"""The P3M self-gravity solver (gravity/p3m.py, csrc/rs_p3m.c, physics/p3m_mesh.P3MMesh):
the pair term against its formula, forces against the converged direct image sum, and the
momentum and energy budgets of a gravitating sheet without collisions, for each solver."""

import ctypes
import math
import platform

import numpy as np
import pytest
import rebound

from ringsim import testing
from ringsim.engine import box, invariants, sheet
from ringsim.engine.native import _LIB, keep_freed_memory
from ringsim.gravity import p3m
from ringsim.physics import p3m_mesh
from ringsim.physics import p3m_scales as scales
from ringsim.physics import selfgravity as sg
from ringsim.physics.constants import G_SI

T_REF = 2345.6    # s: a non-trivial shear offset


@pytest.fixture(scope="module")
def sheet400():
    return testing.random_sheet(400, seed=5)


@pytest.fixture(scope="module")
def reference400(sheet400):
    return testing.reference_for(sheet400, t=T_REF, n_rows=4)


def test_pair_term_is_plummer_minus_the_mesh_part():
    """rs_p3m_short on two particles adds -G m d [(r^2 + b^2)^-3/2 - L(r) / r^3] (file header
    of rs_p3m.c); the table of L(r)/r^3 is interpolated linearly in r^2 (4096 nodes), so the
    long-range term is exact to ~1e-6 of itself and the sum to round-off where it dominates."""
    s = testing.random_sheet(400, seed=1)
    sim = testing.p3m_simulation(s, t=0.0)
    solver = p3m.installed_solver(sim)
    rs, b = solver.params.split, solver.params.softening
    two = rebound.Simulation()
    box.configure_box(two, s["geometry"])
    two.G = G_SI
    two.add(m=1.0e4, x=0.0, y=0.0, z=0.0)
    two.add(m=2.0e4)
    for r in (0.3, 1.7, 6.0, 11.0):
        two.particles[1].x, two.particles[1].y = r * 0.6, r * 0.8
        for p in two.particles:
            p.ax = p.ay = p.az = 0.0
        address = ctypes.addressof(two)
        _LIB.rs_p3m_prepare(address, ctypes.byref(solver.params))
        _LIB.rs_p3m_short(address, ctypes.byref(solver.params))
        long_part = p3m_mesh.long_range_fraction(r, rs) / r**3
        pair = (r * r + b * b) ** -1.5 - long_part
        expected = -G_SI * 2.0e4 * pair * np.array([-0.6, -0.8]) * r
        got = np.array([two.particles[0].ax, two.particles[0].ay])
        assert np.allclose(got, expected, rtol=1e-6, atol=1e-6 * G_SI * 2.0e4 * long_part * r), r
        assert two.particles[1].ax == pytest.approx(-0.5 * got[0], rel=1e-12)


def test_p3m_at_defaults_is_within_one_percent_of_the_direct_sum(sheet400, reference400):
    """Issue 12's bound, < 1 % rms relative error at the default settings (measured 0.87 %
    on this 400-particle sheet, 0.62 % on 10^4 particles); the median error is below 0.5 %."""
    sim = testing.p3m_simulation(sheet400, t=T_REF)
    err = testing.force_errors(testing.accelerations(sim), reference400)
    assert err["rms_relative"] < 0.01, err
    assert err["median_relative"] < 0.005, err


def test_cell_list_and_all_images_paths_agree(sheet400):
    """On the 50 m box a cutoff of 19.9 m gives a 5 x 5 cell list (cells of at least r_c / 2),
    20.2 m the all-pairs path over 3 x 3 images; the forces differ only by the split's
    remainder between them, 1 - L(6.6 r_s) ~ 1e-8 of a pair force there."""
    a = testing.accelerations(testing.p3m_simulation(sheet400, t=T_REF, cutoff=19.9))
    b = testing.accelerations(testing.p3m_simulation(sheet400, t=T_REF, cutoff=20.2))
    scale = np.sqrt(np.mean(np.sum(a * a, axis=1)))
    assert np.max(np.abs(a - b)) < 1e-5 * scale


def test_pairs_just_inside_the_cutoff_are_summed_in_one_column():
    """One column of six particles, added out of height order, whose vertical separations
    fall just inside (14.9, 14.85 m) and just outside (15.2 m) the cutoff r_c = 15 m
    (five pairs within it): rs_p3m_short gives each the sum over the sources within r_c of
    the pair term (test above).  The pair at 14.9 m adds 0.63 % of a Newtonian pull there
    (1 - L(14.9 m) at r_s = 3 m), over 1e3 times the table's tolerance, so a pair lost at
    the cutoff fails this test (checked: a search cut at 0.992 r_c in height fails it)."""
    s = testing.random_sheet(400, seed=1)
    sim = testing.p3m_simulation(s, t=0.0)
    par = p3m.installed_solver(sim).params
    assert par.cutoff == pytest.approx(15.0) and s["Lx"] > 2.5 * par.cutoff  # cell list
    rs, b, rc = par.split, par.softening, par.cutoff
    heights = np.array([30.1, 0.0, 52.0, 7.0, 44.95, 14.9]) - 20.0
    masses = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]) * 1.0e4
    col = rebound.Simulation()
    box.configure_box(col, s["geometry"])
    col.G = G_SI
    for z, m in zip(heights, masses, strict=True):
        col.add(m=m, x=3.0, y=-4.0, z=z)
    address = ctypes.addressof(col)
    _LIB.rs_p3m_prepare(address, ctypes.byref(par))
    _LIB.rs_p3m_short(address, ctypes.byref(par))
    d = heights[:, None] - heights[None, :]
    r = np.abs(d)
    near = (r > 0.0) & (r < rc)
    assert near.sum() == 2 * 5 and np.any(near & (r > 14.8)) and np.any((r > rc) & (r < 15.3))
    with np.errstate(divide="ignore", invalid="ignore"):
        long_part = np.where(near, p3m_mesh.long_range_fraction(np.where(near, r, 1.0), rs)
                             / np.where(near, r, 1.0) ** 3, 0.0)
        pair = np.where(near, (r * r + b * b) ** -1.5 - long_part, 0.0)
    expected = -G_SI * np.sum(masses[None, :] * pair * d, axis=1)
    tolerance = 1e-6 * G_SI * np.sum(masses[None, :] * long_part * r, axis=1)
    got = np.array([p.az for p in col.particles])
    assert np.all(np.abs(got - expected) <= tolerance), (got - expected) / tolerance
    edge = G_SI * 6.0e4 * ((14.9**2 + b * b) ** -1.5
                           - p3m_mesh.long_range_fraction(14.9, rs) / 14.9**3) * 14.9
    assert edge > 1e3 * tolerance[1]      # the 14.9 m pair is far above the tolerance


def test_cell_list_finds_every_close_pair_in_a_thick_ring(thick600):
    """In a ring 57 m thick (rms) on a 61 m box, with r_c = 24 m, the cell list's columns
    span many cutoffs in height.  Its forces equal the all-pairs path's (r_c 24.0 m: 5 x 5
    columns; 24.6 m: all pairs over 3 x 3 images) up to the two cutoffs' tables of
    L(r)/r^3 (linear interpolation, < 1e-6 of a pair force; measured 3e-7 of the rms
    force) and the split's remainder between them (1 - L(24 m) = 5e-7 of a Newtonian pull
    at 24 m).  A pair left out closer than about 17 m (r_s = 3 m) would exceed the 1e-5
    tolerance; losses near r_c are left to the one-column test above.  The forces conserve
    momentum to round-off."""
    assert thick600["Lx"] == pytest.approx(61.4, abs=0.1)
    assert np.std(thick600["pos"][:, 2]) > 2.0 * 24.6
    a = testing.accelerations(testing.p3m_simulation(thick600, t=T_REF, cutoff=24.0))
    b = testing.accelerations(testing.p3m_simulation(thick600, t=T_REF, cutoff=24.6))
    scale = np.sqrt(np.mean(np.sum(a * a, axis=1)))
    assert np.max(np.abs(a - b)) < 1e-5 * scale
    total = np.sum(thick600["mass"][:, None] * a, axis=0)
    assert np.all(np.abs(total) < 1e-13 * np.sum(thick600["mass"]) * scale)


def test_p3m_forces_conserve_momentum_to_round_off(sheet400):
    """Pair forces antisymmetric, mesh assignment and interpolation with the same kernel:
    the net force vanishes to round-off (measured 1e-17 of M rms|a|)."""
    a = testing.accelerations(testing.p3m_simulation(sheet400, t=T_REF))
    total = np.sum(sheet400["mass"][:, None] * a, axis=0)
    scale = np.sum(sheet400["mass"]) * np.sqrt(np.mean(np.sum(a * a, axis=1)))
    assert np.all(np.abs(total) < 1e-13 * scale), total / scale


def test_p3m_is_repeatable_and_raises_after_a_failing_step(sheet400):
    sim = testing.p3m_simulation(sheet400, t=T_REF)
    assert np.array_equal(testing.accelerations(sim), testing.accelerations(sim))
    solver = p3m.installed_solver(sim)
    solver.mesh.fields = None          # the callback now fails inside REBOUND's step
    sim.dt = 10.0
    sim.steps(1)                        # ctypes swallows the exception ...
    with pytest.raises(RuntimeError, match="P3M self-gravity failed"):
        p3m.raise_pending(sim)          # ... the run loop re-raises it after the step
    p3m.raise_pending(sim)              # and only once


def _solver_sim(s, solver, t=0.0, softening=None, **p3m_kwargs):
    if solver == "tree":
        return testing.tree_simulation(s, t=t, ghost_field=True, softening=softening)
    return testing.p3m_simulation(s, t=t, softening=softening, **p3m_kwargs)


@pytest.mark.parametrize("solver", ["tree", "p3m"])
def test_momentum_budget_over_one_orbit(solver, sheet400):
    """The sheet's momentum relative to the shear flow follows the free epicycle of its
    centre of mass (engine.invariants) when the forces sum to zero.  P3M: to round-off
    (bound 1e-9 of rms|a| t: 1000 steps of sums of 400 forces, each exact to ~1e-16 of
    M |a|; measured ~1e-13; before the pair sum wrapped REBOUND's mid-step positions into
    the box it was 1.2e-4).  Tree: Barnes-Hut is not antisymmetric and the truncation field
    is exact to first order about the centre of mass (net force 1.2e-4 of sum m|a|,
    docs/gravity.md): bound 1e-3 of rms|a| t, as tests/test_gravwire.py."""
    Omega = sheet400["geometry"].Omega
    orbit = 2.0 * math.pi / Omega
    sim = _solver_sim(sheet400, solver)
    sim.dt = 1e-3 * orbit
    arrays = sheet.particle_arrays(sim)
    reference = invariants.sheet_momentum(arrays, Omega, sim.t)
    acc = testing.tree_accelerations(sim) if solver == "tree" else testing.accelerations(sim)
    rms_acc = float(np.sqrt(np.mean(np.sum(acc**2, axis=1))))
    sim.integrate(orbit, exact_finish_time=0)
    p3m.raise_pending(sim)
    now = invariants.sheet_momentum(sheet.particle_arrays(sim), Omega, sim.t)
    residual = invariants.momentum_residual(now, reference, Omega)
    bound = {"tree": 1e-3, "p3m": 1e-9}[solver]
    assert residual < bound * rms_acc * sim.t, (residual / (rms_acc * sim.t))


def clump(n=60, sigma=5.0, box_tau=0.02, seed=7):
    """A self-gravitating clump in the middle of a large shear-periodic box: Gaussian of
    ``sigma`` [m] in x, y, z, on the shear flow with a 0.3 mm/s dispersion; 1 m ice."""
    s = testing.random_sheet(n, optical_depth=box_tau, seed=seed)
    rng = np.random.default_rng(seed)
    pos = rng.normal(0.0, sigma, (n, 3))
    vel = rng.normal(0.0, 3e-4, (n, 3))
    vel[:, 1] += -1.5 * s["geometry"].Omega * pos[:, 0]
    return {**s, "pos": pos, "vel": vel}


def jacobi_energy(sim, softening, Omega, Lx, Ly):
    """Hill's-frame Jacobi integral [J] of a clump: sum m (|v|^2 / 2 - 3/2 Omega^2 x^2 +
    Omega^2 z^2 / 2) plus the Plummer pair potential, each pair at its nearest shear-periodic
    image (particles thrown out of the clump meet the others' images across the y edge)."""
    a = sheet.particle_arrays(sim)
    m = a["mass"]
    kinetic = 0.5 * np.sum(m * (a["vx"]**2 + a["vy"]**2 + a["vz"]**2))
    tidal = np.sum(m * (-1.5 * Omega**2 * a["x"]**2 + 0.5 * Omega**2 * a["z"]**2))
    pos = np.column_stack([a["x"], a["y"], a["z"]])
    shift = sg.shear_offset(Omega, Lx, Ly, sim.t)
    d2 = np.sum(sg.minimum_image(pos[:, None] - pos[None], Lx, Ly, shift) ** 2, axis=-1)
    iu = np.triu_indices(len(m), 1)
    pair = -G_SI * np.sum(m[iu[0]] * m[iu[1]] / np.sqrt(d2[iu] + softening**2))
    # the images' mean: the pair's infinite uniform sheets, 2 pi G m_i m_j |dz| / (Lx Ly)
    dz = np.abs(a["z"][iu[0]] - a["z"][iu[1]])
    pair += 2.0 * np.pi * G_SI * np.sum(m[iu[0]] * m[iu[1]] * dz) / (Lx * Ly)
    return kinetic + tidal + pair, abs(pair)


@pytest.mark.parametrize("solver, mesh", [
    ("tree", {}),
    # the clump's box is mostly empty: a 5 m mesh keeps the test fast (4 s instead of 44 s)
    ("p3m", {"cell": 5.0, "dz": 2.5}),
    pytest.param("p3m", {}, marks=pytest.mark.slow),
])
def test_energy_budget_of_a_clump_over_one_orbit(solver, mesh):
    """Jacobi integral (:func:`jacobi_energy`) of a gravitating clump (60 particles, Gaussian
    of 2 m, no collisions, softening 1 m) in a 194 m box, over one orbit at dt = 1e-3 orbit.
    Hill's equations with conservative forces conserve it; what changes it here: (1) the
    non-conservative part of the force error, at most the rms force error (< 1 %) of the
    work the forces exchange, itself of order the potential depth |W|; (2) the kick-drift
    splitting, O((Omega dt)^2) ~ 4e-5 of |W|; (3) the images beyond the nearest one, which
    the integral leaves out but the solvers include: measured 5.7e-3 |W| in a 97 m box,
    ~1.5e-3 in this one (falling with the box).  Measured drift 1.3e-3 |W| (tree), 1.6e-3 |W|
    (P3M at its defaults, the same at dt = 2.5e-4 orbit), -6e-4 |W| (P3M on the 5 m mesh);
    bound 1e-2 |W|, the force-error term.  The clump must stay clear of the x
    edges, where REBOUND's shear-periodic wrap changes v_y and so the integral."""
    s = clump(n=60, sigma=2.0, box_tau=0.005)
    Omega = s["geometry"].Omega
    orbit = 2.0 * math.pi / Omega
    b = 1.0
    sim = _solver_sim(s, solver, softening=b, **mesh)
    sim.dt = 1e-3 * orbit
    e0, depth = jacobi_energy(sim, b, Omega, s["Lx"], s["Ly"])
    for quarter in range(1, 5):
        sim.integrate(quarter * 0.25 * orbit, exact_finish_time=0)
        p3m.raise_pending(sim)
        x = sheet.particle_arrays(sim)["x"]
        assert np.max(np.abs(x)) < 0.4 * s["Lx"], "the clump must stay clear of the edges"
    e1, _ = jacobi_energy(sim, b, Omega, s["Lx"], s["Ly"])
    assert abs(e1 - e0) < 1e-2 * depth, (e1 - e0) / depth


# --- the scenario key and the run file ---------------------------------------------------------

#: The gravitating sheet for 0.05 orbit, a row every 0.025 orbit and a snapshot at the end.
SHORT = {"integration.orbits": 0.05, "output.timeseries_every": 0.025,
         "output.snapshot_every": 0.05}


@pytest.mark.parametrize("sheet_keys, key", [
    ({"gravity_solver": "fmm"}, "sheet.gravity_solver"),
    ({"gravity_solver": "p3m", "opening_angle": 0.3}, "sheet.opening_angle"),
    ({"gravity_solver": "p3m", "n_particles": 20}, "sheet.gravity_solver"),
    ({"gravity_solver": "tree", "p3m_split": 4.0}, "sheet.p3m_split"),
    ({"gravity_solver": "p3m", "p3m_split": -1.0}, "sheet.p3m_split"),
    ({"gravity_solver": "p3m", "p3m_split": "big"}, "sheet.p3m_split"),
    ({"gravity_solver": "p3m", "p3m_split": 8.0}, "sheet.gravity_solver"),
])
def test_bad_gravity_solver_keys_exit_2_naming_the_key(tmp_path, capsys, sheet_keys, key,
                                                       scenario_dict):
    """A bad solver, a tree key with P3M, a P3M key with the tree, a split that is not
    positive or auto, or a box narrower than P3M's cutoff (20 particles make 11 m, the
    cutoff is 15 m; 200 make 35 m, a split of 8 m a cutoff of 40 m): exit 2, one line
    naming file and key, no run file."""
    import yaml

    from ringsim.cli import main

    data = scenario_dict("gravitating", SHORT, {f"sheet.{k}": v for k, v in sheet_keys.items()})
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["run", str(path), "-o", str(tmp_path / "r.h5"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and key in err[0] and "s.yaml" in err[0], err
    assert not (tmp_path / "r.h5").exists()


def test_solver_defaults_and_the_run_file_records_the_solver(tmp_path, gravitating_scenario):
    import ringsim

    sc = gravitating_scenario(SHORT, source="<t>")
    assert sc.sheet.gravity_solver == "p3m"
    tree_by_angle = gravitating_scenario(SHORT, {"sheet.opening_angle": 0.5}, source="<t>")
    assert tree_by_angle.sheet.gravity_solver == "tree"
    path = ringsim.run(sc, output=tmp_path / "g.h5", progress=False)
    attrs = ringsim.open_run(path).attrs
    assert attrs["gravity_solver"] == "p3m"
    assert attrs["p3m_split"] == pytest.approx(3.0) and attrs["units_p3m_split"] == "m"
    assert attrs["p3m_cutoff"] == pytest.approx(15.0) and attrs["units_p3m_cutoff"] == "m"
    assert list(attrs["p3m_mesh"]) == [p3m.p3m_parameters(attrs["Lx"], attrs["Ly"], 3.0)[k]
                                       for k in ("nx", "ny")]
    assert attrs["softening"] == pytest.approx(0.1) and attrs["units_softening"] == "m"


def test_p3m_gives_the_same_bits_on_one_and_two_threads():
    """Interpolation and pair sum are gathers per particle (each sum in a fixed order), the
    pair sum's cell lists and the mean vertical field's interpolation per particle work,
    and scipy's FFTs split independent transforms: the accelerations are identical (==) on
    1 and 2 threads.  5000 particles: above the 2048 per thread at which a second thread
    starts (RS_P3M_PARTICLES_PER_THREAD)."""
    s = testing.random_sheet(5000, seed=8)
    results = []
    for threads in (1, 2):
        sim = testing.p3m_simulation(s, t=T_REF)
        p3m.installed_solver(sim).set_threads(threads)
        results.append(testing.accelerations(sim))
    assert np.array_equal(results[0], results[1])


def test_mean_vertical_field_of_a_thick_ring_is_the_direct_erf_sum():
    """rs_p3m_mean_vertical sums the exact erf kernel over a window of 12 r_s and the masses
    beyond it as +-1 (erf(6) = 1 in double), so a ring hundreds of r_s thick costs O(n x
    window).  Against the direct sum -(2 pi G / Lx Ly) sum_j m_j erf((z_i - z_j) / 2 r_s)
    over the particles: within the fine layers' interpolation error (layers r_s / 16
    apart: < 1e-3 of the field's scale, docs/gravity.md 4b); a window cut too short (or a
    wrong sign of the far masses) is off by up to the whole field."""
    s = testing.random_sheet(400, dispersion=0.05, seed=9)   # 1 m ice, z scale height 250 m
    sim = testing.p3m_simulation(s)
    solver = p3m.installed_solver(sim)
    rs = solver.params.split
    z = s["pos"][:, 2]
    assert np.ptp(z) > 200 * rs                          # hundreds of r_s thick
    for particle in sim.particles:
        particle.ax = particle.ay = particle.az = 0.0
    _LIB.rs_p3m_mean_vertical(ctypes.byref(sim), ctypes.byref(solver.params))
    got = np.array([particle.az for particle in sim.particles])
    from math import erf
    scale = 2 * math.pi * G_SI * float(np.sum(s["mass"])) / (s["Lx"] * s["Ly"])
    direct = np.array([-scale / np.sum(s["mass"]) * sum(
        m * erf((zi - zj) / (2 * rs)) for zj, m in zip(z, s["mass"], strict=True))
        for zi in z])
    assert np.max(np.abs(got - direct)) < 1e-3 * scale, np.max(np.abs(got - direct)) / scale


def test_p3m_solver_keeps_freed_memory_on_glibc():
    """The solver's mesh temporaries reuse freed memory (docs/performance.md, Self-gravity):
    glibc accepts both mallopt settings, and asking again changes nothing."""
    sheet_ = testing.random_sheet(200, 0.5, 1.0, seed=3)
    p3m.P3MSolver(sheet_["Lx"], sheet_["Ly"], 0.1, 3.0)
    expected = platform.libc_ver()[0] == "glibc"
    assert keep_freed_memory() is expected
    assert keep_freed_memory() is expected


# --- sheet.p3m_split: auto, and layer counts padded to a fixed ladder ----------------------------

def test_layer_buckets_are_a_fixed_ladder_that_holds_every_count():
    """layer_bucket(nz) >= nz, at most P3M_LAYER_BUCKET times nz (plus the rounding up of
    one layer), non-decreasing, and a pure function: over nz = 1..500 it takes few values
    (each value is one kernel table for a whole run)."""
    buckets = [scales.layer_bucket(nz) for nz in range(1, 501)]
    assert all(b >= nz for nz, b in zip(range(1, 501), buckets, strict=True))
    assert all(b <= max(scales.P3M_MIN_LAYERS, scales.P3M_LAYER_BUCKET * nz + 1)
               for nz, b in zip(range(1, 501), buckets, strict=True))
    ladder = 1 + math.ceil(math.log(500 / scales.P3M_MIN_LAYERS)
                           / math.log(scales.P3M_LAYER_BUCKET))
    assert buckets == sorted(buckets) and len(set(buckets)) == ladder == 20
    assert [scales.layer_bucket(nz) for nz in range(1, 501)] == buckets


def test_auto_split_is_the_first_rung_for_thin_rings_and_stays_within_the_cell_list():
    """Thin ring (span 20 m): the first rung, the fixed default.  Thicker rings: a rung
    first_split x 2^(k/4), never above the cutoff the pair sum's cell list holds
    (r_c <= min(Lx, Ly) / 2.5), and growing with the span (one rung per factor 2^(5/4))."""
    first, box = 3.0, 86.8
    assert scales.p3m_auto_split(first, 20.0, 1200, box, box) == first
    cap = box / (scales.P3M_CELL_LIST_CUTOFFS * scales.P3M_CUTOFF_SPLITS)
    spans = np.geomspace(10.0, 1e5, 60)
    splits = [scales.p3m_auto_split(first, z, 1200, box, box) for z in spans]
    assert splits == sorted(splits) and max(splits) <= cap < max(splits) * scales.P3M_SPLIT_RUNG
    k = np.log(np.array(splits) / first) / np.log(scales.P3M_SPLIT_RUNG)
    assert np.allclose(k, np.round(k), atol=1e-9)
    # the measured optima (docs/gravity.md 4b): 4.5 m for 2400 particles of 1 m at tau 0.5
    # with a span of 175 m (rung 4.24 m), 6 m for 1200 with 842 m
    assert scales.p3m_auto_split(first, 175.0, 2400, 122.8, 122.8) == pytest.approx(3 * 2**0.5)
    assert scales.p3m_auto_split(first, 842.0, 1200, box, box) == pytest.approx(6.0)


def test_padded_layers_leave_the_field_of_the_occupied_layers_unchanged(sheet400):
    """The mesh of nz occupied layers padded with empty layers on top gives the same field
    on the occupied layers to round-off: the padding changes the FFT length, not the
    physics."""
    mesh = p3m_mesh.P3MMesh(sheet400["Lx"], sheet400["Ly"], 24, 24, 2.25, 3.0)
    rng = np.random.default_rng(3)
    mass = rng.uniform(0.0, 1.0e6, (11, 24, 24))
    padded = np.zeros((scales.layer_bucket(11) + 3, 24, 24))
    padded[:11] = mass
    for g, h in zip(mesh.fields(mass, 0.21), mesh.fields(padded, 0.21), strict=True):
        assert np.max(np.abs(h[:11] - g)) <= 1e-12 * np.max(np.abs(g))


def test_vertical_fft_length_is_fast_and_changes_the_field_by_round_off_only(sheet400):
    """The vertical coupling is a linear convolution over the layer offsets -(nz-1)..(nz-1):
    any zero-padded length >= 2 nz - 1 gives it exactly.  The mesh takes the next 5-smooth
    length, and its field equals that of the length 2 nz (used before; 292 = 4 x 73 for
    the 146 layers of the production runs) to round-off."""
    for nz in (1, 13, 146, 356, 445):
        n = p3m_mesh.P3MMesh.z_length(nz)
        assert 2 * nz - 1 <= n <= 1.1 * (2 * nz - 1) + 1
        for prime in (2, 3, 5):
            while n % prime == 0:
                n //= prime
        assert n == 1

    class TwiceLayers(p3m_mesh.P3MMesh):
        @staticmethod
        def z_length(nz):
            return 2 * nz

    rng = np.random.default_rng(5)
    args = (sheet400["Lx"], sheet400["Ly"], 24, 24, 2.25, 3.0)
    assert p3m_mesh.P3MMesh.z_length(146) == 300 and p3m_mesh.P3MMesh.z_length(13) == 25
    for nz in (13, 146):     # 25 = 2 nz - 1 leaves no zero slot; 300 leaves 9
        mass = rng.uniform(0.0, 1.0e6, (nz, 24, 24))
        for g, h in zip(TwiceLayers(*args).fields(mass, 0.21),
                        p3m_mesh.P3MMesh(*args).fields(mass, 0.21), strict=True):
            assert np.max(np.abs(h - g)) <= 1e-12 * np.max(np.abs(g))


def test_kernel_tables_are_bounded():
    """A mesh keeps at most P3M_TABLES kernel tables, the least recently used dropped
    (before: one per layer count for ever, 6.3 GB in 300 steps of a hot ring)."""
    mesh = p3m_mesh.P3MMesh(40.0, 40.0, 8, 8, 2.25, 3.0)
    for nz in (8, 10, 13, 8, 16, 20, 25, 8):
        mesh._kernel_tables(nz)
        assert len(mesh._tables) <= scales.P3M_TABLES
    assert list(mesh._tables) == [16, 20, 25, 8]


@pytest.fixture(scope="module")
def thick600():
    """600 particles of 1 m at tau = 0.5 with a scale height of 60 m (a hot ring)."""
    return testing.random_sheet(600, dispersion=60.0 * 2.0e-4, seed=21)


def test_auto_split_in_a_thick_ring_is_within_one_percent_and_conserves_momentum(thick600):
    """In a hot ring auto takes a rung above the first, and its forces stay within the
    issue's 1 % rms of the direct shear-periodic sum (measured 0.3 % at 6 m in a 1200-
    particle ring) and sum to zero to round-off."""
    sim = testing.p3m_simulation(thick600, t=T_REF, auto=True)
    acc = testing.accelerations(sim)
    solver = p3m.installed_solver(sim)
    assert solver.params.split > 1.4 * solver.first_split
    rng = np.random.default_rng(0)
    targets = np.sort(rng.choice(600, 150, replace=False))
    shift = sg.shear_offset(thick600["geometry"].Omega, thick600["Lx"], thick600["Ly"], T_REF)
    ref = sg.direct_accelerations(thick600["pos"], thick600["mass"], thick600["Lx"],
                                  thick600["Ly"], shift, 0.1, n_rows=4, targets=targets,
                                  chunk=16)
    assert testing.force_errors(acc[targets], ref)["rms_relative"] < 0.01
    force = thick600["mass"][:, None] * acc
    assert np.all(np.abs(force.sum(axis=0)) < 1e-12 * np.abs(force).sum(axis=0))


def test_hot_p3m_run_with_auto_split_resumes_bit_for_bit(tmp_path, gravitating_scenario):
    """The split auto chooses is a function of the state alone, so a run stopped and
    resumed (its solver made anew) is the uninterrupted run, bit for bit."""

    sc = gravitating_scenario(source="<t>", **{"sheet.n_particles": 600,
                                               "sheet.initial_dispersion": 60.0,
                                               "integration.collision_detection": "line"})
    assert sc.p3m_setting == (3.0, True)
    built = sheet.build_sheet(sc)
    built.sim.steps(1)
    solver = p3m.installed_solver(built.sim)
    assert solver.params.split > 1.4 * solver.first_split     # a rung above the first
    a, _ = testing.assert_resumes_bit_for_bit(sc, tmp_path, stop_orbits=0.1, snapshot=2)
    assert a.n_snapshots == 3
    assert a.attrs["p3m_split_auto"] == 1 and a.attrs["p3m_split_largest"] > 3.0
