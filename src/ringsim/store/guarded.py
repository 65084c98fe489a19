"""HDF5 files written through a file object that a full disk cannot wedge.

When a write fails (ENOSPC: the disk is full; EFBIG: ``ulimit -f``; EDQUOT: the quota),
HDF5's own drivers leave the file open in the library with data it can never flush: the
close fails, the file stays open, and the library's clean-up at the interpreter's exit
crashes the process (a segmentation fault, after a traceback per open object).  Here HDF5
writes through `GuardedFile` (h5py's ``fileobj`` driver): the first failed write is kept,
later writes are dropped, so that HDF5 always closes the file, and `h5_file` then raises
the kept error.  A file written that way is incomplete and is deleted by its caller (every
such file is a temporary copy or a new part file, ``store.runfile``, ``store.bulk``).
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
from collections.abc import Iterator

import h5py

#: errno values of a full disk: no space, a file size limit (``ulimit -f``), a quota.
DISK_FULL = (errno.ENOSPC, errno.EFBIG, errno.EDQUOT)


class GuardedFile(io.RawIOBase):
    """An unbuffered binary file whose first failed write or truncate is kept in `error`
    instead of raised; what follows it is dropped (reads go on)."""

    def __init__(self, path: str | os.PathLike, mode: str):
        super().__init__()
        self.file = io.FileIO(path, mode)
        self.error: OSError | None = None

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        return self.file.readinto(buffer) or 0

    def write(self, data) -> int:
        view = memoryview(data).cast("B")
        total = len(view)
        while self.error is None and len(view):
            try:
                written = self.file.write(view)
            except OSError as exc:
                self.error = exc
                break
            if not written:
                self.error = OSError(28, "no byte written (no space left on device)")
                break
            view = view[written:]
        return total

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        return self.file.seek(offset, whence)

    def tell(self) -> int:
        return self.file.tell()

    def truncate(self, size: int | None = None) -> int:
        if self.error is None:
            try:
                return self.file.truncate(size)
            except OSError as exc:
                self.error = exc
        return self.file.tell() if size is None else size

    def flush(self) -> None:
        """Nothing is buffered here (the writes go straight to the operating system)."""

    def close(self) -> None:
        if not self.closed:
            self.file.close()
        super().close()


@contextlib.contextmanager
def h5_file(path: str | os.PathLike, mode: str) -> Iterator[h5py.File]:
    """An HDF5 file at ``path`` opened with ``mode`` (``"w"``: new, ``"a"``: existing, both
    read-write) through a `GuardedFile`; at the end it is closed, and the first failed
    write raises its OSError (the file is then incomplete)."""
    raw = GuardedFile(path, "w+" if mode == "w" else "r+")
    try:
        with h5py.File(raw, mode) as f:
            yield f
            f.flush()
    except Exception:
        if raw.error is not None:   # what HDF5 made of the dropped writes: not the cause
            raise _named(raw.error, path) from None
        raise
    finally:
        raw.close()
    if raw.error is not None:
        raise _named(raw.error, path)


def _named(error: OSError, path: str | os.PathLike) -> OSError:
    """``error`` with the file's name (os.write's errors have none)."""
    return OSError(error.errno, error.strerror or str(error), os.fspath(path))


@contextlib.contextmanager
def full_disk(path: str | os.PathLike) -> Iterator[None]:
    """Turn a full disk (`DISK_FULL`) while the run file ``path`` is written into an
    OSError whose one line says what the file keeps and what to do: ``--resume`` once
    there is space if it holds a checkpoint, else run again with ``--force``."""
    try:
        yield
    except OSError as exc:
        if exc.errno not in DISK_FULL:
            raise
        try:
            with h5py.File(path, "r") as f:
                kept = "checkpoint" in f
        except OSError:
            kept = False
        advice = (f"{os.fspath(path)} keeps its last commit; continue it with --resume once "
                  "there is space" if kept else f"{os.fspath(path)} holds no checkpoint "
                  "yet; run it again with --force once there is space")
        raise OSError(exc.errno, f"{exc.strerror} writing {exc.filename or os.fspath(path)}: "
                      f"{advice}") from None
