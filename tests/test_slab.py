"""The slab solver (``sheet.gravity_solver: slab``): the vertical field of the horizontally
averaged layer, in C (``rs_slab_field``) against its numpy twin and a hand count, its
momentum, the scenario keys, resume and the run's analysis (docs/gravity.md, "Slab")."""

import ctypes
import math

import numpy as np
import pytest
import rebound

import ringsim
from ringsim import testing
from ringsim.analysis.gravitating import gravity_equilibrium
from ringsim.config.scenario import scenario_from_dict
from ringsim.config.schema import ScenarioError
from ringsim.engine import box, sheet
from ringsim.gravity import registry
from ringsim.physics.constants import G_SI
from ringsim.physics.selfgravity import slab_field


def slab_simulation(s):
    """A REBOUND shearing sheet of ``s`` (``testing.random_sheet``) with the slab field only."""
    sim = rebound.Simulation()
    box.configure_box(sim, s["geometry"])
    sim.collision = "none"
    registry.install_gravity(sim, "slab", softening=0.0)
    state = {k: s["pos"][:, i] for i, k in enumerate("xyz")}
    state.update({k: s["vel"][:, i] for i, k in enumerate(("vx", "vy", "vz"))})
    sheet.add_particles(sim, state, s["radius"], s["mass"])
    return sim


def accelerations(sim):
    rebound.clibrebound.reb_simulation_update_acceleration(ctypes.byref(sim))
    acc = np.empty((sim.N, 3))
    for i, p in enumerate(sim.particles):
        acc[i] = (p.ax, p.ay, p.az)
    return acc


def test_c_slab_field_is_the_numpy_twin_and_vertical():
    s = testing.random_sheet(400, seed=5, dispersion=0.02)
    sim = slab_simulation(s)
    assert registry.installed_solver_name(sim) == "slab" and sim.gravity == "none"
    acc = accelerations(sim)
    expected = slab_field(s["pos"][:, 2], s["mass"], s["Lx"], s["Ly"])
    assert np.all(acc[:, :2] == 0.0)
    # prefix sums against a sum of signs: round-off of the total mass only
    assert np.max(np.abs(acc[:, 2] - expected)) < 1e-12 * np.max(np.abs(expected))


def test_slab_field_counted_by_hand():
    """Three sheets: the middle one is pulled down by the lower mass and up by the upper."""
    z = np.array([-1.0, 0.0, 2.0])
    m = np.array([1.0e6, 2.0e6, 5.0e6])
    c = 2.0 * math.pi * G_SI / (10.0 * 20.0)
    g = slab_field(z, m, 10.0, 20.0)
    np.testing.assert_allclose(g, [c * (2.0e6 + 5.0e6), -c * (1.0e6 - 5.0e6),
                                   -c * (1.0e6 + 2.0e6)], rtol=1e-14)


def test_slab_field_conserves_vertical_momentum():
    s = testing.random_sheet(1000, seed=8, dispersion=0.05)
    acc = accelerations(slab_simulation(s))
    force = s["mass"] * acc[:, 2]
    assert abs(force.sum()) < 1e-13 * np.abs(force).sum()


def test_slab_field_of_a_thick_gaussian_layer_is_the_erf_profile():
    """Many particles in a Gaussian layer of rms thickness sigma: the field approaches the
    plane-parallel -2 pi G Sigma erf(z / (sqrt(2) sigma)) (Poisson noise ~ N^-1/2: 2 % at
    N = 20000, the tolerance)."""
    rng = np.random.default_rng(4)
    n, sigma, L = 20000, 10.0, 100.0
    z = rng.normal(0.0, sigma, n)
    m = np.full(n, 3.0e3)
    g = slab_field(z, m, L, L)
    Sigma = m.sum() / L**2
    from scipy.special import erf
    expected = -2.0 * math.pi * G_SI * Sigma * erf(z / (math.sqrt(2.0) * sigma))
    assert np.max(np.abs(g - expected)) < 0.02 * 2.0 * math.pi * G_SI * Sigma


#: The gravitating sheet with the slab solver.
SLAB = {"name": "slab", "sheet.gravity_solver": "slab"}


@pytest.fixture(scope="module")
def slab_scenario(gravitating_scenario):
    """Factory: 200 identical 1 m ice particles at tau = 0.5, 1e8 m from Saturn, slab
    gravity, with dotted overrides, ``slab_scenario(**{key: value})``."""
    return lambda **overrides: gravitating_scenario(SLAB, overrides)


@pytest.mark.parametrize("key, value", [("opening_angle", 0.3), ("softening", 0.1)])
def test_slab_refuses_the_keys_it_does_not_use(key, value, slab_scenario):
    d = slab_scenario().to_dict()
    d["sheet"][key] = value
    with pytest.raises(ScenarioError, match=f"sheet.{key}"):
        scenario_from_dict(d, source="<test>")


def test_extending_a_slab_run_is_bit_identical_and_has_no_gravitational_viscosity(tmp_path,
                                                                                  slab_scenario):
    """REBOUND does not save function pointers: the resumed run re-installs the slab field,
    so it ends in the bits of the uninterrupted run; the field acted (the run differs from
    the same run without gravity); no torque acted, so the gravitational viscosity is 0."""
    long = ringsim.run(slab_scenario(), output=tmp_path / "long.h5", progress=False)
    short = tmp_path / "short.h5"
    ringsim.run(slab_scenario(**{"integration.orbits": 0.1}), output=short, progress=False)
    ringsim.run(slab_scenario(), output=short, resume=True, progress=False)
    d = slab_scenario().to_dict()
    d["sheet"]["gravity"] = False
    del d["sheet"]["gravity_solver"]
    plain = ringsim.run(scenario_from_dict(d, source="<test>"), output=tmp_path / "plain.h5",
                        progress=False)
    a, b, c = (ringsim.open_run(p) for p in (long, short, plain))
    assert a.attrs["gravity_solver"] == "slab"
    for key in ("x", "y", "z", "vx", "vy", "vz"):
        assert np.array_equal(a.snapshot(2)[key], b.snapshot(2)[key]), key
    assert not np.array_equal(a.snapshot(2)["vz"], c.snapshot(2)["vz"])
    eq = gravity_equilibrium(a, 0)
    assert eq["gravitational_viscosity"]["mean"] == 0.0
