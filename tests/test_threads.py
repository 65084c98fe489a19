"""Line detection on several OpenMP threads: ``integration.threads`` and the same bits.

The detector's search is split over threads (``rs_sheet_detect.c``, step 3a); the contacts
are resolved serially in a total order, so the thread count must change no result: the
same pairs from the search, and the same run file (every dataset ``==``; the checkpoint
compared by the state it loads, since REBOUND's binary embeds wall-clock fields).
"""

from __future__ import annotations

import math
import subprocess
import sys

import h5py
import numpy as np
import pytest
import rebound

from ringsim.config.scenario import ScenarioError, scenario_from_dict
from ringsim.engine import detector, native
from ringsim.engine.binary import simulation_from_binary
from ringsim.engine.resolver import install_resolver
from ringsim.engine.runner import run
from ringsim.engine.sheet import particle_arrays

OMEGA = 2.0e-4
#: Enough particles that the search is split over 2 threads (2 x RS_PARTICLES_PER_THREAD).
N_SPLIT = 2 * native.particles_per_thread() + 100

needs_openmp = pytest.mark.skipif(not native.openmp_available(),
                                  reason="ringsim._resolver built without OpenMP")


def scenario_dict(threads, n_particles: int = N_SPLIT) -> dict:
    return {
        "name": "threads", "seed": 11, "planet": {"Omega": OMEGA},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}},
        "sheet": {"optical_depth": 0.5, "n_particles": n_particles},
        "restitution": {"model": "bridges"},
        "integration": {"orbits": 0.06, "dt": "auto", "collision_detection": "line",
                        "threads": threads},
        "output": {"timeseries_every": 0.02, "snapshot_every": 0.04,
                   "checkpoint_every": 0.04},
    }


# -- the scenario key -------------------------------------------------------------------------

@pytest.mark.parametrize("value", [0, -2, 1.5, "two", True, "Auto", [2]])
def test_threads_rejects_bad_values(value):
    with pytest.raises(ScenarioError, match=r"integration\.threads"):
        scenario_from_dict(scenario_dict(value, 100), source="bad.yaml")


@pytest.mark.parametrize("value, expected", [(1, 1), (2, 2), (7, 7)])
def test_threads_accepts_integers(value, expected):
    sc = scenario_from_dict(scenario_dict(value, 100), source="ok.yaml")
    assert sc.integration.threads == expected
    assert sc.integration.thread_count() == expected


def test_threads_auto_is_the_cores_of_the_process():
    import os

    sc = scenario_from_dict(scenario_dict("auto", 100), source="ok.yaml")
    assert sc.integration.threads == "auto"
    assert sc.integration.thread_count() == len(os.sched_getaffinity(0))
    default = scenario_dict("auto", 100)
    del default["integration"]["threads"]
    assert scenario_from_dict(default, source="ok.yaml").integration.threads == "auto"


def test_bad_threads_exits_2_with_one_line_and_no_file(tmp_path):
    import yaml

    path = tmp_path / "bad.yaml"
    out = tmp_path / "run.h5"
    text = yaml.safe_dump(scenario_dict(0, 100))
    path.write_text(text)
    proc = subprocess.run([sys.executable, "-m", "ringsim.cli", "run", str(path), "-o",
                           str(out)], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path)   # not the source tree: it would shadow the install
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.yaml" in lines[0] and "integration.threads" in lines[0]
    assert "Traceback" not in proc.stderr
    assert not out.exists()


# -- the search --------------------------------------------------------------------------------

def dense_sheet(seed: int, n: int) -> rebound.Simulation:
    """A random dense shear-periodic sheet (tau ~ 1, overlaps allowed) after one step."""
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.5, 2.0, n)
    box = math.sqrt(np.sum(np.pi * radii**2))     # optical depth 1
    sim = rebound.Simulation()
    sim.integrator = "sei"
    sim.OMEGA = sim.OMEGAZ = OMEGA
    sim.boundary = "shear"
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = 1
    sim.N_root_z = 1
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.collision = "none"
    sim.gravity = "none"
    sim.dt = 1e-3 * 2.0 * math.pi / OMEGA
    x = rng.uniform(-box / 2, box / 2, n)
    y = rng.uniform(-box / 2, box / 2, n)
    for i in range(n):
        sim.add(m=900.0 * radii[i] ** 3, r=radii[i], x=x[i], y=y[i], z=rng.normal(0.0, 3.0),
                vx=rng.normal(0.0, 0.05), vy=-1.5 * OMEGA * x[i] + rng.normal(0.0, 0.05),
                vz=rng.normal(0.0, 0.05))
    sim.steps(1)
    return sim


def sorted_pairs(pairs: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Pairs and offsets in one total order (p1, p2, gb)."""
    rows = np.column_stack([pairs.astype(float), offsets])
    return rows[np.lexsort(rows.T[::-1])]


@needs_openmp
@pytest.mark.parametrize("seed", [5, 6])
def test_search_finds_the_same_pairs_on_1_and_2_threads(seed):
    sim = dense_sheet(seed, N_SPLIT)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    detector.set_lists(handle.address, 0)   # the cells' search (the lists: test_neighbour_lists)
    found = {}
    for threads in (1, 2):
        native.set_detector_threads(handle.address, threads)
        pairs, offsets = handle.detect_pairs()
        assert native.detector_threads_used(handle.address) == threads
        found[threads] = (pairs, offsets)
    assert len(found[1][0]) > 1000, "too few swept contacts to test anything"
    # joined in thread order, the lists are even in the serial search order
    np.testing.assert_array_equal(found[2][0], found[1][0])
    np.testing.assert_array_equal(sorted_pairs(*found[2]), sorted_pairs(*found[1]))


def test_small_sheets_search_on_one_thread():
    sim = dense_sheet(7, 500)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    native.set_detector_threads(handle.address, 2)
    handle.detect_pairs()
    assert native.detector_threads_used(handle.address) == 1


def test_set_detector_threads_checks_its_argument():
    sim = dense_sheet(8, 300)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              collision_detection="line")
    for bad in (0, -1, 1.0, True):
        with pytest.raises(ValueError, match="threads"):
            native.set_detector_threads(handle.address, bad)


# -- a whole run -------------------------------------------------------------------------------

#: Attributes that record when and how long, not what: the wall clock, and the hash of the
#: REBOUND binary (which embeds wall-clock fields).
WALL_CLOCK_ATTRIBUTES = ("wall_time_s", "cpu_time_s", "created_utc", "sha256")


def _datasets(path) -> dict[str, object]:
    """Every dataset of a run file (the checkpoint's binary as the state it loads) and the
    attributes, without the wall-clock ones; the scenario without its threads line."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, item):
            if isinstance(item, h5py.Dataset):
                if name == "checkpoint":
                    sim = simulation_from_binary(item[()].tobytes(), path)
                    arrays = particle_arrays(sim)
                    for key, values in arrays.items():
                        out[f"checkpoint:{key}"] = values
                    out["checkpoint:t"] = np.array(sim.t)
                else:
                    out[name] = item[()]
            for key, value in item.attrs.items():
                if key not in WALL_CLOCK_ATTRIBUTES:
                    out[f"{name}@{key}"] = value
        f.visititems(visit)
        for key, value in f.attrs.items():
            if key == "scenario_yaml":
                value = "\n".join(line for line in str(value).splitlines()
                                   if not line.strip().startswith("threads:"))
            if key not in WALL_CLOCK_ATTRIBUTES:
                out[f"@{key}"] = value
    return out


@needs_openmp
def test_run_gives_the_same_bits_on_1_and_2_threads(tmp_path):
    files = {}
    for threads in (1, 2):
        sc = scenario_from_dict(scenario_dict(threads), source="threads.yaml")
        files[threads] = run(sc, output=tmp_path / f"t{threads}.h5", progress=False)
    one, two = _datasets(files[1]), _datasets(files[2])
    assert set(one) == set(two)
    assert int(np.asarray(one["timeseries/collisions"]).sum()) > 100, "too few collisions"
    for key in one:
        a, b = np.asarray(one[key]), np.asarray(two[key])
        if a.dtype.kind == "f":
            assert np.array_equal(a, b, equal_nan=True), key
        else:
            assert np.array_equal(a, b), key


def test_resume_accepts_another_thread_count(tmp_path):
    path = tmp_path / "resume.h5"
    first = scenario_dict(1, 200)
    first["integration"]["orbits"] = 0.02
    run(scenario_from_dict(first, source="threads.yaml"), output=path, progress=False)
    longer = scenario_dict(2, 200)
    longer["integration"]["orbits"] = 0.04
    run(scenario_from_dict(longer, source="threads.yaml"), output=path, resume=True,
        progress=False)
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "finished"
        assert f["timeseries/orbits"][-1] == pytest.approx(0.04, abs=1e-3)  # one step
