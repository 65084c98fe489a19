"""Set-up from a file (``sheet.initial_state``): the particles of a run-file snapshot or of
a CSV, checked, with their box and the time at which the sheet starts.

A run file gives radii, masses, positions, velocities (SI, vy including the shear flow
-1.5 Omega x), the box (``root_size``, ``N_root_x``, ``N_root_y``) and, from a run with
friction, the spins ``wx wy wz`` [rad/s] (relative to the rotating frame, in its axes at
the snapshot's time).  Hill's equations and the spins' precession in the frame (x, y
turning at -Omega) do not depend on the time itself, so the state, spins included, is
given to the sheet as it is at the start time below.
The shearing sheet depends on time only through the y offset of the images across the
radial boundary, a = 1.5 Omega Lx t mod Ly, which repeats every Ly / (1.5 Omega Lx): the
sheet starts at the snapshot's time reduced modulo that period, so that pairs across the
radial boundary are exactly where they were (starting at t = 0 would shift them by a).  With
``tile: [n_x, n_y]`` the snapshot's sheet is repeated into a box n_x Lx by n_y Ly
(`tile_sheet`): each copy is one of the sheet's own images at that time, so the larger
sheet is, at its start, the same infinite shear-periodic ring.

A CSV (comment lines start with ``#``) has the header ``x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,
radius_m,mass_kg``, optionally with the spin columns ``wx_rad_s,wy_rad_s,wz_rad_s``; its box
has Ly / Lx = ``sheet.aspect`` (as a ratio of small integers) and holds the particles at
``sheet.optical_depth``, and it starts at ``sheet.initial_state.t`` (default 0: no offset),
reduced modulo the shear period.

Every problem is an `InputError` naming the scenario file and ``sheet.initial_state.file``
(or ``.snapshot``): missing file, not a run file, snapshot out of range, another Omega,
missing or unknown columns, non-finite values, radii or masses <= 0, particles outside the
box, pairs overlapping by more than 10 % of the smaller radius, or a snapshot of a tiled
start whose copies are not independent yet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringsim.config.intervals import MAX_STEPS
from ringsim.engine.box import (
    OVERLAP_REPORT_FRACTION,
    SheetGeometry,
    box_geometry,
    count_overlaps,
)
from ringsim.engine.timestep import auto_dt
from ringsim.errors import InputError, excerpt
from ringsim.physics.constants import SHEAR, SPEED_OF_LIGHT
from ringsim.physics.selfgravity import shear_offset
from ringsim.store.bulk import SPIN_FIELDS
from ringsim.store.run_checks import check_box
from ringsim.store.runfile import open_run

#: CSV columns of a particle file, in the order `ringsim export --csv` writes them, and the
#: particle field of each.
CSV_COLUMNS = ("x_m", "y_m", "z_m", "vx_m_s", "vy_m_s", "vz_m_s", "radius_m", "mass_kg")
CSV_FIELDS = ("x", "y", "z", "vx", "vy", "vz", "radius", "mass")
#: Optional spin columns of a CSV, all three or none (`SPIN_FIELDS`: relative to the
#: rotating frame, in its axes), written by `ringsim export --csv` for a run with friction.
CSV_SPIN_COLUMNS = ("wx_rad_s", "wy_rad_s", "wz_rad_s")
_KEY = "sheet.initial_state.file"


@dataclass(frozen=True)
class FileState:
    """Particles read from a file.

    Attributes
    ----------
    arrays : dict of arrays
        x, y, z [m], vx, vy, vz [m/s], radius [m], mass [kg].
    root_size : float [m] or None
        The run file's root box (None for a CSV: sized from the scenario).
    n_root_x, n_root_y : int
    t : float [s]
        Time at which the sheet starts (the snapshot's time modulo the shear period).
    """

    arrays: dict
    root_size: float | None
    n_root_x: int
    n_root_y: int
    t: float


def resolve_path(scenario) -> Path:
    """The file of ``sheet.initial_state``: relative paths from the scenario file's folder,
    or from the run file's folder for a scenario a run file holds (its source is that run
    file; a study's started run names its start file beside it), else from the working
    directory (a scenario not read from a file)."""
    path = Path(scenario.sheet.initial_state.file)
    source = Path(scenario.source)
    suffix = source.suffix.lower()
    if not path.is_absolute() and ((suffix in (".yaml", ".yml") and source.is_file())
                                   or suffix in (".h5", ".hdf5")):
        path = source.parent / path
    return path


def shear_period(Lx: float, Ly: float, Omega: float) -> float:
    """Period [s] of the radial images' y offset 1.5 Omega Lx t mod Ly."""
    return Ly / (SHEAR * Omega * Lx)


def tile_sheet(arrays: dict, Lx: float, Ly: float, Omega: float, t: float, n_x: int,
               n_y: int) -> dict:
    """A shear-periodic sheet repeated ``n_x`` times radially and ``n_y`` times azimuthally.

    The copy i (radially, 0 ... n_x - 1) and j is the sheet moved by d = (i - (n_x - 1)/2) Lx
    radially (a half-integer multiple of Lx for even n_x), as Hill's equations move it:
    x + d, y + (j - (n_y - 1)/2) Ly - 1.5 Omega d t, vy - 1.5 Omega d, then wrapped into
    the box n_x Lx by n_y Ly centred on 0.  Neighbouring copies are the sheet's own radial
    images (offset s = 1.5 Omega Lx t, `shear_offset`), and the images of the large box
    across its radial boundary, 1.5 Omega n_x Lx t, are n_x s modulo Ly as the repeated
    sheet's: the same ring, shear-periodic in the large box at time t, so a larger box
    starts from an equilibrium of a smaller one.  (Each copy's y shift follows its x shift
    in time, so tiling a later state of the small sheet gives the later state of the large
    one.)

    Parameters
    ----------
    arrays : dict of arrays
        x, y, z [m], vx, vy (including the shear flow), vz [m/s], radius [m], mass [kg];
        x in [-Lx/2, Lx/2], y in [-Ly/2, Ly/2].
    Lx, Ly : float [m]
        The sheet's box.
    Omega : float [1/s]
    t : float [s]
        Time of the state.
    n_x, n_y : int
        Copies radially and azimuthally.
    """
    i_grid, j_grid = np.meshgrid(np.arange(n_x), np.arange(n_y), indexing="ij")
    i, j = i_grid.ravel(), j_grid.ravel()
    dx = (i - 0.5 * (n_x - 1)) * Lx
    dy = (j - 0.5 * (n_y - 1)) * Ly - np.array([shear_offset(Omega, d, Ly, t) for d in dx])
    half_y = 0.5 * n_y * Ly
    out = {f: np.tile(np.asarray(v, dtype=float), i.size) for f, v in arrays.items()}
    n = np.asarray(arrays["x"]).size
    out["x"] = out["x"] + np.repeat(dx, n)
    y = np.mod(out["y"] + np.repeat(dy, n) + half_y, 2.0 * half_y) - half_y
    out["y"] = np.where(y >= half_y, y - 2.0 * half_y, y)     # np.mod can round up to 2 half
    out["vy"] = out["vy"] - SHEAR * Omega * np.repeat(dx, n)
    return out


def _error(scenario, problem: str, key: str = _KEY) -> InputError:
    return InputError(scenario.source, key, problem)


def _number(scenario, path: Path, attrs: dict, name: str) -> float:
    """The run file's root attribute ``name`` as a float; InputError if it is no number."""
    value = attrs.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _error(scenario, f"{path}: the attribute {name} is {excerpt(value)}, not a "
                     "number")
    return float(value)


def _read_run(scenario, path: Path) -> FileState:
    try:
        run = open_run(path)
    except (OSError, KeyError) as exc:
        raise _error(scenario, f"{path} is not a ringsim run file ({exc})") from None
    check_box(run.attrs, path)
    index = scenario.sheet.initial_state.snapshot
    if not -run.n_snapshots <= index < run.n_snapshots:
        raise _error(scenario, f"{path} has {run.n_snapshots} snapshots, no index {index} "
                     f"(-{run.n_snapshots} ... {run.n_snapshots - 1})",
                     "sheet.initial_state.snapshot")
    Omega = _number(scenario, path, run.attrs, "Omega")
    if not math.isclose(Omega, scenario.orbital_frequency, rel_tol=1e-12):
        raise _error(scenario, f"{path} was run at Omega = {Omega:.10g} 1/s, the scenario's "
                     f"planet gives {scenario.orbital_frequency:.10g} 1/s (the velocities "
                     "include the shear flow of the run's Omega)")
    snap = run.snapshot(index)
    root = _number(scenario, path, run.attrs, "root_size")
    nx, ny = (int(_number(scenario, path, run.attrs, n)) for n in ("N_root_x", "N_root_y"))
    t = float(snap["t"]) % shear_period(root * nx, root * ny, Omega)
    arrays = {f: np.asarray(snap[f], dtype=float) for f in CSV_FIELDS
              + (SPIN_FIELDS if all(w in snap for w in SPIN_FIELDS) else ())}
    tx, ty = scenario.sheet.initial_state.tile
    if (tx, ty) != (1, 1):
        # the large box starts at this t too (not reduced by its own shear period, which
        # would shift its copies' frames against each other when tx != ty)
        arrays = tile_sheet(arrays, root * nx, root * ny, Omega, t, tx, ty)
        nx, ny = tx * nx, ty * ny
    return FileState(arrays, root, nx, ny, t)


def refuse_copies_alike(scenario) -> None:
    """InputError if ``sheet.initial_state`` is a snapshot of a run from a tiled start whose
    copies are not independent yet at that snapshot: a run started from it, tiled again or
    not, would hold copies alike that nothing in its own file marks (``analysis.tiling``;
    its snapshots are read up to the chosen one).  For runs (`sheet.build_sheet`); an
    export of such a snapshot is the snapshot itself, so `new_simulation` does not ask (a
    CSV exported from it carries no record of its origin and is not checked)."""
    from ringsim.analysis.tiling import independent_from_orbit

    state = scenario.sheet.initial_state
    if state is None or state.kind != "run":
        return
    path = resolve_path(scenario)
    run = open_run(path)              # read_initial_state has checked it (and the index)
    index = state.snapshot % run.n_snapshots
    independent = independent_from_orbit(run, last=index)
    if independent is None or math.isfinite(independent):
        return
    origin = run.scenario.sheet.initial_state   # a tiled start (independent_from_orbit)
    if origin is None:
        return
    orbit = float(run.snapshot(index)["t"]) / run.scenario.orbital_period
    tile = origin.tile
    raise _error(scenario, f"snapshot {state.snapshot} of {path} (orbit {orbit:.4g}) is from "
                 f"a start tiled {tile[0]} x {tile[1]} whose copies are not independent yet "
                 "there (docs/scenario.md, tile): start from a later snapshot, or tile the "
                 "snapshot that run was tiled from", "sheet.initial_state.snapshot")


def _read_csv(scenario, path: Path) -> FileState:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise _error(scenario, f"{path}: not UTF-8 text ({exc.reason} at byte "
                     f"{exc.start})") from None
    lines = [line for line in text.splitlines()
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise _error(scenario, f"{path} has no header line ({', '.join(CSV_COLUMNS)})")
    header = [name.strip() for name in lines[0].split(",")]
    spin = any(c in header for c in CSV_SPIN_COLUMNS)
    wanted = CSV_COLUMNS + (CSV_SPIN_COLUMNS if spin else ())
    missing = [c for c in wanted if c not in header]
    unknown = [c for c in header if c not in wanted]
    if missing or unknown or len(header) != len(wanted):
        what = (f"unknown column {excerpt(unknown[0])}" if unknown else
                f"missing column {missing[0]!r}" if missing else "a column appears twice")
        raise _error(scenario, f"{path}: {what} (the header is {','.join(CSV_COLUMNS)}, "
                     f"optionally followed by all of {','.join(CSV_SPIN_COLUMNS)}; units in "
                     "the names: m, m/s, kg, rad/s)")
    try:
        table = np.array([[float(cell) for cell in line.split(",")] for line in lines[1:]],
                         dtype=float).reshape(-1, len(header))
    except ValueError as exc:
        raise _error(scenario, f"{path}: not a table of numbers "
                     f"({excerpt(str(exc), 100)})") from None
    arrays = {field: table[:, header.index(column)]
              for field, column in zip(CSV_FIELDS + SPIN_FIELDS, wanted, strict=False)}
    return FileState(arrays, None, 0, 0, scenario.sheet.initial_state.t)


def _check_speeds(scenario, path: Path, a: dict, Omega: float) -> None:
    """Refuse speeds relative to the shear flow at or above the speed of light, and, with
    ``dt: auto`` and tree detection, speeds whose time step would make the run longer than
    `config.intervals.MAX_STEPS` steps (dt << r/v: ``engine.timestep.auto_dt``)."""
    w = np.sqrt(a["vx"] ** 2 + (a["vy"] + SHEAR * Omega * a["x"]) ** 2 + a["vz"] ** 2)
    fastest = float(np.max(w))
    if not fastest < SPEED_OF_LIGHT:
        raise _error(scenario, f"{path}: a particle moves at {fastest:.3g} m/s relative to "
                     f"the shear flow, not below the speed of light ({SPEED_OF_LIGHT:g} m/s)")
    integration = scenario.integration
    if integration.dt != "auto" or integration.collision_detection != "tree":
        return
    dt = auto_dt(a, Omega, integration.dt_safety)
    steps = integration.orbits * scenario.orbital_period / dt
    if steps > MAX_STEPS:
        raise _error(scenario, f"{path}: a particle moves at {fastest:.3g} m/s relative to "
                     f"the shear flow: dt: auto would take {steps:.3g} steps, more than "
                     f"{MAX_STEPS:.0e}")


def read_initial_state(scenario):
    """(radii [m], masses [kg], state dict, geometry, t [s], spins) of
    ``sheet.initial_state``.

    ``spins``: (N, 3) [rad/s] relative to the rotating frame, in its axes, from a run file
    written with friction or a CSV with spin columns; else None.  The geometry's
    vertical extent is a placeholder (one root box): the caller sizes it.
    """
    path = resolve_path(scenario)
    if not path.is_file():
        raise _error(scenario, f"no such file: {path}")
    kind = scenario.sheet.initial_state.kind
    loaded = _read_run(scenario, path) if kind == "run" else _read_csv(scenario, path)
    a = loaded.arrays
    n = a["radius"].size
    if n < 2:
        raise _error(scenario, f"{path} has {n} particle(s); a sheet needs at least 2")
    for field in (f for f in CSV_FIELDS + SPIN_FIELDS if f in a):
        if not np.all(np.isfinite(a[field])):
            raise _error(scenario, f"{path}: {field} has values that are not finite")
    for field in ("radius", "mass"):
        if not np.all(a[field] > 0):
            raise _error(scenario, f"{path}: every {field} must be > 0")
    Omega = scenario.orbital_frequency
    _check_speeds(scenario, path, a, Omega)
    if loaded.root_size is not None:
        geometry = SheetGeometry(loaded.root_size, loaded.n_root_x, loaded.n_root_y, 1, Omega)
    else:
        geometry = box_geometry(a["radius"], scenario.sheet.optical_depth,
                                scenario.sheet.aspect, Omega, 0.0)
        loaded = FileState(a, None, 0, 0, loaded.t % shear_period(geometry.Lx, geometry.Ly,
                                                                   Omega))
    slack = 1e-9 * max(geometry.Lx, geometry.Ly)
    for field, half in (("x", 0.5 * geometry.Lx), ("y", 0.5 * geometry.Ly)):
        if np.any(np.abs(a[field]) > half + slack):
            raise _error(scenario, f"{path}: particles outside the box, |{field}| > {half:.6g} m"
                         f" (box {geometry.Lx:.6g} m x {geometry.Ly:.6g} m"
                         + (" from sheet.optical_depth and sheet.aspect)" if kind == "csv"
                            else ")"))
    overlapping = count_overlaps(a, geometry, loaded.t, OVERLAP_REPORT_FRACTION)
    if overlapping:
        raise _error(scenario, f"{path}: {overlapping} pairs overlap by more than "
                     f"{OVERLAP_REPORT_FRACTION:.0%} of the smaller radius")
    state = {f: a[f].copy() for f in ("x", "y", "z", "vx", "vy", "vz")}
    spins = np.column_stack([a[w] for w in SPIN_FIELDS]) if SPIN_FIELDS[0] in a else None
    return a["radius"].copy(), a["mass"].copy(), state, geometry, loaded.t, spins
