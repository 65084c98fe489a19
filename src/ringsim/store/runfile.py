"""The run file (HDF5): time series, snapshots, checkpoint and the scenario that made it.

Layout (docs/interface.md "Run file"; every item in docs/run_file.md):

* ``/`` attributes ``format_version`` (:data:`FORMAT_VERSION`), ``ringsim_version``,
  ``rebound_version``, ``scenario_yaml``, ``units`` = "SI", ``seed``, ``created_utc``,
  ``status`` ("running", "finished", "stopped", "failed"; a failed run also has
  ``failure``), ``wall_time_s`` and the box geometry of the sheet (``Lx``, ``Omega``, ...).
* ``/timeseries/NAME`` resizable 1-D datasets (2-D ``(n, n_bins)`` for per-size-bin
  arrays), each with a ``units`` attribute.
* ``/snapshots/NNNNNN/`` groups (attribute ``t``) with ``x y z vx vy vz radius mass``.
* ``/checkpoint``: the REBOUND binary of the last checkpoint as bytes; its attributes hold
  what the run loop needs to resume (:data:`CHECKPOINT_KEYS`) and its ``sha256``;
  ``/checkpoint_statistics/`` the resolver's statistics of the open interval.
* ``/guards``: what the run's guards did, as a resizable event table.

Crash consistency: the file a reader sees is only ever replaced whole.  The one writer
(:class:`RunFileWriter`, holding the lock of ``ringsim.store.lock``) copies the file to
``RUN.h5.tmp``, changes the copy, flushes it to disk and renames it over the file
(``os.replace``, atomic on POSIX).  A process killed at any moment therefore leaves the
previous complete state (time series, snapshots and checkpoint of one commit), and a
reader never sees a half-written file.  HDF5 itself changes a file in place through many
separate writes, so in-place updates do not give this (docs/run_file.md has the
measurements).  A full disk fails a commit cleanly (``store.guarded``).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ringsim import quantities
from ringsim.errors import InputError
from ringsim.store import bulk, contents, guarded, paths
from ringsim.store.bulk import (  # noqa: F401 (the layout's names, declared in bulk)
    CHECKPOINT_SPINS,
    CHECKPOINT_STATISTICS,
    EXTERNAL_BYTES,
    SNAPSHOT_FIELDS,
    SNAPSHOT_UNITS,
    SPIN_FIELDS,
    SPIN_STATE_FRAME,
    Parts,
    _fsync,
    linked_parts,
)
from ringsim.store.bulk import write_checkpoint as _write_checkpoint
from ringsim.store.bulk import write_snapshot as _write_snapshot
from ringsim.store.contents import RunFileError  # noqa: F401 (raised by the readers)
from ringsim.store.lock import writer_of

#: Version of the run-file layout this ringsim writes (root attribute ``format_version``).
#: A reader opens every file of the same MAJOR version (files without the attribute are
#: "1.0") and refuses a newer major version.
FORMAT_VERSION = "1.2"
#: Version assumed for a file without the attribute ``format_version``.
UNVERSIONED = "1.0"
#: Checkpoint attributes the run loop needs to resume.
CHECKPOINT_KEYS = ("rows", "snapshots", "guard_events", "dt_warned", "overlap_warned",
                   "rand_seed", "root_size", "N_root_x", "N_root_y", "N_root_z", "t")

#: Units of the time-series quantities, in the order of a row (per-bin arrays share the
#: units of their scalar): a view of ``ringsim.quantities``, where each is declared.
TIMESERIES_UNITS = quantities.units(quantities.TIMESERIES)

#: Bin edges stored beside the histogram time series: name -> (edges dataset, units).
HISTOGRAM_EDGES = {name: (edges, quantities.unit(edges)) for name, edges in (
    ("one_minus_epsilon_histogram", "one_minus_epsilon_bin_edges"),
    ("impact_speed_histogram", "impact_speed_bin_edges"))}


def units_of(name: str) -> str:
    """The unit string of a time-series quantity; KeyError for an undeclared one."""
    return TIMESERIES_UNITS[name]


def _utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _short(exc: BaseException) -> str:
    """An h5py/HDF5 error message in one short line."""
    text = " ".join(str(exc).split())
    return text if len(text) <= 120 else text[:117] + "..."


def _text(value: object) -> object:
    return value.decode() if isinstance(value, bytes) else value


# --- writing ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Checkpoint:
    """A checkpoint: REBOUND binary, run-loop state and the resolver's open-interval statistics.

    Attributes
    ----------
    binary : bytes
        ``rebound.Simulation.save_to_file`` output (embeds wall-clock fields: compare two
        checkpoints by the state they load, not by these bytes).
    state : dict
        :data:`CHECKPOINT_KEYS` and whatever else the run loop saved (numbers).
    statistics : dict of arrays, or None
        ``ResolverHandle.stats_state()`` (None in format-1.0 files).
    spins : array (N, 3) [rad/s], or None
        ``ResolverHandle.spin_state()`` of a run with friction (None without), see
        :data:`SPIN_STATE_FRAME`.
    """

    binary: bytes
    state: dict
    statistics: dict | None = field(default=None)
    spins: np.ndarray | None = field(default=None)


def _append_rows(group: h5py.Group, name: str, values: np.ndarray, units: str,
                 n_before: int) -> None:
    """Append rows (first axis) to a resizable dataset, creating it on first use.

    A dataset first written when the group already has ``n_before`` rows (a file made by an
    older ringsim and continued by this one) is created with those rows filled: NaN for
    floats, -1 for integers.
    """
    values = np.asarray(values)
    row_shape = values.shape[1:]
    if name not in group:
        size = int(np.prod(row_shape)) if row_shape else 1
        dtype = values.dtype if values.dtype.kind in "iu" else np.dtype("f8")
        ds = group.create_dataset(name, shape=(n_before,) + row_shape,
                                  maxshape=(None,) + row_shape, dtype=dtype,
                                  chunks=(max(1, 4096 // max(1, size)),) + row_shape,
                                  fillvalue=-1 if dtype.kind in "iu" else np.nan)
        ds.attrs["units"] = units
    ds = group[name]
    n = ds.shape[0]
    ds.resize(n + values.shape[0], axis=0)
    ds[n:] = values


def _append_timeseries(f: h5py.File, rows: Sequence[Mapping[str, object]]) -> None:
    ts = f["timeseries"]
    n_before = ts["t"].shape[0] if "t" in ts else 0
    for name in rows[0]:
        _append_rows(ts, name, np.array([row[name] for row in rows]), units_of(name),
                     n_before)


def _append_guard_events(f: h5py.File, events: Sequence[tuple[float, float, str]]) -> None:
    g = f["guards"]
    for column, name in enumerate(("t", "orbits", "message")):
        ds = g[name]
        n = ds.shape[0]
        ds.resize(n + len(events), axis=0)
        for k, event in enumerate(events):
            ds[n + k] = event[column]


def _truncate(f: h5py.File, rows: int, n_snapshots: int, n_guard_events: int) -> None:
    """Drop time-series rows, snapshots and guard events written after the checkpoint."""
    for ds in f["timeseries"].values():
        if ds.maxshape[0] is None and ds.shape[0] > rows:
            ds.resize(rows, axis=0)
    for name in list(f["snapshots"].keys()):
        if int(name) >= n_snapshots:
            del f["snapshots"][name]
    for ds in f["guards"].values():
        if ds.shape[0] > n_guard_events:
            ds.resize(n_guard_events, axis=0)


class RunFileWriter:
    """The writer of one run file (an emcee-style HDF5 backend that owns its file).

    Every change is one :meth:`commit`: the file is copied to ``RUN.h5.tmp``, the copy is
    changed and flushed to disk, and renamed over the file.  Whatever happens to the process,
    the file is either the state before a commit or the state after it.  Large snapshots
    and checkpoints go into part files beside it (``ringsim.store.bulk``), written and
    flushed before the commit that links them, so that a commit does not copy them again.
    The caller holds the file's lock (``ringsim.store.lock.RunFileLock``).

    Parameters
    ----------
    path : the run file
    external_bytes : int
        Snapshots and checkpoints larger than this [bytes] go into part files.
    """

    def __init__(self, path: str | os.PathLike, external_bytes: int | None = None):
        self.path = Path(path)
        self.tmp = self.path.with_name(self.path.name + ".tmp")
        self.external_bytes = int(bulk.EXTERNAL_BYTES if external_bytes is None
                                  else external_bytes)

    @contextlib.contextmanager
    def _replacing(self, copy: bool) -> Iterator[tuple[h5py.File, Parts]]:
        parts = Parts(self.path, self.external_bytes)
        paths.create_new(self.tmp, copy_of=self.path if copy else None)
        try:
            with guarded.h5_file(self.tmp, "a" if copy else "w") as f:   # full disk: OSError
                yield f, parts
                linked = linked_parts(f)
            parts.flush()
            _fsync(self.tmp)
            os.replace(self.tmp, self.path)
        except BaseException:   # also KeyboardInterrupt: leave the file as it was
            self.tmp.unlink(missing_ok=True)
            parts.discard_new()
            raise
        parts.remove_unlinked(linked)   # those of earlier commits that are replaced now

    def create(self, *, scenario_yaml: str, seed: int, attributes: Mapping[str, object],
               size_bin_edges: np.ndarray | None,
               histogram_edges: Mapping[str, np.ndarray]) -> Path:
        """Create a new, empty run file (replacing ``path``).

        Parameters
        ----------
        scenario_yaml : str
            The full scenario text, embedded so the file documents what made it.
        seed : int
        attributes : mapping
            Further root attributes (the sheet geometry: ``Lx`` [m], ``Ly`` [m],
            ``Omega`` [1/s], ...).  Numbers or strings.
        size_bin_edges : array [m] or None
            Edges of the radius bins of the per-size-bin time series.
        histogram_edges : mapping
            Bin edges of each histogram time series (keys of :data:`HISTOGRAM_EDGES`).
        """
        import rebound

        from ringsim import __version__

        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._replacing(copy=False) as (f, _parts):
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["ringsim_version"] = __version__
            f.attrs["rebound_version"] = rebound.__version__
            f.attrs["scenario_yaml"] = scenario_yaml
            f.attrs["units"] = "SI"
            f.attrs["seed"] = int(seed)
            f.attrs["created_utc"] = _utc_now()
            f.attrs["status"] = "running"
            for key, value in attributes.items():
                f.attrs[key] = value
            ts = f.create_group("timeseries")
            if size_bin_edges is not None:
                edges = ts.create_dataset("size_bin_edges",
                                          data=np.asarray(size_bin_edges, float))
                edges.attrs["units"] = quantities.unit("size_bin_edges")
            for name, edges in histogram_edges.items():
                dataset, units = HISTOGRAM_EDGES[name]
                ts.create_dataset(dataset, data=np.asarray(edges, float)).attrs["units"] = units
            f.create_group("snapshots")
            guards = f.create_group("guards")
            for name in ("t", "orbits"):
                ds = guards.create_dataset(name, shape=(0,), maxshape=(None,), dtype="f8",
                                           chunks=(256,))
                ds.attrs["units"] = quantities.unit(name)
            msg = guards.create_dataset("message", shape=(0,), maxshape=(None,),
                                        dtype=h5py.string_dtype(), chunks=(256,))
            msg.attrs["units"] = "text"
        return self.path

    def commit(self, *, rows: Sequence[Mapping[str, object]] = (),
               events: Sequence[tuple[float, float, str]] = (),
               snapshot: tuple[int, float, Mapping[str, np.ndarray]] | None = None,
               checkpoint: Checkpoint | None = None,
               attributes: Mapping[str, object] | None = None,
               truncate: tuple[int, int, int] | None = None) -> None:
        """Apply one consistent set of changes atomically.

        Parameters
        ----------
        rows : time-series rows (all with the same keys, each declared in
            :data:`TIMESERIES_UNITS`)
        events : guard events ``(t [s], orbits, message)``
        snapshot : ``(index, t [s], arrays)`` written as ``/snapshots/NNNNNN``
        checkpoint : replaces ``/checkpoint`` (and ``/checkpoint_statistics``)
        attributes : root attributes to set (e.g. ``status``)
        truncate : ``(rows, snapshots, guard_events)``: first drop everything written
            after a checkpoint with these counters
        """
        with self._replacing(copy=True) as (f, parts):
            f.attrs["format_version"] = FORMAT_VERSION
            if truncate is not None:
                _truncate(f, *truncate)
            if rows:
                _append_timeseries(f, rows)
            if events:
                _append_guard_events(f, events)
            if snapshot is not None:
                _write_snapshot(f, *snapshot, parts)
            if checkpoint is not None:
                _write_checkpoint(f, checkpoint, parts)
            for key, value in (attributes or {}).items():
                f.attrs[key] = value


def pack(path: str | os.PathLike) -> int:
    """Make a run file whole again: copy the snapshots and the checkpoint it keeps in part
    files (``RUN.h5.parts/``, written while it ran) into the file itself, in one atomic
    commit, and remove the part files.  Returns the number of items copied (0 and the file
    untouched when it has no part files).  The caller holds the file's lock."""
    path = Path(path)
    if not bulk.parts_folder(path).is_dir():
        return 0
    writer = RunFileWriter(path)
    with writer._replacing(copy=True) as (f, _parts):
        packed = bulk.pack_links(f, path)
    return packed


def set_attributes(path: str | os.PathLike, **attributes: object) -> None:
    """Set root attributes (e.g. ``status``) of a run file nobody is writing."""
    from ringsim.store.lock import RunFileLock

    with RunFileLock(path):
        RunFileWriter(path).commit(attributes=attributes)


# --- reading ----------------------------------------------------------------------------------

def _version(value: object, path: Path) -> tuple[int, int]:
    text = _text(value) if value is not None else UNVERSIONED
    try:
        major, minor = (int(part) for part in str(text).split("."))
    except ValueError:
        raise RunFileError(path, f"{text!r} is not a version (MAJOR.MINOR)",
                           "format_version") from None
    return major, minor


@contextlib.contextmanager
def _reading(path: str | os.PathLike, item: str | None = None) -> Iterator[h5py.File]:
    """Open a run file for reading after checking it is one this ringsim can read.

    Raises RunFileError (bad input, exit status 2) for a missing, empty, non-HDF5,
    truncated or otherwise unreadable file, a newer format, a file being written by another
    process, a link out of the file or its part files (``store.contents``; only those of
    ``item`` when given), and for HDF5 errors while reading it.
    """
    path = Path(path)
    if not path.is_file():
        raise RunFileError(path, "no such file")
    writer = writer_of(path)
    if writer is not None:
        raise RunFileError(path, f"is being written by {writer}; wait until that run "
                           "stops (or ends) and try again")
    if path.stat().st_size == 0:
        raise RunFileError(path, "is empty (0 bytes): not a run file")
    if not h5py.is_hdf5(path):
        raise RunFileError(path, "is not an HDF5 file (no HDF5 signature): not a run file")
    try:
        f = h5py.File(path, "r")
    except (OSError, RuntimeError, ValueError) as exc:
        raise RunFileError(path, f"is truncated or damaged: HDF5 cannot open it "
                           f"({_short(exc)})") from None
    with f:
        major, minor = _version(f.attrs.get("format_version"), path)
        if major > int(FORMAT_VERSION.split(".")[0]):
            raise RunFileError(path, f"was written in run-file format {major}.{minor} by a "
                               f"newer ringsim; this ringsim reads formats up to "
                               f"{FORMAT_VERSION}: upgrade ringsim", "format_version")
        try:
            contents.check_links(f, path, only=item)   # before any link is followed
            yield f
        except InputError:
            raise
        except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:
            raise RunFileError(path, f"is damaged: {_short(exc)}") from None


def _require(f: h5py.File, path: Path) -> None:
    """Check the layout every run file has; RunFileError naming the first missing item."""
    for attr in ("scenario_yaml", "status"):
        if attr not in f.attrs:
            raise RunFileError(path, "missing root attribute: not a complete ringsim run "
                               "file", attr)
    for item in ("timeseries", "timeseries/t", "snapshots", "guards", "guards/t",
                 "guards/orbits", "guards/message"):
        if item not in f:
            raise RunFileError(path, "missing: not a complete ringsim run file", f"/{item}")
    n = f["timeseries/t"].shape[0]
    for ds in list(f["timeseries"].values()) + list(f["guards"].values()):
        contents.check_rows(ds, path)
    for name, ds in f["timeseries"].items():
        if ds.maxshape[0] is None and ds.shape[0] != n:
            raise RunFileError(path, f"has {ds.shape[0]} rows, /timeseries/t has {n}",
                               f"/timeseries/{name}")
    for name, g in f["snapshots"].items():
        for field_name in SNAPSHOT_FIELDS:
            if field_name not in g:
                raise RunFileError(path, "missing", f"/snapshots/{name}/{field_name}")


def read_checkpoint(path: str | os.PathLike) -> Checkpoint | None:
    """The last checkpoint, or None if the file has none.

    Raises RunFileError when the checkpoint is incomplete or its bytes do not match the
    SHA-256 stored with them.
    """
    path = Path(path)
    with _reading(path) as f:
        if "checkpoint" not in f:
            return None
        ds = f["checkpoint"]
        contents.check_bytes(ds, contents.MAX_CHECKPOINT_BYTES, path)
        binary = ds[...].tobytes()
        state = {k: (v.item() if isinstance(v, np.generic) else _text(v))
                 for k, v in ds.attrs.items()}
        digest = state.pop("sha256", None)
        if digest is not None and hashlib.sha256(binary).hexdigest() != digest:
            raise RunFileError(path, "is damaged: its bytes do not match their SHA-256",
                               "/checkpoint")
        missing = [key for key in CHECKPOINT_KEYS if key not in state]
        if missing:
            raise RunFileError(path, f"is incomplete (no {', '.join(missing)})",
                               "/checkpoint")
        contents.check_checkpoint_state(state, f, path)
        statistics = None
        if CHECKPOINT_STATISTICS in f:
            for d in f[CHECKPOINT_STATISTICS].values():
                contents.check_bytes(d, contents.MAX_STATISTICS, path)
            statistics = {name: d[...] for name, d in f[CHECKPOINT_STATISTICS].items()}
        if CHECKPOINT_SPINS in f:
            contents.check_bytes(f[CHECKPOINT_SPINS], 3 * contents.particle_count(state), path)
        spins = f[CHECKPOINT_SPINS][...] if CHECKPOINT_SPINS in f else None
        if spins is not None and "frame" not in f[CHECKPOINT_SPINS].attrs:
            raise RunFileError(path, "spins written before their precession was followed "
                               "(no 'frame'): rerun", f"/{CHECKPOINT_SPINS}")
        return Checkpoint(binary=binary, state=state, statistics=statistics, spins=spins)


class Run:
    """Read access to a run file (``ringsim.open_run``).

    Attributes
    ----------
    path : Path
    attrs : dict
        Root attributes.
    format_version : str
        Run-file format (``"1.0"`` for a file without the attribute).
    scenario : Scenario
        The scenario embedded in the file.
    timeseries : dict of numpy arrays (SI; see ``units``)
    units : dict
        Unit of each time series.
    n_snapshots : int
    snapshot_times : array [s]
    guard_events : list of (orbits, message)

    Raises
    ------
    RunFileError
        The file is not a readable ringsim run file (missing, empty, not HDF5, truncated,
        incomplete, newer format, being written); the message says what is wrong.
    """

    def __init__(self, path: str | os.PathLike):
        from ringsim.config.scenario import scenario_from_text
        from ringsim.config.schema import ScenarioError

        self.path = Path(path)
        with _reading(self.path) as f:
            _require(f, self.path)
            self.attrs = {k: (v.item() if isinstance(v, np.generic) else _text(v))
                          for k, v in f.attrs.items()}
            self.timeseries = {name: ds[...] for name, ds in f["timeseries"].items()}
            self.units = {name: _text(ds.attrs.get("units", ""))
                          for name, ds in f["timeseries"].items()}
            self._snapshot_names = sorted(f["snapshots"].keys())
            self.snapshot_times = np.array([float(f["snapshots"][name].attrs["t"])
                                            for name in self._snapshot_names])
            self.guard_events = [(float(t), str(_text(m))) for t, m in zip(
                f["guards"]["orbits"][...], f["guards"]["message"][...], strict=True)]
        self.format_version = str(self.attrs.get("format_version", UNVERSIONED))
        try:
            self.scenario = scenario_from_text(str(self.attrs["scenario_yaml"]),
                                               source=str(self.path))
        except ScenarioError as exc:
            raise RunFileError(self.path, f"the embedded scenario is invalid ({exc.key}: "
                               f"{exc.problem})", "scenario_yaml") from None

    def _n_particles(self, f: h5py.File) -> int | None:
        """The run's particle count: the checkpoint's, else the first snapshot's."""
        n = f["checkpoint"].attrs.get("n_particles") if "checkpoint" in f else None
        if n is None and self._snapshot_names:
            first = f["snapshots"][self._snapshot_names[0]]
            n = contents.check_snapshot(first, SNAPSHOT_FIELDS, None, self.path)
        return None if n is None else int(n)

    @property
    def n_snapshots(self) -> int:
        return len(self._snapshot_names)

    def snapshot(self, i: int) -> dict:
        """Snapshot ``i`` (negative counts from the end) as a dict of arrays plus ``t`` [s]."""
        name = self._snapshot_names[i]
        with _reading(self.path, f"/snapshots/{name}") as f:
            g = f["snapshots"][name]
            contents.check_snapshot(g, SNAPSHOT_FIELDS + SPIN_FIELDS, self._n_particles(f),
                                    self.path)
            out = {key: g[key][...] for key in SNAPSHOT_FIELDS + SPIN_FIELDS if key in g}
            contents.check_finite(out, g.name, self.path)
            out["t"] = float(g.attrs["t"])
        return out

    def __repr__(self) -> str:
        n = len(self.timeseries.get("t", ()))
        return f"<ringsim Run {self.path} rows={n} snapshots={self.n_snapshots}>"


def open_run(path: str | os.PathLike) -> Run:
    """Open a run file written by ``ringsim run`` (RunFileError if it cannot be read)."""
    return Run(path)
