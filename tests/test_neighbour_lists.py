"""The line detector's neighbour list gives the same bits as its cells.

``rs_sheet_detect.c`` (Method 9) keeps, over several steps, a list of the pairs within
their reaches widened by a relative margin (the shear of those steps) and by each
particle's skin, and checks at every step that no pair outside it can be within the
bound of the step (each particle's drift from its anchor moved with the shear flow, the
growth of its reach).  The pairs a step reports are an exact set and the contacts are
resolved in a total order (Method 5), so a complete list must give the same results to the
bit as the cells:

* colliding sheets evolve to ``==`` particle states with and without the lists, on 1 and
  2 threads, with self-gravity's kicks (P3M) and with the reach classes (Method 2a);
* a search through the list finds the same pairs and ghost-box offsets as the cells after
  every kind of change between two searches: small moves, moves along the shear flow over
  a later time, a particle moved far, a radius or a speed made larger, particles shifted
  by a whole box, in shear-periodic and periodic boxes;
* and exactly REBOUND's own swept-sphere pairs.

No tolerance anywhere: any difference is a missed or an extra pair.  Every test checks
that the lists were used, so that none of them passes on the cells alone.
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
N_SPLIT = 2 * native.particles_per_thread() + 100
NO_LISTS = 0


def sheet_scenario(n: int, gravity: bool = False, sizes: dict | None = None,
                   dt: float = 1e-3) -> dict:
    """The benchmark sheet of benchmarks/scale.yaml (0.5-5 m, tau = 0.25, Bridges law,
    line detection) with ``n`` particles: cool enough that the lists pay."""
    return {
        "name": "lists", "seed": 5, "planet": {"Omega": OMEGA},
        "particles": {"density": 900.0, "size_distribution": sizes or {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}},
        "sheet": {"optical_depth": 0.25, "n_particles": n, "gravity": gravity},
        "restitution": {"model": "bridges"},
        "integration": {"orbits": 1.0, "dt": dt, "collision_detection": "line",
                        "threads": 1},
    }


def evolve(scenario: dict, lists: int, threads: int, steps: int) -> tuple[dict, dict, dict]:
    """Particle arrays, resolution counters and list counters after ``steps`` steps."""
    built = build_sheet(scenario_from_dict(scenario, source="lists.yaml"))
    detector.set_lists(built.resolver.address, lists)
    native.set_detector_threads(built.resolver.address, threads)
    built.sim.steps(steps)
    return (particle_arrays(built.sim), built.resolver.order_stats(),
            detector.list_counters(built.resolver.address))


def assert_same_states(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def assert_lists_used(counters: dict, steps: int) -> None:
    assert counters["builds"] >= 2, counters
    assert counters["steps"] >= 0.8 * steps, counters


@pytest.mark.parametrize("threads", [1, 2])
def test_cool_sheet_evolves_to_the_same_bits_with_and_without_lists(threads):
    scenario = sheet_scenario(N_SPLIT)
    reference, order, none = evolve(scenario, NO_LISTS, 1, 200)
    states, list_order, counters = evolve(scenario, detector.LIST_STEPS, threads, 200)
    assert none["builds"] == 0 and none["steps"] == 0
    assert_lists_used(counters, 200)
    assert counters["wide_checks"] > 0, "no re-check met a partner of large deviation"
    assert order["resolved"] > 1000, "too few collisions to test anything"
    assert list_order == order
    assert_same_states(states, reference)


def test_self_gravitating_sheet_gives_the_same_bits_with_and_without_lists():
    scenario = sheet_scenario(3000, gravity=True,
                              sizes={"kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 2.0})
    reference, order, _ = evolve(scenario, NO_LISTS, 1, 100)
    states, list_order, counters = evolve(scenario, detector.LIST_STEPS, 1, 100)
    assert_lists_used(counters, 100)
    assert order["resolved"] > 100, "too few collisions to test anything"
    assert list_order == order
    assert_same_states(states, reference)


def test_lists_with_reach_classes_give_the_same_bits():
    # 0.2-5 m at a fifth of the benchmark's step: cool enough for lists, broad enough
    # for classes
    scenario = sheet_scenario(N_SPLIT, sizes={"kind": "powerlaw", "q": 3.0, "r_min": 0.2,
                                              "r_max": 5.0}, dt=2e-4)
    built = build_sheet(scenario_from_dict(scenario, source="lists.yaml"))
    built.sim.steps(150)
    assert built.resolver.detector_stats()["classes"] >= 2
    assert_lists_used(detector.list_counters(built.resolver.address), 150)
    reference, order, _ = evolve(scenario, NO_LISTS, 1, 150)
    assert built.resolver.order_stats() == order
    assert order["resolved"] > 100, "too few collisions to test anything"
    assert_same_states(particle_arrays(built.sim), reference)


# --- one search after a change ---------------------------------------------------------------

def cool_random_sheet(seed: int, n: int, boundary: str = "shear", collision: str = "none",
                      step: bool = True, omega: float = OMEGA,
                      roots: tuple[int, int] = (1, 1)) -> rebound.Simulation:
    """A random sheet of 0.5-2 m particles (tau = 0.4, overlaps allowed, speeds of 0.1
    mm/s about the shear flow of ``omega`` [1/s]) in a box of ``roots`` (x, y) square root
    boxes, after one step with ``step``; REBOUND's own ``collision`` search."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(0.0, 1.0, n)
    radii = (0.5**-2 + u * (2.0**-2 - 0.5**-2)) ** -0.5
    root = math.sqrt(np.sum(np.pi * radii**2) / 0.4 / (roots[0] * roots[1]))
    sim = rebound.Simulation()
    shear = boundary == "shear"
    sim.integrator = "sei" if shear else "leapfrog"
    if shear:
        sim.OMEGA = sim.OMEGAZ = omega
    sim.boundary = boundary
    sim.root_size = root
    sim.N_root_x, sim.N_root_y = roots
    sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.collision = collision
    sim.gravity = "none"
    sim.dt = 1e-3 * 2.0 * math.pi / abs(omega)
    x = rng.uniform(-root * roots[0] / 2, root * roots[0] / 2, n)
    y = rng.uniform(-root * roots[1] / 2, root * roots[1] / 2, n)
    z = rng.normal(0.0, 1.0, n)
    for i in range(n):
        sim.add(m=900.0 * radii[i] ** 3, r=radii[i], x=x[i], y=y[i], z=z[i],
                vx=rng.normal(0.0, 1e-4),
                vy=-1.5 * omega * x[i] * shear + rng.normal(0.0, 1e-4),
                vz=rng.normal(0.0, 1e-4))
    if step:
        sim.steps(1)
    return sim


def sorted_pairs(pairs: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    rows = np.column_stack([pairs.astype(float), offsets])
    return rows[np.lexsort(rows.T[::-1])]


def phase_space(sim: rebound.Simulation) -> np.ndarray:
    xyz = np.zeros((sim.N, 3))
    vxyz = np.zeros((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vxyz)
    return np.hstack([xyz, vxyz])


def set_phase_space(sim: rebound.Simulation, state: np.ndarray) -> None:
    sim.set_serialized_particle_data(xyz=np.ascontiguousarray(state[:, :3]),
                                     vxvyvz=np.ascontiguousarray(state[:, 3:]))


def small_moves(sim, rng):
    state = phase_space(sim)
    state[:, :3] += rng.normal(0.0, 0.01, (sim.N, 3))
    set_phase_space(sim, state)


def along_the_flow(sim, rng):
    """Three steps later, every particle carried by the shear flow (the ghost boxes have
    slid on); in a periodic box, which has no flow, moved as the flow would move it."""
    later = 3.0 * sim.dt
    state = phase_space(sim)
    omega = sim.OMEGA if sim.boundary == "shear" else OMEGA     # periodic: a real move
    state[:, 1] += -1.5 * omega * state[:, 0] * later
    sim.t += later
    set_phase_space(sim, state)


def one_far(sim, rng):
    """Particle 7 moved onto the particle farthest from it in x."""
    state = phase_space(sim)
    far = int(np.argmax(np.abs(state[:, 0] - state[7, 0])))
    state[7, :3] = state[far, :3] + np.array([0.3, 0.2, 0.1])
    set_phase_space(sim, state)


def larger_radius(sim, rng):
    sim.particles[5].r *= 2.0


def faster(sim, rng):
    sim.particles[9].vx += 0.05


def shifted_by_a_box(sim, rng):
    """A third of the particles not yet wrapped: shifted into the next box (as the detector
    sees them before REBOUND's boundary check)."""
    state = phase_space(sim)
    lx = sim.root_size * sim.N_root_x
    ly = sim.root_size * sim.N_root_y
    shear = sim.boundary == "shear"
    slide = math.fmod(1.5 * sim.OMEGA * lx * sim.t, ly) if shear else 0.0
    moved = np.arange(0, sim.N, 3)
    state[moved, 0] += lx
    state[moved, 1] -= slide
    if shear:
        state[moved, 4] -= 1.5 * sim.OMEGA * lx
    set_phase_space(sim, state)


CHANGES = {"small moves": (small_moves, True), "along the flow": (along_the_flow, True),
           "one far": (one_far, False), "larger radius": (larger_radius, False),
           "faster": (faster, False), "shifted by a box": (shifted_by_a_box, True)}


@pytest.mark.parametrize("boundary", ["shear", "periodic"])
@pytest.mark.parametrize("change", sorted(CHANGES))
def test_search_through_the_list_after_a_change_finds_the_pairs_of_the_cells(change, boundary):
    sim = cool_random_sheet(13, 6000, boundary)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    detector.set_lists(handle.address, detector.LIST_STEPS)
    handle.detect_pairs()                                   # builds the list
    built = detector.list_counters(handle.address)
    assert built["builds"] == 1 and built["pairs"] > 0
    apply, kept = CHANGES[change]
    kept = kept and (boundary == "shear" or change != "along the flow")  # no flow to follow
    apply(sim, np.random.default_rng(1))
    through_list = handle.detect_pairs()
    after = detector.list_counters(handle.address)
    assert after["steps"] > built["steps"]
    # the changes within the skins keep the list; the others outgrow it
    assert after["builds"] == built["builds"] + (0 if kept else 1)
    detector.set_lists(handle.address, NO_LISTS)
    through_cells = handle.detect_pairs()
    assert len(through_cells[0]) > 500, "too few swept contacts to test anything"
    np.testing.assert_array_equal(sorted_pairs(*through_list), sorted_pairs(*through_cells))


@pytest.mark.parametrize("omega, roots", [(-OMEGA, (1, 1)), (OMEGA, (2, 1)), (OMEGA, (1, 2))])
@pytest.mark.parametrize("change", ["small moves", "along the flow", "shifted by a box"])
def test_list_in_other_boxes_and_flows_finds_the_pairs_of_the_cells(change, omega, roots):
    """The same as above with the flow reversed and in boxes longer than wide and wider
    than long (the slide then wraps in y over a box of another length)."""
    sim = cool_random_sheet(19, 6000, omega=omega, roots=roots)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    handle.detect_pairs()                                   # builds the list
    built = detector.list_counters(handle.address)
    assert built["builds"] == 1
    CHANGES[change][0](sim, np.random.default_rng(3))
    through_list = handle.detect_pairs()
    after = detector.list_counters(handle.address)
    assert after["steps"] > built["steps"] and after["builds"] == built["builds"]
    detector.set_lists(handle.address, NO_LISTS)
    through_cells = handle.detect_pairs()
    assert len(through_cells[0]) > 500, "too few swept contacts to test anything"
    np.testing.assert_array_equal(sorted_pairs(*through_list), sorted_pairs(*through_cells))


def test_a_changed_box_builds_the_list_again():
    sim = cool_random_sheet(23, 3000)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    handle.detect_pairs()
    sim.root_size *= 1.01
    through_list = handle.detect_pairs()
    assert detector.list_counters(handle.address)["builds"] == 2
    detector.set_lists(handle.address, NO_LISTS)
    np.testing.assert_array_equal(sorted_pairs(*through_list),
                                  sorted_pairs(*handle.detect_pairs()))


def test_search_through_the_list_finds_exactly_the_pairs_of_rebound_line_search():
    reported = []

    def record(sim_pointer, collision):
        reported.append((min(collision.p1, collision.p2), max(collision.p1, collision.p2)))
        return 0

    brute = cool_random_sheet(17, 3000, collision="line", step=False)
    brute.collision_resolve = record
    brute.steps(1)
    assert len(reported) > 200, "too few swept contacts to test anything"
    sim = cool_random_sheet(17, 3000, step=False)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5})  # detection only
    sim.steps(1)
    np.testing.assert_array_equal(phase_space(sim), phase_space(brute))
    pairs, _ = handle.detect_pairs()
    assert detector.list_counters(handle.address)["steps"] >= 1
    assert len(pairs) == len({tuple(p) for p in pairs}), "each pair reported once"
    assert {tuple(p) for p in pairs} == set(reported)


def test_set_lists_checks_its_argument():
    sim = cool_random_sheet(1, 50)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    for bad in (-1, 1001, 1.5, True, "2"):
        with pytest.raises(ValueError, match="steps"):
            detector.set_lists(handle.address, bad)
    assert detector.set_lists(handle.address, 3) == 3
    assert detector.list_counters(handle.address)["list_steps"] == 3
