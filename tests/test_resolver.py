"""Tests of ringsim's native collision resolver (ringsim/csrc/rs_resolver.c).

What is checked, and to what tolerance:

* the C resolver and its pure-Python twin resolve a 300-particle shearing sheet
  collision by collision identically (same count, states equal to 1e-10 relative);
* with a constant eps it reproduces REBOUND's built-in hard-sphere resolver (states
  to 1e-9 relative after 40 steps, same collisions_log_n, collisions_plog to 1e-9);
* for every restitution law, in hand-made two-particle collisions with and without
  ghost-box offsets: momentum conserved to 1e-12, the energy lost equals
  (1 - eps^2) M_bar v_n^2 / 2 to 1e-10, the eps applied equals ringsim.restitution's to
  the law's ``tol``; pairs reported twice are resolved once, receding pairs untouched;
* minimum_collision_velocity as in REBOUND, per-simulation parameters, statistics,
  checkpoint reinstall, validation and memory ownership.
"""

from __future__ import annotations

import ctypes
import gc
import math
import warnings

import numpy as np
import pytest
import rebound
from rebound.simulation import CORFF, CollisionS
from rebound.vectors import Vec6d

from ringsim.engine import native, resolver
from ringsim.engine.native import LOG_DTYPE
from ringsim.engine.resolver import ResolverHandle, install_resolver
from ringsim.physics import restitution as rs
from ringsim.physics.sizes import PowerLaw
from ringsim.testing import PythonReferenceResolver

OMEGA = 2e-4                       # [1/s]
ORBIT = 2.0 * math.pi / OMEGA      # [s]
DENSITY = 900.0                    # [kg/m^3]
DILLEY_KAPPA01 = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}


# --- fixtures: a shearing sheet and single collisions ------------------------------------

def powerlaw_radii(rng: np.random.Generator, n: int, r_min: float, r_max: float,
                   q: float) -> np.ndarray:
    """Radii [m] drawn from dN/dR ∝ R^-q on [r_min, r_max] (ringsim's one sampler)."""
    return PowerLaw(q=q, r_min=r_min, r_max=r_max).draw_radii(n, rng)


def make_sheet(n: int = 300, seed: int = 1, tau: float = 0.25, r_min: float = 0.5,
               r_max: float = 2.0, q: float = 3.0, dt_orbits: float = 1e-3,
               dispersion_rOmega: float = 2.0) -> rebound.Simulation:
    """A non-overlapping shearing-sheet patch, SEI, shear boundaries, tree collisions.

    Box side L [m] from the optical depth tau = sum(pi r^2) / L^2; random velocities of
    ``dispersion_rOmega`` x 1 m x Omega per component on top of the shear flow.
    """
    rng = np.random.default_rng(seed)
    radii = np.sort(powerlaw_radii(rng, n, r_min, r_max, q))[::-1]
    box = math.sqrt(np.sum(np.pi * radii**2) / tau)
    sim = rebound.Simulation()
    sim.OMEGA = OMEGA
    sim.integrator = "sei"
    sim.boundary = "shear"
    sim.gravity = "none"
    sim.collision = "tree"
    sim.N_ghost_x = 1
    sim.N_ghost_y = 1
    sim.N_ghost_z = 0      # the box is as tall as it is wide: |z| stays << L/2
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.dt = dt_orbits * ORBIT
    sim.rand_seed = seed

    positions = np.empty((n, 3))
    placed = 0
    while placed < n:      # random sequential placement without overlaps
        trial = np.array([rng.uniform(-box / 2, box / 2), rng.uniform(-box / 2, box / 2),
                          rng.normal(0.0, 2.0 * radii[placed])])
        d = positions[:placed] - trial
        d[:, :2] -= box * np.round(d[:, :2] / box)
        if np.all(np.sum(d * d, axis=1) > (radii[:placed] + radii[placed]) ** 2):
            positions[placed] = trial
            placed += 1
    velocities = rng.normal(0.0, dispersion_rOmega * OMEGA, (n, 3))
    velocities[:, 1] += -1.5 * OMEGA * positions[:, 0]
    masses = DENSITY * 4.0 / 3.0 * np.pi * radii**3
    for (x, y, z), (vx, vy, vz), m, r in zip(positions, velocities, masses, radii,
                                             strict=True):
        sim.add(m=m, r=r, x=x, y=y, z=z, vx=vx, vy=vy, vz=vz)
    return sim


def phase_space(sim: rebound.Simulation) -> np.ndarray:
    """(N, 6) array of x, y, z [m], vx, vy, vz [m/s]."""
    xyz = np.zeros((sim.N, 3))
    vxyz = np.zeros((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vxyz)
    return np.hstack([xyz, vxyz])


def assert_states_close(a: np.ndarray, b: np.ndarray, rtol: float, what: str) -> None:
    """Element-wise relative agreement; near-zero elements are compared on the scale of
    their column (positions to the box, velocities to the shear speed)."""
    scale = np.max(np.abs(b), axis=0)
    excess = np.abs(a - b) - rtol * np.maximum(np.abs(b), scale)
    assert np.all(excess <= 0.0), f"{what}: worst excess {np.max(excess):.3g}"


def call_resolver(sim: rebound.Simulation, i: int, j: int,
                  ghost: tuple[float, ...] = (0.0,) * 6) -> int:
    """Call the installed collision_resolve for the pair (i, j) with ghost offset."""
    collision = CollisionS(p1=i, p2=j, gb=Vec6d(*ghost), ri=0)
    return sim._collision_resolve(ctypes.byref(sim), collision)


def pair_simulation(rng: np.random.Generator, R1: float, R2: float, M1: float, M2: float,
                    speed: float, ghost: tuple[float, ...], overlap: float = 0.05,
                    tangential: float = 0.7) -> rebound.Simulation:
    """Two spheres overlapping by ``overlap`` (R1+R2), approaching along a random normal
    with normal speed ``speed`` [m/s] and a tangential speed ``tangential`` x speed;
    particle 0 sits in the ghost box ``ghost`` (x, y, z [m], vx, vy, vz [m/s])."""
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    t = np.cross(normal, rng.normal(size=3))
    t /= np.linalg.norm(t)
    x2 = rng.uniform(-5.0, 5.0, 3)
    # Particle 1 moves with about the impact speed, less if it is the heavier one (a
    # massive brick at rest can take up a tiny velocity change without round-off).
    v2 = rng.normal(0.0, abs(speed) * min(1.0, M1 / M2), 3)
    x1 = x2 + (1.0 - overlap) * (R1 + R2) * normal - np.array(ghost[:3])
    v1 = v2 - speed * normal + tangential * speed * t - np.array(ghost[3:])
    sim = rebound.Simulation()
    sim.add(m=M1, r=R1, x=x1[0], y=x1[1], z=x1[2], vx=v1[0], vy=v1[1], vz=v1[2])
    sim.add(m=M2, r=R2, x=x2[0], y=x2[1], z=x2[2], vx=v2[0], vy=v2[1], vz=v2[2])
    return sim


def ghost_frame_velocities(sim: rebound.Simulation, ghost: tuple[float, ...]) -> np.ndarray:
    """(2, 3) velocities [m/s] with particle 0 shifted into the ghost box."""
    v = phase_space(sim)[:, 3:]
    v[0] += np.array(ghost[3:])
    return v


def sphere_mass(radius: float, density: float = DENSITY) -> float:
    """Mass [kg] of a sphere of radius [m]."""
    return density * 4.0 / 3.0 * math.pi * radius**3


# A ghost box one box width away in x, sheared: gb.vy = -1.5 Omega L.
SHEAR_GHOST = (60.0, 17.3, 0.0, 0.0, -1.5 * OMEGA * 60.0, 0.0)
NO_GHOST = (0.0,) * 6


# --- import-time layout check -------------------------------------------------------------

def test_struct_sizes_agree_with_loaded_rebound():
    rebound.clibrebound.reb_simulation_struct_size.restype = ctypes.c_size_t
    loaded = rebound.clibrebound.reb_simulation_struct_size()
    compiled = native._LIB.rs_simulation_struct_size()
    assert compiled == loaded == ctypes.sizeof(rebound.Simulation)
    native.check_simulation_struct_size(compiled, loaded)
    with pytest.raises(ImportError, match="struct reb_simulation"):
        native.check_simulation_struct_size(compiled, compiled + 8)


# --- C versus its Python twin, collision by collision --------------------------------------

def test_c_and_python_twin_agree_collision_by_collision():
    """Same sheet, same rand_seed: the twin must reproduce every collision."""
    duration = 2.0 * ORBIT
    sim_c = make_sheet()
    handle = install_resolver(sim_c, DILLEY_KAPPA01, log_capacity=100_000)
    sim_c.integrate(duration)

    sim_py = make_sheet()
    twin = PythonReferenceResolver(DILLEY_KAPPA01)
    sim_py.collision_resolve = twin
    sim_py.integrate(duration)

    stats = handle.stats()
    assert twin.errors == []
    assert stats["count"] > 500, "too few collisions to test anything"
    assert stats["count"] == twin.count == sim_c.collisions_log_n == sim_py.collisions_log_n
    assert_states_close(phase_space(sim_c), phase_space(sim_py), 1e-10, "C vs twin states")
    assert sim_c.collisions_plog == pytest.approx(sim_py.collisions_plog, rel=1e-10)
    twin_log = twin.stats()["log"]
    for field in LOG_DTYPE.names:
        np.testing.assert_allclose(stats["log"][field], twin_log[field], rtol=1e-10,
                                   err_msg=f"sampled log field {field}")
    # Every collision's eps is Dilley's law for its own pair (kappa = 0.1).
    log = stats["log"]
    expected = rs.dilley_epsilon(log["v_n"], log["R_bar"], log["M_bar"], kappa=0.1)
    np.testing.assert_allclose(log["epsilon"], expected, rtol=1e-14)


def test_c_and_python_twin_agree_with_swept_path_detection():
    """linetree search with a step 10x longer than the tree test (contacts inside the step
    are resolved at the contact time): the twin reproduces every collision."""
    sims = []
    for use_c in (True, False):
        sim = make_sheet(n=300, seed=2, dt_orbits=1e-2, dispersion_rOmega=10.0)
        sim.collision = "linetree"
        if use_c:
            handle = install_resolver(sim, DILLEY_KAPPA01, log_capacity=10_000)
        else:
            twin = PythonReferenceResolver(DILLEY_KAPPA01)
            sim.collision_resolve = twin
        sim.integrate(1.0 * ORBIT)
        sims.append(sim)
    assert twin.errors == []
    assert handle.stats()["count"] == twin.count > 300
    assert_states_close(phase_space(sims[0]), phase_space(sims[1]), 1e-10, "linetree states")
    np.testing.assert_allclose(handle.stats()["log"]["epsilon"],
                               twin.stats()["log"]["epsilon"], rtol=1e-10)


# --- constant eps versus REBOUND's built-in hard-sphere resolver ---------------------------

def builtin_with_constant_epsilon(sim: rebound.Simulation, epsilon: float) -> None:
    """REBOUND's hard-sphere resolver with eps from ringsim's C callback (which reads it
    from the resolver struct attached to this simulation)."""
    install_resolver(sim, {"model": "constant", "epsilon": epsilon})
    sim.collision_resolve = "hardsphere"
    sim._corfp = CORFF(resolver.constant_epsilon_callback_address())
    sim._coefficient_of_restitution = sim._corfp


def test_constant_epsilon_matches_rebound_hardsphere():
    sim_rs = make_sheet(n=1000, seed=3)
    handle = install_resolver(sim_rs, {"model": "constant", "epsilon": 0.5})
    sim_rs.steps(40)

    sim_reb = make_sheet(n=1000, seed=3)
    builtin_with_constant_epsilon(sim_reb, 0.5)
    sim_reb.steps(40)

    assert sim_reb._extras_ref.stats()["count"] == 0, "built-in must have resolved them"
    assert sim_rs.collisions_log_n == sim_reb.collisions_log_n == handle.stats()["count"]
    assert sim_rs.collisions_log_n > 30
    assert_states_close(phase_space(sim_rs), phase_space(sim_reb), 1e-9, "vs hardsphere")
    assert sim_rs.collisions_plog == pytest.approx(sim_reb.collisions_plog, rel=1e-9)


@pytest.mark.slow
def test_constant_epsilon_equilibrium_matches_rebound_hardsphere():
    """Long runs (8 orbits, 1000 particles): the same equilibrium velocity dispersion and
    collision rate within 3 standard errors of the block means."""
    def run(builtin: bool) -> tuple[float, float, float, float]:
        sim = make_sheet(n=1000, seed=5)
        if builtin:
            builtin_with_constant_epsilon(sim, 0.5)
        else:
            install_resolver(sim, {"model": "constant", "epsilon": 0.5})
        sim.integrate(4.0 * ORBIT)
        dispersion, rate = [], []
        for k in range(1, 41):
            n0 = sim.collisions_log_n
            sim.integrate((4.0 + 0.1 * k) * ORBIT)
            v = phase_space(sim)
            v[:, 4] += 1.5 * OMEGA * v[:, 0]
            dispersion.append(math.sqrt(np.mean(v[:, 3:] ** 2)))
            rate.append((sim.collisions_log_n - n0) / (0.1 * sim.N))
        blocks_d = np.mean(np.reshape(dispersion, (8, 5)), axis=1)
        blocks_r = np.mean(np.reshape(rate, (8, 5)), axis=1)
        return (blocks_d.mean(), blocks_d.std(ddof=1) / math.sqrt(8), blocks_r.mean(),
                blocks_r.std(ddof=1) / math.sqrt(8))

    d1, sd1, r1, sr1 = run(builtin=False)
    d2, sd2, r2, sr2 = run(builtin=True)
    assert abs(d1 - d2) < 3.0 * math.hypot(sd1, sd2) + 0.02 * d2, \
        f"velocity dispersion [m/s]: ringsim {d1:.4g}±{sd1:.2g}, REBOUND {d2:.4g}±{sd2:.2g}"
    assert abs(r1 - r2) < 3.0 * math.hypot(sr1, sr2) + 0.02 * r2, \
        f"collisions per particle per orbit: ringsim {r1:.4g}±{sr1:.2g}, REBOUND {r2:.4g}±{sr2:.2g}"


# --- per collision, every restitution law ------------------------------------------------

class LawChecks:
    """Checks every restitution law must pass; subclasses set the law and ``tol``."""

    restitution: dict = {}
    tol: float = 1e-14           # relative tolerance of eps versus ringsim.restitution
    speeds = np.array([1e-5, 1e-4, 1e-3, 1e-2, 1e-1])   # normal impact speeds [m/s]

    def reference(self, v, R_bar, M_bar):
        return rs.epsilon_for_pair(self.restitution, v, R_bar, M_bar)

    def pairs(self):
        """(R1, R2, M1, M2) [m, kg]: equal ice spheres, small on big, unequal densities,
        a sphere against a nearly immovable brick."""
        return [
            (1.0, 1.0, sphere_mass(1.0), sphere_mass(1.0)),
            (0.3, 2.5, sphere_mass(0.3), sphere_mass(2.5)),
            (0.025, 0.05, sphere_mass(0.025, 500.0), sphere_mass(0.05, 1500.0)),
            (0.5, 4.0, sphere_mass(0.5), 1e9 * sphere_mass(4.0)),
        ]

    def test_law_matches_restitution_module(self):
        rng = np.random.default_rng(11)
        v = np.concatenate([np.geomspace(1e-8, 10.0, 400), [0.0]])
        R_bar = rng.uniform(0.01, 3.0, v.size)
        M_bar = rng.uniform(0.01, 3e4, v.size)
        with ResolverHandle(self.restitution) as handle:
            eps_c = handle.epsilon(v, R_bar, M_bar)
            np.testing.assert_allclose(eps_c, self.reference(v, R_bar, M_bar),
                                       rtol=self.tol, atol=0.0)
            np.testing.assert_array_equal(handle.epsilon(-v, R_bar, M_bar), eps_c)
        assert np.all((eps_c >= 0.0) & (eps_c <= 1.0))
        twin = PythonReferenceResolver(self.restitution)
        eps_py = [twin.epsilon(a, b, c) for a, b, c in zip(v, R_bar, M_bar, strict=True)]
        np.testing.assert_array_equal(eps_c, eps_py)   # same libm calls, same order

    @pytest.mark.parametrize("ghost", [NO_GHOST, SHEAR_GHOST], ids=["local", "ghost"])
    def test_conservation_and_applied_epsilon(self, ghost):
        rng = np.random.default_rng(21)
        for R1, R2, M1, M2 in self.pairs():
            for speed in self.speeds:
                sim = pair_simulation(rng, R1, R2, M1, M2, speed, ghost)
                handle = install_resolver(sim, self.restitution, log_capacity=4)
                before = ghost_frame_velocities(sim, ghost)
                ps = phase_space(sim)
                normal = ps[0, :3] + np.array(ghost[:3]) - ps[1, :3]
                normal /= np.linalg.norm(normal)
                assert call_resolver(sim, 0, 1, ghost) == 0
                after = ghost_frame_velocities(sim, ghost)
                masses = np.array([M1, M2])

                R_bar, M_bar = rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2)
                v_n = -np.dot(before[0] - before[1], normal)
                log = handle.stats()["log"]
                assert log.size == 1 and handle.stats()["count"] == 1
                eps = log["epsilon"][0]
                assert eps == pytest.approx(self.reference(v_n, R_bar, M_bar), rel=self.tol,
                                            abs=0.0), "eps applied"
                assert log["v_n"][0] == pytest.approx(v_n, rel=1e-12)
                assert log["R_bar"][0] == pytest.approx(R_bar, rel=1e-15)
                assert log["M_bar"][0] == pytest.approx(M_bar, rel=1e-15)

                dp = masses @ (after - before)
                p_scale = np.sum(masses * np.linalg.norm(before, axis=1))
                assert np.all(np.abs(dp) <= 1e-12 * p_scale), "momentum"

                # Kinetic energy change without cancellation: m/2 (v'-v).(v'+v).
                d_energy = 0.5 * np.sum(masses * np.sum((after - before) * (after + before),
                                                        axis=1))
                normal_energy = 0.5 * M_bar * v_n**2
                expected = -(1.0 - eps**2) * normal_energy
                assert d_energy == pytest.approx(expected, rel=1e-10,
                                                 abs=1e-12 * normal_energy), "energy lost"

                rel_after = after[0] - after[1]
                rel_before = before[0] - before[1]
                assert np.dot(rel_after, normal) == pytest.approx(eps * v_n, rel=1e-10,
                                                                  abs=1e-13 * v_n)
                tangential = rel_before - np.dot(rel_before, normal) * normal
                tangential_after = rel_after - np.dot(rel_after, normal) * normal
                np.testing.assert_allclose(tangential_after, tangential, rtol=0,
                                           atol=1e-12 * np.linalg.norm(rel_before))
                handle.close()

    @pytest.mark.parametrize("ghost", [NO_GHOST, SHEAR_GHOST], ids=["local", "ghost"])
    def test_pair_reported_twice_is_resolved_once(self, ghost):
        rng = np.random.default_rng(31)
        for speed in self.speeds:
            sim = pair_simulation(rng, 0.8, 1.3, sphere_mass(0.8), sphere_mass(1.3), speed,
                                  ghost)
            handle = install_resolver(sim, self.restitution)
            call_resolver(sim, 0, 1, ghost)
            once = phase_space(sim)
            plog = sim.collisions_plog
            mirrored = tuple(-g for g in ghost)
            call_resolver(sim, 1, 0, mirrored)
            call_resolver(sim, 0, 1, ghost)
            np.testing.assert_array_equal(phase_space(sim), once)
            assert handle.stats()["count"] == 1
            assert sim.collisions_log_n == 1 and sim.collisions_plog == plog

    @pytest.mark.parametrize("ghost", [NO_GHOST, SHEAR_GHOST], ids=["local", "ghost"])
    @pytest.mark.parametrize("depth", [0.3, 3.0], ids=["overlapping", "tunnelled"])
    def test_swept_path_contact_resolved_at_contact_time(self, ghost, depth):
        """Line search: a pair that touched at time s_c before the end of the step (and
        may have passed through each other) bounces at the contact, and both particles
        move on with their new velocities for s_c; reported twice, resolved once."""
        rng = np.random.default_rng(81)
        for R1, R2, M1, M2 in self.pairs():
            for speed in self.speeds:
                normal = rng.normal(size=3)
                normal /= np.linalg.norm(normal)
                tangent = np.cross(normal, rng.normal(size=3))
                tangent /= np.linalg.norm(tangent)
                dv = -speed * normal + 0.5 * speed * tangent     # relative velocity
                back_time = depth * (R1 + R2) / speed            # contact -> end of step
                dr_end = (R1 + R2) * normal + back_time * dv     # separation at the end
                v2 = rng.normal(0.0, speed * min(1.0, M1 / M2), 3)
                x2 = rng.uniform(-5.0, 5.0, 3)
                x1 = x2 + dr_end - np.array(ghost[:3])
                v1 = v2 + dv - np.array(ghost[3:])
                sim = rebound.Simulation()
                sim.collision = "line"
                sim.dt_last_done = 1.5 * back_time
                sim.add(m=M1, r=R1, x=x1[0], y=x1[1], z=x1[2], vx=v1[0], vy=v1[1], vz=v1[2])
                sim.add(m=M2, r=R2, x=x2[0], y=x2[1], z=x2[2], vx=v2[0], vy=v2[1], vz=v2[2])
                handle = install_resolver(sim, self.restitution, log_capacity=2)
                call_resolver(sim, 0, 1, ghost)
                call_resolver(sim, 1, 0, tuple(-g for g in ghost))
                assert handle.stats()["count"] == 1 and sim.collisions_log_n == 1

                R_bar, M_bar = rs.reduced_radius(R1, R2), rs.reduced_mass(M1, M2)
                eps = handle.stats()["log"]["epsilon"][0]
                assert eps == pytest.approx(self.reference(speed, R_bar, M_bar), rel=max(
                    self.tol, 1e-13)), "eps of the normal speed at contact"
                impulse = (1.0 + eps) * speed * M_bar * normal  # on particle 0 [kg m/s]
                v1_new, v2_new = v1 + impulse / M1, v2 - impulse / M2
                expected = np.array([
                    np.concatenate([x1 + back_time * (v1_new - v1), v1_new]),
                    np.concatenate([x2 + back_time * (v2_new - v2), v2_new])])
                got = phase_space(sim)
                scale = np.array([np.max(np.abs(expected[:, :3]))] * 3
                                 + [np.max(np.abs(expected[:, 3:]))] * 3)
                excess = np.abs(got - expected) - 1e-11 * scale
                assert np.all(excess <= 0.0), f"state after the bounce, excess {excess.max()}"
                separation = got[0, :3] + np.array(ghost[:3]) - got[1, :3]
                assert np.linalg.norm(separation) >= (R1 + R2) * (1.0 - 1e-12), \
                    "the pair must end the step apart"

    def test_receding_and_separated_pairs_untouched(self):
        rng = np.random.default_rng(41)
        receding = pair_simulation(rng, 1.0, 1.0, 1e3, 1e3, -1e-3, NO_GHOST)
        apart = pair_simulation(rng, 1.0, 1.0, 1e3, 1e3, 1e-3, NO_GHOST, overlap=-0.01)
        for sim in (receding, apart):
            handle = install_resolver(sim, self.restitution)
            start = phase_space(sim)
            assert call_resolver(sim, 0, 1) == 0
            np.testing.assert_array_equal(phase_space(sim), start)
            assert handle.stats()["count"] == 0 and sim.collisions_log_n == 0


class TestDilley(LawChecks):
    restitution = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0}
    tol = 1e-14


class TestDilleyMassDependent(LawChecks):
    restitution = DILLEY_KAPPA01
    tol = 1e-14


class TestBridges(LawChecks):
    restitution = {"model": "bridges", "v_c": 7.7e-5, "exponent": 0.234}
    tol = 1e-14


class TestConstant(LawChecks):
    restitution = {"model": "constant", "epsilon": 0.0}   # the hardest case for "once"
    tol = 0.0


class TestAndrews(LawChecks):
    restitution = {"model": "andrews", "v_c": 2e-4}
    tol = 1e-14


class TestTabor(LawChecks):
    restitution = {"model": "tabor", "v_c": 2e-4, "q": 0.375}
    tol = 1e-13

    def test_implicit_equation_solved(self):
        """eps satisfies eq. (4.10) to 1e-13 for q across (0, 1/2)."""
        v = np.geomspace(2.0001e-4, 10.0, 300)
        for q in (0.05, 0.2, 0.375, 0.45, 0.499):
            with ResolverHandle({"model": "tabor", "v_c": 2e-4, "q": q}) as handle:
                eps = handle.epsilon(v, 1.0, 1.0)
            u = v / 2e-4
            rhs = u ** -(1.0 - 2.0 * q) * ((1.0 - q * eps**2) / (1.0 - q)) ** q
            np.testing.assert_allclose(eps, rhs, rtol=0, atol=1e-13, err_msg=f"q={q}")


def test_batch_resolution_matches_twin_bit_for_bit():
    """Forty independent collisions, half across a sheared ghost box, each reported twice:
    one C call resolves each once, exactly as the Python twin does."""
    rng = np.random.default_rng(71)
    n_pairs = 40
    ghosts = np.array([SHEAR_GHOST if k % 2 else NO_GHOST for k in range(n_pairs)])
    pair_states = []
    for ghost in ghosts:
        pair = pair_simulation(rng, *rng.uniform(0.2, 2.0, 2), *rng.uniform(1e2, 1e4, 2),
                               10 ** rng.uniform(-5, -1), tuple(ghost))
        pair_states.append((phase_space(pair), [p.m for p in pair.particles],
                            [p.r for p in pair.particles]))
    sims = []
    for _ in range(2):
        sim = rebound.Simulation()
        for k, (state, masses, radii) in enumerate(pair_states):
            for (x, y, z, vx, vy, vz), m, r in zip(state, masses, radii, strict=True):
                sim.add(m=m, r=r, x=x + 100.0 * k, y=y, z=z, vx=vx, vy=vy, vz=vz)
        sims.append(sim)
    first = np.arange(0, 2 * n_pairs, 2)
    pairs = np.empty((2 * n_pairs, 2), dtype=np.int64)
    pairs[0::2] = np.column_stack([first, first + 1])
    pairs[1::2] = np.column_stack([first + 1, first])
    all_ghosts = np.empty((2 * n_pairs, 6))
    all_ghosts[0::2] = ghosts
    all_ghosts[1::2] = -ghosts

    handle = install_resolver(sims[0], DILLEY_KAPPA01, log_capacity=100)
    assert handle.resolve_batch(resolver.collision_records(pairs, all_ghosts)) == n_pairs
    twin = PythonReferenceResolver(DILLEY_KAPPA01)
    sims[1].collision_resolve = twin
    for (i, j), ghost in zip(pairs, all_ghosts, strict=True):
        call_resolver(sims[1], int(i), int(j), tuple(ghost))
    assert twin.count == n_pairs and twin.errors == []
    np.testing.assert_array_equal(phase_space(sims[0]), phase_space(sims[1]))
    assert sims[0].collisions_plog == sims[1].collisions_plog
    np.testing.assert_array_equal(handle.stats()["log"], twin.stats()["log"])


# --- REBOUND semantics ----------------------------------------------------------------------

def test_minimum_collision_velocity_as_rebound():
    """With a large minimum_collision_velocity w the separation speed is REBOUND's floor
    min(R_min w (1 - (d - R_max)/R_min), R_max w) = min(w x overlap depth, w R_max);
    velocities and collisions_plog as REBOUND's own resolver gives them."""
    rng = np.random.default_rng(51)
    R1, R2, w = 0.6, 1.4, 0.05          # w [1/s]
    for overlap in (0.01, 0.2, 0.8):    # the deepest overlap reaches the cap w R_max
        for ghost in (NO_GHOST, SHEAR_GHOST):
            seed = int(rng.integers(1 << 30))
            ours = pair_simulation(np.random.default_rng(seed), R1, R2, sphere_mass(R1),
                                   sphere_mass(R2), 1e-4, ghost, overlap=overlap)
            theirs = pair_simulation(np.random.default_rng(seed), R1, R2, sphere_mass(R1),
                                     sphere_mass(R2), 1e-4, ghost, overlap=overlap)
            for sim in (ours, theirs):
                sim.minimum_collision_velocity = w
            handle = install_resolver(ours, {"model": "constant", "epsilon": 0.3})
            builtin_with_constant_epsilon(theirs, 0.3)
            ps = phase_space(ours)
            d = np.linalg.norm(ps[0, :3] + np.array(ghost[:3]) - ps[1, :3])
            floor = min(R1 * w * (1.0 - (d - R2) / R1), R2 * w)
            assert floor == pytest.approx(min(w * (R1 + R2 - d), w * R2), rel=1e-12)
            assert floor > 1.3 * 1e-4, "the floor must be active in this test"

            before = ghost_frame_velocities(ours, ghost)
            call_resolver(ours, 0, 1, ghost)
            call_resolver(theirs, 0, 1, ghost)
            after = ghost_frame_velocities(ours, ghost)
            normal = (ps[0, :3] + np.array(ghost[:3]) - ps[1, :3]) / d
            separation = np.dot(after[0] - after[1], normal) - np.dot(before[0] - before[1],
                                                                       normal)
            assert separation == pytest.approx(floor, rel=1e-12)
            assert handle.stats()["n_floored"] == 1
            np.testing.assert_allclose(phase_space(ours), phase_space(theirs), rtol=1e-12,
                                       atol=1e-15)
            assert ours.collisions_plog == pytest.approx(theirs.collisions_plog, rel=1e-12)
            assert ours.collisions_log_n == theirs.collisions_log_n == 1


def test_two_simulations_with_different_kappa_do_not_interfere():
    """Interleaved stepping of kappa = 0 and kappa = 0.3 sheets gives bit-for-bit the runs
    made one after the other; each applies its own law."""
    laws = [{"model": "dilley", "kappa": 0.0}, {"model": "dilley", "kappa": 0.3}]
    alone = []
    for law in laws:
        sim = make_sheet(n=200, seed=7)
        install_resolver(sim, law)
        sim.steps(600)
        alone.append(phase_space(sim))

    sims = [make_sheet(n=200, seed=7) for _ in laws]
    handles = [install_resolver(s, law, log_capacity=10_000)
               for s, law in zip(sims, laws, strict=True)]
    for _ in range(600):
        for sim in sims:
            sim.steps(1)
    for sim, state, handle, law in zip(sims, alone, handles, laws, strict=True):
        np.testing.assert_array_equal(phase_space(sim), state)
        log = handle.stats()["log"]
        assert log.size > 50
        expected = rs.dilley_epsilon(log["v_n"], log["R_bar"], log["M_bar"],
                                     kappa=law["kappa"])
        np.testing.assert_allclose(log["epsilon"], expected, rtol=1e-14)
    # Metre-sized pairs have M_bar >> 60 g, so kappa > 0 lowers xi: more elastic.
    assert handles[1].stats()["mean_epsilon"] > handles[0].stats()["mean_epsilon"]


# --- statistics ------------------------------------------------------------------------------

def test_statistics_histograms_log_and_reset():
    full_sim = make_sheet(n=200, seed=9)
    full = install_resolver(full_sim, DILLEY_KAPPA01, log_capacity=100_000)
    full_sim.steps(800)
    sampled_sim = make_sheet(n=200, seed=9)
    sampled = install_resolver(sampled_sim, DILLEY_KAPPA01, log_capacity=7, log_every=3)
    sampled_sim.steps(800)

    stats = full.stats()
    log = stats["log"]
    count = stats["count"]
    assert count == log.size == full_sim.collisions_log_n > 100
    assert stats["mean_epsilon"] == pytest.approx(np.mean(log["epsilon"]), rel=1e-12)
    assert stats["mean_vn"] == pytest.approx(np.mean(log["v_n"]), rel=1e-12)

    hist = stats["histograms"]["v_n"]
    counts, _ = np.histogram(log["v_n"], bins=hist["edges"])
    np.testing.assert_array_equal(hist["counts"], counts)
    assert hist["counts"].sum() + hist["underflow"] + hist["overflow"] == count
    diss = stats["histograms"]["one_minus_epsilon"]
    counts, _ = np.histogram(1.0 - log["epsilon"], bins=diss["edges"])
    np.testing.assert_array_equal(diss["counts"], counts)
    assert diss["underflow"] == np.sum(1.0 - log["epsilon"] < 1e-4)
    assert diss["counts"].sum() + diss["underflow"] == count

    # Ring buffer: every 3rd collision, the last 7 of them, oldest first.
    ring = sampled.stats()
    assert ring["log_written"] == len(range(0, count, 3))
    np.testing.assert_array_equal(ring["log"], log[::3][-7:])

    full.reset_stats()
    reset = full.stats()
    assert reset["count"] == 0 and reset["log"].size == 0 and math.isnan(reset["mean_vn"])
    assert reset["histograms"]["v_n"]["counts"].sum() == 0


# --- lifetime, checkpoints, validation -----------------------------------------------------

def test_reinstall_after_checkpoint_continues_exactly(tmp_path):
    straight = make_sheet(n=200, seed=13)
    straight_handle = install_resolver(straight, DILLEY_KAPPA01)
    straight.integrate(0.2 * ORBIT)
    straight.integrate(0.4 * ORBIT)

    first = make_sheet(n=200, seed=13)
    handle = install_resolver(first, DILLEY_KAPPA01)
    first.integrate(0.2 * ORBIT)
    path = tmp_path / "checkpoint.bin"
    first.save_to_file(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # "reset function pointers"
        loaded = rebound.Simulation(str(path))
    assert loaded.extras is None
    handle.reinstall(loaded)
    loaded.integrate(0.4 * ORBIT)

    np.testing.assert_array_equal(phase_space(loaded), phase_space(straight))
    assert handle.stats()["count"] == straight_handle.stats()["count"] > 0
    assert handle.stats()["sum_epsilon"] == straight_handle.stats()["sum_epsilon"]
    assert first.extras is None, "the old simulation must be detached"


def test_closed_resolver_stops_integration_instead_of_ignoring_collisions():
    sim = make_sheet(n=200, seed=15)
    handle = install_resolver(sim, DILLEY_KAPPA01)
    handle.close()
    assert handle.closed and sim.extras is None
    with pytest.raises(rebound.GenericError):
        sim.integrate(0.5 * ORBIT)
    assert sim.collisions_log_n == 0


def test_handle_memory_freed_with_simulation():
    sim = make_sheet(n=20, seed=17)
    handle = install_resolver(sim, DILLEY_KAPPA01, log_capacity=1000)
    finalizer = handle._finalizer
    assert sim._extras_ref is handle, "the simulation keeps its resolver alive"
    del handle
    gc.collect()
    assert finalizer.alive
    del sim
    gc.collect()
    assert not finalizer.alive, "C memory of the resolver was not freed"


@pytest.mark.parametrize("bad, key", [
    ({"model": "dilly"}, "model"),
    ({"xi0": 0.16}, "model"),
    ({"model": "dilley", "kapa": 0.1}, "kapa"),
    ({"model": "tabor", "v_c": 1e-4, "q": 0.7}, "q"),
    ({"model": "andrews"}, "v_c"),
    ({"model": "constant", "epsilon": 1.5}, "epsilon"),
    ({"model": "bridges", "v_c": -1.0}, "v_c"),
])
def test_invalid_restitution_rejected_naming_the_key(bad, key):
    sim = rebound.Simulation()
    with pytest.raises(ValueError, match=key):
        install_resolver(sim, bad)
    with pytest.raises(ValueError, match=key):
        PythonReferenceResolver(bad)
    assert sim.extras is None


def test_invalid_log_settings_rejected():
    with pytest.raises(ValueError, match="log_every"):
        ResolverHandle(DILLEY_KAPPA01, log_every=0)
    with pytest.raises(ValueError, match="log_capacity"):
        ResolverHandle(DILLEY_KAPPA01, log_capacity=-1)


def test_python_twin_records_errors_and_leaves_collision_unresolved():
    rng = np.random.default_rng(61)
    sim = pair_simulation(rng, 1.0, 1.0, 1e3, 1e3, 1e-3, NO_GHOST)
    twin = PythonReferenceResolver(DILLEY_KAPPA01)
    sim.collision_resolve = twin
    start = phase_space(sim)
    assert call_resolver(sim, 0, 5) == 0            # no particle 5
    assert len(twin.errors) == 1 and twin.count == 0
    np.testing.assert_array_equal(phase_space(sim), start)
    assert sim.N == 2


def test_second_install_replaces_first_and_foreign_extras_refused():
    sim = make_sheet(n=200, seed=19)
    first = install_resolver(sim, {"model": "dilley", "kappa": 0.0})
    second = install_resolver(sim, {"model": "dilley", "kappa": 0.3}, log_capacity=1000)
    sim.steps(300)
    assert first.stats()["count"] == 0 and first.simulation is None
    assert second.stats()["count"] == sim.collisions_log_n > 0
    log = second.stats()["log"]
    np.testing.assert_allclose(log["epsilon"], rs.dilley_epsilon(
        log["v_n"], log["R_bar"], log["M_bar"], kappa=0.3), rtol=1e-14)

    foreign = rebound.Simulation()
    buffer = ctypes.create_string_buffer(64)     # stands for another library's struct
    foreign.extras = ctypes.addressof(buffer)
    with pytest.raises(ValueError, match="extras"):
        install_resolver(foreign, DILLEY_KAPPA01)
    assert foreign.extras == ctypes.addressof(buffer)
    foreign.extras = None
