"""The structure-free reference of the azimuthal asymmetry (``analysis.asymmetry_reference``,
``ringsim observe --reference K``)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import ringsim
from ringsim.analysis import occultation as oc
from ringsim.analysis.asymmetry_reference import (
    amplitude,
    p_value,
    reference_amplitudes,
    structure_free,
)
from ringsim.cli import main

AZIMUTHS = (0.0, 45.0, 90.0, 135.0)


def _tracer(Lx: float, Ly: float, seed: int):
    rng = np.random.default_rng(seed)

    def tau_of_view(snaps, b, a):
        views = [oc.trace_view(s, Lx, Ly, 0.0, b, a, rng, rays=20_000) for s in snaps]
        T = float(np.mean([v["transmission"] for v in views]))
        return -math.sin(math.radians(b)) * math.log(T)
    return tau_of_view


def _bars(Lx: float, Ly: float) -> dict:
    """Chains of 0.5 m spheres along y, one every 5 m in x: T 0.6 across them and 0.8 along
    them at B = 30 deg (tests/test_observe.py, the hand calculation)."""
    ys = np.arange(-0.5 * Ly, 0.5 * Ly, 0.05)
    xs = (np.arange(4) + 0.5) * Lx / 4 - 0.5 * Lx
    X, Y = np.meshgrid(xs, ys)
    return {"x": X.ravel(), "y": Y.ravel(), "z": np.zeros(X.size),
            "radius": np.full(X.size, 0.5)}


def test_bars_are_asymmetric_beyond_every_structure_free_copy():
    Lx = Ly = 20.0
    snap = _bars(Lx, Ly)
    trace = _tracer(Lx, Ly, 1)
    observed = amplitude([trace([snap], 30.0, a) for a in AZIMUTHS])
    # tau_n from T = 0.6 and 0.8: (ln 0.6 - ln 0.8) / mean over the four views, about 0.77
    assert observed > 0.5
    ref = reference_amplitudes([snap], Lx, Ly, 30.0, AZIMUTHS, 9,
                               np.random.default_rng(2), trace)
    # the copies (1600 spheres at one height, random x and y) scatter by 0.05-0.2
    assert len(ref) == 9 and max(ref) < 0.5 * observed
    assert p_value(observed, ref) == pytest.approx(1 / 10)


def test_a_layer_without_structure_is_not_called_asymmetric():
    """A Poisson layer: its amplitude is one draw of the reference's distribution; with 19
    copies it is the largest only by a 1-in-20 chance (not for this seed)."""
    rng = np.random.default_rng(5)
    n, tau, r = 3000, 0.3, 0.5
    L = math.sqrt(n * math.pi * r * r / tau)
    snap = {"x": (rng.random(n) - 0.5) * L, "y": (rng.random(n) - 0.5) * L,
            "z": (rng.random(n) - 0.5) * 20.0, "radius": np.full(n, r)}
    trace = _tracer(L, L, 6)
    observed = amplitude([trace([snap], 20.0, a) for a in AZIMUTHS])
    ref = reference_amplitudes([snap], L, L, 20.0, AZIMUTHS, 19, rng, trace)
    assert p_value(observed, ref) > 0.1


def test_the_copies_keep_sizes_and_heights_and_fill_the_box():
    rng = np.random.default_rng(3)
    snap = {"x": np.zeros(500), "y": np.zeros(500), "z": rng.normal(size=500),
            "radius": rng.random(500) + 0.1, "t": 12.0}
    twin = structure_free(snap, 8.0, 4.0, rng)
    assert twin["z"] is snap["z"] and twin["radius"] is snap["radius"] and twin["t"] == 12.0
    assert np.all(np.abs(twin["x"]) <= 4.0) and np.all(np.abs(twin["y"]) <= 2.0)
    assert np.std(twin["x"]) == pytest.approx(8.0 / math.sqrt(12), rel=0.1)
    assert math.isnan(amplitude([0.5, math.inf]))
    assert p_value(math.nan, [0.1]) is None and p_value(0.3, []) is None
    assert p_value(0.3, [0.1, 0.3, 0.5, math.nan]) == pytest.approx(3 / 4)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory, line_scenario):
    """conftest's LINE run: 60 particles, 0.3 orbit."""
    out = tmp_path_factory.mktemp("reference") / "tiny.h5"
    return ringsim.run(line_scenario(), output=out, progress=False)


def test_observe_with_a_reference_keeps_its_views_and_adds_p_values(tiny, tmp_path):
    args = ["observe", str(tiny), "--elevation", "30", "--azimuth", "0", "90", "--rays", "2000"]
    assert main([*args, "--json", str(tmp_path / "a.json")]) == 0
    assert main([*args, "--reference", "3", "--json", str(tmp_path / "b.json")]) == 0
    plain = json.loads((tmp_path / "a.json").read_text())
    with_ref = json.loads((tmp_path / "b.json").read_text())
    assert with_ref["views"] == plain["views"], "the reference traces after the views"
    (row,) = with_ref["azimuthal_asymmetry"]
    assert len(row["reference_amplitudes"]) == 3
    assert row["reference_p_value"] in (0.25, 0.5, 0.75, 1.0)
    assert "reference_amplitudes" not in plain["azimuthal_asymmetry"][0]
    assert main([*args, "--reference", "-1"]) == 2
