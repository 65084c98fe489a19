"""Checks of what a run file holds, made before ringsim follows a link or allocates an array.

A run file comes from anywhere (a colleague, a download, a crafted file), so a reader
trusts none of it:

* **Links** (`check_links`).  HDF5 follows external links into other files and soft links
  to other paths.  ringsim writes only external links to its own part files
  (``RUN.h5.parts/<kind>_<hex>.h5``, ``store.bulk``), so every other external link (an
  absolute path, ``../``, ``RUN.h5.parts/../x``, a name ringsim does not make) is refused;
  a part file must be a regular file (not a symbolic link) in a folder that is not a link,
  and holds no external link of its own.  A soft link must name a path inside the file
  made of hard links only.
* **Sizes** (`check_rows`, `check_snapshot`, `check_bytes`).  A dataset's shape is only a
  few bytes in the file, yet reading it allocates the whole shape: an array is read only
  when its shape fits the run's particle count and the bounds below.
* **Checkpoint attributes** (`check_checkpoint_state`).  The checkpoint's SHA-256 covers
  the REBOUND binary only; the loop counters, the box and the seed beside it are checked
  for their types, ranges and consistency with the file.

Each failure is a `RunFileError` (bad input, exit status 2) naming the item.
"""

from __future__ import annotations

import math
import os
import re
import stat
from collections.abc import Mapping
from pathlib import Path

import h5py
import numpy as np

from ringsim.errors import InputError

#: Names of part files (``store.bulk.Parts.new_file``): kind, 6 random bytes in hex.
PART_NAME = re.compile(r"(snapshot_[0-9]{6}|checkpoint)_[0-9a-f]{12}\.h5")
#: Most particles a snapshot may hold (the largest sheets of docs/scaling.md).
MAX_PARTICLES = 10**8
#: Most rows a time series or the guard table may hold.
MAX_ROWS = 10**8
#: Most values in one row of a per-size-bin or histogram time series.
MAX_ROW_WIDTH = 10**4
#: Most bytes of the REBOUND binary of a checkpoint (a generous 1 kB per particle).
MAX_CHECKPOINT_BYTES = 1024 * MAX_PARTICLES
#: Most values in one dataset of ``/checkpoint_statistics``.
MAX_STATISTICS = 10**6
#: Most links a run file (with its part files) may hold: a walk of them is bounded.
MAX_LINKS = 10**6
#: Most root boxes of a sheet (N_root_x N_root_y N_root_z).
MAX_ROOT_BOXES = 10**7
#: Relative tolerance of Lx = root_size N_root_x (and Ly) in a checkpoint (the product is
#: exact to one rounding).
BOX_RTOL = 1e-12


class RunFileError(InputError):
    """A run file that cannot be used: missing, empty, not HDF5, truncated, incomplete, of
    a newer format, being written by another process, or holding what ringsim refuses (a
    link out of the file, an oversized array, a bad checkpoint attribute): exit status 2.

    Parameters
    ----------
    path : the run file
    problem : str
        What is wrong, in one line.
    key : str
        The item concerned (default "run file"; e.g. "/checkpoint", "format_version").
    """

    def __init__(self, path: str | os.PathLike, problem: str, key: str = "run file"):
        super().__init__(str(path), key, problem)

    def __reduce__(self):
        return (type(self), (self.file, self.problem, self.key))


# --- links ------------------------------------------------------------------------------------

def part_file(run_path: Path, filename: str, key: str) -> Path:
    """The part file an external link of ``run_path`` names, checked to be one of its own:
    ``RUN.h5.parts/<part name>``, a regular file in a folder that is not a link.

    Raises RunFileError naming the link ``key`` otherwise (and for a missing part file)."""
    folder_name = run_path.name + ".parts"
    head, _, name = filename.partition("/")
    if head != folder_name or not PART_NAME.fullmatch(name):
        raise RunFileError(run_path, f"an external link to {filename[:200]!r}, outside the "
                           f"run file's part files ({folder_name}/): refused", key)
    folder = run_path.parent / folder_name
    for item, kind in ((folder, stat.S_ISDIR), (folder / name, stat.S_ISREG)):
        try:
            mode = os.lstat(item).st_mode
        except FileNotFoundError:
            raise RunFileError(run_path, f"is damaged: its part file {item} is missing",
                               key) from None
        if not kind(mode):
            raise RunFileError(run_path, f"{item} is a symbolic link or not a "
                               f"{'folder' if kind is stat.S_ISDIR else 'regular file'}: "
                               "refused", key)
    return folder / name


def _check_soft(f: h5py.File, link: h5py.SoftLink, key: str, run_path: Path) -> None:
    """A soft link must name an absolute path of the file made of hard links only."""
    target = str(link.path)
    node: h5py.Group = f
    parts = [p for p in target.split("/") if p]
    if not target.startswith("/") or not parts:
        raise RunFileError(run_path, f"a soft link to {target[:200]!r}, not an absolute "
                           "path inside the file: refused", key)
    for i, part in enumerate(parts):
        hop = node.get(part, getlink=True) if isinstance(node, h5py.Group) else None
        if not isinstance(hop, h5py.HardLink):
            raise RunFileError(run_path, f"a soft link to {target[:200]!r}, which does not "
                               "lead to an object of the file through hard links: refused",
                               key)
        if i < len(parts) - 1:
            node = node[part]


def _non_hard_links(f: h5py.File, only: str | None, run_path: Path) -> tuple[list[str], int]:
    """Paths of the links of ``f`` (or of ``only`` and below it) that are not hard links,
    and how many links were visited (HDF5's own walk, ``H5Lvisit``: each group once)."""
    found: list[str] = []
    walked = 0
    base = "" if only is None else only.rstrip("/")

    def visit(name: bytes, info) -> bool | None:
        nonlocal walked
        walked += 1
        if info.type != h5py.h5l.TYPE_HARD:
            found.append(f"{base}/{name.decode(errors='replace')}")
        return True if walked > MAX_LINKS else None   # True stops the walk

    if only is not None:
        walked += 1
        link = f.get(only, getlink=True)
        if not isinstance(link, h5py.HardLink):
            return [base], walked
        if f.get(only, getclass=True) is not h5py.Group:
            return [], walked
    top = f[only or "/"]   # held: the walk needs its identifier open
    top.id.links.visit(visit, info=True)
    if walked > MAX_LINKS:
        raise RunFileError(run_path, f"holds more than {MAX_LINKS} links: refused")
    return found, walked


def check_links(f: h5py.File, run_path: str | os.PathLike, *, part: bool = False,
                only: str | None = None) -> int:
    """Check every link of the open file ``f`` (and of the part files it links); returns
    how many were visited.  ``run_path`` is the run file (its part-file folder is beside
    it); ``part`` is true when ``f`` is itself a part file (which may hold no external
    link); ``only`` names one item (``"/snapshots/000001"``) whose link and contents alone
    are checked, in a file checked whole when it was opened.  RunFileError naming the
    first refused link."""
    run_path = Path(run_path)
    keys, walked = _non_hard_links(f, only, run_path)
    for key in keys:
        link = f.get(key, getlink=True)
        if isinstance(link, h5py.ExternalLink):
            if part:
                raise RunFileError(run_path, "a part file holds an external link: refused",
                                   key)
            path = part_file(run_path, str(link.filename), key)
            with h5py.File(path, "r") as linked:
                walked += check_links(linked, run_path, part=True)
        elif isinstance(link, h5py.SoftLink):
            _check_soft(f, link, key, run_path)
        else:
            raise RunFileError(run_path, "a link of a kind ringsim does not write (user-"
                               "defined): refused", key)
    return walked


# --- sizes ------------------------------------------------------------------------------------

def check_rows(ds: h5py.Dataset, run_path: Path) -> None:
    """A time series or guard column: at most `MAX_ROWS` rows of at most `MAX_ROW_WIDTH`."""
    width = math.prod(ds.shape[1:])
    if ds.ndim == 0 or ds.ndim > 2 or ds.shape[0] > MAX_ROWS or width > MAX_ROW_WIDTH:
        raise RunFileError(run_path, f"has shape {ds.shape}: a column of at most "
                           f"{MAX_ROWS} rows of at most {MAX_ROW_WIDTH} values expected",
                           ds.name)


def check_snapshot(g: h5py.Group, names: tuple[str, ...], n_particles: int | None,
                   run_path: Path) -> int:
    """The particle arrays ``names`` of a snapshot group: 1-D, all of one length, that of
    the run (``n_particles``, None if unknown) and at most `MAX_PARTICLES`; returns it."""
    n = n_particles
    for name in names:
        ds = g.get(name)
        if ds is None:
            continue
        if not isinstance(ds, h5py.Dataset) or ds.ndim != 1 or ds.shape[0] > MAX_PARTICLES:
            raise RunFileError(run_path, f"has shape {getattr(ds, 'shape', None)}: one "
                               f"value per particle (at most {MAX_PARTICLES}) expected",
                               f"{g.name}/{name}")
        if n is not None and ds.shape[0] != n:
            raise RunFileError(run_path, f"holds {ds.shape[0]} particles, the run {n}",
                               f"{g.name}/{name}")
        n = ds.shape[0]
    return -1 if n is None else n


def check_finite(arrays: Mapping[str, np.ndarray], group: str, run_path: Path) -> None:
    """A snapshot's particle arrays read: every value finite (a run never writes NaN or
    infinite positions, velocities, radii or masses; a file that holds them is damaged)."""
    for name, values in arrays.items():
        values = np.asarray(values)
        if values.dtype.kind == "f" and not np.all(np.isfinite(values)):
            raise RunFileError(run_path, "holds values that are not finite (NaN or "
                               "infinite): a damaged file", f"{group}/{name}")


def check_bytes(ds: h5py.Dataset, limit: int, run_path: Path) -> None:
    """A dataset read whole: at most ``limit`` values."""
    if not isinstance(ds, h5py.Dataset) or ds.size > limit:
        raise RunFileError(run_path, f"has {getattr(ds, 'size', '?')} values, at most "
                           f"{limit} expected", getattr(ds, "name", "?"))


def particle_count(state: Mapping[str, object]) -> int:
    """The checkpoint's ``n_particles`` (checked by `check_checkpoint_state`), or
    `MAX_PARTICLES` for a file without it."""
    n = state.get("n_particles")
    return int(n) if isinstance(n, (int, np.integer)) else MAX_PARTICLES


# --- checkpoint attributes --------------------------------------------------------------------

#: Checkpoint attributes that are counts: name -> least value.
_COUNTS = {"rows": 0, "snapshots": 0, "guard_events": 0, "dt_warned": 0,
           "overlap_warned": 0, "rand_seed": 0, "N_root_x": 1, "N_root_y": 1, "N_root_z": 1,
           "n_particles": 1}
#: Checkpoint attributes that are finite real numbers: name -> (least, strictly above it).
_REALS = {"root_size": (0.0, True), "t": (0.0, False), "Lx": (0.0, True),
          "Ly": (0.0, True), "Omega": (0.0, True)}
#: The largest value of each count (REBOUND's rand_seed is an unsigned int).
_MOST = {"dt_warned": 1, "overlap_warned": 1, "rand_seed": 2**32 - 1,
         "n_particles": MAX_PARTICLES, "N_root_x": MAX_ROOT_BOXES,
         "N_root_y": MAX_ROOT_BOXES, "N_root_z": MAX_ROOT_BOXES}


def _typed(state: Mapping[str, object], run_path: Path) -> None:
    for key, value in state.items():
        where = f"/checkpoint {key}"
        if key in _COUNTS:
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise RunFileError(run_path, f"{value!r:.60} is not an integer", where)
            most = _MOST.get(key, MAX_ROWS)
            if not _COUNTS[key] <= value <= most:
                raise RunFileError(run_path, f"{value} is outside {_COUNTS[key]} ... {most}",
                                   where)
        elif key in _REALS:
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise RunFileError(run_path, f"{value!r:.60} is not a number", where)
            least, strict = _REALS[key]
            if not math.isfinite(value) or value < least or (strict and value == least):
                raise RunFileError(run_path, f"{value!r} is not a finite number "
                                   f"{'>' if strict else '>='} {least:g}", where)


def check_checkpoint_state(state: Mapping[str, object], f: h5py.File,
                           run_path: str | os.PathLike) -> None:
    """The checkpoint's attributes ``state`` against their types, ranges and the file ``f``:
    counters within the rows, snapshots and guard events the file holds, the box's
    ``Lx``/``Ly`` = ``root_size`` times ``N_root_x``/``N_root_y``, at most
    `MAX_ROOT_BOXES` root boxes.  RunFileError naming the first bad attribute."""
    run_path = Path(run_path)
    _typed(state, run_path)
    held = {"rows": f["timeseries/t"].shape[0] if "timeseries/t" in f else 0,
            "snapshots": len(f["snapshots"]) if "snapshots" in f else 0,
            "guard_events": f["guards/t"].shape[0] if "guards/t" in f else 0}
    for key, n in held.items():
        if key in state and int(state[key]) > n:   # type: ignore[call-overload]
            raise RunFileError(run_path, f"{state[key]} is more than the {n} the file holds",
                               f"/checkpoint {key}")
    boxes = [int(state.get(f"N_root_{a}", 1)) for a in "xyz"]   # type: ignore[call-overload]
    if math.prod(boxes) > MAX_ROOT_BOXES:
        raise RunFileError(run_path, f"{boxes[0]} x {boxes[1]} x {boxes[2]} root boxes are "
                           f"more than {MAX_ROOT_BOXES}", "/checkpoint N_root_x")
    size = state.get("root_size")
    for axis, n in (("x", boxes[0]), ("y", boxes[1])):
        length = state.get(f"L{axis}", f.attrs.get(f"L{axis}"))
        if size is None or length is None:
            continue
        expected = float(size) * n   # type: ignore[arg-type]
        if not abs(float(length) - expected) <= BOX_RTOL * expected:   # type: ignore[arg-type]
            raise RunFileError(run_path, f"root_size {size!r} x N_root_{axis} {n} is not "
                               f"the box's L{axis} {length!r}", f"/checkpoint N_root_{axis}")
