"""The line detector's grid per reach class gives the same bits as its one grid.

``rs_sheet_detect.c`` (Method 2a) sorts the particles of a broad size distribution into
classes of reach, each with its own cell grid, and looks for every pair from its particle
of the smaller class.  The pairs a step reports are an exact set (closest approach of the
straight paths <= R_i + R_j) and the contacts are resolved in a heap with a total order
(Method 5), so a complete search in any grid must give the same results to the bit:

* the search of a dense random sheet of 1 cm - 1 m particles (q = 3; shear-periodic and
  periodic) finds the same pairs, ghost-box offsets included, with classes and with one
  grid (exact equality), among them
  pairs across the radial boundary whose particle of lower index is the larger one (the
  offset the search from the smaller particle has to find again);
* a colliding sheet of 1 cm - 2 m particles evolves to ``==`` particle states over 300
  steps with classes (on 1 and 2 threads) and with one grid, and over 150 steps with
  self-gravity's kicks (P3M);
* a sheet of equal sizes is one class, and ``==`` as well.

No tolerance anywhere: any difference is a missed or an extra pair.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import rebound

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine import detector, native
from ringsim.engine.resolver import install_resolver
from ringsim.engine.sheet import build_sheet, particle_arrays

OMEGA = 2.0e-4                  # [1/s]
ONE_GRID = 1
#: Enough particles that the search is split over 2 threads (2 x RS_PARTICLES_PER_THREAD).
N_SPLIT = 2 * native.particles_per_thread() + 100


def power_law_radii(rng: np.random.Generator, n: int, r_min: float, r_max: float,
                    q: float = 3.0) -> np.ndarray:
    """n radii [m] of dn/dr ~ r^-q between r_min and r_max [m] (inverse of the CDF)."""
    u = rng.uniform(0.0, 1.0, n)
    a, b = r_min ** (1.0 - q), r_max ** (1.0 - q)
    return (a + u * (b - a)) ** (1.0 / (1.0 - q))


def empty_sheet(box: float, boundary: str) -> rebound.Simulation:
    """An empty sheet of one box ``box`` [m] wide: shear-periodic with SEI, or periodic
    with leapfrog and no shear flow (``boundary``); no collisions or gravity of REBOUND's,
    dt = 1e-3 orbit."""
    sim = rebound.Simulation()
    shear = boundary == "shear"
    sim.integrator = "sei" if shear else "leapfrog"
    if shear:
        sim.OMEGA = sim.OMEGAZ = OMEGA
    sim.boundary = boundary
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.collision = "none"
    sim.gravity = "none"
    sim.dt = 1e-3 * 2.0 * math.pi / OMEGA
    return sim


def dense_broad_sheet(seed: int, n: int, boundary: str = "shear") -> rebound.Simulation:
    """A random shear-periodic (or periodic, without the shear flow: ``boundary``) sheet
    of 1 cm - 1 m particles (q = 3, tau = 0.3, overlaps
    allowed, random speeds of 0.3 mm/s: reaches from about 2 cm to 1 m), half of them
    crowded within 1.5 m of the radial boundary with the 20 of lowest index 1 m large,
    after one step."""
    rng = np.random.default_rng(seed)
    radii = power_law_radii(rng, n, 0.01, 1.0)
    radii[:20] = 1.0    # large particles of low index, in the crowd at the boundary
    box = math.sqrt(np.sum(np.pi * radii**2) / 0.3)
    sim = empty_sheet(box, boundary)
    shear = boundary == "shear"
    x = rng.uniform(-box / 2, box / 2, n)
    edge = rng.uniform(0.5 * box - 1.5, 0.5 * box + 1.5, n // 2)
    x[: n // 2] = edge - box * (edge >= 0.5 * box)
    y = rng.uniform(-box / 2, box / 2, n)
    z = rng.normal(0.0, 0.5, n)
    speed = 3e-4        # [m/s]
    for i in range(n):
        sim.add(m=900.0 * radii[i] ** 3, r=radii[i], x=x[i], y=y[i], z=z[i],
                vx=rng.normal(0.0, speed),
                vy=-1.5 * OMEGA * x[i] * shear + rng.normal(0.0, speed),
                vz=rng.normal(0.0, speed))
    sim.steps(1)
    return sim


def sorted_pairs(pairs: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Pairs and offsets in one total order (p1, p2, gb)."""
    rows = np.column_stack([pairs.astype(float), offsets])
    return rows[np.lexsort(rows.T[::-1])]


@pytest.mark.parametrize("seed, boundary", [(3, "shear"), (4, "shear"), (11, "periodic")])
def test_search_finds_the_same_pairs_with_classes_and_one_grid(seed, boundary):
    sim = dense_broad_sheet(seed, 10000, boundary)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    detector.set_lists(handle.address, 0)   # the cells' search, the subject here
    found = {}
    for classes in (detector.MAX_CLASSES, ONE_GRID):
        detector.set_classes(handle.address, classes)
        found[classes] = handle.detect_pairs()
        used = handle.detector_stats()["classes"]
        assert used >= 3 if classes > 1 else used == 1
        assert handle.detector_stats()["half_shell"]
    with_classes = sorted_pairs(*found[detector.MAX_CLASSES])
    one_grid = sorted_pairs(*found[ONE_GRID])
    assert len(one_grid) > 1000, "too few swept contacts to test anything"
    np.testing.assert_array_equal(with_classes, one_grid)
    # pairs across the radial boundary whose particle of lower index (p1) is the larger:
    # the search from the smaller particle (higher index) reported them as p1 would
    pairs, offsets = found[ONE_GRID]
    radii = np.array([p.r for p in sim.particles])
    across = offsets[:, 0] != 0.0
    larger_first = radii[pairs[:, 0]] > 4.0 * radii[pairs[:, 1]]
    assert np.count_nonzero(across & larger_first) >= 20


@pytest.mark.skipif(not native.openmp_available(), reason="built without OpenMP")
def test_the_threads_shares_of_the_classes_keep_the_serial_order():
    """With classes, the threads' runs of the sorted particles are weighted by the grids
    their particles look into (rs_search_share); joined in thread order they give the
    serial search's reports in its order, on 2 and 3 threads."""
    sim = dense_broad_sheet(5, 3 * native.particles_per_thread() + 500)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    detector.set_classes(handle.address, detector.MAX_CLASSES)
    detector.set_lists(handle.address, 0)   # the cells' search, the subject here
    found = {}
    for threads in (1, 2, 3):
        native.set_detector_threads(handle.address, threads)
        found[threads] = handle.detect_pairs()
        assert native.detector_threads_used(handle.address) == threads
        assert handle.detector_stats()["classes"] >= 3
    assert len(found[1][0]) > 1000, "too few swept contacts to test anything"
    for threads in (2, 3):
        np.testing.assert_array_equal(found[threads][0], found[1][0])
        np.testing.assert_array_equal(found[threads][1], found[1][1])


def hot_broad_sheet(seed: int, n: int) -> rebound.Simulation:
    """A shear-periodic sheet of 2-30 cm particles (q = 3, tau = 0.3) moving at 1 cm/s
    rms per component, with 20 spheres of 4 m: the small particles' reaches, set by their
    speeds (dt w, 0.1-1.5 m), put most of them in the class just below the largest, as
    in the A ring's hot equilibria; after one step."""
    rng = np.random.default_rng(seed)
    radii = power_law_radii(rng, n, 0.02, 0.3)
    radii[:20] = 4.0
    box = math.sqrt(np.sum(np.pi * radii**2) / 0.3)
    sim = empty_sheet(box, "shear")
    x = rng.uniform(-box / 2, box / 2, n)
    y = rng.uniform(-box / 2, box / 2, n)
    z = rng.normal(0.0, 3.0, n)
    speed = 1e-2        # [m/s]
    for i in range(n):
        sim.add(m=900.0 * radii[i] ** 3, r=radii[i], x=x[i], y=y[i], z=z[i],
                vx=rng.normal(0.0, speed), vy=-1.5 * OMEGA * x[i] + rng.normal(0.0, speed),
                vz=rng.normal(0.0, speed))
    sim.steps(1)
    return sim


def test_classes_are_used_where_most_particles_reach_a_quarter_of_the_largest():
    """The choice of the classes weighs the cost of both searches (rs_layout_cost): here
    the class holding the most particles reaches about a quarter of the largest reach,
    where a rule on that ratio alone kept one grid with cells set by the 4 m spheres.  The
    classes find the same pairs."""
    sim = hot_broad_sheet(8, 20000)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    detector.set_lists(handle.address, 0)   # the cells' search, the subject here
    reaches = np.array([p.r + sim.dt * math.hypot(p.vx, p.vy + 1.5 * OMEGA * p.x, p.vz)
                        for p in sim.particles])
    classes = np.minimum((np.log(reaches.max() / reaches) / math.log(4.0)).astype(int), 7)
    most = np.bincount(classes).argmax()
    assert most == 1 and 8.0 * reaches[classes == most].max() > reaches.max()
    found = {}
    for limit in (detector.MAX_CLASSES, ONE_GRID):
        detector.set_classes(handle.address, limit)
        found[limit] = sorted_pairs(*handle.detect_pairs())
        assert (handle.detector_stats()["classes"] >= 3) == (limit > 1)
    assert len(found[ONE_GRID]) > 1000, "too few swept contacts to test anything"
    np.testing.assert_array_equal(found[detector.MAX_CLASSES], found[ONE_GRID])


def broad_scenario(n: int, gravity: bool, sizes: dict) -> dict:
    return {
        "name": "classes", "seed": 7, "planet": {"Omega": OMEGA},
        "particles": {"density": 450.0, "size_distribution": sizes},
        "sheet": {"optical_depth": 0.5, "n_particles": n, "gravity": gravity},
        "restitution": {"model": "bridges"},
        "integration": {"orbits": 1.0, "dt": "auto", "collision_detection": "line",
                        "threads": 1},
    }


BROAD = {"kind": "powerlaw", "q": 3.0, "r_min": 0.01, "r_max": 2.0}      # [m]
EQUAL = {"kind": "monodisperse", "radius": 1.0}                          # [m]


def evolve(scenario: dict, classes: int, threads: int, steps: int) -> tuple[dict, dict, dict]:
    """Particle arrays, search counters (with the threads the last search ran on) and
    resolution counters after ``steps`` steps."""
    built = build_sheet(scenario_from_dict(scenario, source="classes.yaml"))
    detector.set_classes(built.resolver.address, classes)
    detector.set_lists(built.resolver.address, 0)   # the cells' search, the subject here
    native.set_detector_threads(built.resolver.address, threads)
    built.sim.steps(steps)
    stats = built.resolver.detector_stats()
    stats["threads"] = native.detector_threads_used(built.resolver.address)
    return particle_arrays(built.sim), stats, built.resolver.order_stats()


def assert_same_states(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


@pytest.mark.parametrize("threads", [1, 2])
def test_broad_sheet_evolves_to_the_same_bits_with_classes_and_one_grid(threads):
    scenario = broad_scenario(N_SPLIT, False, BROAD)
    reference, grid_stats, order = evolve(scenario, ONE_GRID, 1, 300)
    states, class_stats, class_order = evolve(scenario, detector.MAX_CLASSES, threads, 300)
    assert grid_stats["classes"] == 1 and class_stats["classes"] >= 3
    assert order["resolved"] > 5000, "too few collisions to test anything"
    if native.openmp_available():
        assert class_stats["threads"] == threads
    assert class_order == order
    assert class_stats["reports"] == grid_stats["reports"]
    assert_same_states(states, reference)


def test_self_gravitating_broad_sheet_gives_the_same_bits_with_classes_and_one_grid():
    scenario = broad_scenario(3000, True, BROAD)
    reference, grid_stats, order = evolve(scenario, ONE_GRID, 1, 150)
    states, class_stats, class_order = evolve(scenario, detector.MAX_CLASSES, 1, 150)
    assert class_stats["classes"] >= 3
    assert order["resolved"] > 500, "too few collisions to test anything"
    assert class_order == order
    assert_same_states(states, reference)


def test_classes_are_refused_where_they_do_not_pay():
    """The 0.5-5 m sheet at tau = 0.25 (benchmarks/scale.yaml's), where the classes cost
    1.3 times the one grid (docs/performance.md), keeps its one grid: the estimate weighs
    the rows of cells the classes add against the neighbours they spare."""
    sizes = {"kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}    # [m]
    scenario = broad_scenario(5000, False, sizes)
    scenario["sheet"]["optical_depth"] = 0.25
    _, stats, _ = evolve(scenario, detector.MAX_CLASSES, 1, 3)
    assert stats["classes"] == 1


def test_equal_sizes_are_one_class_and_the_same_bits():
    scenario = broad_scenario(3000, False, EQUAL)
    reference, _, order = evolve(scenario, ONE_GRID, 1, 200)
    states, stats, class_order = evolve(scenario, detector.MAX_CLASSES, 1, 200)
    assert stats["classes"] == 1
    assert order["resolved"] > 100, "too few collisions to test anything"
    assert class_order == order
    assert_same_states(states, reference)


def test_set_classes_checks_its_argument():
    sim = dense_broad_sheet(1, 50)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    for bad in (0, detector.MAX_CLASSES + 1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="classes"):
            detector.set_classes(handle.address, bad)
    assert detector.set_classes(handle.address, 3) == 3
