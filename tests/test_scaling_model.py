"""docs/scaling.md's estimates are benchmarks/scaling_model.py's output, and the model adds up."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks import scaling_model as model

ROOT = Path(__file__).resolve().parents[1]


def test_doc_section_is_the_models_output():
    doc = (ROOT / model.DOC).read_text()
    assert model.table() in doc


def test_slab_ghosts_are_two_faces_of_the_reach():
    # A 100 x 10 m sheet of 1000 particles (1 per m^2), slabs: each face brings reach x Ly.
    sheet = model.Sheet("t", 100.0, 10.0, 1000.0, 2.0, 3.0, 13, False, True)
    assert model.ghost_particles(sheet, 4) == pytest.approx(2 * 2.0 * 10.0)


def test_grid_ghosts_are_the_domains_ring():
    # 4 ranks on a 100 x 100 m sheet of 1 per m^2: domains of 50 m, a ring of width 2 m.
    sheet = model.Sheet("t", 100.0, 100.0, 1e4, 2.0, 3.0, 13, False, False)
    assert model.ghost_particles(sheet, 4) == pytest.approx((50 + 2 * 2) ** 2 - 50 ** 2)


def test_without_communication_cost_the_efficiency_is_one_and_compute_splits():
    sheet = model.Sheet("t", 1e5, 200.0, 9.5e6, 2.5, 3.0, 13, False, True)
    one = model.step_time(sheet, 16, 1e-7)
    four = model.step_time(sheet, 64, 1e-7)
    assert one["compute"] == pytest.approx(4 * four["compute"])
    assert one["comm"] == pytest.approx(four["comm"])   # a surface term, the same per slab
