"""The self-gravity harness of the tests and benchmarks.

Random sheets (`random_sheet`, built with the run's own initial state) in a REBOUND
shearing sheet with the tree (`tree_simulation`) or P3M (`p3m_simulation`), their
accelerations at one instant (`accelerations`, through REBOUND's public C entry point
``reb_simulation_update_acceleration``; the ghost boxes carry the shear offset of
``sim.t``), and their errors (`force_errors`) against the converged shear-periodic image
sum (`reference_for` of a random sheet, `simulation_reference` of a built simulation's
particles; ``physics.selfgravity.direct_accelerations``).
"""

from __future__ import annotations

import ctypes

import numpy as np
import rebound

from ringsim.engine.box import box_geometry, configure_box
from ringsim.engine.sheet import initial_state, particle_arrays
from ringsim.gravity.p3m import P3MSolver, install_p3m, raise_pending
from ringsim.gravity.tree import DEFAULT_GHOST_BOXES, install_ghost_field
from ringsim.physics.constants import G_SI
from ringsim.physics.gravity_solvers import AUTO_SOFTENING_FRACTION, OPENING_ANGLE
from ringsim.physics.p3m_scales import P3M_SPLIT_RADII
from ringsim.physics.selfgravity import direct_accelerations, shear_offset

#: The harness's default softening, as a fraction of the smallest radius (as the scenario's
#: ``sheet.softening: auto``).
DEFAULT_SOFTENING_FRACTION = AUTO_SOFTENING_FRACTION
#: The harness's default opening angle [rad] of the tree (the scenario's default).
DEFAULT_OPENING_ANGLE = OPENING_ANGLE.default


def random_sheet(n, optical_depth=0.5, radius=1.0, density=900.0, Omega=2.0e-4,
                 dispersion=None, aspect=1.0, seed=1):
    """A random sheet of identical particles: uniform in (x, y), Gaussian in z, no overlaps.

    Built with the run's own :func:`ringsim.engine.sheet.initial_state` (scale height
    dispersion / Omega, at least two radii).

    Parameters
    ----------
    n : int
    optical_depth : float [dimensionless]
    radius : float [m]
    density : float [kg/m^3]
    Omega : float [1/s]
    dispersion : float [m/s], optional
        1-D velocity dispersion (default 2 radius Omega: a cool ring).
    aspect : float
        Ly / Lx.
    seed : int

    Returns
    -------
    dict with ``pos`` (N, 3) [m], ``vel`` (N, 3) [m/s], ``mass`` [kg], ``radius`` [m],
    ``Lx``, ``Ly`` [m], ``geometry`` (SheetGeometry).
    """
    rng = np.random.default_rng(seed)
    radii = np.full(n, float(radius))
    disp = 2.0 * radius * Omega if dispersion is None else dispersion
    h = max(disp / Omega, 2.0 * radius)
    geometry = box_geometry(radii, optical_depth, aspect, Omega, z_half_height=20.0 * h)
    state = initial_state(radii, geometry, disp, rng)
    pos = np.column_stack([state["x"], state["y"], state["z"]])
    vel = np.column_stack([state["vx"], state["vy"], state["vz"]])
    mass = 4.0 / 3.0 * np.pi * density * radii**3
    return {"pos": pos, "vel": vel, "mass": mass, "radius": radii, "Lx": geometry.Lx,
            "Ly": geometry.Ly, "geometry": geometry}


def _sheet_simulation(sheet, t: float, G: float) -> rebound.Simulation:
    """A REBOUND shearing sheet in ``sheet``'s box, without collisions, at time ``t`` [s]."""
    sim = rebound.Simulation()
    configure_box(sim, sheet["geometry"])
    sim.collision = "none"
    sim.G = G
    sim.t = t
    return sim


def _add_sheet(sim: rebound.Simulation, sheet) -> None:
    for p, v, m, r in zip(sheet["pos"], sheet["vel"], sheet["mass"], sheet["radius"],
                          strict=True):
        sim.add(m=m, r=r, x=p[0], y=p[1], z=p[2], vx=v[0], vy=v[1], vz=v[2])


def _softening(sheet, softening: float | None) -> float:
    """``softening`` [m], or DEFAULT_SOFTENING_FRACTION x the sheet's smallest radius."""
    return (DEFAULT_SOFTENING_FRACTION * float(np.min(sheet["radius"])) if softening is None
            else softening)


def tree_simulation(sheet, t=0.0, opening_angle=DEFAULT_OPENING_ANGLE, softening=None,
                    n_ghost=DEFAULT_GHOST_BOXES, G=G_SI, ghost_field=False):
    """A REBOUND shearing sheet holding ``sheet`` (from :func:`random_sheet`) with tree gravity.

    ``ghost_field``: install the C truncation field (``gravity.tree.install_ghost_field``),
    as runs do.

    Parameters
    ----------
    t : float [s]
        Simulation time, which sets the ghost boxes' shear offset.
    opening_angle : float [rad]
    softening : float [m], optional
        Default DEFAULT_SOFTENING_FRACTION x the smallest radius.
    n_ghost : int or (int, int)
        Ghost-box rings in x and y.
    """
    sim = _sheet_simulation(sheet, 0.0, G)
    sim.gravity = "tree"
    sim.softening = _softening(sheet, softening)
    sim.opening_angle2 = opening_angle**2
    nx, ny = (n_ghost, n_ghost) if np.isscalar(n_ghost) else n_ghost
    sim.N_ghost_x, sim.N_ghost_y = int(nx), int(ny)
    sim.t = t
    if ghost_field:
        install_ghost_field(sim)
    _add_sheet(sim, sheet)
    return sim


def p3m_simulation(sheet, t=0.0, split=None, softening=None, G=G_SI, **kwargs):
    """A REBOUND shearing sheet holding ``sheet`` (:func:`random_sheet`) with P3M gravity
    (``kwargs``: further arguments of ``gravity.p3m.P3MSolver``).

    Parameters
    ----------
    t : float [s]
    split : float [m], optional
        Default P3M_SPLIT_RADII x the mean radius.
    softening : float [m], optional
        Default DEFAULT_SOFTENING_FRACTION x the smallest radius.
    """
    sim = _sheet_simulation(sheet, 0.0, G)
    sim.N_ghost_x, sim.N_ghost_y, sim.N_ghost_z = 1, 1, 0
    rs = P3M_SPLIT_RADII * float(np.mean(sheet["radius"])) if split is None else split
    install_p3m(sim, P3MSolver(sheet["Lx"], sheet["Ly"], _softening(sheet, softening), rs,
                               G=G, **kwargs))
    sim.t = t
    _add_sheet(sim, sheet)
    return sim


def accelerations(sim) -> np.ndarray:
    """Accelerations [m/s^2] (N, 3) of the simulation's forces at its current state (an
    error of P3M's callback re-raised)."""
    rebound.clibrebound.reb_simulation_update_acceleration(ctypes.byref(sim))
    raise_pending(sim)
    acc = np.empty((sim.N, 3))
    for i, p in enumerate(sim.particles):
        acc[i] = (p.ax, p.ay, p.az)
    return acc


def tree_accelerations(sim) -> np.ndarray:
    """Accelerations [m/s^2] (N, 3) of REBOUND's gravity at the simulation's current state."""
    return accelerations(sim)


def force_errors(acc, reference):
    """Error measures of accelerations against a reference [dimensionless].

    Returns
    -------
    dict: ``rms_relative`` sqrt(mean(|da_i|^2 / |a_i|^2)) (per-particle relative error, rms),
    ``median_relative``, ``p90_relative``, and ``normalised`` sqrt(mean |da|^2 / mean |a|^2).
    """
    da = np.linalg.norm(np.asarray(acc) - reference, axis=1)
    a = np.linalg.norm(reference, axis=1)
    rel = da / a
    return {"rms_relative": float(np.sqrt(np.mean(rel**2))),
            "median_relative": float(np.median(rel)),
            "p90_relative": float(np.quantile(rel, 0.9)),
            "normalised": float(np.sqrt(np.mean(da**2) / np.mean(a**2)))}


def reference_for(sheet, t=0.0, softening=None, n_rows=4, G=G_SI):
    """Reference accelerations [m/s^2] of ``sheet`` at time ``t`` [s]: the converged
    shear-periodic image sum (``physics.selfgravity.direct_accelerations``)."""
    shift = shear_offset(sheet["geometry"].Omega, sheet["Lx"], sheet["Ly"], t)
    return direct_accelerations(sheet["pos"], sheet["mass"], sheet["Lx"], sheet["Ly"], shift,
                                _softening(sheet, softening), n_rows=n_rows, G=G)


def simulation_reference(sim, targets, n_rows=4):
    """Reference accelerations [m/s^2] of the particles ``targets`` (indices) of a built
    shearing sheet ``sim`` at its time: the converged shear-periodic image sum of all its
    particles with its softening and G (``physics.selfgravity.direct_accelerations``)."""
    arrays = particle_arrays(sim)
    pos = np.column_stack([arrays["x"], arrays["y"], arrays["z"]])
    Lx, Ly = sim.root_size * sim.N_root_x, sim.root_size * sim.N_root_y
    shift = shear_offset(sim.OMEGA, Lx, Ly, sim.t)
    return direct_accelerations(pos, arrays["mass"], Lx, Ly, shift, sim.softening,
                                n_rows=n_rows, targets=targets, chunk=16, G=sim.G)
