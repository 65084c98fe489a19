"""The large items of a run file: snapshots and the checkpoint (run-file format 1.2).

Snapshot datasets are chunked (`CHUNK_ELEMENTS`) and compressed with HDF5's own deflate
(gzip level `GZIP_LEVEL`) after the byte shuffle: every HDF5 reader can read them, and at
10^6 particles they are 13 % smaller than raw doubles (positions and velocities are
nearly random numbers; benchmarks/io_scale.py, docs/performance.md).

A run file is committed by copying it (``runfile.RunFileWriter``), so an item that is large
(more than ``external_bytes``, default `EXTERNAL_BYTES`) is not put into the file, where
every later commit would copy it again, but into a file of its own in the folder
``RUN.h5.parts/`` beside the run file, written and flushed to disk before the commit that
links it: the run file holds an HDF5 external link (``/snapshots/NNNNNN`` -> the snapshot
file's root group, ``/checkpoint`` -> its checkpoint file's dataset), which every HDF5
reader follows.  Part files are never changed once written (a new checkpoint is a new
file); after each commit the files the run file no longer links are removed.  So a commit
costs the copy of the small run file plus the new item, and a process killed at any moment
leaves the previous commit, whose links all point at complete files.  The folder belongs to
the run file: move or copy them together, under the same names.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import secrets
from collections.abc import Iterator, Mapping
from pathlib import Path

import h5py
import numpy as np

from ringsim.store import contents, guarded, paths

SNAPSHOT_FIELDS = ("x", "y", "z", "vx", "vy", "vz", "radius", "mass")
#: Spins [rad/s] relative to the rotating frame (w_z > 0 prograde), only in runs with friction.
SPIN_FIELDS = ("wx", "wy", "wz")
SNAPSHOT_UNITS = {"x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "vz": "m/s",
                  "radius": "m", "mass": "kg", "wx": "rad/s", "wy": "rad/s", "wz": "rad/s"}
#: Stored spins at the checkpoint, (N, 3) [rad/s] (runs with friction; SPIN_STATE_FRAME).
CHECKPOINT_SPINS, SPIN_STATE_FRAME = "checkpoint_spins", (
    "rotating frame of the sheet; x, y in its axes at t = 0 (rotate by -Omega t for its "
    "axes at t), z along the orbital angular momentum")
#: Group holding the resolver's interval statistics at the checkpoint (format 1.1).
CHECKPOINT_STATISTICS = "checkpoint_statistics"

#: Elements per chunk of a snapshot dataset (512 kB of doubles).
CHUNK_ELEMENTS = 1 << 16
#: Deflate level of snapshot datasets: level 1 saves as much as level 4 on ring snapshots
#: (13 % at N = 1e6) in less time.
GZIP_LEVEL = 1
#: Items larger than this [bytes] go into part files (a snapshot of ~125,000 particles, a
#: checkpoint of ~60,000).
EXTERNAL_BYTES = 8 * 1024 * 1024


def parts_folder(path: str | os.PathLike) -> Path:
    """The folder of a run file's part files: ``RUN.h5.parts`` beside it."""
    path = Path(path)
    return path.with_name(path.name + ".parts")


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class Parts:
    """The part files of one commit: where they go, which are new, which stay linked.

    Parameters
    ----------
    run_path : the run file (its final name, not the temporary copy)
    external_bytes : int
        Items larger than this go into part files.
    """

    def __init__(self, run_path: str | os.PathLike, external_bytes: int = EXTERNAL_BYTES):
        self.run_path = Path(run_path)
        self.folder = parts_folder(run_path)
        self.external_bytes = int(external_bytes)
        self.new: list[Path] = []

    @contextlib.contextmanager
    def new_file(self, kind: str) -> Iterator[tuple[h5py.File, str]]:
        """A new part file (created here under a new name, never over an existing one or
        through a link; open for writing, closed at the end; OSError if the disk is full,
        ``store.guarded``) and its link target relative to the run file's folder."""
        if not paths.folder_of_parts(self.folder):   # InputError for a link in its place
            self.folder.mkdir()
        name = f"{kind}_{secrets.token_hex(6)}.h5"
        path = self.folder / name
        self.new.append(path)
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644))
        with guarded.h5_file(path, "w") as part:
            yield part, f"{self.folder.name}/{name}"

    def flush(self) -> None:
        """Put the new part files (and their folder entries) on disk."""
        for path in self.new:
            _fsync(path)
        if self.new:
            _fsync(self.folder)

    def discard_new(self) -> None:
        """Remove the new part files of a commit that did not happen."""
        for path in self.new:
            path.unlink(missing_ok=True)
        self.new = []

    def remove_unlinked(self, linked: set[str]) -> None:
        """Remove the part files whose names are not in ``linked``: only files of the names
        ringsim gives them, in the folder itself (never through a link in its place)."""
        if not paths.folder_of_parts(self.folder):
            return
        for path in self.folder.iterdir():
            if path.name not in linked and contents.PART_NAME.fullmatch(path.name) \
                    and path.is_file() and not path.is_symlink():
                path.unlink(missing_ok=True)
        if not any(self.folder.iterdir()):
            self.folder.rmdir()


def linked_parts(f: h5py.File) -> set[str]:
    """Names of the part files the run file ``f`` links."""
    names = set()
    groups = [f] + ([f["snapshots"]] if "snapshots" in f else [])
    for group in groups:
        for key in group:
            link = group.get(key, getlink=True)
            if isinstance(link, h5py.ExternalLink):
                names.add(Path(link.filename).name)
    return names


def _snapshot_datasets(g: h5py.Group, arrays: Mapping[str, np.ndarray]) -> None:
    for field_name in SNAPSHOT_FIELDS + SPIN_FIELDS:
        if field_name not in arrays and field_name in SPIN_FIELDS:
            continue
        data = np.asarray(arrays[field_name], dtype=float)
        ds = g.create_dataset(field_name, data=data,
                              chunks=(max(1, min(data.size, CHUNK_ELEMENTS)),),
                              compression="gzip", compression_opts=GZIP_LEVEL, shuffle=True)
        ds.attrs["units"] = SNAPSHOT_UNITS[field_name]


def _delete(group: h5py.Group, name: str) -> None:
    if group.get(name, getlink=True) is not None:
        del group[name]


def write_snapshot(f: h5py.File, index: int, t: float, arrays: Mapping[str, np.ndarray],
                   parts: Parts | None = None) -> None:
    """``/snapshots/NNNNNN`` (attribute ``t`` [s]) with the particle arrays (SI), in the
    run file or, when larger than ``parts.external_bytes``, in a part file it links."""
    snaps = f["snapshots"]
    name = f"{index:06d}"
    _delete(snaps, name)
    size = sum(np.asarray(a).size * 8 for a in arrays.values())
    if parts is None or size <= parts.external_bytes:
        g = snaps.create_group(name)
    else:
        with parts.new_file(f"snapshot_{name}") as (part, target):
            _snapshot_attributes(part, t)
            _snapshot_datasets(part, arrays)
        snaps[name] = h5py.ExternalLink(target, "/")
        return
    _snapshot_attributes(g, t)
    _snapshot_datasets(g, arrays)


def _snapshot_attributes(g: h5py.Group, t: float) -> None:
    g.attrs["t"] = float(t)
    g.attrs["units_t"] = "s"


def _overwrite(group: h5py.Group, name: str, data: np.ndarray) -> h5py.Dataset:
    """Write ``data`` as ``group[name]``, in place when shape and type allow (no file growth)."""
    data = np.asarray(data)
    if name in group:
        ds = group[name]
        if ds.shape == data.shape and ds.dtype == data.dtype:
            ds[...] = data
            return ds
        del group[name]
    return group.create_dataset(name, data=data)


def _checkpoint_dataset(f: h5py.File | h5py.Group, checkpoint) -> None:
    """The REBOUND binary as ``f["checkpoint"]`` (resizable bytes) with the loop state."""
    data = np.frombuffer(checkpoint.binary, dtype=np.uint8)
    ds = f.get("checkpoint")
    if ds is None or ds.maxshape[0] is not None:   # absent, or contiguous (format 1.0)
        if ds is not None:
            del f["checkpoint"]
        ds = f.create_dataset("checkpoint", shape=(0,), maxshape=(None,), dtype=np.uint8,
                              chunks=(1 << 16,))
    ds.resize(data.size, axis=0)
    ds[...] = data
    for key in list(ds.attrs):
        del ds.attrs[key]
    ds.attrs["units"] = "bytes (REBOUND simulation binary)"
    ds.attrs["sha256"] = hashlib.sha256(checkpoint.binary).hexdigest()
    for key, value in checkpoint.state.items():
        ds.attrs[key] = value


def _spins_dataset(f: h5py.File, spins: np.ndarray) -> None:
    ds = f.create_dataset(CHECKPOINT_SPINS, data=np.asarray(spins, float))
    ds.attrs["units"] = "rad/s"
    ds.attrs["frame"] = SPIN_STATE_FRAME


def write_checkpoint(f: h5py.File, checkpoint, parts: Parts | None = None) -> None:
    """``/checkpoint`` (REBOUND binary, loop state, SHA-256), the spins and the resolver's
    statistics, in the run file or, when larger than ``parts.external_bytes``, the binary
    and the spins in a new part file the run file links."""
    if "checkpoint_new" in f:   # left by format 1.0's rename scheme
        del f["checkpoint_new"]
    spins = checkpoint.spins
    size = len(checkpoint.binary) + (0 if spins is None else np.asarray(spins).size * 8)
    for name in ("checkpoint", CHECKPOINT_SPINS):
        link = f.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink) or (name == CHECKPOINT_SPINS and link):
            del f[name]
    if parts is not None and size > parts.external_bytes:
        if "checkpoint" in f:
            del f["checkpoint"]
        with parts.new_file("checkpoint") as (part, target):
            _checkpoint_dataset(part, checkpoint)
            if spins is not None:
                _spins_dataset(part, spins)
        f["checkpoint"] = h5py.ExternalLink(target, "/checkpoint")
        if spins is not None:
            f[CHECKPOINT_SPINS] = h5py.ExternalLink(target, f"/{CHECKPOINT_SPINS}")
    else:
        _checkpoint_dataset(f, checkpoint)
        if spins is not None:
            _spins_dataset(f, spins)
    if checkpoint.statistics is not None:
        g = f.require_group(CHECKPOINT_STATISTICS)
        for name in set(g) - set(checkpoint.statistics):
            del g[name]
        for name, value in checkpoint.statistics.items():
            _overwrite(g, name, value)


def pack_links(f: h5py.File, run_path: Path) -> int:
    """Copy every item ``f`` links in a part file into ``f`` itself (compression kept);
    returns how many.  ``run_path`` is the run file (link targets are its own part files,
    `contents.part_file`, or refused).  The caller commits ``f`` and then removes the part
    files no longer linked."""
    packed = 0
    groups = [f] + ([f["snapshots"]] if "snapshots" in f else [])
    for group in groups:
        for key in list(group):
            link = group.get(key, getlink=True)
            if not isinstance(link, h5py.ExternalLink):
                continue
            source = contents.part_file(Path(run_path), str(link.filename), key)
            del group[key]
            with h5py.File(source, "r") as part:
                contents.check_links(part, run_path, part=True)
                group.copy(part[link.path], group, name=key)
            packed += 1
    return packed
