"""Same scenario, same bits whatever numpy's BLAS threads (``engine.blas``): the set-up and
the outputs sum N terms with ``np.dot`` and ``@``, which OpenBLAS splits over its threads
above ~1e4 terms.  Before, a 3e4-particle run differed in every snapshot between 1 and 2
BLAS threads (the initial velocities' last bits, then chaos)."""

import os
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import ringsim
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.engine import invariants, sheet
from ringsim.engine.blas import one_blas_thread
from ringsim.engine.runner import Runner

SCALE = Path(__file__).resolve().parent.parent / "benchmarks" / "scale.yaml"

needs_two_cores = pytest.mark.skipif((os.cpu_count() or 1) < 2,
                                     reason="OpenBLAS splits sums only with 2 or more cores")


def _sheet_and_first_row(threads, path):
    """Initial particles and the first time-series row of a 2e4-particle sheet, made with
    BLAS on ``threads`` threads outside ringsim."""
    sc = with_overrides(load_scenario(SCALE), {"sheet.n_particles": 20000})
    with threadpool_limits(limits=threads, user_api="blas"):
        runner = Runner(sc, path, progress=False)
        runner.start_new()   # the set-up and the first output, committed with a checkpoint
        runner._writes.join()
    return sheet.particle_arrays(runner.sim), ringsim.open_run(path).timeseries


@needs_two_cores
def test_set_up_and_first_output_do_not_depend_on_blas_threads(tmp_path):
    one = _sheet_and_first_row(1, tmp_path / "one.h5")
    two = _sheet_and_first_row(2, tmp_path / "two.h5")
    for key in one[0]:
        assert np.array_equal(one[0][key], two[0][key]), f"initial {key}"
    assert one[1].keys() == two[1].keys()
    for key in one[1]:
        assert np.array_equal(one[1][key], two[1][key], equal_nan=True), f"/timeseries/{key}"


@needs_two_cores
def test_one_blas_thread_gives_the_one_thread_sum():
    rng = np.random.default_rng(2)
    n = 200_000
    xyz = rng.normal(size=(n, 3))   # strided columns, as sheet.particle_arrays gives them
    arrays = {"mass": rng.uniform(1.0, 2.0, n), "x": xyz[:, 0], "vx": xyz[:, 1],
              "vy": xyz[:, 2], "z": xyz[:, 0], "vz": xyz[:, 1]}
    with threadpool_limits(limits=1, user_api="blas"):
        reference = invariants.sheet_momentum(arrays, 2e-4, 0.0)
    with threadpool_limits(limits=2, user_api="blas"):
        limited = one_blas_thread(invariants.sheet_momentum)(arrays, 2e-4, 0.0)
    assert limited == reference
