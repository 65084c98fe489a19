"""``sheet.initial_toomre_q``: a self-gravitating sheet that starts at a given Toomre Q.

What is checked: the drawn sheet's radial velocity dispersion gives Toomre's Q (Salo 1995's
stellar form, sigma_x Omega / (3.36 G Sigma), with the box's own surface density) within
its sampling error (relative standard error of an rms over N values, 1/sqrt(2 N), three of
them); the key round-trips and is refused, with one line, without self-gravity, beside
``initial_dispersion`` and at Q <= 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringsim.config.scenario import scenario_from_dict
from ringsim.config.schema import ScenarioError
from ringsim.engine import sheet
from ringsim.physics.gravity import toomre_q

BASE = {
    "name": "q-start",
    "seed": 4,
    "planet": {"GM": 3.7931e16, "a": 1.3e8},
    "particles": {"density": 450.0,
                  "size_distribution": {"kind": "powerlaw", "q": 3.0, "r_min": 0.1,
                                        "r_max": 2.0}},
    "sheet": {"optical_depth": 0.5, "n_particles": 2000, "gravity": True,
              "initial_toomre_q": 2.0},
}


def _with_sheet(**keys) -> dict:
    return {**BASE, "sheet": {**BASE["sheet"], **keys}}


def test_drawn_sheet_starts_at_the_requested_toomre_q():
    sc = scenario_from_dict(BASE, source="q-start")
    assert sc.to_dict()["sheet"]["initial_toomre_q"] == 2.0
    assert "initial_dispersion" not in sc.to_dict()["sheet"]
    assert scenario_from_dict(sc.to_dict()) == sc
    sim, geometry, radii, masses, _ = sheet.new_simulation(sc)
    arrays = sheet.particle_arrays(sim)
    Sigma = masses.sum() / (geometry.Lx * geometry.Ly)            # [kg/m^2]
    sigma_x = float(np.sqrt(np.mean(arrays["vx"] ** 2)))         # [m/s]
    Q = float(toomre_q(sigma_x, Sigma, sc.orbital_frequency))
    assert Q == pytest.approx(2.0, rel=3.0 / math.sqrt(2 * radii.size))


@pytest.mark.parametrize("keys, message", [
    ({"gravity": False}, "only used with self-gravity"),
    ({"initial_dispersion": 3.0}, "given with sheet.initial_dispersion"),
    ({"initial_toomre_q": 0.0}, "initial_toomre_q"),
])
def test_bad_initial_toomre_q_is_refused(keys, message):
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(_with_sheet(**keys), source="bad")


def test_the_same_sheet_without_gravity_starts_from_the_same_state():
    """``engine.sheet.without_gravity`` (the baseline of gravitating benchmarks) turns the
    Q start into the equal initial_dispersion of the same draw: the same bits."""
    sc = scenario_from_dict(BASE, source="q-start")
    plain = sheet.without_gravity(sc)
    assert not plain.sheet.gravity and plain.sheet.initial_toomre_q is None
    a = sheet.particle_arrays(sheet.new_simulation(sc)[0])
    b = sheet.particle_arrays(sheet.new_simulation(plain)[0])
    for key in ("x", "y", "z", "vx", "vy", "vz", "radius", "mass"):
        assert np.array_equal(a[key], b[key]), key
