"""Issue 16, set-up at scale: particles added in one C call, overlap-free placement on a grid.

The placement's result is fixed by its rule (of each overlapping pair the much smaller
particle, else the higher index, is drawn again) and the exact pair test, so the C grid
search must find exactly the pairs a brute-force numpy search finds; the C add must build
the simulation ``sim.add`` builds.
"""

import numpy as np
import pytest
import rebound

from ringsim.engine import box, placement, sheet

#: The broad sheet packed to tau = 1.5 with 20000 particles, in line mode.
DENSE = {"name": "dense", "seed": 5, "sheet.optical_depth": 1.5, "sheet.n_particles": 20000,
         "integration.collision_detection": "line"}


def _brute_force(x, y, z, radii, Lx, Ly, searched=None):
    """Every pair (or every pair with a particle of ``searched``) by the numpy twin."""
    n = radii.size
    i, j = np.triu_indices(n, 1)
    if searched is not None:
        flag = np.zeros(n, bool)
        flag[searched] = True
        keep = flag[i] | flag[j]
        i, j = i[keep], j[keep]
    return placement.overlapping_later(x, y, z, radii, i, j, Lx, Ly)


@pytest.mark.parametrize("Lx, Ly, radii_kind", [
    (60.0, 90.0, "broad"),      # several cells along each axis
    (9.0, 25.0, "broad"),       # fewer than 3 cells along x: the periodic range wraps
    (40.0, 40.0, "equal"),      # one radius class
])
def test_grid_search_finds_exactly_the_brute_force_pairs(Lx, Ly, radii_kind):
    rng = np.random.default_rng(3)
    n = 700
    radii = (np.full(n, 1.3) if radii_kind == "equal"
             else 0.3 * np.exp(rng.uniform(0.0, np.log(12.0), n)))
    pos = np.column_stack([rng.uniform(-Lx / 2, Lx / 2, n), rng.uniform(-Ly / 2, Ly / 2, n),
                           rng.normal(0.0, 4.0, n)])
    x, y = placement.wrap_horizontal(pos, Lx, Ly)
    z = np.ascontiguousarray(pos[:, 2])
    expected = _brute_force(x, y, z, radii, Lx, Ly)
    assert expected.size > 50, "the configuration must be dense enough to test anything"
    with placement.OverlapGrid(x, y, z, radii, Lx, Ly) as grid:
        np.testing.assert_array_equal(grid.overlapping_later(), expected)
        # move some particles (one far outside the initial height range) and search again
        moved = np.sort(rng.choice(n, 120, replace=False))
        pos[moved] = np.column_stack([rng.uniform(-Lx / 2, Lx / 2, moved.size),
                                      rng.uniform(-Ly / 2, Ly / 2, moved.size),
                                      rng.normal(0.0, 4.0, moved.size)])
        pos[moved[0], 2] = 80.0
        pos[moved[1]] = pos[moved[0]] + [0.1, 0.0, 0.2]   # overlapping above the grid's top
        x[moved], y[moved] = placement.wrap_horizontal(pos[moved], Lx, Ly)
        z[moved] = pos[moved, 2]
        grid.move(moved, x, y, z)
        found = grid.overlapping_later(moved)
    np.testing.assert_array_equal(found, _brute_force(x, y, z, radii, Lx, Ly, moved))
    pair = np.array([min(moved[0], moved[1])]), np.array([max(moved[0], moved[1])])
    assert placement.yielding(*pair, radii)[0] in found


def test_the_much_smaller_particle_of_an_overlapping_pair_yields():
    radii = np.array([1.0, 12.0, 1.0, 0.05, 5.0, 0.5, 5.0])
    lo, hi = np.array([0, 1, 0, 1, 2, 3, 5]), np.array([1, 3, 2, 4, 3, 4, 6])
    # 0 is 12 times smaller than 1: 0 yields; 3 is 240 times smaller than 1: 3 yields; equal
    # radii: the higher index; 4 (5 m) is within a factor 10 of 1 (12 m): the higher index;
    # 3 (5 cm) is 20 times smaller than 2 and 100 times smaller than 4; 5 and 6 are exactly
    # a factor 10 apart, as the ends of a 0.5-5 m power law: the higher index, the larger
    np.testing.assert_array_equal(placement.yielding(lo, hi, radii), [0, 3, 2, 4, 3, 3, 6])
    assert placement.YIELD_RATIO == 10.0   # RS_YIELD_RATIO of csrc/rs_setup.c


def test_dense_sheet_starts_without_overlaps(broad_scenario):
    # tau = 1.5 with radii spanning a factor 10: the densest set-up the issue asks for
    built = sheet.build_sheet(broad_scenario(DENSE))
    arrays = sheet.particle_arrays(built.sim)
    assert built.sim.N == 20000
    assert box.count_overlaps(arrays, built.geometry, fraction=0.0) == 0


def test_add_particles_builds_what_sim_add_builds(broad_scenario):
    sc = broad_scenario(DENSE, {"sheet.optical_depth": 0.3, "sheet.n_particles": 300})
    built = sheet.build_sheet(sc)
    arrays = sheet.particle_arrays(built.sim)
    sims = []
    for by_c in (True, False):
        sim = rebound.Simulation()
        sheet.configure_simulation(sim, built.geometry, gravity=None,
                                   collision_detection="tree", rand_seed=1)
        if by_c:
            sheet.add_particles(sim, arrays, arrays["radius"], arrays["mass"])
        else:
            for k in range(arrays["radius"].size):
                sim.add(m=float(arrays["mass"][k]), r=float(arrays["radius"][k]),
                        **{key: float(arrays[key][k])
                           for key in ("x", "y", "z", "vx", "vy", "vz")})
        sim.collision_resolve = "hardsphere"   # the tree (built as particles arrive) matters
        sim.dt = 1e-3 * built.geometry.orbit
        sim.integrate(0.05 * built.geometry.orbit)
        sims.append(sheet.particle_arrays(sim))
    for key in sims[0]:
        np.testing.assert_array_equal(sims[0][key], sims[1][key], err_msg=key)


def test_add_particles_refuses_arrays_of_other_lengths():
    sim = rebound.Simulation()
    geometry = box.SheetGeometry(10.0, 1, 1, 1, 2.0e-4)
    sheet.configure_simulation(sim, geometry, gravity=None,
                               collision_detection="tree", rand_seed=1)
    state = {key: np.zeros(3) for key in ("x", "y", "z", "vx", "vy", "vz")}
    with pytest.raises(ValueError, match="2 entries"):
        sheet.add_particles(sim, state, np.ones(2), np.ones(3))
    assert sim.N == 0
