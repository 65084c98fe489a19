"""How the analysis scripts reuse, continue or refuse an existing run file
(``analysis/kappa_comparison.run_one``, which every campaign of ``analysis/`` runs through)."""

import importlib.util
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("kappa_comparison",
                                               ROOT / "analysis" / "kappa_comparison.py")
kappa_comparison = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(kappa_comparison)

SCENARIO = str(ROOT / "scenarios" / "kappa0.yaml")


def job(path: Path, orbits: float) -> tuple:
    return (SCENARIO, {"seed": 7, "sheet.n_particles": 60, "integration.orbits": orbits},
            str(path))


def series(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        return {k: f["timeseries"][k][()] for k in f["timeseries"]}


def test_a_stopped_run_asked_for_more_orbits_is_continued_bit_for_bit(tmp_path):
    whole = tmp_path / "whole.h5"
    kappa_comparison.run_one(job(whole, 0.4))
    part = tmp_path / "part.h5"
    kappa_comparison.run_one(job(part, 0.2))
    with h5py.File(part, "r+") as f:     # what a run stopped by SIGINT at its end records
        f.attrs["status"] = "stopped"
        f.attrs["kept_if_continued"] = 1     # a rewrite from the start would drop it
    kappa_comparison.run_one(job(part, 0.4))
    with h5py.File(part, "r") as f:
        assert f.attrs["status"] == "finished" and "kept_if_continued" in f.attrs
    a, b = series(whole), series(part)
    assert a.keys() == b.keys()
    for key in a:       # continued, not rewritten: the same rows, the same bits
        assert np.array_equal(a[key], b[key], equal_nan=True), key


def test_a_stopped_run_is_continued_on_another_thread_count(tmp_path):
    """The thread count changes no result (docs/scenario.md, integration.threads), so a
    job that differs from the file only in it continues the file (on the job's threads)
    instead of rewriting it from the start."""
    whole = tmp_path / "whole.h5"
    kappa_comparison.run_one(job(whole, 0.4))
    part = tmp_path / "part.h5"
    first = job(part, 0.2)
    kappa_comparison.run_one((first[0], {**first[1], "integration.threads": 1}, first[2]))
    with h5py.File(part, "r+") as f:
        f.attrs["status"] = "stopped"
        f.attrs["kept_if_continued"] = 1
    second = job(part, 0.4)
    kappa_comparison.run_one((second[0], {**second[1], "integration.threads": 2}, second[2]))
    with h5py.File(part, "r") as f:
        assert f.attrs["status"] == "finished" and "kept_if_continued" in f.attrs
    a, b = series(whole), series(part)
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=True), key


def test_a_run_longer_than_asked_is_refused_not_rewritten(tmp_path):
    path = tmp_path / "run.h5"
    kappa_comparison.run_one(job(path, 0.3))
    before = series(path)
    with pytest.raises(ValueError, match="more than the 0.2 asked"):
        kappa_comparison.run_one(job(path, 0.2))
    after = series(path)
    assert all(np.array_equal(before[k], after[k], equal_nan=True) for k in before)
