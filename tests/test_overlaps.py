"""The overlap count of every output: the C count (``rs_count_overlaps`` behind
``engine.box.count_overlaps``) against its numpy twin (``testing.count_overlaps_numpy``),
exactly (both test a pair with the same operations on the same coordinates)."""

import numpy as np
import pytest

import ringsim
from ringsim.engine import box
from ringsim.testing import count_overlaps_numpy

OMEGA = 2.0e-4  # [1/s]


def _both(arrays, geometry, t, fraction):
    """(C count, numpy count) of one state."""
    shift = 1.5 * geometry.Omega * geometry.Lx * t
    return (box.count_overlaps(arrays, geometry, t, fraction),
            count_overlaps_numpy(arrays, geometry.Lx, geometry.Ly, shift, fraction))


def _sheet(rng, n, geometry, radii, thickness):
    """n particles uniform in the box, Gaussian heights of rms ``thickness`` [m]."""
    return {"x": rng.uniform(-0.5 * geometry.Lx, 0.5 * geometry.Lx, n),
            "y": rng.uniform(-0.5 * geometry.Ly, 0.5 * geometry.Ly, n),
            "z": rng.normal(0.0, thickness, n), "radius": radii}


def _straddling(rng, arrays, geometry, t, k):
    """Append k pairs straddling the radial boundary, each partner placed at the sheared
    image of the other with a random depth of overlap (some deeper than 0.1 r, some not)."""
    Lx, Ly = geometry.Lx, geometry.Ly
    shift = 1.5 * geometry.Omega * Lx * t
    r = rng.uniform(0.5, 2.0, (k, 2))
    x_high = 0.5 * Lx - rng.uniform(0.0, 0.5, k) * r[:, 0]
    y_high = rng.uniform(-0.5 * Ly, 0.5 * Ly, k)
    z = rng.normal(0.0, 1.0, k)
    gap = (r[:, 0] + r[:, 1]) * rng.uniform(0.7, 1.1, k)   # centre distance [m]
    direction = rng.normal(size=(k, 3))
    direction[:, 0] = np.abs(direction[:, 0])   # the partner lies beyond the boundary
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    # partner's image at x_high + d: the partner itself at x - Lx, y + shift (wrapped)
    x_low = x_high + gap * direction[:, 0] - Lx
    y_low = (y_high + gap * direction[:, 1] + shift + 0.5 * Ly) % Ly - 0.5 * Ly
    keep = x_low < 0.5 * Lx
    return {"x": np.concatenate([arrays["x"], x_high[keep], x_low[keep]]),
            "y": np.concatenate([arrays["y"], y_high[keep], y_low[keep]]),
            "z": np.concatenate([arrays["z"], z[keep], z[keep] + gap[keep]
                                 * direction[keep, 2]]),
            "radius": np.concatenate([arrays["radius"], r[keep, 0], r[keep, 1]])}


@pytest.mark.parametrize("t_orbits", [0.0, 0.123, 1.7, 250.3])
def test_c_count_equals_numpy_with_pairs_straddling_the_radial_boundary(t_orbits):
    rng = np.random.default_rng(int(t_orbits * 1000) + 1)
    geometry = box.SheetGeometry(40.0, 2, 3, 4, OMEGA)
    t = t_orbits * geometry.orbit
    n = 800
    arrays = _sheet(rng, n, geometry, rng.uniform(0.3, 2.0, n), 2.0)
    arrays = _straddling(rng, arrays, geometry, t, 60)
    for fraction in (0.0, 0.1, 0.4):
        c, numpy = _both(arrays, geometry, t, fraction)
        assert c == numpy, f"fraction {fraction}: C {c}, numpy {numpy}"
    c, _ = _both(arrays, geometry, t, 0.1)
    alone, _ = _both({k: v[:n] for k, v in arrays.items()}, geometry, t, 0.1)
    assert c - alone >= 20, "most planted boundary pairs are deep and counted"
    if t_orbits:
        # the same positions counted without the shear offset miss the planted pairs
        unsheared, numpy = _both(arrays, geometry, 0.0, 0.1)
        assert unsheared == numpy and unsheared < c


@pytest.mark.parametrize("seed", [3, 4])
def test_c_count_equals_numpy_on_very_polydisperse_sheets(seed):
    """Radii over 6 decades (10 radius classes of the count's grid, a factor 4 each), and
    over 4^33 (beyond the grid's 32 classes: the largest take the last class)."""
    rng = np.random.default_rng(seed)
    geometry = box.SheetGeometry(30.0, 1, 1, 2, OMEGA)
    for low, high in ((1e-4, 1e2 / 50.0), (1e-20, 5.0)):
        n = 3000
        radii = np.exp(rng.uniform(np.log(low), np.log(high), n))
        arrays = _sheet(rng, n, geometry, radii, 1.0)
        for t in (0.0, 0.31 * geometry.orbit):
            c, numpy = _both(arrays, geometry, t, 0.1)
            assert c == numpy and c > 0, f"radii {low}-{high} m, t {t}: C {c}, numpy {numpy}"


def test_the_count_on_threads_is_the_numpy_count():
    """A sheet large enough for the count's search to run on several threads (4096
    particles a thread at least), with thousands of deep pairs, some across the radial
    boundary: every number of threads gives the numpy twin's count."""
    rng = np.random.default_rng(7)
    geometry = box.SheetGeometry(60.0, 1, 1, 2, OMEGA)
    n = 14000
    arrays = _sheet(rng, n, geometry, rng.uniform(0.2, 1.2, n), 1.0)
    t = 0.27 * geometry.orbit
    shift = 1.5 * geometry.Omega * geometry.Lx * t
    numpy = count_overlaps_numpy(arrays, geometry.Lx, geometry.Ly, shift, 0.1)
    counts = [box.count_overlaps(arrays, geometry, t, 0.1, threads=k) for k in (1, 2, 3, 4)]
    assert numpy > 1000
    assert counts == [numpy] * 4


def test_two_particles_and_fewer():
    geometry = box.SheetGeometry(10.0, 1, 1, 1, OMEGA)
    t = 0.4 * geometry.orbit
    shift = 1.5 * OMEGA * geometry.Lx * t
    y_image = (1.0 + shift + 5.0) % 10.0 - 5.0   # where the image of y = 1 beyond x = +5 lands
    two = {"x": np.array([4.6, -4.9]), "y": np.array([1.0, y_image - 0.2]),
           "z": np.array([0.0, 0.1]), "radius": np.array([0.5, 0.4])}
    assert _both(two, geometry, t, 0.1) == (1, 1)
    assert _both(two, geometry, 0.0, 0.1) == (0, 0), "unsheared, the partner is elsewhere"
    one = {key: value[:1] for key, value in two.items()}
    none = {key: value[:0] for key, value in two.items()}
    assert _both(one, geometry, t, 0.1) == (0, 0)
    assert _both(none, geometry, t, 0.1) == (0, 0)


def test_a_pair_deep_directly_and_across_the_boundary_counts_once():
    """A box narrower than the pair's reach: the pair overlaps both directly and through
    the radial image; it is one physical pair."""
    geometry = box.SheetGeometry(2.5, 1, 4, 1, OMEGA)
    two = {"x": np.array([-0.6, 0.6]), "y": np.array([0.0, 0.0]), "z": np.zeros(2),
           "radius": np.array([1.0, 1.0])}
    assert _both(two, geometry, 0.0, 0.1) == (1, 1)


def test_a_runs_overlapping_pairs_are_the_numpy_count_of_its_snapshots(tmp_path, ring_scenario):
    """Tree detection with a coarse fixed step misses collisions: pairs overlap, and every
    output's count in /timeseries/overlapping_pairs is the twin's count of the state."""
    sc = ring_scenario(name="overlapping", seed=5, **{
        "planet.Omega": OMEGA, "sheet.optical_depth": 0.4, "integration.orbits": 0.6,
        "integration.dt": 0.02, "output.timeseries_every": 0.1})
    run = ringsim.open_run(ringsim.run(sc, output=tmp_path / "o.h5", progress=False))
    a = run.attrs
    counted = dict(zip(run.timeseries["t"], run.timeseries["overlapping_pairs"], strict=True))
    twin = []
    for k in range(run.n_snapshots):
        snap = run.snapshot(k)
        shift = 1.5 * a["Omega"] * a["Lx"] * snap["t"]
        twin.append(count_overlaps_numpy(snap, a["Lx"], a["Ly"], shift,
                                         box.OVERLAP_REPORT_FRACTION))
        assert counted[snap["t"]] == twin[-1], f"snapshot {k}"
    assert run.n_snapshots == 7 and sum(twin) > 0, "pairs overlapped"
