"""The scenario key ``sheet.initial_state``: start a run from the particles of a file.

``sheet.initial_state: {file: other_run.h5, snapshot: -1}`` takes radii, masses, positions,
velocities and the box of a snapshot of a run file (with ``tile: [n_x, n_y]``: that sheet
repeated n_x times radially and n_y times azimuthally, a box n_x Lx by n_y Ly);
``{file: particles.csv}`` takes the particles of a CSV (columns ``x_m, y_m, z_m, vx_m_s,
vy_m_s, vz_m_s, radius_m, mass_kg``) in the box that ``sheet.optical_depth`` and
``sheet.aspect`` give them.  The keys the file replaces may not be given with it.  This
module checks the key; the file itself is read and checked when the sheet is built
(`ringsim.engine.initial_file`).  See docs/scenario.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Any

from ringsim.config.schema import Section, show

#: Suffixes of the files ``sheet.initial_state.file`` may name.
INITIAL_STATE_SUFFIXES = {".h5": "run", ".hdf5": "run", ".csv": "csv"}
#: Keys of ``sheet`` that the file replaces (radii, positions and velocities come from it;
#: a run file also gives the box), by kind of file.
_REPLACED_BY_FILE = {"run": ("optical_depth", "n_particles", "aspect", "initial_dispersion",
                             "initial_toomre_q"),
                     "csv": ("n_particles", "initial_dispersion", "initial_toomre_q")}


@dataclass(frozen=True)
class InitialStateFile:
    """Initial particles from a file (``sheet.initial_state``).

    Attributes
    ----------
    file : str
        A run file (``.h5``) or a particle CSV (``.csv``), as written in the scenario:
        relative paths are relative to the scenario file's folder.
    snapshot : int
        Snapshot of a run file (negative counts from the end); -1 for a CSV.
    t : float [s]
        For a CSV: the time of the state, which sets the y offset of the images across the
        radial boundary (1.5 Omega Lx t mod Ly); a run file gives its snapshot's time.
    tile : (int, int)
        For a run file: copies of its sheet radially and azimuthally (``(1, 1)``: the sheet
        as it is), placed as the sheet's own shear-periodic images.
    """

    file: str
    snapshot: int = -1
    t: float = 0.0
    tile: tuple[int, int] = (1, 1)

    @property
    def kind(self) -> str:
        """"run" or "csv"."""
        return INITIAL_STATE_SUFFIXES[PurePath(self.file).suffix.lower()]

    def to_dict(self) -> dict[str, Any]:
        if self.kind == "csv":
            return {"file": self.file, "t": self.t}
        d: dict[str, Any] = {"file": self.file, "snapshot": self.snapshot}
        if self.tile != (1, 1):
            d["tile"] = list(self.tile)
        return d


def sheet_dict_with_file(sheet, d: dict[str, Any]) -> dict[str, Any]:
    """Sheet.to_dict with an initial-state file: without the keys the file replaces."""
    for name in _REPLACED_BY_FILE[sheet.initial_state.kind]:
        d.pop(name, None)
    d.update(sheet.gravity_dict())
    d["z_box"] = sheet.z_box
    d["initial_state"] = sheet.initial_state.to_dict()
    return d


def read_initial_state(sheet: Section) -> InitialStateFile | None:
    """``sheet.initial_state: {file: run.h5, snapshot: -1}`` or ``{file: particles.csv}``.

    The file's contents are checked when the sheet is built (ringsim.engine.initial_file),
    so that a run file that embeds this scenario can be opened after the file is gone."""
    if not sheet.has("initial_state"):
        return None
    allowed = "a mapping: file (a run file .h5 with snapshot, or a particle .csv)"
    sec = sheet.section("initial_state", allowed=allowed)
    sec.check_keys(("file", "snapshot", "t", "tile"))
    name = sec.string("file", what="a run file (.h5) or a particle CSV (.csv)")
    suffix = Path(name).suffix.lower()
    if suffix not in INITIAL_STATE_SUFFIXES:
        raise sec.error("file", f"{show(name)} is neither a run file nor a CSV",
                        "a file ending in .h5, .hdf5 or .csv")
    kind = INITIAL_STATE_SUFFIXES[suffix]
    if kind == "csv" and sec.has("snapshot"):
        raise sec.error("snapshot", "only for a run file", "remove the key for a CSV")
    if kind == "run" and sec.has("t"):
        raise sec.error("t", "only for a CSV", "remove the key: a run file gives its time")
    if kind == "csv" and sec.has("tile"):
        raise sec.error("tile", "only for a run file", "remove the key for a CSV")
    snapshot = sec.integer("snapshot", -1) if kind == "run" else -1
    tile = _read_tile(sec) if kind == "run" else (1, 1)
    t = sec.number("t", 0.0, unit="s") if kind == "csv" else 0.0
    for key in _REPLACED_BY_FILE[kind]:
        if sheet.has(key):
            raise sheet.error(key, "given with sheet.initial_state, which replaces it",
                              f"remove the key (the {'run ' if kind == 'run' else ''}file "
                              "gives the particles" + (" and the box)" if kind == "run"
                                                       else ")"))
    return InitialStateFile(file=name, snapshot=snapshot, t=t, tile=tile)


#: Most copies of a run file's sheet in one direction (``tile``).
MAX_TILE = 16


def _read_tile(sec: Section) -> tuple[int, int]:
    """``tile: [n_x, n_y]`` (copies radially and azimuthally), default [1, 1]."""
    allowed = f"a list of two integers [n_x, n_y], each 1 ... {MAX_TILE}"
    value = sec.get("tile", [1, 1], allowed)
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(n, int) and not isinstance(n, bool) for n in value)):
        raise sec.error("tile", f"got {show(value)}", allowed)
    if not all(1 <= n <= MAX_TILE for n in value):
        raise sec.error("tile", f"{list(value)} is out of range", allowed)
    return int(value[0]), int(value[1])


def check_tiled_stop(top: Section, initial_state: InitialStateFile | None,
                     until_equilibrium: bool) -> None:
    """``integration.until_equilibrium`` is refused with a tiled start: its window must wait
    until the copies are independent, which only the run's snapshots show
    (``ringsim.analysis.tiling``), so the run is given a fixed length."""
    if until_equilibrium and initial_state is not None and initial_state.tile != (1, 1):
        raise top.error("integration.until_equilibrium", "true with a tiled start "
                        "(sheet.initial_state.tile), whose window must wait until its copies "
                        "are independent, which only the run's snapshots show",
                        "false: run a fixed integration.orbits, then ringsim analyze")
