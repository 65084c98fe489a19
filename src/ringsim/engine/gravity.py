"""Self-gravity solvers measured against the reference sum: REBOUND's tree and the PM solver.

The reference is :func:`ringsim.physics.selfgravity.direct_accelerations` (converged shear-
periodic image sum).  :func:`tree_accelerations` asks REBOUND 5.2.2 for the accelerations of
its tree gravity (``sim.gravity = "tree"``, ``opening_angle2``, ``softening``,
``N_ghost_x/y``) at one instant through its public C entry point
``reb_simulation_update_acceleration``; the ghost boxes carry the shear offset of ``sim.t``.
:func:`force_errors` compares any solver with the reference.

Findings (docs/gravity.md, measured by benchmarks/gravity.py): REBOUND's ghost-box sum has no
uniform-background term, so the sheet beyond the ghost boxes is simply missing; its pull
falls only as 1 / N_ghost (rms error 23 % of the field at N_ghost = 1, 13 % at 2, 4 % at 8 on
a tau = 0.5 sheet).  :func:`ghost_truncation_field` supplies the missing field analytically;
with it the tree's error is its own multipole error, set by the opening angle.

Wiring into runs: :func:`install_gravity` sets up the scenario's solver, ``tree`` (below) or
``p3m`` (``engine.p3m``, the default of ``sheet.gravity_solver``, chosen by
benchmarks/gravity.py); :func:`solver_attributes` names it and its parameters in the run
file.  For the tree, :func:`install_ghost_field` puts the C twin of
:func:`ghost_truncation_field` (``rs_ghost_field`` in ``ringsim/csrc/rs_gravity.c``) into
REBOUND's ``additional_forces`` (``engine.sheet.configure_simulation`` does it for every
gravitating sheet, the run loop again after loading a checkpoint, since REBOUND does not save
function pointers); :func:`sheet_gravity` gives the numbers ``ringsim run`` prints and stores.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import rebound

from ringsim.config.scenario import DEFAULTS
from ringsim.physics import gravity as patch
from ringsim.physics.constants import G_SI
from ringsim.physics.selfgravity import direct_accelerations, shear_offset

#: Default opening angle [rad] of REBOUND's tree for ``gravity: true``: the largest that keeps
#: the rms relative force error below 1 % with :func:`ghost_truncation_field` (docs/gravity.md).
#: Declared once, as the scenario's default ``sheet.opening_angle``.
DEFAULT_OPENING_ANGLE = DEFAULTS["sheet.opening_angle"]
#: Default ghost-box rings in x and y with the truncation field added (deeper rings change
#: the error by < 0.1 %: it is the opening angle that sets it).
DEFAULT_GHOST_BOXES = 1
#: Default softening as a fraction of the smallest particle radius.
DEFAULT_SOFTENING_FRACTION = 0.1


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
    from ringsim.engine.sheet import box_geometry, initial_state

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


def tree_simulation(sheet, t=0.0, opening_angle=DEFAULT_OPENING_ANGLE, softening=None,
                    n_ghost=DEFAULT_GHOST_BOXES, G=G_SI, ghost_field=False):
    """A REBOUND shearing sheet holding ``sheet`` (from :func:`random_sheet`) with tree gravity.

    ``ghost_field``: install the C truncation field (:func:`install_ghost_field`), as runs do.

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
    from ringsim.engine.sheet import configure_box

    sim = rebound.Simulation()
    configure_box(sim, sheet["geometry"])
    sim.collision = "none"
    sim.G = G
    sim.gravity = "tree"
    sim.softening = (DEFAULT_SOFTENING_FRACTION * float(np.min(sheet["radius"]))
                     if softening is None else softening)
    sim.opening_angle2 = opening_angle**2
    nx, ny = (n_ghost, n_ghost) if np.isscalar(n_ghost) else n_ghost
    sim.N_ghost_x, sim.N_ghost_y = int(nx), int(ny)
    sim.t = t
    if ghost_field:
        install_ghost_field(sim)
    for p, v, m, r in zip(sheet["pos"], sheet["vel"], sheet["mass"], sheet["radius"],
                          strict=True):
        sim.add(m=m, r=r, x=p[0], y=p[1], z=p[2], vx=v[0], vy=v[1], vz=v[2])
    return sim


def tree_accelerations(sim):
    """Accelerations [m/s^2] (N, 3) of REBOUND's gravity at the simulation's current state."""
    rebound.clibrebound.reb_simulation_update_acceleration(ctypes.byref(sim))
    n = sim.N
    acc = np.empty((n, 3))
    for i, p in enumerate(sim.particles):
        acc[i] = (p.ax, p.ay, p.az)
    return acc


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
    """Reference accelerations [m/s^2] of ``sheet`` at time ``t`` [s] (direct image sum)."""
    b = (DEFAULT_SOFTENING_FRACTION * float(np.min(sheet["radius"]))
         if softening is None else softening)
    shift = shear_offset(sheet["geometry"].Omega, sheet["Lx"], sheet["Ly"], t)
    return direct_accelerations(sheet["pos"], sheet["mass"], sheet["Lx"], sheet["Ly"], shift,
                                b, n_rows=n_rows, G=G)


def rebound_row_offsets(Omega: float, Lx: float, Ly: float, t: float, n_ghost_x: int):
    """Azimuthal offsets [m] of REBOUND's ghost-box rows i = -n..n at time t [s].

    Row i's ghost boxes sit at (i Lx, j Ly + offset_i) for j = -n_ghost_y..n_ghost_y, with
    offset_i congruent to -1.5 Omega i Lx t modulo Ly and in REBOUND 5.2.2's range
    (``reb_boundary_get_ghostbox``: (-Ly, 0] for i > 0, [0, Ly) for i < 0, (-Ly, Ly) for 0).
    """
    offsets = []
    for i in range(-n_ghost_x, n_ghost_x + 1):
        shiftvy = -1.5 * i * Omega * Lx
        if i == 0:
            shift = -math.fmod(shiftvy * t, Ly)
        elif i > 0:
            shift = -math.fmod(shiftvy * t - 0.5 * Ly, Ly) - 0.5 * Ly
        else:
            shift = -math.fmod(shiftvy * t + 0.5 * Ly, Ly) + 0.5 * Ly
        offsets.append(-shift)
    return np.array(offsets)


def ghost_truncation_field(pos, mass, Lx, Ly, Omega, t, n_ghost_x, n_ghost_y, G=G_SI):
    """The field [m/s^2] that REBOUND's finite ghost-box sum leaves out, for each particle.

    REBOUND sums the box and its (2 n_x + 1)(2 n_y + 1) ghost copies; everything beyond is
    missing.  Beyond the ghost boxes the sheet is modelled as uniform, of surface density
    M / (Lx Ly), in the plane of the centre of mass z_cm and with the ghost boxes' union
    shifted by the centre of mass (x_cm, y_cm) (the box's mass dipole): the missing field is
    that of an infinite uniform sheet (vertical only, -2 pi G Sigma sign(z - z_cm)) minus
    that of the ghost boxes' union, each row a uniform rectangle.  Exact to first order in
    (z - z_cm) / (distance to the missing images) and up to the quadrupole of the point
    images, which falls as n^-2 beyond the ghost boxes.  Adding it to REBOUND's tree
    accelerations (an additional force, cost O(N n_x)) removes the truncation error that
    otherwise falls only as 1 / n (docs/gravity.md).

    Parameters
    ----------
    pos : array (N, 3) [m]
    mass : array (N,) [kg]
    Lx, Ly : float [m]
    Omega : float [1/s]
    t : float [s]
        Time of the positions (sets REBOUND's row offsets).
    n_ghost_x, n_ghost_y : int
    """
    from ringsim.physics.selfgravity import _rectangle_field

    pos = np.asarray(pos, dtype=float)
    mass = np.asarray(mass, dtype=float)
    x_cm, y_cm, z_cm = (np.sum(mass[:, None] * pos, axis=0) / np.sum(mass)).tolist()
    G_sigma = G * float(np.sum(mass)) / (Lx * Ly)
    Z = pos[:, 2] - z_cm
    out = np.zeros_like(pos)
    out[:, 2] = -2.0 * np.pi * G_sigma * np.sign(Z)
    offsets = rebound_row_offsets(Omega, Lx, Ly, t, n_ghost_x)
    for i, off in zip(range(-n_ghost_x, n_ghost_x + 1), offsets, strict=True):
        u1 = x_cm + (i - 0.5) * Lx - pos[:, 0]
        u2 = x_cm + (i + 0.5) * Lx - pos[:, 0]
        v1 = y_cm + off - (n_ghost_y + 0.5) * Ly - pos[:, 1]
        v2 = y_cm + off + (n_ghost_y + 0.5) * Ly - pos[:, 1]
        gx, gy, gz = _rectangle_field(u1, u2, v1, v2, Z, G_sigma)
        out[:, 0] -= gx
        out[:, 1] -= gy
        out[:, 2] -= gz
    return out


# --- wiring into runs ---------------------------------------------------------------------------

def _c_field_pointer(name: str):
    """A ctypes function pointer to the C field ``name`` of ``rs_gravity.c`` (REBOUND's
    additional_forces type)."""
    from ringsim.engine.native import _LIB, _POST_TIMESTEP

    if not hasattr(_LIB, name):
        raise ImportError("ringsim._resolver was built without rs_gravity.c; rebuild the "
                          "extension (`python setup.py build_ext --inplace`)")
    return _POST_TIMESTEP(ctypes.cast(getattr(_LIB, name), ctypes.c_void_p).value)


def _has_c_field(sim: rebound.Simulation, name: str) -> bool:
    current = ctypes.cast(sim._additional_forces, ctypes.c_void_p).value
    return current is not None and current == ctypes.cast(_c_field_pointer(name),
                                                           ctypes.c_void_p).value


def has_ghost_field(sim: rebound.Simulation) -> bool:
    """True if ``sim.additional_forces`` is ringsim's ghost-box truncation field."""
    return _has_c_field(sim, "rs_ghost_field")


def installed_solver_name(sim: rebound.Simulation) -> str | None:
    """The self-gravity solver installed in ``sim``: "tree", "p3m", "slab", or None."""
    from ringsim.engine import p3m

    if sim.gravity == "tree":
        return "tree"
    if p3m.installed_solver(sim) is not None:
        return "p3m"
    return "slab" if _has_c_field(sim, "rs_slab_field") else None


def install_ghost_field(sim: rebound.Simulation) -> None:
    """Add the field of the sheet beyond the ghost boxes to ``sim``'s tree gravity.

    Sets REBOUND's ``additional_forces`` to ``rs_ghost_field`` (``ringsim/csrc/rs_gravity.c``,
    the C twin of :func:`ghost_truncation_field`): REBOUND calls it right after its tree
    gravity, at the same time ``sim.t`` (which sets the ghost rows' shear offsets), so the
    two together are the field of the infinite shear-periodic sheet to 0.5-0.7 % rms at
    opening angle 0.3 (docs/gravity.md).  It reads everything from the simulation (G,
    Omega, box, N_ghost_x/y, boundary), so it stays right after the box is enlarged.  REBOUND
    does not save function pointers: call it again after loading a simulation from a file.

    Raises ValueError if ``additional_forces`` already holds another function.
    """
    if sim._additional_forces and not has_ghost_field(sim):
        raise ValueError("sim.additional_forces is already set; the ghost-box truncation "
                         "field needs it")
    fp = _c_field_pointer("rs_ghost_field")
    sim._additional_forces = fp
    sim._afp = fp    # REBOUND's slot that keeps the ctypes object alive with the simulation


def install_gravity(sim: rebound.Simulation, solver: str, *, softening: float,
                    opening_angle: float | None = None,
                    p3m_setting: tuple[float, bool] | None = None) -> None:
    """Switch self-gravity on in a configured shearing sheet (before or after adding
    particles; again after loading one from a file).

    Parameters
    ----------
    solver : "tree", "p3m" or "slab"
        "tree": REBOUND's tree at ``opening_angle`` [rad], DEFAULT_GHOST_BOXES rings of ghost
        boxes and the field of the sheet beyond them (:func:`install_ghost_field`).
        "p3m": ``engine.p3m`` with ``p3m_setting`` = (split scale [m], auto: the split
        follows the height span from there up) and the other parameters at their
        defaults (``physics.selfgravity.P3M_*``).
        "slab": the vertical field of the horizontally averaged layer only
        (``rs_slab_field``, ``physics.selfgravity.slab_field``).
    softening : float [m]
        Plummer softening (tree and p3m; the slab has no close pairs to soften).
    """
    from ringsim.engine import p3m

    sim.G = G_SI
    sim.softening = softening
    if solver == "tree":
        sim.gravity = "tree"
        sim.opening_angle2 = opening_angle**2
        # one ring of ghost boxes plus the analytic field of the sheet beyond them
        # (rs_gravity.c): deeper rings change the force error by < 0.1 % (docs/gravity.md)
        sim.N_ghost_x, sim.N_ghost_y = DEFAULT_GHOST_BOXES, DEFAULT_GHOST_BOXES
        install_ghost_field(sim)
    elif solver == "p3m":
        Lx = sim.root_size * sim.N_root_x
        Ly = sim.root_size * sim.N_root_y
        split, auto = p3m_setting
        p3m.install_p3m(sim, p3m.P3MSolver(Lx, Ly, softening, split, G=G_SI, auto=auto))
    elif solver == "slab":
        sim.gravity = "none"
        fp = _c_field_pointer("rs_slab_field")
        sim._additional_forces = fp
        sim._afp = fp    # REBOUND's slot that keeps the ctypes object alive
    else:
        raise ValueError(f"unknown gravity solver {solver!r}")


def scenario_gravity_arguments(scenario) -> dict:
    """The arguments of :func:`install_gravity` for a gravitating scenario: solver,
    softening [m], opening_angle [rad] and p3m_setting (None where the scenario has none)."""
    sheet = scenario.sheet
    return {"solver": sheet.gravity_solver or "tree", "softening": scenario.softening_length,
            "opening_angle": sheet.opening_angle, "p3m_setting": scenario.p3m_setting}


def install_scenario_gravity(sim: rebound.Simulation, scenario) -> None:
    """:func:`install_gravity` with a scenario's solver and parameters (function pointers
    are not saved by REBOUND: the run loop calls this after loading a checkpoint, and the
    code `ringsim export --rebound` prints does the same)."""
    install_gravity(sim, **scenario_gravity_arguments(scenario))


def solver_attributes(scenario, geometry) -> dict:
    """Root attributes of a run file naming the scenario's gravity solver and its parameters,
    each with ``units_<name>`` beside it."""
    from ringsim.engine import p3m

    sheet = scenario.sheet
    if sheet.gravity_solver == "p3m":
        return p3m.describe(geometry.Lx, geometry.Ly, scenario.softening_length,
                            *scenario.p3m_setting)
    if sheet.gravity_solver == "slab":
        return {"gravity_solver": "slab"}
    return {"gravity_solver": "tree",
            "tree_opening_angle": float(sheet.opening_angle), "units_tree_opening_angle": "rad",
            "tree_ghost_boxes": DEFAULT_GHOST_BOXES,
            "units_tree_ghost_boxes": "rings (x and y), plus the field beyond them",
            "softening": float(scenario.softening_length), "units_softening": "m"}


def sheet_gravity(radii, masses, density: float, Lx: float, Ly: float, Omega: float,
                  GM: float | None = None, a: float | None = None) -> dict:
    """The dimensionless numbers of a self-gravitating sheet that ``ringsim run`` prints
    and stores (``physics.gravity``).

    Parameters
    ----------
    radii : array [m]
    masses : array [kg]
    density : float [kg/m^3]
    Lx, Ly : float [m]
    Omega : float [1/s]
    GM : float [m^3/s^2] or None
    a : float [m] or None
        The planet: r_h needs M_p = GM / G and a; with ``planet: {Omega}`` only it is
        unknown (None).

    Returns
    -------
    dict: ``r_h`` (mean pair, ``physics.gravity.mean_pair_hill_parameter``; None if
    unknown), ``Sigma`` [kg/m^2], ``lambda_cr`` [m], ``box`` (``wake_box_spans``),
    ``attributes`` (root attributes of the run file, each ``units_<name>`` beside it) and
    ``message`` (one line for stderr).
    """
    Sigma = patch.surface_density(float(np.sum(masses)), Lx, Ly)
    lambda_cr = float(patch.toomre_wavelength(Sigma, Omega))
    r_h = (None if GM is None or a is None
           else patch.mean_pair_hill_parameter(radii, density, GM, a))
    box = patch.wake_box_spans(Lx, Ly, lambda_cr)
    attributes = {"Sigma": Sigma, "units_Sigma": "kg/m^2",
                  "lambda_cr": lambda_cr, "units_lambda_cr": "m",
                  "box_lambda_cr": box["smallest"],
                  "units_box_lambda_cr": "lambda_cr (smaller of Lx, Ly)",
                  "r_h": math.nan if r_h is None else r_h,
                  "units_r_h": "dimensionless (mean pair; NaN: planet GM and a not given)"}
    rh_text = ("r_h unknown (planet given by Omega only; give GM and a)" if r_h is None
               else f"r_h = {r_h:.3g} (mean pair)")
    level = {"warn": "WARNING: ", "advise": "advice: ", "ok": ""}[box["level"]]
    message = (f"self-gravity: {rh_text}, Sigma = {Sigma:.4g} kg/m^2, lambda_cr = "
               f"{lambda_cr:.4g} m; {level}{box['message']}")
    return {"r_h": r_h, "Sigma": Sigma, "lambda_cr": lambda_cr, "box": box,
            "attributes": attributes, "message": message}


def scenario_gravity(scenario, radii, masses, geometry) -> dict:
    """:func:`sheet_gravity` of a scenario's sheet (its planet, density and box).

    Parameters
    ----------
    scenario : Scenario
    radii : array [m]
    masses : array [kg]
    geometry : SheetGeometry
    """
    planet = scenario.planet
    out = sheet_gravity(radii, masses, scenario.particles.density, geometry.Lx, geometry.Ly,
                        scenario.orbital_frequency, planet.GM, planet.a)
    out["attributes"].update(solver_attributes(scenario, geometry))
    out["message"] += f"; solver {scenario.sheet.gravity_solver or 'tree'}"
    return out
