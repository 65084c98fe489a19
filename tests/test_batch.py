"""The run-file policy of ``ringsim.batch`` that the sweep and the study share, on one tiny
run: a stopped run asked for more orbits is lengthened bit for bit, also on another thread
count, and a run longer than asked is refused, not rewritten."""

from pathlib import Path

import h5py
import numpy as np
import pytest

from ringsim import load_scenario
from ringsim.batch import existing_action, run_to_file
from ringsim.config.scenario import with_overrides
from ringsim.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
BASE = load_scenario(ROOT / "scenarios" / "kappa0.yaml")


def scenario(orbits: float, threads: int = 1):
    return with_overrides(BASE, {"seed": 7, "sheet.n_particles": 60,
                                 "integration.orbits": orbits,
                                 "integration.threads": threads})


def series(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        return {k: f["timeseries"][k][()] for k in f["timeseries"]}


def stopped_part(path: Path, orbits: float, threads: int = 1) -> None:
    """A run of ``orbits`` left as a SIGINT at its end leaves it, with a marker attribute
    that a rewrite from the start would drop."""
    run_to_file(scenario(orbits, threads), path, "run")
    with h5py.File(path, "r+") as f:
        f.attrs["status"] = "stopped"
        f.attrs["kept_if_continued"] = 1


def assert_same_rows(a: Path, b: Path) -> None:
    x, y = series(a), series(b)
    assert x.keys() == y.keys()
    for key in x:       # continued, not rewritten: the same rows, the same bits
        assert np.array_equal(x[key], y[key], equal_nan=True), key


@pytest.mark.parametrize("threads", [1, 2])
def test_a_stopped_run_asked_for_more_orbits_is_lengthened_bit_for_bit(tmp_path, threads):
    """The thread count changes no result (docs/scenario.md, integration.threads), so a
    stopped run asked for on another thread count is continued, not rewritten."""
    whole = tmp_path / "whole.h5"
    run_to_file(scenario(0.4), whole, "run")
    part = tmp_path / "part.h5"
    stopped_part(part, 0.2)
    asked = scenario(0.4, threads)
    action = existing_action(part, asked, extend=True, asker="the study")
    assert action == "extend"
    run_to_file(asked, part, action)
    with h5py.File(part, "r") as f:
        assert f.attrs["status"] == "finished" and "kept_if_continued" in f.attrs
    assert_same_rows(whole, part)
    assert existing_action(part, asked, extend=True) == "reuse"


def test_a_run_longer_than_asked_is_refused_not_rewritten(tmp_path):
    path = tmp_path / "run.h5"
    run_to_file(scenario(0.3), path, "run")
    before = series(path)
    with pytest.raises(InputError, match="more than the 0.2"):
        existing_action(path, scenario(0.2), extend=True, asker="the study")
    after = series(path)
    assert all(np.array_equal(before[k], after[k], equal_nan=True) for k in before)
