"""Rotational energy by size bin (``physics.spin_by_size``), against sums done by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringsim.physics.sizes import size_bin_index
from ringsim.physics.spin_by_size import size_bin_spin_row


def test_the_bins_follow_numpy_histogram():
    edges = np.array([0.1, 0.3, 1.0, 3.0])
    r = np.array([0.1, 0.29, 0.3, 2.999, 3.0, 0.05, 3.1])
    assert size_bin_index(r, edges).tolist() == [0, 0, 1, 2, 2, -1, -1]
    counts, _ = np.histogram(r, bins=edges)
    inside = size_bin_index(r, edges)
    assert np.bincount(inside[inside >= 0], minlength=3).tolist() == counts.tolist()


def test_energies_per_bin_by_hand():
    # three particles, two in the first bin and one in the third; the second bin is empty
    m = np.array([2.0, 2.0, 4.0])
    r = np.array([0.2, 0.2, 2.0])
    edges = np.array([0.1, 0.5, 1.0, 3.0])
    # velocities relative to the shear flow (rows vx, vy, vz); their mass-weighted mean is
    # ((2 - 2 + 2) / 8, 0, 0) = (0.25, 0, 0)
    v = np.array([[1.0, -1.0, 0.5], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    w = np.array([[0.0, 0.0, 3.0], [1.0, 0.0, 0.0], [0.0, 0.5, 0.0]])
    k = 0.4
    row = size_bin_spin_row(m, r, v, w, k, edges)
    # E_rot = 1/2 k m r^2 |w|^2: 0.144 + 0.016 in the first bin, 0.8 in the third
    e_rot = row["size_bin_rotational_energy"]
    assert e_rot[0] == pytest.approx(0.160, rel=1e-14)
    assert math.isnan(e_rot[1])
    assert e_rot[2] == pytest.approx(0.8, rel=1e-14)
    # E_tr about it: 1/2 2 0.75^2 + 1/2 2 1.25^2 = 2.125 for the first bin, 1/2 4 0.25^2 =
    # 0.125 for the third
    ratio = row["size_bin_rotational_energy_ratio"]
    assert ratio[0] == pytest.approx(0.160 / 2.125, rel=1e-14)
    assert math.isnan(ratio[1])
    assert ratio[2] == pytest.approx(0.8 / 0.125, rel=1e-14)


def test_a_bin_at_the_mean_velocity_has_a_ratio_of_zero():
    m, r = np.array([1.0, 1.0]), np.array([0.2, 2.0])
    v = np.zeros((3, 2))
    w = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    row = size_bin_spin_row(m, r, v, w, 0.4, np.array([0.1, 1.0, 3.0]))
    assert row["size_bin_rotational_energy_ratio"].tolist() == [0.0, 0.0]
    assert row["size_bin_rotational_energy"][0] > 0.0
