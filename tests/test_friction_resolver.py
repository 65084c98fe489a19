"""Rough spheres in the C resolver (rs_resolver.c with friction) and its Python twin.

What is checked, and to what tolerance:

* for every restitution law x {beta = -1, 0, 0.5, 1; Coulomb mu = 0.1, 0.5}, collisions
  resolved by the C library (the friction engineer's collision set of
  tests/test_friction.py: four pairs, five impact speeds, tangential speeds 1e-2 to 1e2 of
  them, random spins; with and without a sheared ghost offset): velocities and spins
  equal (==) to the numpy reference ``physics.friction.collision_impulse``; linear
  momentum conserved to 1e-12 of sum m|v|, total angular momentum (spins + orbital about
  the pair's centre of mass) to 1e-12 of the sum of its terms' magnitudes, the energy
  lost equal to ``friction.energy_loss`` to 1e-12 of the contact energy (with a sheared
  ghost offset the scales include the velocities as stored, M_bar |dr| |v| and
  M_bar |dv| |v|: a change is stored to the ulp of the box's shear speed; the energy
  scale includes the stored rotational energies I |w|^2, which for the 1e9 kg brick hold
  a spin change only to the ulp of its spin), the C's
  tangential dissipation statistic to the closed form's tangential part (1e-12);
* beta = -1 gives states bit-identical to the resolver without friction, spins stay 0;
* the C accepts and refuses the friction parameters and the inertia factor exactly at
  their declared bounds (``FRICTION``, ``INERTIA_FACTOR``);
* the Python twin matches the C collision by collision on a 300-particle sheet (states,
  spins, plog: ==) for beta = 0.5 and mu = 0.5;
* spins: set/get round trip, survive ``reinstall`` into an enlarged copy of the sheet.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import test_friction as tf
from test_resolver import ORBIT, make_sheet, phase_space

from ringsim.engine import box, native, sheet
from ringsim.engine.resolver import collision_records, install_resolver
from ringsim.physics import friction as fr
from ringsim.physics.laws import Parameter
from ringsim.testing import PythonReferenceResolver

FRICTIONS = [
    {"model": "constant", "beta": -1.0},
    {"model": "constant", "beta": 0.0},
    {"model": "constant", "beta": 0.5},
    {"model": "constant", "beta": 1.0},
    {"model": "coulomb", "mu": 0.1},
    {"model": "coulomb", "mu": 0.5},
]
GHOSTS = {"no_ghost": tf.NO_GHOST, "shear_ghost": tf.SHEAR_GHOST}


def resolve_in_c(c: dict, restitution: dict, friction: dict | None, ghost: tuple):
    """Resolve every collision of ``c`` in one simulation (pairs 2i, 2i+1, particle 2i in
    the ghost box); returns (states (2n, 6) before and after, spins after, handle)."""
    import rebound

    sim = rebound.Simulation()
    gx, gv = np.array(ghost[:3]), np.array(ghost[3:])
    n = c["R1"].size
    for i in range(n):
        x1, v1 = c["x1"][i] - gx, c["v1"][i] - gv
        sim.add(m=c["M1"][i], r=c["R1"][i], x=x1[0], y=x1[1], z=x1[2], vx=v1[0], vy=v1[1],
                vz=v1[2])
        x2, v2 = c["x2"][i], c["v2"][i]
        sim.add(m=c["M2"][i], r=c["R2"][i], x=x2[0], y=x2[1], z=x2[2], vx=v2[0], vy=v2[1],
                vz=v2[2])
    handle = install_resolver(sim, restitution, friction)
    spins = np.empty((2 * n, 3))
    spins[0::2], spins[1::2] = c["w1"], c["w2"]
    handle.set_spins(spins)
    before = phase_space(sim)
    pairs = np.stack([np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)], axis=1)
    resolved = handle.resolve_batch(collision_records(pairs, ghost))
    assert resolved == n, "every collision resolved"
    return before, phase_space(sim), handle.spins(), handle


class FrictionResolverChecks:
    """The C resolver with friction, for one restitution law (subclasses set it)."""

    restitution: dict = {}
    speeds = tf.RoughCollisionChecks.speeds
    pairs = tf.RoughCollisionChecks.pairs
    collisions = tf.RoughCollisionChecks.collisions

    @pytest.fixture(params=FRICTIONS, ids=lambda f: "-".join(f"{v}" for v in f.values()))
    def friction(self, request):
        return request.param

    @pytest.mark.parametrize("ghost", GHOSTS.values(), ids=GHOSTS.keys())
    def test_c_equals_reference_and_conserves(self, friction, ghost):
        c = self.collisions(5)
        before, after, spins, handle = resolve_in_c(c, self.restitution, friction, ghost)
        gb = np.array(ghost)
        p1, p2 = before[0::2], before[1::2]
        dr = (p1[:, :3] + gb[:3]) - p2[:, :3]
        dv = (p1[:, 3:] + gb[3:]) - p2[:, 3:]
        R_bar = c["R1"] * c["R2"] / (c["R1"] + c["R2"])
        M_bar = c["M1"] * c["M2"] / (c["M1"] + c["M2"])
        probe = fr.collision_impulse(dr, dv, c["w1"], c["w2"], c["R1"], c["R2"], c["M1"],
                                     c["M2"], 0.0, friction)
        eps = handle.epsilon(probe.impact_speed, R_bar, M_bar)    # the C law, as the C
        imp = fr.collision_impulse(dr, dv, c["w1"], c["w2"], c["R1"], c["R2"], c["M1"],
                                   c["M2"], eps, friction)
        # C against the numpy reference, collision by collision, bit for bit.
        assert np.array_equal(after[0::2, 3:], p1[:, 3:] + imp.dv1), "v1 == reference"
        assert np.array_equal(after[1::2, 3:], p2[:, 3:] + imp.dv2), "v2 == reference"
        assert np.array_equal(spins[0::2], c["w1"] + imp.dw1), "w1 == reference"
        assert np.array_equal(spins[1::2], c["w2"] + imp.dw2), "w2 == reference"
        assert np.array_equal(after[:, :3], before[:, :3]), "positions unchanged"

        # In the frame of the pair's centre of mass (the ghost offset's velocity would
        # only add round-off): orbital angular momentum M_bar dr x dv, kinetic energy
        # M_bar |dv|^2 / 2, with dv' = dv + (change of v1) - (change of v2).
        m1, m2 = c["M1"][:, None], c["M2"][:, None]
        I1 = fr.moment_of_inertia(c["M1"], c["R1"])[:, None]
        I2 = fr.moment_of_inertia(c["M2"], c["R2"])[:, None]
        d1, d2 = after[0::2, 3:] - p1[:, 3:], after[1::2, 3:] - p2[:, 3:]
        w1, w2, w1n, w2n = c["w1"], c["w2"], spins[0::2], spins[1::2]
        dp = m1 * d1 + m2 * d2
        p_scale = c["M1"] * np.linalg.norm(p1[:, 3:] + gb[3:], axis=1) + \
            c["M2"] * np.linalg.norm(p2[:, 3:], axis=1)
        assert np.all(np.abs(dp) <= 1e-12 * p_scale[:, None]), "linear momentum"
        dv_new = dv + (d1 - d2)
        mb = M_bar[:, None]
        # Velocities are stored in each particle's own box: a change is rounded to the ulp
        # of the stored speed (the ghost box's shear speed 1.5 Omega L >> v_n at 1e-5 m/s),
        # so the scales include the stored speeds.
        stored = np.linalg.norm(p1[:, 3:], axis=1) + np.linalg.norm(p2[:, 3:], axis=1)

        def angular_momentum(rel, wa, wb):
            terms = [mb * np.cross(dr, rel), I1 * wa, I2 * wb]
            return sum(terms), sum(np.linalg.norm(t, axis=1) for t in terms)
        L0, s0 = angular_momentum(dv, w1, w2)
        L1, s1 = angular_momentum(dv_new, w1n, w2n)
        s_stored = M_bar * np.linalg.norm(dr, axis=1) * stored
        assert np.all(np.abs(L1 - L0) <= 1e-12 * np.maximum(np.maximum(s0, s1), s_stored)
                      [:, None]), "angular momentum (spins + orbital about the centre of mass)"

        d_energy = 0.5 * np.sum(mb * (d1 - d2) * (dv_new + dv) + I1 * (w1n - w1) * (w1n + w1)
                                + I2 * (w2n - w2) * (w2n + w2), axis=1)
        g_t = np.linalg.norm(imp.g_t, axis=1)
        expected = fr.energy_loss(M_bar, imp.impact_speed, eps, g_t, imp.beta,
                                  imp.tangential_factor)
        contact = 0.5 * M_bar * (imp.impact_speed**2 + imp.tangential_factor * g_t**2)
        e_stored = M_bar * np.linalg.norm(dv, axis=1) * stored + \
            (I1 * w1 * w1).sum(axis=1) + (I2 * w2 * w2).sum(axis=1)
        assert np.all(np.abs(d_energy + expected) <= 1e-12 * np.maximum(contact, e_stored)), \
            "energy lost = closed form"
        tangential = fr.energy_loss(M_bar, 0.0, eps, g_t, imp.beta, imp.tangential_factor)
        stats = handle.stats()
        assert abs(stats["tangential_dissipation"] - tangential.sum()) <= \
            1e-12 * contact.sum(), "tangential dissipation statistic"
        assert stats["n_sliding"] == int(imp.sliding.sum())
        if friction["model"] == "coulomb":
            assert 0 < stats["n_sliding"] < c["R1"].size, "sliding and sticking both met"

    def test_beta_minus_one_is_the_smooth_resolver_bit_for_bit(self):
        c = self.collisions(6)
        smooth = resolve_in_c(c, self.restitution, None, tf.SHEAR_GHOST)
        c["w1"][:], c["w2"][:] = 0.0, 0.0
        rough = resolve_in_c(c, self.restitution, {"model": "constant", "beta": -1.0},
                             tf.SHEAR_GHOST)
        assert np.array_equal(smooth[1], rough[1]), "states =="
        assert np.all(rough[2] == 0.0), "spins stay zero"
        assert smooth[3].stats()["count"] == rough[3].stats()["count"]


class TestDilley(FrictionResolverChecks):
    restitution = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0}


class TestDilleyMassDependent(FrictionResolverChecks):
    restitution = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}


class TestBridges(FrictionResolverChecks):
    restitution = {"model": "bridges"}


class TestConstant(FrictionResolverChecks):
    restitution = {"model": "constant", "epsilon": 0.5}


class TestAndrews(FrictionResolverChecks):
    restitution = {"model": "andrews", "v_c": 2e-4}


class TestTabor(FrictionResolverChecks):
    restitution = {"model": "tabor", "v_c": 2e-4, "q": 0.375}


# --- the C guard agrees with the declaration at every bound ---------------------------------

def _probes(par: Parameter) -> list[float]:
    """Each finite bound, the nearest floats inside and outside it, and non-finite values."""
    values = [math.nan, math.inf, -math.inf]
    for bound, inward in ((par.lower, math.inf), (par.upper, -math.inf)):
        if math.isfinite(bound):
            values += [bound, math.nextafter(bound, inward), math.nextafter(bound, -inward)]
        else:
            values.append(math.copysign(np.finfo(float).max, bound))
    return values


def _c_accepts(code: int, packed: list[float], k: float) -> bool:
    address = native._LIB.rs_resolver_create(2, 0.5, 0.0, 0.0, 0.0, 0, 1)
    try:
        return bool(native._LIB.rs_resolver_set_friction(address, code, *packed, k))
    finally:
        native._LIB.rs_resolver_free(address)


FRICTION_PARAMETERS = [(law, par) for law in fr.FRICTION for par in law.parameters]


@pytest.mark.parametrize("law, par", FRICTION_PARAMETERS,
                         ids=[f"{law.name}.{par.name}" for law, par in FRICTION_PARAMETERS])
def test_c_accepts_exactly_the_declared_friction_range(law, par):
    typical = {p.name: p.typical for p in law.parameters}
    for x in _probes(par):
        packed = list(law.pack({**typical, par.name: x}, fr.FRICTION.n_slots))
        assert _c_accepts(law.code, packed, 0.4) == par.contains(x), \
            f"C and declaration disagree on {law.name}.{par.name} = {x!r}"
        values = {"model": law.name, **typical, par.name: x}
        if par.contains(x):
            assert fr.friction_parameters(values)[1][par.name] == x
        else:
            with pytest.raises(ValueError, match=f"^{par.name}:"):
                fr.friction_parameters(values)


def test_c_accepts_exactly_the_declared_inertia_factor():
    par = fr.INERTIA_FACTOR
    for x in _probes(par):
        for code, packed in ((0, [0.0] * 3), (1, [0.0] * 3), (2, [0.5, 0.0, 0.0])):
            assert _c_accepts(code, packed, x) == par.contains(x), \
                f"inertia_factor = {x!r} with friction code {code}"
    with pytest.raises(ValueError, match="^inertia_factor"):
        install_resolver(make_sheet(n=10), {"model": "constant", "epsilon": 0.5},
                         {"model": "constant", "beta": 0.0}, inertia_factor=0.7)


def test_unknown_friction_code_refused():
    assert not _c_accepts(3, [0.0] * 3, 0.4)


# --- the twin, collision by collision -------------------------------------------------------

@pytest.mark.parametrize("friction", [{"model": "constant", "beta": 0.5},
                                      {"model": "coulomb", "mu": 0.5}],
                         ids=["beta0.5", "mu0.5"])
def test_c_and_python_twin_agree_bit_for_bit(friction):
    restitution = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}
    sim_c = make_sheet(seed=3)
    handle = install_resolver(sim_c, restitution, friction, inertia_factor=0.35)
    sim_c.integrate(1.0 * ORBIT)
    sim_py = make_sheet(seed=3)
    twin = PythonReferenceResolver(restitution, friction, inertia_factor=0.35)
    sim_py.collision_resolve = twin
    sim_py.integrate(1.0 * ORBIT)
    assert twin.errors == []
    stats = handle.stats()
    assert stats["count"] == twin.count > 300
    assert np.array_equal(phase_space(sim_c), phase_space(sim_py)), "states =="
    spins_twin = np.array(twin.spins + [[0.0] * 3] * (sim_py.N - len(twin.spins)))
    assert np.array_equal(handle.spin_state(), spins_twin), "stored spins =="
    assert np.array_equal(handle.spins(), twin.rotating_spins(sim_py)), "spins at t =="
    assert np.any(handle.spins() != 0.0)
    assert sim_c.collisions_plog == sim_py.collisions_plog
    assert stats["tangential_dissipation"] == twin.tangential_dissipation > 0.0
    assert stats["normal_dissipation"] == twin.normal_dissipation > 0.0
    assert stats["n_sliding"] == twin.n_sliding
    if friction["model"] == "coulomb":
        assert 0 < stats["n_sliding"] < stats["count"]


# --- spins in the handle -------------------------------------------------------------------

def test_spins_round_trip_and_shape_checked():
    sim = make_sheet(n=50)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              {"model": "coulomb", "mu": 0.5})
    assert handle.spins().shape == (50, 3) and np.all(handle.spins() == 0.0)
    w = np.random.default_rng(1).normal(size=(50, 3)) * 1e-4
    handle.set_spins(w)
    assert np.array_equal(handle.spins(), w)
    for bad in (np.zeros((49, 3)), np.zeros((50, 2)), np.full((50, 3), np.nan)):
        with pytest.raises(ValueError, match="^spins"):
            handle.set_spins(bad)
    assert np.array_equal(handle.spins(), w), "a refused set changes nothing"


def test_spins_survive_reinstall_into_an_enlarged_box():
    """The vertical guard moves the particles, in order, to a new simulation."""
    sim = make_sheet(n=200, seed=4)
    handle = install_resolver(sim, {"model": "constant", "epsilon": 0.5},
                              {"model": "constant", "beta": 0.0})
    sim.integrate(0.2 * ORBIT)
    w = handle.spins()
    assert np.any(w != 0.0) and handle.stats()["count"] > 0
    g = box.SheetGeometry(sim.root_size, sim.N_root_x, sim.N_root_y, sim.N_root_z,
                          tf.OMEGA)
    new_sim, _ = sheet.enlarged_copy(sim, g, 2 * sim.N_root_z)
    handle.reinstall(new_sim)
    assert np.array_equal(handle.spins(), w), "spins kept by particle index"
    new_sim.integrate(new_sim.t + 0.1 * ORBIT)
    assert handle.stats()["count"] > 0

