"""Scenario -> REBOUND shearing sheet: box, size distribution, initial state and guards.

The patch is REBOUND's shearing sheet (Wisdom & Tremaine 1988): Hill's equations
integrated with the symplectic epicycle integrator SEI (Rein & Tremaine 2011), shear-
periodic boundaries in x (radial) and periodic ones in y (azimuthal), ghost boxes, and
tree collision detection.  With shear boundaries REBOUND also makes z periodic, with
period ``root_size * N_root_z``: :func:`vertical_guard` keeps every particle's vertical
oscillation well inside it.

Units are SI throughout (G = 6.674e-11 m^3 kg^-1 s^-2 when self-gravity is on).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import rebound

from ringsim.engine.timestep import choose_dt
from ringsim.physics.constants import G_SI, SHEAR
from ringsim.physics.sizes import size_bin_edges

#: A particle's vertical amplitude may reach this fraction of the half z period.
VERTICAL_GUARD_FRACTION = 0.4
#: Overlaps deeper than this fraction of the smaller radius are reported.
OVERLAP_REPORT_FRACTION = 0.1


@dataclass(frozen=True)
class SheetGeometry:
    """The box of a sheet.

    Attributes
    ----------
    root_size : float [m]
        Edge of one cubic root box.
    n_root_x, n_root_y, n_root_z : int
        Root boxes along x, y, z.
    Omega : float [1/s]
    """

    root_size: float
    n_root_x: int
    n_root_y: int
    n_root_z: int
    Omega: float

    @property
    def Lx(self) -> float:
        """Radial box size [m]."""
        return self.root_size * self.n_root_x

    @property
    def Ly(self) -> float:
        """Azimuthal box size [m]."""
        return self.root_size * self.n_root_y

    @property
    def z_period(self) -> float:
        """Vertical period of the box [m]."""
        return self.root_size * self.n_root_z

    @property
    def orbit(self) -> float:
        """Orbital period 2 pi / Omega [s]."""
        return 2.0 * math.pi / self.Omega

    def attributes(self) -> dict:
        """Geometry as run-file attributes (SI)."""
        return {"root_size": self.root_size, "N_root_x": self.n_root_x,
                "N_root_y": self.n_root_y, "N_root_z": self.n_root_z, "Lx": self.Lx,
                "Ly": self.Ly, "Omega": self.Omega}


# --- box ---------------------------------------------------------------------------------------

def box_geometry(radii: np.ndarray, optical_depth: float, aspect: float, Omega: float,
                 z_half_height: float) -> SheetGeometry:
    """Root boxes holding ``radii`` at dynamical optical depth ``optical_depth``.

    The horizontal box satisfies sum(pi r^2) = tau Lx Ly exactly; Ly/Lx is the closest
    ratio of small integers to ``aspect`` (REBOUND's root boxes are cubes).  The vertical
    period is at least 2 ``z_half_height``.

    Parameters
    ----------
    radii : array [m]
    optical_depth : float [dimensionless]
    aspect : float [dimensionless]
        Requested Ly / Lx.
    Omega : float [1/s]
    z_half_height : float [m]
        Half of the smallest acceptable vertical period.
    """
    ratio = Fraction(aspect).limit_denominator(8)
    if ratio <= 0:
        ratio = Fraction(1, 8)
    n_x, n_y = ratio.denominator, ratio.numerator
    area = float(np.sum(np.pi * radii**2)) / optical_depth
    root_size = math.sqrt(area / (n_x * n_y))
    n_z = max(1, math.ceil(2.0 * z_half_height / root_size))
    return SheetGeometry(root_size, n_x, n_y, n_z, Omega)


# --- initial state -----------------------------------------------------------------------------

def initial_state(radii: np.ndarray, geometry: SheetGeometry, dispersion: float,
                  rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Positions [m] and velocities [m/s] of a ring with a small random dispersion.

    Positions are uniform in the box with a Gaussian vertical distribution of scale
    height dispersion/Omega (at least twice the largest radius); velocities are the
    shear flow vy = -1.5 Omega x plus isotropic Gaussian motions of 1-D dispersion
    ``dispersion``.  Particles drawn overlapping another are drawn again, so the run starts
    without overlaps.

    Parameters
    ----------
    radii : array [m]
    geometry : SheetGeometry
    dispersion : float [m/s]
    rng : numpy Generator
    """
    from scipy.spatial import cKDTree

    n = radii.size
    Lx, Ly, Omega = geometry.Lx, geometry.Ly, geometry.Omega
    h = max(dispersion / Omega, 2.0 * radii.max())
    z_limit = VERTICAL_GUARD_FRACTION * 0.5 * geometry.z_period

    def draw(k):
        xyz = np.empty((k, 3))
        xyz[:, 0] = rng.uniform(-0.5 * Lx, 0.5 * Lx, k)
        xyz[:, 1] = rng.uniform(-0.5 * Ly, 0.5 * Ly, k)
        xyz[:, 2] = np.clip(rng.normal(0.0, h, k), -0.5 * z_limit, 0.5 * z_limit)
        return xyz

    pos = draw(n)
    r_max = radii.max()
    for _ in range(200):
        # periodic in x and y (the shear offset at the x edges is ignored here; the
        # resolver separates any pair the approximation misses)
        wrapped = pos + np.array([0.5 * Lx, 0.5 * Ly, 0.0])
        wrapped[:, 0] %= Lx
        wrapped[:, 1] %= Ly
        wrapped[:, 2] -= wrapped[:, 2].min()
        tree = cKDTree(wrapped, boxsize=[Lx, Ly, 1e300])
        pairs = tree.query_pairs(2.0 * r_max, output_type="ndarray")
        if pairs.size:
            d = wrapped[pairs[:, 0]] - wrapped[pairs[:, 1]]
            d[:, 0] -= Lx * np.round(d[:, 0] / Lx)
            d[:, 1] -= Ly * np.round(d[:, 1] / Ly)
            overlap = np.sum(d * d, axis=1) < (radii[pairs[:, 0]] + radii[pairs[:, 1]]) ** 2
            bad = np.unique(pairs[overlap, 1])
        else:
            bad = np.array([], dtype=int)
        if bad.size == 0:
            break
        pos[bad] = draw(bad.size)
    vel = rng.normal(0.0, dispersion, (n, 3))
    vel[:, 1] += -1.5 * Omega * pos[:, 0]
    return {"x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2],
            "vx": vel[:, 0], "vy": vel[:, 1], "vz": vel[:, 2]}


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

def configure_simulation(sim: rebound.Simulation, geometry: SheetGeometry, *, gravity: bool,
                         softening: float, opening_angle: float, detection: str,
                         rand_seed: int) -> None:
    """Set a REBOUND simulation up as a shearing sheet (no particles added).

    Parameters
    ----------
    geometry : SheetGeometry
    gravity : bool
        Tree self-gravity with ``softening`` [m] and ``opening_angle`` [rad].
    detection : "tree" (overlaps at step ends) or "line" (REBOUND's linetree)
    rand_seed : int
        Seed of REBOUND's collision shuffle.
    """
    sim.integrator = "sei"
    sim.OMEGA = geometry.Omega
    sim.OMEGAZ = geometry.Omega
    # REBOUND 5.2 has no configure_box: the root grid is set field by field, before any
    # particle is added (the tree is built as particles arrive).
    sim.root_size = geometry.root_size
    sim.N_root_x, sim.N_root_y, sim.N_root_z = (geometry.n_root_x, geometry.n_root_y,
                                                geometry.n_root_z)
    sim.boundary = "shear"
    sim.collision = "linetree" if detection == "line" else "tree"
    if gravity:
        sim.G = G_SI
        sim.gravity = "tree"
        sim.softening = softening
        sim.opening_angle2 = opening_angle**2
        sim.N_ghost_x, sim.N_ghost_y = 2, 2
    else:
        sim.gravity = "none"
        sim.N_ghost_x, sim.N_ghost_y = 1, 1
    sim.N_ghost_z = 0
    sim.rand_seed = int(rand_seed)


def add_particles(sim: rebound.Simulation, state: dict[str, np.ndarray], radii: np.ndarray,
                  masses: np.ndarray) -> None:
    """Add particles (SI arrays) to ``sim`` in index order."""
    for i in range(radii.size):
        sim.add(m=float(masses[i]), r=float(radii[i]), x=float(state["x"][i]),
                y=float(state["y"][i]), z=float(state["z"][i]), vx=float(state["vx"][i]),
                vy=float(state["vy"][i]), vz=float(state["vz"][i]))


@dataclass
class Sheet:
    """A built sheet: the simulation, its geometry and what the run loop needs."""

    sim: rebound.Simulation
    geometry: SheetGeometry
    radii: np.ndarray
    masses: np.ndarray
    size_bin_edges: np.ndarray | None
    resolver: object


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


def build_sheet(scenario) -> Sheet:
    """Scenario -> ready-to-run shearing sheet with ringsim's native resolver installed.

    The scenario's ``seed`` seeds both numpy (radii, positions, velocities) and REBOUND's
    collision shuffle (``sim.rand_seed``): the same scenario gives the same bits.
    """
    from ringsim.engine.resolver import install_resolver

    rng = np.random.default_rng(scenario.seed)
    Omega = scenario.orbital_frequency
    particles, sheet_cfg = scenario.particles, scenario.sheet
    radii = particles.size_distribution.draw_radii(sheet_cfg.n_particles, rng)
    masses = particles.density * 4.0 / 3.0 * np.pi * radii**3
    r_mean = float(radii.mean())
    dispersion = sheet_cfg.initial_dispersion * r_mean * Omega
    z_half = initial_z_half_height(sheet_cfg, r_mean, dispersion, Omega)
    geometry = box_geometry(radii, sheet_cfg.optical_depth, sheet_cfg.aspect, Omega, z_half)
    state = centre_of_mass_at_rest(initial_state(radii, geometry, dispersion, rng), masses,
                                   Omega)
    # the initial velocities may already carry particles beyond the requested box
    amplitude = max_vertical_amplitude(state, Omega)
    if amplitude >= VERTICAL_GUARD_FRACTION * 0.5 * geometry.z_period:
        n_root_z = math.ceil(1.5 * amplitude / (VERTICAL_GUARD_FRACTION * 0.5)
                             / geometry.root_size)
        geometry = SheetGeometry(geometry.root_size, geometry.n_root_x, geometry.n_root_y,
                                 n_root_z, Omega)
    sim = rebound.Simulation()
    configure_simulation(sim, geometry, gravity=sheet_cfg.gravity,
                         softening=scenario.softening_length or 0.0,
                         opening_angle=sheet_cfg.opening_angle or 0.0,
                         detection=scenario.integration.collision_detection,
                         rand_seed=scenario.seed)
    add_particles(sim, state, radii, masses)
    sim.minimum_collision_velocity = minimum_collision_velocity(radii, Omega)
    handle = install_resolver(sim, scenario.restitution_dict(),
                              log_capacity=scenario.output.log_collisions,
                              detector=detector_for(scenario.integration.collision_detection))
    edges = size_bin_edges(particles.size_distribution)
    sim.dt = choose_dt(scenario.integration, particle_arrays(sim), Omega)
    return Sheet(sim, geometry, radii, masses, edges, handle)


def detector_for(detection: str) -> str:
    """The resolver's collision search for a scenario's ``collision_detection``.

    ``line`` uses ringsim's swept-sphere search for shearing sheets
    (``rs_sheet_detect.c``), whose cost per particle-step does not grow with the box as
    that of REBOUND's ``linetree`` does; ``tree`` uses REBOUND's tree search.
    """
    return "sheet" if detection == "line" else "rebound"


def initial_z_half_height(sheet_cfg, r_mean: float, dispersion: float, Omega: float) -> float:
    """Half the initial vertical period [m]: ``sheet.z_box`` mean radii, or automatic.

    Automatic: room for a ring 20 times thicker than the initial one, and at least 50 mean
    radii; the vertical guard enlarges it further if the ring heats beyond that.
    """
    if sheet_cfg.z_box != "auto":
        return 0.5 * float(sheet_cfg.z_box) * r_mean
    return max(50.0 * r_mean, 20.0 * dispersion / Omega) / VERTICAL_GUARD_FRACTION


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


def count_overlaps(arrays: dict[str, np.ndarray], geometry: SheetGeometry, t: float = 0.0,
                   fraction: float = OVERLAP_REPORT_FRACTION) -> int:
    """Pairs overlapping by more than ``fraction`` of the smaller radius.

    Shear-periodic like the sheet: periodic in y; across the radial boundary a particle's
    image at x +- Lx is shifted in y by -+ 1.5 Omega Lx t (the shear flow carries the
    neighbouring boxes along), so pairs straddling that boundary are counted correctly.

    Parameters
    ----------
    arrays : particle arrays (SI)
    geometry : SheetGeometry
    t : float [s]
        Time of the state (sets the shear offset of the radial images).
    fraction : float [dimensionless]
    """
    from scipy.spatial import cKDTree

    r = arrays["radius"]
    n = r.size
    if n < 2:
        return 0
    Lx, Ly = geometry.Lx, geometry.Ly
    reach = 2.0 * float(r.max())
    x, y, z = arrays["x"], arrays["y"], arrays["z"]
    shift = 1.5 * geometry.Omega * Lx * t
    # originals, then images of particles near the radial edges (index map back to them)
    near_high = np.flatnonzero(x > 0.5 * Lx - reach)
    near_low = np.flatnonzero(x < -0.5 * Lx + reach)
    index = np.concatenate([np.arange(n), near_high, near_low])
    px = np.concatenate([x, x[near_high] - Lx, x[near_low] + Lx])
    py = np.concatenate([y, y[near_high] + shift, y[near_low] - shift])
    pz = z[index]
    pos = np.column_stack([px - px.min(), np.mod(py + 0.5 * Ly, Ly), pz - pz.min()])
    tree = cKDTree(pos, boxsize=[1e300, Ly, 1e300])
    pairs = tree.query_pairs(reach, output_type="ndarray")
    if pairs.size == 0:
        return 0
    i, j = index[pairs[:, 0]], index[pairs[:, 1]]
    keep = i < j  # each physical pair once (an image pair duplicates an original pair)
    d = pos[pairs[keep, 0]] - pos[pairs[keep, 1]]
    d[:, 1] -= Ly * np.round(d[:, 1] / Ly)
    dist = np.sqrt(np.sum(d * d, axis=1))
    ri, rj = r[i[keep]], r[j[keep]]
    deep = ri + rj - dist > fraction * np.minimum(ri, rj)
    return int(np.unique(np.column_stack([i[keep][deep], j[keep][deep]]), axis=0).shape[0])


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
    configure_simulation(new, new_geometry, gravity=sim.gravity == "tree",
                         softening=sim.softening, opening_angle=math.sqrt(sim.opening_angle2),
                         detection="tree" if sim.collision == "tree" else "line",
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
