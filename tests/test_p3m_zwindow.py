"""P3M's pair sum through the height index (``rs_p3m_window``): in a ring many cutoffs
thick a target scans only the sources whose height bins lie within r_c of its own, and sums
those within r_c in the order the column scan sums them, so the accelerations are the same
bits as the column scan's (``P3MSolver.set_height_index(False)``, the reference) on any
number of threads."""

import numpy as np
import pytest

from ringsim import testing
from ringsim.gravity import p3m

T_REF = 2345.6    # s: a non-trivial shear offset
N_TWO_THREADS = 4200   # particles: above 2 x RS_P3M_PARTICLES_PER_THREAD (2048) in rs_p3m.c


def _sheet_simulation(n, sigma, split, seed=6):
    """``n`` random 1 m particles at tau = 0.5 whose heights have rms ``sigma`` [m], with
    P3M at the split ``split`` [m] (r_c = 5 split), every third particle's radius 0.4 m (so
    that ``pair_min_radius`` 0.5 m makes them field-only)."""
    s = testing.random_sheet(n, dispersion=sigma * 2.0e-4, seed=seed)
    z = s["pos"][:, 2]
    s["pos"][:, 2] = (z - z.mean()) / z.std() * sigma
    s["radius"] = np.array(s["radius"], dtype=float)
    s["radius"][::3] = 0.4
    return testing.p3m_simulation(s, t=T_REF, split=split)


def _both_ways(sim):
    """Accelerations [m/s^2] with the column scan and with the height index, and the
    number of height bins the index took (1: none)."""
    solver = p3m.installed_solver(sim)
    out = []
    for on in (False, True):
        solver.set_height_index(on)
        out.append(testing.accelerations(sim))
    return out[0], out[1], solver.params.zbins


@pytest.mark.parametrize("sigma, split, indexed", [
    (45.0, 4.0, True),     # thick: rms height 2.25 r_c, 16 x 16 cells of 16 particles
    (12.0, 3.0, True),     # about as thick against r_c as the B-ring preset
    (1.0, 3.0, False),     # thin: no index, the column scan
])
def test_the_height_index_gives_the_column_scans_bits(sigma, split, indexed):
    """Every combination of 1 and 2 threads, field-only particles or none, and the mesh's
    tail apart or not (its corrections, rs_p3m_fixes, stay on the column scan): the same
    accelerations (==) both ways, and the index is taken where the ring is thick."""
    sim = _sheet_simulation(N_TWO_THREADS, sigma, split)
    solver = p3m.installed_solver(sim)
    for threads in (1, 2):
        solver.set_threads(threads)
        for pair_min_radius, tail_fraction in ((0.0, 0.0), (0.5, 0.08)):
            solver.params.pair_min_radius = pair_min_radius
            solver.tail_fraction = tail_fraction
            column, window, zbins = _both_ways(sim)
            case = (threads, pair_min_radius, tail_fraction, zbins)
            assert (zbins > 1) == indexed, case
            assert np.array_equal(column, window), case
            assert np.all(np.isfinite(window)) and np.abs(window).max() > 0.0


def test_the_index_finds_every_pair_just_inside_the_cutoff():
    """Pairs 0.999 999 r_c apart in a ring whose heights are spread evenly over 8 r_c: one
    straight up with its upper particle 1e-5 r_c above an edge of the index's height bins
    (33 bins at 4 per r_c, RS_P3M_ZBINS_PER_CUTOFF in rs_p3m.c), so that a window short of
    r_c by more than about 1e-5 r_c misses it, and one along a diagonal: the accelerations
    through the index are the column scan's, and each pair's short-range pull is in them
    (making the pair field-only changes its lower particle's acceleration)."""
    sim = _sheet_simulation(1200, 60.0, 3.0, seed=8)
    rc = 5.0 * 3.0
    ps = sim.particles
    for k, p in enumerate(ps):
        p.z = -4.0 * rc + 8.0 * rc * k / (len(ps) - 1)
        p.r = 1.0
    d = 0.999999 * rc
    edge = -4.0 * rc + 17 * (8.0 * rc / 33)
    ps[601].x, ps[601].y, ps[601].z = ps[600].x, ps[600].y, edge + 1e-5 * rc
    ps[600].z = ps[601].z - d
    ps[603].x, ps[603].y, ps[603].z = (ps[602].x + d / np.sqrt(3.0), ps[602].y + d / np.sqrt(3.0),
                                       ps[602].z + d / np.sqrt(3.0))
    column, window, zbins = _both_ways(sim)
    assert zbins == 33
    assert np.array_equal(column, window)
    params = p3m.installed_solver(sim).params
    for lower, upper in ((600, 601), (602, 603)):
        ps[lower].r = ps[upper].r = 0.4
        params.pair_min_radius = 0.5
        alone = testing.accelerations(sim)
        assert not np.array_equal(alone[lower], window[lower]), (lower, upper)
        ps[lower].r = ps[upper].r = 1.0
        params.pair_min_radius = 0.0


def test_the_column_scans_ways_still_agree_where_the_index_is_taken():
    """tests/test_p3m_pair_passes.py's thick sheet (rms 60 m) now takes the index, which
    bypasses rs_p3m_pairs; with the index off its one loop and two passes still give the
    same bits there, and the index gives them too."""
    s = testing.random_sheet(300, dispersion=60.0 * 2.0e-4, seed=6)
    z = s["pos"][:, 2]
    s["pos"][:, 2] = (z - z.mean()) / z.std() * 60.0
    sim = testing.p3m_simulation(s, t=T_REF)
    solver = p3m.installed_solver(sim)
    solver.set_height_index(False)
    ways = []
    for two_pass in (0, 1):
        solver.params.two_pass = two_pass
        ways.append(testing.accelerations(sim))
    solver.set_height_index(True)
    ways.append(testing.accelerations(sim))
    assert solver.params.zbins > 1
    assert np.array_equal(ways[0], ways[1]) and np.array_equal(ways[0], ways[2])
