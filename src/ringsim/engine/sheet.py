"""Scenario -> REBOUND shearing sheet: size distribution, initial state and guards in the
box of ``engine.box``.

The patch is REBOUND's shearing sheet (Wisdom & Tremaine 1988): Hill's equations
integrated with the symplectic epicycle integrator SEI (Rein & Tremaine 2011), shear-
periodic boundaries in x (radial) and periodic ones in y (azimuthal), ghost boxes, and
tree collision detection.  With shear boundaries REBOUND also makes z periodic, with
period ``root_size * N_root_z``: :func:`vertical_guard` keeps every particle's vertical
oscillation well inside it.

Units are SI throughout (G = 6.674e-11 m^3 kg^-1 s^-2 when self-gravity is on).
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass

import numpy as np
import rebound

from ringsim.config.gravity_keys import SOLVER_KEYS
from ringsim.config.scenario import scenario_from_dict
from ringsim.engine.blas import one_blas_thread
from ringsim.engine.box import SheetGeometry, box_geometry, configure_box
from ringsim.engine.hardsphere import HardsphereHandle, install_scenario_resolver
from ringsim.engine.initial_file import read_initial_state, refuse_copies_alike
from ringsim.engine.native import _LIB
from ringsim.engine.placement import OverlapGrid, wrap_horizontal
from ringsim.engine.resolver import ResolverHandle
from ringsim.engine.timestep import choose_dt
from ringsim.errors import InputError
from ringsim.gravity.registry import (
    install_gravity,
    installed_gravity,
    scenario_gravity_arguments,
)
from ringsim.physics.constants import SHEAR
from ringsim.physics.gravity import toomre_dispersion
from ringsim.physics.sizes import size_bin_edges

#: A particle's vertical amplitude may reach this fraction of the half z period.
VERTICAL_GUARD_FRACTION = 0.4


# --- initial state -----------------------------------------------------------------------------

#: Largest volume filling factor at the mid-plane of the initial layer.
INITIAL_FILLING_FACTOR = 0.1
#: Rounds of random draws the initial placement may take, far more than a dense sheet of
#: 1e6 particles needs (docs/performance.md, "Set-up and snapshot I/O at scale").  More is
#: an error.
PLACEMENT_ROUNDS = 2000


class PlacementError(ValueError):
    """The particles do not fit into the box without overlaps (`initial_state`)."""


def minimum_scale_height(radii: np.ndarray, area: float) -> float:
    """Thinnest initial Gaussian layer [m] whose mid-plane filling factor is 0.1.

    The mid-plane volume filling factor of N spheres in a Gaussian layer of scale height h
    over the box area A is sum(4/3 pi R^3) / (A sqrt(2 pi) h); a layer this dilute is
    filled by random draws without overlaps in a few rounds.

    Parameters
    ----------
    radii : array [m]
    area : float [m^2]
        Lx Ly.
    """
    volume = float(np.sum(4.0 / 3.0 * np.pi * radii**3))
    return volume / (area * math.sqrt(2.0 * math.pi) * INITIAL_FILLING_FACTOR)


def initial_state(radii: np.ndarray, geometry: SheetGeometry, dispersion: float,
                  rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Positions [m] and velocities [m/s] of a ring with a small random dispersion.

    Positions are uniform in the box with a Gaussian vertical distribution of scale
    height h = max(dispersion / Omega, `minimum_scale_height`); velocities are the shear
    flow vy = -1.5 Omega x plus Gaussian motions of 1-D dispersion ``dispersion`` in x
    and y and Omega h in z.  z and vz / Omega then share one Gaussian: the layer is in
    vertical equilibrium from the start.  (Heights drawn with vz of the horizontal
    dispersion would all fall through the mid-plane together a quarter orbit later, a
    burst of collisions that heats the ring, crowds the layer and enlarges the box.)
    Of two particles drawn overlapping, one is drawn again (the much smaller one, else the
    higher index: ``engine.placement``), so the run starts without overlaps and the largest
    particles find room first; the box is
    shear-periodic at t = 0, where the images across the radial boundary are not shifted in
    y.

    Parameters
    ----------
    radii : array [m]
    geometry : SheetGeometry
    dispersion : float [m/s]
    rng : numpy Generator
    """
    n = radii.size
    Lx, Ly, Omega = geometry.Lx, geometry.Ly, geometry.Omega
    h = max(dispersion / Omega, minimum_scale_height(radii, Lx * Ly))
    z_limit = VERTICAL_GUARD_FRACTION * 0.5 * geometry.z_period

    def draw(k):
        xyz = np.empty((k, 3))
        xyz[:, 0] = rng.uniform(-0.5 * Lx, 0.5 * Lx, k)
        xyz[:, 1] = rng.uniform(-0.5 * Ly, 0.5 * Ly, k)
        xyz[:, 2] = np.clip(rng.normal(0.0, h, k), -0.5 * z_limit, 0.5 * z_limit)
        return xyz

    pos = draw(n)
    x, y = wrap_horizontal(pos, Lx, Ly)
    z = np.ascontiguousarray(pos[:, 2])
    with OverlapGrid(x, y, z, radii, Lx, Ly) as grid:
        bad = grid.overlapping_later()
        for _ in range(PLACEMENT_ROUNDS):
            if bad.size == 0:
                break
            pos[bad] = draw(bad.size)
            x[bad], y[bad] = wrap_horizontal(pos[bad], Lx, Ly)
            z[bad] = pos[bad, 2]
            grid.move(bad, x, y, z)
            bad = grid.overlapping_later(bad)
    if bad.size:
        raise PlacementError(f"{bad.size} of {n} particles could not be placed without "
                             f"overlaps in {PLACEMENT_ROUNDS} rounds of random draws")
    vel = np.empty((n, 3))
    vel[:, :2] = rng.normal(0.0, dispersion, (n, 2))
    vel[:, 2] = rng.normal(0.0, Omega * h, n)
    vel[:, 1] += -1.5 * Omega * pos[:, 0]
    return {"x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2],
            "vx": vel[:, 0], "vy": vel[:, 1], "vz": vel[:, 2]}


def placed_state(scenario, radii: np.ndarray, geometry: SheetGeometry, dispersion: float,
                 rng: np.random.Generator) -> dict[str, np.ndarray]:
    """`initial_state` of a scenario; a sheet that cannot be placed is bad input (`InputError`
    naming the scenario's file and ``sheet.optical_depth``: exit status 2), not a failure.

    Parameters
    ----------
    scenario : Scenario
    radii : array [m]
    geometry : SheetGeometry
    dispersion : float [m/s]
    rng : numpy Generator
    """
    try:
        return initial_state(radii, geometry, dispersion, rng)
    except PlacementError as exc:
        raise InputError(scenario.source, "sheet.optical_depth",
                         f"{exc}; lower the optical depth, narrow the size distribution or "
                         "raise sheet.z_box") from None


def centre_of_mass_at_rest(state: dict[str, np.ndarray], masses: np.ndarray,
                           Omega: float) -> dict[str, np.ndarray]:
    """The state with the sheet's centre of mass at rest in the shear flow, in the midplane.

    Subtracts the mass-weighted mean of the velocity relative to the shear flow,
    (vx, vy + 1.5 Omega x, vz), and the mass-weighted mean height z.  A random draw leaves
    them non-zero (of order c / sqrt(N)); since collisions conserve momentum and Hill's
    equations move the centre of mass as a free particle, that offset would otherwise
    perform an undamped epicycle (and vertical oscillation) for the whole run and add to
    every dispersion.  Relative positions and velocities are unchanged.

    Parameters
    ----------
    state : positions x, y, z [m] and velocities vx, vy, vz [m/s]
    masses : array [kg]
    Omega : float [1/s]
    """
    weights = masses / np.sum(masses)
    out = dict(state)
    w_y = state["vy"] + SHEAR * Omega * state["x"]
    for key, values in (("vx", state["vx"]), ("vz", state["vz"]), ("z", state["z"])):
        out[key] = values - np.dot(weights, values)
    out["vy"] = state["vy"] - np.dot(weights, w_y)
    return out


# --- the simulation ----------------------------------------------------------------------------

def configure_simulation(sim: rebound.Simulation, geometry: SheetGeometry, *,
                         gravity: dict | None, collision_detection: str,
                         rand_seed: int) -> None:
    """Set a REBOUND simulation up as a shearing sheet (no particles added).

    Parameters
    ----------
    geometry : SheetGeometry
    gravity : dict or None
        Self-gravity: the arguments of ``gravity.registry.install_gravity`` (solver,
        softening [m] and the solver's keywords; a scenario's are
        ``gravity.registry.scenario_gravity_arguments``); None for none.
    collision_detection : "tree" (overlaps at step ends) or "line" (swept paths: REBOUND's
        linetree here; ``install_resolver`` replaces it by ringsim's sheet detector)
    rand_seed : int
        Seed of REBOUND's collision shuffle.
    """
    configure_box(sim, geometry)
    sim.collision = "linetree" if collision_detection == "line" else "tree"
    sim.N_ghost_x, sim.N_ghost_y = 1, 1
    if gravity is not None:
        install_gravity(sim, **gravity)
    else:
        sim.gravity = "none"
    sim.N_ghost_z = 0
    sim.rand_seed = int(rand_seed)


def add_particles(sim: rebound.Simulation, state: dict[str, np.ndarray], radii: np.ndarray,
                  masses: np.ndarray) -> None:
    """Add particles to ``sim`` in index order, in one C call (``rs_setup.c``).

    The same REBOUND calls as ``sim.add`` particle by particle, so the same simulation to
    the bit, without ~20 us of Python per particle.

    Parameters
    ----------
    state : positions x, y, z [m] and velocities vx, vy, vz [m/s]
    radii : array [m]
    masses : array [kg]
    """
    if (sim.gravity == "tree" or sim.collision in ("tree", "linetree")) \
            and not sim.root_size > 0.0:
        raise ValueError("configure the box before adding particles (tree code)")
    n = int(radii.size)
    columns = [np.ascontiguousarray(a, dtype=np.float64)
               for a in (masses, radii, state["x"], state["y"], state["z"], state["vx"],
                         state["vy"], state["vz"])]
    if any(c.shape != (n,) for c in columns):
        raise ValueError(f"every particle array must have {n} entries")
    double_p = ctypes.POINTER(ctypes.c_double)
    n_before = sim.N
    add = ctypes.cast(rebound.clibrebound.reb_simulation_add, ctypes.c_void_p)
    n_after = _LIB.rs_add_particles(ctypes.byref(sim), add, n,
                                    *(c.ctypes.data_as(double_p) for c in columns))
    if n_after != n_before + n:
        raise RuntimeError(f"REBOUND holds {n_after} particles after adding {n} to {n_before}")
    sim.process_messages()


@dataclass
class BuiltSheet:
    """A built sheet: the simulation, its geometry and what the run loop needs."""

    sim: rebound.Simulation
    geometry: SheetGeometry
    radii: np.ndarray
    masses: np.ndarray
    size_bin_edges: np.ndarray | None
    resolver: ResolverHandle | HardsphereHandle


def particle_arrays(sim: rebound.Simulation) -> dict[str, np.ndarray]:
    """Positions, velocities, radii and masses of all particles as SI arrays (no Python loop)."""
    n = sim.N
    xyz = np.empty((n, 3))
    vxyz = np.empty((n, 3))
    r = np.empty(n)
    m = np.empty(n)
    sim.serialize_particle_data(xyz=xyz, vxvyvz=vxyz, r=r, m=m)
    return {"x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2], "vx": vxyz[:, 0],
            "vy": vxyz[:, 1], "vz": vxyz[:, 2], "radius": r, "mass": m}


@one_blas_thread   # the centre of mass at rest: sums of N terms, same bits on any machine
def build_sheet(scenario) -> BuiltSheet:
    """Scenario -> ready-to-run shearing sheet with its resolver installed (ringsim's
    native one, or REBOUND's with ``integration.resolver: rebound_hardsphere``).

    The scenario's ``seed`` seeds both numpy (radii, positions, velocities) and REBOUND's
    collision shuffle (``sim.rand_seed``): the same scenario gives the same bits.  With
    ``sheet.initial_state`` the particles come from the file instead
    (`ringsim.engine.initial_file`).
    """
    sim, geometry, radii, masses, spins = new_simulation(scenario)
    refuse_copies_alike(scenario)
    handle = install_scenario_resolver(sim, scenario)
    if spins is not None and handle.friction is not None:   # smooth spheres: no spins
        handle.set_spins(spins)
    edges = size_bin_edges(scenario.particles.size_distribution)
    return BuiltSheet(sim, geometry, radii, masses, edges, handle)


def new_simulation(scenario) -> tuple[rebound.Simulation, SheetGeometry, np.ndarray,
                                      np.ndarray, np.ndarray | None]:
    """The scenario's REBOUND simulation before a resolver is installed: (sim, geometry, radii
    [m], masses [kg], spins). ``spins``: (N, 3) [rad/s] in the rotating frame's axes
    from a ``sheet.initial_state`` run file written with friction or a CSV with spin
    columns, else None (REBOUND particles have no spins: `build_sheet` gives them to the
    resolver). `ringsim export --rebound` saves this simulation, so that a REBOUND
    user's continuation and ringsim's are the same."""
    Omega = scenario.orbital_frequency
    sheet_cfg = scenario.sheet
    if sheet_cfg.initial_state is not None:
        radii, masses, state, geometry, t0, spins = read_initial_state(scenario)
        w = np.column_stack([state["vx"], state["vy"] + 1.5 * Omega * state["x"],
                             state["vz"]])
        dispersion = float(np.sqrt(np.mean(w * w)))
    else:
        rng = np.random.default_rng(scenario.seed)
        radii, masses = drawn_particles(scenario, rng)
        dispersion = initial_dispersion(sheet_cfg, radii, masses, Omega)
        geometry, t0, spins = None, 0.0, None
    z_half = initial_z_half_height(sheet_cfg, float(radii.mean()), dispersion, Omega,
                                   r_max=float(radii.max()),
                                   expected_dispersion=expected_dispersion(scenario, radii,
                                                                           masses))
    if geometry is None:
        geometry = box_geometry(radii, sheet_cfg.optical_depth, sheet_cfg.aspect, Omega,
                                z_half)
        state = centre_of_mass_at_rest(placed_state(scenario, radii, geometry, dispersion,
                                                    rng), masses, Omega)
    else:
        geometry = SheetGeometry(geometry.root_size, geometry.n_root_x, geometry.n_root_y,
                                 max(1, math.ceil(2.0 * z_half / geometry.root_size)), Omega)
    # the initial velocities may already carry particles beyond the requested box
    amplitude = max_vertical_amplitude(state, Omega)
    if amplitude >= VERTICAL_GUARD_FRACTION * 0.5 * geometry.z_period:
        n_root_z = math.ceil(1.5 * amplitude / (VERTICAL_GUARD_FRACTION * 0.5)
                             / geometry.root_size)
        geometry = SheetGeometry(geometry.root_size, geometry.n_root_x, geometry.n_root_y,
                                 n_root_z, Omega)
    sim = rebound.Simulation()
    configure_simulation(sim, geometry,
                         gravity=(scenario_gravity_arguments(scenario) if sheet_cfg.gravity
                                  else None),
                         collision_detection=scenario.integration.collision_detection,
                         rand_seed=scenario.seed)
    add_particles(sim, state, radii, masses)
    sim.t = t0
    sim.minimum_collision_velocity = minimum_collision_velocity(radii, Omega)
    sim.dt = choose_dt(scenario.integration, particle_arrays(sim), Omega)
    return sim, geometry, radii, masses, spins


#: Room the automatic box leaves above the expected equilibrium thickness, in units of that
#: thickness c_eq / Omega: the product of how low the dilute kinetic estimate can be, how
#: much faster the smallest particles move than the mean, and how far the largest of a long
#: run's vertical amplitudes exceeds their Rayleigh scale (docs/scenario.md, ``z_box``).
EQUILIBRIUM_AMPLITUDES = 16.0


def expected_dispersion(scenario, radii: np.ndarray, masses: np.ndarray) -> float:
    """The scenario's equilibrium velocity dispersion [m/s] by the dilute kinetic estimate
    (``physics.kinetic``; Goldreich & Tremaine 1978 balance of its restitution law), or 0
    where that estimate has no stable balance (a cold ring that collapses to a monolayer).

    Parameters
    ----------
    scenario : Scenario
    radii : array [m]
    masses : array [kg]
    """
    from ringsim.physics.kinetic import kinetic_dispersion_estimate  # loads scipy.optimize

    estimate = kinetic_dispersion_estimate(scenario.restitution_dict(), radii, masses,
                                           scenario.sheet.optical_depth,
                                           scenario.orbital_frequency)
    if estimate["status"] != "equilibrium":
        return 0.0
    c = estimate["velocity_dispersion"]     # [m/s]: a number whenever there is an equilibrium
    if not isinstance(c, (int, float)):
        raise TypeError(f"kinetic_dispersion_estimate: velocity_dispersion {c!r} is no number")
    return float(c)


def initial_z_half_height(sheet_cfg, r_mean: float, dispersion: float, Omega: float,
                          r_max: float = 0.0, expected_dispersion: float = 0.0) -> float:
    """Half the initial vertical period [m]: ``sheet.z_box`` mean radii, or automatic.

    Automatic: room for vertical amplitudes of 20 times the initial thickness, of 50 mean
    radii and of 20 largest radii (the guard keeps amplitudes below 0.4 of the half
    period).  The last term is for broad size distributions: the shear across a large
    particle, 1.5 Omega (r_max + r), kicks small particles to ~3 Omega r_max in their first
    collisions, so their amplitudes reach several r_max within an orbit whatever the
    initial dispersion.  And room for `EQUILIBRIUM_AMPLITUDES` times the equilibrium
    thickness the kinetic estimate expects (``expected_dispersion`` / Omega), so that a ring
    heating to its equilibrium never needs a larger box.  The vertical guard enlarges the
    box further if the ring heats beyond that.

    Parameters
    ----------
    sheet_cfg : the scenario's sheet section
    r_mean : float [m]
    dispersion : float [m/s]
        Initial 1-D velocity dispersion.
    Omega : float [1/s]
    r_max : float [m]
        Largest radius.
    expected_dispersion : float [m/s]
        Equilibrium velocity dispersion expected (0: unknown).
    """
    if sheet_cfg.z_box != "auto":
        return 0.5 * float(sheet_cfg.z_box) * r_mean
    return (max(50.0 * r_mean, 20.0 * r_max, 20.0 * dispersion / Omega,
                EQUILIBRIUM_AMPLITUDES * expected_dispersion / Omega)
            / VERTICAL_GUARD_FRACTION)


def drawn_particles(scenario, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Radii [m] and masses [kg] of the scenario's particles, drawn with ``rng``."""
    radii = scenario.particles.size_distribution.draw_radii(scenario.sheet.n_particles, rng)
    return radii, scenario.particles.density * 4.0 / 3.0 * np.pi * radii**3


def initial_dispersion(sheet_cfg, radii: np.ndarray, masses: np.ndarray,
                       Omega: float) -> float:
    """Initial 1-D velocity dispersion relative to the shear flow [m/s] of a drawn sheet:
    ``initial_toomre_q`` Q with the sheet's surface density Sigma = tau sum(m) /
    sum(pi r^2) [kg/m^2] (the box holds the particles at the optical depth tau), else
    ``initial_dispersion`` mean radii x Omega.

    Parameters
    ----------
    radii : array [m]
    masses : array [kg]
    Omega : float [1/s]
    """
    if sheet_cfg.initial_toomre_q is not None:
        Sigma = sheet_cfg.optical_depth * float(masses.sum()) / float(np.pi * np.sum(radii**2))
        return float(toomre_dispersion(sheet_cfg.initial_toomre_q, Sigma, Omega))
    return sheet_cfg.initial_dispersion * float(radii.mean()) * Omega


def without_gravity(scenario):
    """``scenario`` with self-gravity off and everything else alike: the baseline of a
    gravitating step.  A start at a Toomre Q (``initial_toomre_q``, which needs gravity)
    becomes the equal ``initial_dispersion`` of the same drawn radii, so both sheets start
    from the same state."""
    d = scenario.to_dict()
    sheet_d = {k: v for k, v in d["sheet"].items()
               if k not in ("gravity_solver", "initial_toomre_q", *SOLVER_KEYS)}
    sheet_d["gravity"] = False
    if scenario.sheet.initial_toomre_q is not None and scenario.sheet.initial_state is None:
        radii, masses = drawn_particles(scenario, np.random.default_rng(scenario.seed))
        c = initial_dispersion(scenario.sheet, radii, masses, scenario.orbital_frequency)
        sheet_d["initial_dispersion"] = c / (float(radii.mean())
                                             * scenario.orbital_frequency)
    d["sheet"] = sheet_d
    return scenario_from_dict(d, source=scenario.name)


def minimum_collision_velocity(radii: np.ndarray, Omega: float) -> float:
    """REBOUND's ``minimum_collision_velocity`` for the sheet [m/s].

    A small fraction (1e-3) of the shear across the smallest particle, as in REBOUND's
    shearing-sheet example, so that slowly approaching overlapping pairs separate instead
    of sinking into each other.
    """
    return 1e-3 * float(radii.min()) * Omega


# --- guards ------------------------------------------------------------------------------------

def max_vertical_amplitude(arrays: dict[str, np.ndarray], Omega: float) -> float:
    """Largest vertical oscillation amplitude sqrt(z^2 + (vz/Omega)^2) [m].

    Between collisions a particle's height oscillates harmonically with this amplitude, so
    it bounds how high a particle can go before its next collision.
    """
    z, vz = arrays["z"], arrays["vz"]
    return float(np.sqrt(np.max(z * z + (vz / Omega) ** 2))) if z.size else 0.0


def vertical_guard_ok(arrays: dict[str, np.ndarray], geometry: SheetGeometry) -> bool:
    """True while every particle's vertical amplitude stays below 0.4 of the half period."""
    return (max_vertical_amplitude(arrays, geometry.Omega)
            < VERTICAL_GUARD_FRACTION * 0.5 * geometry.z_period)


def enlarged_copy(sim: rebound.Simulation, geometry: SheetGeometry,
                  n_root_z: int) -> tuple[rebound.Simulation, SheetGeometry]:
    """A copy of ``sim`` with a taller box (``n_root_z`` root boxes), state unchanged.

    REBOUND cannot resize the box of a simulation whose tree exists, so the particles,
    time, step, random-number state and collision logs are moved to a new simulation
    configured like the old one.  The caller re-installs the resolver.
    """
    new_geometry = SheetGeometry(geometry.root_size, geometry.n_root_x, geometry.n_root_y,
                                 n_root_z, geometry.Omega)
    new = rebound.Simulation()
    configure_simulation(new, new_geometry, gravity=installed_gravity(sim),
                         collision_detection="tree" if sim.collision == "tree" else "line",
                         rand_seed=0)
    arrays = particle_arrays(sim)
    add_particles(new, arrays, arrays["radius"], arrays["mass"])
    new.t = sim.t
    new.dt = sim.dt
    new.rand_seed = sim.rand_seed
    new.collisions_plog = sim.collisions_plog
    new.collisions_log_n = sim.collisions_log_n
    new.minimum_collision_velocity = sim.minimum_collision_velocity
    return new, new_geometry
