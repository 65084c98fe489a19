"""Dilley's mass term through the C resolver: kappa > 0 acts both ways about 60 g.

xi = xi0 (R_bar / 2.5 cm)^-0.2 (M_bar / 60 g)^-kappa (v / 1 cm/s)^p (Dilley 1993, eq. 5.15):
for a pair whose reduced mass is below the 60 g of the reference sphere, kappa = 0.1 raises
xi and lowers eps; above 60 g it lowers xi and raises eps; at 60 g it changes nothing.  The
pairs are resolved by ringsim's C resolver in a plain REBOUND simulation (one head-on
impact each), and eps is read from the velocities before and after.
"""

import ctypes
import math

import numpy as np
import pytest
import rebound
from rebound.simulation import CollisionS
from rebound.vectors import Vec6d

from ringsim.config.scenario import scenario_from_dict, with_overrides
from ringsim.engine.resolver import install_resolver
from ringsim.physics import restitution as rs
from ringsim.study.runs import run_id

ICE = 900.0          # [kg/m^3]
SPEED = 0.01         # [m/s] normal impact speed, Dilley's reference speed
M_REF = 0.060        # [kg] Dilley's reference mass


def sphere_mass(radius: float, density: float = ICE) -> float:
    """Mass [kg] of a sphere of radius [m] and density [kg/m^3]."""
    return density * 4.0 / 3.0 * math.pi * radius**3


def applied_epsilon(kappa: float, R1: float, R2: float, M1: float, M2: float,
                    **law: float) -> float:
    """eps the C resolver applies to a head-on impact at `SPEED` of spheres R1, R2 [m] of
    masses M1, M2 [kg]: minus the ratio of the normal relative speeds after and before.
    ``law``: other Dilley parameters (xi0 0.16 and p 0.65 unless given)."""
    sim = rebound.Simulation()
    gap = 0.999 * (R1 + R2)          # touching, slightly overlapping: a collision
    sim.add(m=M1, r=R1, x=gap, vx=-SPEED * M2 / (M1 + M2))
    sim.add(m=M2, r=R2, x=0.0, vx=SPEED * M1 / (M1 + M2))
    install_resolver(sim, {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": kappa, **law})
    before = sim.particles[0].vx - sim.particles[1].vx
    collision = CollisionS(p1=0, p2=1, gb=Vec6d(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), ri=0)
    sim._collision_resolve(ctypes.byref(sim), collision)
    after = sim.particles[0].vx - sim.particles[1].vx
    return -after / before


#: (name, R1 [m], R2 [m], M1 [kg], M2 [kg]): a 1 cm on a 2.5 cm ice sphere (M_bar 3.5 g),
#: two 2.5 cm ice spheres (M_bar 29 g); two 0.5 m ice spheres (M_bar 236 kg), a 10 cm on a
#: 5 m ice sphere (M_bar 3.8 kg).
LIGHT = [("1cm-2.5cm", 0.01, 0.025, sphere_mass(0.01), sphere_mass(0.025)),
         ("2.5cm-2.5cm", 0.025, 0.025, sphere_mass(0.025), sphere_mass(0.025))]
HEAVY = [("0.5m-0.5m", 0.5, 0.5, sphere_mass(0.5), sphere_mass(0.5)),
         ("10cm-5m", 0.1, 5.0, sphere_mass(0.1), sphere_mass(5.0))]


@pytest.mark.parametrize("name, R1, R2, M1, M2", LIGHT, ids=[p[0] for p in LIGHT])
def test_a_pair_lighter_than_60_g_is_less_elastic_with_kappa(name, R1, R2, M1, M2):
    assert rs.reduced_mass(M1, M2) < M_REF
    eps0, eps1 = applied_epsilon(0.0, R1, R2, M1, M2), applied_epsilon(0.1, R1, R2, M1, M2)
    # the C resolver applies the law's eps (to round-off of the velocity update)
    R_bar, M_bar = rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2)
    assert eps1 == pytest.approx(rs.dilley_epsilon(SPEED, R_bar, M_bar, kappa=0.1), rel=1e-9)
    assert eps1 < eps0 - 0.01, (eps0, eps1)


@pytest.mark.parametrize("name, R1, R2, M1, M2", HEAVY, ids=[p[0] for p in HEAVY])
def test_a_pair_heavier_than_60_g_is_more_elastic_with_kappa(name, R1, R2, M1, M2):
    assert rs.reduced_mass(M1, M2) > M_REF
    eps0, eps1 = applied_epsilon(0.0, R1, R2, M1, M2), applied_epsilon(0.1, R1, R2, M1, M2)
    R_bar, M_bar = rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2)
    assert eps1 == pytest.approx(rs.dilley_epsilon(SPEED, R_bar, M_bar, kappa=0.1), rel=1e-9)
    assert eps1 > eps0 + 0.01, (eps0, eps1)


def test_at_60_g_kappa_changes_nothing():
    # masses chosen for M_bar = M1 M2 / (M1 + M2) = 60 g exactly (the radii do not matter)
    M2 = 1.0
    M1 = M_REF * M2 / (M2 - M_REF)
    eps = [applied_epsilon(k, 0.05, 0.05, M1, M2) for k in (0.0, 0.1)]
    assert rs.reduced_mass(M1, M2) == pytest.approx(M_REF, rel=1e-12)
    np.testing.assert_allclose(eps[1], eps[0], rtol=1e-9)


# --- the reference mass M_ref (Dilley 1993 sect. 2, 5: the pendulum's effective mass) -------

@pytest.mark.parametrize("name, R1, R2, M1, M2", LIGHT + HEAVY, ids=[p[0] for p in LIGHT + HEAVY])
def test_a_600_g_reference_mass_is_xi0_times_ten_to_the_kappa(name, R1, R2, M1, M2):
    # (M_bar / 0.6 kg)^-kappa = 10^kappa (M_bar / 60 g)^-kappa: the same law as xi0 10^kappa
    # with the 60 g reference, to round-off of the powers (rel 1e-9 as above)
    kappa = 0.1
    eps_ref = applied_epsilon(kappa, R1, R2, M1, M2, reference_mass=0.6)
    eps_xi0 = applied_epsilon(kappa, R1, R2, M1, M2, xi0=0.16 * 10.0**kappa)
    R_bar, M_bar = rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2)
    assert eps_ref == pytest.approx(eps_xi0, rel=1e-9)
    assert eps_ref == pytest.approx(rs.dilley_epsilon(SPEED, R_bar, M_bar, kappa=kappa,
                                                      reference_mass=0.6), rel=1e-9)
    # a heavier reference makes every pair less elastic for kappa > 0
    assert eps_ref < applied_epsilon(kappa, R1, R2, M1, M2) - 0.005


def test_at_the_reference_mass_kappa_changes_nothing_whatever_it_is():
    M2 = 10.0
    M1 = 0.6 * M2 / (M2 - 0.6)        # M_bar = 600 g
    eps = [applied_epsilon(k, 0.05, 0.05, M1, M2, reference_mass=0.6) for k in (0.0, 0.1)]
    np.testing.assert_allclose(eps[1], eps[0], rtol=1e-9)


def test_the_default_reference_mass_leaves_a_scenario_and_its_run_identity_unchanged():
    # runs made before M_ref was a parameter are found again by their hash
    base = scenario_from_dict({
        "name": "m-ref", "seed": 1, "planet": {"Omega": 2.0e-4},
        "particles": {"size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "restitution": {"model": "dilley", "kappa": 0.1}})
    explicit = with_overrides(base, {"restitution.reference_mass": M_REF})
    heavier = with_overrides(base, {"restitution.reference_mass": 0.6})
    assert base.restitution.reference_mass == M_REF
    assert "reference_mass" not in base.to_dict()["restitution"]
    assert explicit.to_dict() == base.to_dict() and run_id(explicit) == run_id(base)
    assert heavier.to_dict()["restitution"]["reference_mass"] == 0.6
    assert run_id(heavier) != run_id(base)
