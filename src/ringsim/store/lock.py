"""One writer per run file: a lock file beside it, held with ``fcntl.flock``.

``RUN.h5.lock`` holds the writer's pid, host and start time (JSON) for the messages; the
exclusion itself is the kernel's ``flock`` on that file, which is released when the writer
exits for whatever reason (normal end, exception, SIGKILL, scheduler kill).  So a lock file
left behind by a killed process is recognised as stale without guessing from pids: nobody
holds its ``flock``, and the next writer takes it over.  Only when the file system refuses
``flock`` altogether (some network mounts) does the lock fall back to the recorded pid: a
lock of a pid that no longer runs on this host is stale, one of another host is respected.

The lock file is removed when the writer releases it.  Removal and acquisition race in the
classic way (B opens the old file, A removes it, C creates a new one); a writer that got the
``flock`` therefore checks that the path still names the inode it locked, and retries if not.
"""

from __future__ import annotations

import datetime as _dt
import errno
import fcntl
import json
import os
import socket
import time
from pathlib import Path

from ringsim.errors import InputError
from ringsim.store.paths import refuse_links

#: flock errors that mean "this file system has no flock" (not "someone holds it").
_NO_FLOCK = (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL)


def lock_path(path: str | os.PathLike) -> Path:
    """The lock file of a run file: ``RUN.h5.lock`` beside it."""
    path = Path(path)
    return path.with_name(path.name + ".lock")


#: How long [s] a refused writer waits for the holder's record to appear: the holder
#: takes the lock first and writes its record just after, so a writer refused in between
#: would otherwise find an empty record (seen under load in tests/test_hardening.py).
RECORD_WAIT = 2.0


def _describe(lock_file: Path) -> str:
    """Who holds a lock, from its JSON record ("another process" if it stays unreadable
    for ``RECORD_WAIT``)."""
    deadline = time.monotonic() + RECORD_WAIT
    while True:
        try:
            info = json.loads(lock_file.read_text())
            return (f"process {int(info['pid'])} on {info['host']} (since "
                    f"{info['started_utc']})")
        except (OSError, ValueError, KeyError, TypeError):
            if time.monotonic() >= deadline:
                return "another process"
            time.sleep(0.02)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:   # exists, owned by someone else
        return True
    return True


def _is_this_process(lock_file: Path) -> bool:
    """The lock record names this process (a writer reading its own file)."""
    try:
        info = json.loads(lock_file.read_text())
        return int(info["pid"]) == os.getpid() and info["host"] == socket.gethostname()
    except (OSError, ValueError, KeyError, TypeError):
        return False


def _record_says_alive(lock_file: Path) -> bool:
    """Fallback without flock: the recorded writer still runs (or runs on another host)."""
    try:
        info = json.loads(lock_file.read_text())
        pid, host = int(info["pid"]), str(info["host"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    if _is_this_process(lock_file):
        return False
    return host != socket.gethostname() or _pid_alive(pid)


class RunFileLock:
    """The exclusive right to write one run file; a context manager.

    Parameters
    ----------
    path : the run file (the lock is ``path + ".lock"``)

    Raises
    ------
    InputError (on :meth:`acquire`)
        Another live process writes the file; the message names it (exit status 2).
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.file = lock_path(self.path)
        self._fd: int | None = None

    def acquire(self) -> RunFileLock:
        """Take the lock; InputError if a writer holds it, or if a name the run file owns
        is a symbolic link (``store.paths.refuse_links``: nothing is created then)."""
        refuse_links(self.path)
        self.file.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.file, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise InputError(str(self.path), "run file", "is being written by "
                                 f"{_describe(self.file)}; one writer per file (lock "
                                 f"{self.file})") from None
            except OSError as exc:
                if exc.errno not in _NO_FLOCK:
                    os.close(fd)
                    raise
                if _record_says_alive(self.file):
                    os.close(fd)
                    raise InputError(str(self.path), "run file", "is being written by "
                                     f"{_describe(self.file)}; one writer per file (lock "
                                     f"{self.file}; this file system has no flock)") from None
            try:
                same = os.stat(self.file).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)   # the lock file was replaced while we waited: try again
        record = {"pid": os.getpid(), "host": socket.gethostname(),
                  "started_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(
                      timespec="seconds")}
        os.ftruncate(fd, 0)
        os.write(fd, json.dumps(record).encode())
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.file.unlink()
        except FileNotFoundError:
            pass
        os.close(self._fd)   # closing drops the flock
        self._fd = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def __enter__(self) -> RunFileLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def writer_of(path: str | os.PathLike) -> str | None:
    """Who is writing ``path`` now (a description), or None if nobody is.

    Read-only: opens an existing lock file and tries a shared ``flock`` on it, which fails
    while a writer holds its exclusive one; never creates or changes a file.
    """
    lock_file = lock_path(path)
    try:
        fd = os.open(lock_file, os.O_RDONLY | os.O_NOFOLLOW)
    except (FileNotFoundError, PermissionError):
        return None
    except OSError as exc:   # ELOOP: a link in its place, which no writer of ringsim holds
        if exc.errno == errno.ELOOP:
            return None
        raise
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return None if _is_this_process(lock_file) else _describe(lock_file)
        except OSError as exc:
            if exc.errno not in _NO_FLOCK:
                raise
            return _describe(lock_file) if _record_says_alive(lock_file) else None
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)
