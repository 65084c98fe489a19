"""ringsim's threaded SEI (csrc/rs_sei.c) is REBOUND's SEI, bit for bit, on any thread count.

The run loop integrates with it (``engine.native.use_threaded_sei``); these tests hold it to
REBOUND's own ``sei`` over thousands of steps of a colliding, gravitating sheet, and to
itself on 1 and 2 threads, with ``==`` on every coordinate.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import rebound

from ringsim.engine import native
from ringsim.engine.binary import simulation_binary, simulation_from_binary
from ringsim.engine.sheet import build_sheet, particle_arrays
from ringsim.gravity.registry import install_scenario_gravity

needs_openmp = pytest.mark.skipif(not native.openmp_available(),
                                  reason="ringsim._resolver built without OpenMP")
COORDINATES = ("x", "y", "z", "vx", "vy", "vz")


def _sheet(scenario, integrator: str, threads: int = 1) -> rebound.Simulation:
    """The scenario's sheet (its resolver stays installed: ``sim._extras_ref``)."""
    sim = build_sheet(scenario).sim
    if scenario.sheet.gravity:
        install_scenario_gravity(sim, scenario)
    if integrator == "sei":
        sim.integrator = "sei"
    else:
        native.use_threaded_sei(sim, threads)
    return sim


def _collisions(sim: rebound.Simulation) -> int:
    return int(sim._extras_ref.stats()["count"])


def _state(sim: rebound.Simulation) -> dict[str, np.ndarray]:
    arrays = particle_arrays(sim)
    return {key: arrays[key] for key in COORDINATES}


def _assert_same_bits(a: rebound.Simulation, b: rebound.Simulation) -> None:
    assert a.t == b.t
    sa, sb = _state(a), _state(b)
    for key in COORDINATES:
        assert np.array_equal(sa[key], sb[key]), key


def test_the_sheet_integrates_with_the_threaded_sei(gravitating_scenario):
    sim = build_sheet(gravitating_scenario()).sim
    assert str(sim.integrator) == native.THREADED_SEI


def test_threaded_sei_is_rebounds_sei_over_2000_steps_of_a_gravitating_colliding_sheet(
        gravitating_scenario):
    sc = gravitating_scenario({"sheet.n_particles": 400, "integration.dt": 1e-3,
                               "integration.collision_detection": "line"})
    ours, theirs = _sheet(sc, native.THREADED_SEI), _sheet(sc, "sei")
    ours.steps(2000)
    theirs.steps(2000)
    assert _collisions(ours) > 100     # the sheet does collide
    _assert_same_bits(ours, theirs)


@needs_openmp
def test_threaded_sei_gives_the_same_bits_on_1_and_2_threads(gravitating_scenario):
    n = 2 * native.sei_particles_per_thread() + 100   # enough that 2 threads split the loops
    sc = gravitating_scenario({"sheet.n_particles": n, "integration.dt": 1e-3,
                               "integration.collision_detection": "line"})
    one, two, theirs = (_sheet(sc, native.THREADED_SEI, 1), _sheet(sc, native.THREADED_SEI, 2),
                        _sheet(sc, "sei"))
    for sim in (one, two, theirs):
        sim.steps(100)
    assert _collisions(one) > 100
    _assert_same_bits(one, two)
    _assert_same_bits(one, theirs)


def test_checkpoints_name_rebounds_sei_and_resume_threaded(gravitating_scenario, tmp_path):
    sc = gravitating_scenario({"sheet.n_particles": 100})
    sim = _sheet(sc, native.THREADED_SEI, 2)
    sim.steps(5)
    binary = simulation_binary(sim)
    assert str(sim.integrator) == native.THREADED_SEI and sim.integrator.threads == 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # REBOUND's reminder of the function pointers
        loaded = simulation_from_binary(binary, tmp_path / "x.h5")
    assert str(loaded.integrator) == "sei"     # plain REBOUND can load the checkpoint


def test_other_integrators_are_left_alone():
    sim = rebound.Simulation()
    sim.integrator = "leapfrog"
    native.use_threaded_sei(sim, 2)
    assert str(sim.integrator) == "leapfrog"
