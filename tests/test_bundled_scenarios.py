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
    # the Saturn presets of 3.4e4-1.8e5 particles: their set-up and first steps (the reduced
    # twins, saturn-*-small, run the first passages through the mid-plane)
    "saturn-a-ring": 0.01, "saturn-b-ring": 0.01, "saturn-c-ring": 0.01,
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


#: The Saturn presets (issue 39) and their reduced twins.
SATURN = ("saturn-a-ring", "saturn-b-ring", "saturn-c-ring")
#: Keys a reduced twin may change: its sizes, particles and duration (and the name, with the
#: output path and the checkpoints that follow the name and the snapshots).
TWIN_KEYS = ("name", "particles.size_distribution.r_min", "particles.size_distribution.r_max",
             "sheet.n_particles", "integration.orbits", "integration.until_equilibrium",
             "output.snapshot_every", "output.path", "output.checkpoint_every")


def _flat(d, prefix=""):
    out = {}
    for key, value in d.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


@pytest.mark.parametrize("name", SATURN)
def test_saturn_presets_are_real_rings_with_reduced_twins(name):
    full = load_scenario(SCENARIOS / f"{name}.yaml")
    twin = load_scenario(SCENARIOS / f"{name}-small.yaml")
    for sc in (full, twin):
        # self-gravity and friction on, porous ice, a distance inside Saturn's main rings
        # (C ring inner edge 74 490 km to A ring outer edge 136 770 km, Colwell et al. 2009)
        assert sc.sheet.gravity and sc.friction is not None
        assert sc.particles.density < 900.0
        assert 7.449e7 <= sc.planet.a <= 1.3677e8
        assert sc.particles.size_distribution.kind == "powerlaw"
        assert 2.75 <= sc.particles.size_distribution.q <= 3.5   # Brilliantov et al. 2015
    sizes = full.particles.size_distribution
    assert sizes.r_max / sizes.r_min >= 10, "a broad distribution"
    # the twin differs only in sizes, particle number and duration
    a, b = _flat(full.to_dict()), _flat(twin.to_dict())
    differ = {k for k in a.keys() | b.keys() if a.get(k) != b.get(k)}
    assert differ <= set(TWIN_KEYS), sorted(differ - set(TWIN_KEYS))
    assert twin.sheet.n_particles < full.sheet.n_particles
    # every value has its source in the preset's comments
    text = (SCENARIOS / f"{name}.yaml").read_text()
    for word in ("distance", "optical depth", "sizes", "density", "surface density"):
        assert f"# * {word}" in text, f"{name}: no source for {word}"


def test_the_a_ring_preset_starts_its_centimetre_particles_without_overlaps():
    # 178 000 particles of 2.5 cm to 5 m at tau = 0.5 (the set-up, about a CPU-second)
    sc = load_scenario(SCENARIOS / "saturn-a-ring.yaml")
    sim, geometry, radii, _, _ = sheet.new_simulation(sc)
    assert sim.N == 178_000 and radii.min() < 0.03 and radii.max() > 2.0
    assert box.count_overlaps(sheet.particle_arrays(sim), geometry, fraction=0.0) == 0
