"""`ringsim run` with a friction section: spins in snapshots and checkpoints.

Checked: with ``friction: {model: constant, beta: -1}`` every dataset of the run file of
the same scenario without the section is identical (==) in the friction run, the
checkpoint compared by the state it loads (REBOUND's binary embeds wall-clock fields),
and the friction run's spins are all zero; a friction run extended by ``--resume`` from
its checkpoint equals (==) an uninterrupted run in every snapshot (spins included), time
series and checkpoint state; spins carry units and change in rough runs.
"""

from __future__ import annotations

import warnings

import h5py
import numpy as np
import rebound

import ringsim
from ringsim.store import runfile
from ringsim.testing import run_file_datasets

ROUGH = {"model": "coulomb", "mu": 0.5}


def loaded_state(path) -> np.ndarray:
    """(N, 7) x, y, z, vx, vy, vz, t of the checkpoint's simulation."""
    binary = runfile.read_checkpoint(path).binary
    tmp = path.with_suffix(".bin")
    tmp.write_bytes(binary)
    with warnings.catch_warnings():   # function pointers: not needed to read the state
        warnings.filterwarnings("ignore", message="You have to reset function pointers")
        sim = rebound.Simulation(str(tmp))
    state = np.array([[p.x, p.y, p.z, p.vx, p.vy, p.vz, sim.t] for p in sim.particles])
    sim = None
    tmp.unlink()
    return state


def test_beta_minus_one_run_equals_run_without_friction(tmp_path, small_scenario,
                                                        rough_scenario):
    smooth = ringsim.run(small_scenario(), output=tmp_path / "smooth.h5", progress=False)
    rough = ringsim.run(rough_scenario({"model": "constant", "beta": -1.0}),
                        output=tmp_path / "rough.h5", progress=False)
    a, b = run_file_datasets(smooth), run_file_datasets(rough)
    assert ringsim.open_run(smooth).timeseries["collisions"].sum() > 0
    for name in a:
        assert name in b and a[name] == b[name], f"dataset {name} differs"
    extra = set(b) - set(a)
    assert extra, "the friction run has its spins"
    for name in extra:
        with h5py.File(rough, "r") as f:
            assert np.all(f[name][...] == 0), f"{name}: spins stay zero with beta = -1"
    assert np.array_equal(loaded_state(smooth), loaded_state(rough)), "checkpoint state"


def test_resumed_rough_run_equals_uninterrupted(tmp_path, rough_scenario):
    long = rough_scenario(ROUGH, **{"integration.orbits": 0.8})
    short = rough_scenario(ROUGH, **{"integration.orbits": 0.4})
    direct = ringsim.run(long, output=tmp_path / "direct.h5", progress=False)
    path = ringsim.run(short, output=tmp_path / "ext.h5", progress=False)
    ringsim.run(long, output=path, resume=True, progress=False)
    a, b = run_file_datasets(direct), run_file_datasets(path)
    assert a.keys() == b.keys()
    for name in a:
        if not name.startswith("guards/"):     # the extension is a guard event
            assert a[name] == b[name], f"dataset {name} differs after --resume"
    assert np.array_equal(loaded_state(direct), loaded_state(path)), "checkpoint state"
    run = ringsim.open_run(direct)
    last = run.snapshot(-1)
    assert np.any(last["wz"] != 0.0), "rough collisions spin the particles"
    with h5py.File(direct, "r") as f:
        for field in runfile.SPIN_FIELDS:
            assert f["snapshots/000003"][field].attrs["units"] == "rad/s"
        assert f[runfile.CHECKPOINT_SPINS].attrs["units"] == "rad/s"
        assert f[runfile.CHECKPOINT_SPINS].shape == (150, 3)
