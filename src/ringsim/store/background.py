"""Commits made by a writer thread while the run goes on.

A commit of a large sheet (compressing and flushing a snapshot of 10^6 particles takes
seconds) would otherwise stop the integration; REBOUND integrates without Python's GIL, so
a thread can write meanwhile.  Commits stay one at a time and in order: a new one first
waits for the one before and raises its error if it failed.  What a commit writes is
handed over as copies that nobody changes afterwards.  A process killed during a commit
leaves the file of the last complete commit (``store.runfile.RunFileWriter``).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


class CommitThread:
    """One commit at a time in a background thread.

    Attributes
    ----------
    last_cost : float [s]
        Wall time of the last completed commit.
    """

    def __init__(self) -> None:
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self.last_cost = 0.0

    def _run(self, commit: Callable[[], None]) -> None:
        start = time.perf_counter()
        try:
            commit()
        except BaseException as exc:   # handed to the caller by wait()
            self._error = exc
        self.last_cost = time.perf_counter() - start

    def wait(self) -> None:
        """Wait for the commit in progress; raise its error if it failed."""
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        error, self._error = self._error, None
        if error is not None:
            raise error

    def join(self) -> None:
        """Wait for the commit in progress; its error, if any, is raised by the next
        `wait` or `submit` (this is for leaving on another error)."""
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def submit(self, commit: Callable[[], None], wait: bool = False) -> None:
        """Run ``commit`` after the one in progress, in the background unless ``wait``."""
        self.wait()
        if wait:
            self._run(commit)
            self.wait()
            return
        self._thread = threading.Thread(target=self._run, args=(commit,),
                                        name="ringsim-writer")
        self._thread.start()
