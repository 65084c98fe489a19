"""Every bundled scenario runs clean: no warning on screen, no WARNING guard event.

Each runs for a short time (orbits overridden; the quick start runs in full) that covers
the first passages of the initial layer through the mid-plane (a quarter and three
quarters of an orbit), where a badly set-up state shows deep overlaps and a box that
must be enlarged at once.
"""

import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

import ringsim
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.engine import box, sheet

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
BUNDLED = sorted(p for p in SCENARIOS.glob("*.yaml") if not p.name.startswith("sweep"))
#: Orbits each scenario is run for (the quick start: all of it).
SHORT_ORBITS = 0.8
#: Scenarios too costly for SHORT_ORBITS, with the orbits they run for instead and why.
COSTLY_ORBITS: dict[str, float] = {
    # (empty since the kappa-with-gravity pair runs line detection with the tree for
    # gravity: 20-35 CPU-seconds per orbit instead of ~3.4 CPU-hours)
}
#: Run in the default test run (a few seconds each); the others are marked slow.
FAST = ("quickstart", "kappa0.1")
CASES = [pytest.param(p, id=p.stem, marks=() if p.stem in FAST else pytest.mark.slow)
         for p in BUNDLED]


def test_the_bundled_scenarios_are_found():
    names = {p.stem for p in BUNDLED}
    assert {"quickstart", "kappa0", "kappa0.1", "bridges", "constant-eps-0.5"} <= names


@pytest.mark.parametrize("path", CASES)
def test_bundled_scenario_runs_without_warning(path, tmp_path, capfd):
    sc = load_scenario(path)
    if sc.name in COSTLY_ORBITS:
        sc = with_overrides(sc, {"integration.orbits": COSTLY_ORBITS[sc.name]})
    elif sc.integration.orbits > 5.0:
        sc = with_overrides(sc, {"integration.orbits": SHORT_ORBITS})
    out = tmp_path / f"{sc.name}.h5"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ringsim.run(sc, output=out, progress=False)
    stderr = capfd.readouterr().err
    assert not [w for w in caught if "function pointers" not in str(w.message)], \
        [str(w.message) for w in caught]
    assert "warning" not in stderr.lower(), stderr
    assert "vertical guard" not in stderr, "the automatic box is too low: " + stderr
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "finished"
        messages = [m.decode() if isinstance(m, bytes) else m
                    for m in (f["guards/message"][:] if "message" in f["guards"] else [])]
        assert not [m for m in messages if "WARNING" in m or "vertical guard" in m], messages
        assert int(np.max(f["timeseries/overlapping_pairs"][:])) == 0, "deep overlaps"


def test_initial_layer_is_in_vertical_equilibrium():
    # z and vz / Omega share one Gaussian: the layer does not fall through the mid-plane
    # in step a quarter orbit later (the cause of the quick start's deep overlap)
    sc = load_scenario(SCENARIOS / "kappa0.yaml")
    built = sheet.build_sheet(sc)
    arrays = sheet.particle_arrays(built.sim)
    Omega = sc.orbital_frequency
    ratio = np.std(arrays["vz"] / Omega) / np.std(arrays["z"])
    assert abs(ratio - 1.0) < 0.05, f"std(vz/Omega) / std(z) = {ratio}"
    assert abs(np.mean(arrays["z"] * arrays["vz"])) < 0.05 * np.std(arrays["z"]) \
        * np.std(arrays["vz"]), "z and vz uncorrelated (phases mixed)"
    h = np.std(arrays["z"])
    assert h == pytest.approx(sheet.minimum_scale_height(built.radii, built.geometry.Lx
                                                         * built.geometry.Ly), rel=0.05)
    assert box.count_overlaps(arrays, built.geometry, fraction=0.0) == 0


def test_automatic_box_leaves_room_for_shear_kicked_small_particles():
    sc = load_scenario(SCENARIOS / "kappa0.1.yaml")
    built = sheet.build_sheet(sc)
    limit = sheet.VERTICAL_GUARD_FRACTION * 0.5 * built.geometry.z_period
    assert limit >= 20.0 * built.radii.max(), "room for amplitudes of 20 r_max"
