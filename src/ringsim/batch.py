"""Run scenarios to run files: the policy `ringsim sweep` and `ringsim study` share.

What happens to the run file a batch asks for (`existing_action`):

* no file: the scenario is run (``run``);
* a file whose status is ``finished`` (or ``failed``: reported as it is) is reused, not
  rerun (``reuse``);
* a file left ``running`` (its process died) or ``stopped`` (SIGINT/SIGTERM) continues
  from its last checkpoint, bit-identical to an uninterrupted run (``resume``), or is
  run again from the start when it has no checkpoint yet (``restart``), also when its
  process died before the first output, which leaves a file without time series;
* with ``extend=True`` (the study), a file whose scenario differs only by a smaller
  ``integration.orbits`` is continued to the longer duration (``extend``: ``ringsim run
  --resume`` with the larger value, docs/interface.md "Extending a run"); a file holding
  more orbits than asked is refused, since a run is only ever lengthened;
* a file made by any other scenario is never touched: bad input (exit status 2) naming the
  first key that differs.  ``integration.threads`` is not compared: it changes the speed,
  never a result.

A damaged file, a file of a newer format or a file another process is writing is refused
at planning too (``store.runfile.RunFileError``, ``store.lock``).

The executors (`run_local`, `run_dask`) send picklable tasks to a function in local worker
processes (``concurrent.futures.ProcessPoolExecutor``) or on a Dask cluster
(``dask.distributed.Client``) and hand each result to a callback as it arrives; a task that
raises is turned into a failed result by the caller's ``failed`` function.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import multiprocessing
import os
import signal
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as futures_completed
from pathlib import Path
from typing import Any

from ringsim.config.scenario import result_dict
from ringsim.errors import InputError

__all__ = [
    "ACTIONS",
    "LabelledStream",
    "dask_client",
    "existing_action",
    "first_difference",
    "run_dask",
    "run_local",
    "run_to_file",
]

#: What a batch does with one run file, in the order its plan line counts them.
ACTIONS = ("run", "restart", "resume", "extend", "reuse")
_RESUMABLE = ("running", "stopped")


def first_difference(a: Any, b: Any, prefix: str = "", asker: str = "the sweep") -> str | None:
    """The first dotted key whose values differ between two nested mappings, with both
    values (``a`` is the file's, ``b`` the one ``asker`` asks for)."""
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        for key in list(a) + [k for k in b if k not in a]:
            here = f"{prefix}.{key}" if prefix else str(key)
            if key not in a or key not in b:
                return f"{here} present in only one of them"
            found = first_difference(a[key], b[key], here, asker)
            if found:
                return found
        return None
    if a != b:
        return f"{prefix or '<scenario>'}: {a!r} in the file, {b!r} in {asker}"
    return None


def _compared(scenario, extend: bool) -> dict:
    """The scenario's keys that must agree with a run file's: all but the thread count
    (and, when a run may be extended, its duration)."""
    return result_dict(scenario, without_orbits=extend)


def existing_action(path: str | Path, scenario, *, extend: bool = False,
                    asker: str = "the sweep",
                    advice: str = "delete it or choose another --out") -> str:
    """How to treat an existing run file: ``reuse``, ``resume``, ``restart`` or ``extend``.

    Parameters
    ----------
    path : the run file
    scenario : Scenario the batch asks for
    extend : bool
        Whether a shorter run of the same scenario is lengthened (else it is a different
        scenario, refused).
    asker : str
        Who asks, for the message ("the sweep", "the study").
    advice : str
        What the user can do about a refused file.

    Raises
    ------
    InputError
        The file is damaged, of a newer format or being written by another process
        (``store.runfile.RunFileError``), was made by another scenario, holds more orbits
        than asked (with ``extend``) or has an unknown status.
    """
    from ringsim.store.runfile import RunFileError, open_run, read_checkpoint

    try:
        run = open_run(path)             # RunFileError: damaged, newer format, locked
    except RunFileError:
        made_by = _died_at_start(path)
        if made_by is None:
            raise
        _check_same(path, made_by, scenario, extend, asker, advice)
        return "restart"
    checkpoint = read_checkpoint(path)   # RunFileError: damaged checkpoint
    status = run.attrs.get("status")
    _check_same(path, run.scenario, scenario, extend, asker, advice)
    had, asked = run.scenario.integration.orbits, scenario.integration.orbits
    if extend and had > asked:
        raise InputError(str(path), "integration.orbits", f"the run file holds a run of "
                         f"{had:g} orbits, more than the {asked:g} {asker} asks for, and a "
                         f"run is only ever lengthened; ask for {had:g} orbits or {advice}")
    if status == "failed" or (status == "finished" and had == asked):
        return "reuse"
    if status == "finished" or status in _RESUMABLE:
        if checkpoint is None:
            return "restart"
        return "extend" if had < asked else "resume"
    raise InputError(str(path), "status", f"unknown run status {status!r}; {advice}")


def _check_same(path, made_by, scenario, extend: bool, asker: str, advice: str) -> None:
    difference = first_difference(_compared(made_by, extend), _compared(scenario, extend),
                                  asker=asker)
    if difference:
        raise InputError(str(path), "scenario", f"the existing run file was made by a "
                         f"different scenario ({difference}); {advice}")


def _died_at_start(path: str | Path):
    """The scenario of a run file whose process died before the run's first output (status
    ``running``, not a time-series row, snapshot or checkpoint written, nobody writing it),
    else None: such a file holds nothing to keep and is run again from the start."""
    import h5py

    from ringsim.config.scenario import scenario_from_text
    from ringsim.config.schema import ScenarioError
    from ringsim.store.lock import writer_of

    if writer_of(path) is not None:
        return None
    try:
        with h5py.File(path, "r") as f:
            status, text = f.attrs.get("status"), f.attrs.get("scenario_yaml")
            empty = ("checkpoint" not in f and "t" not in f.get("timeseries", {"t": 0})
                     and not len(f.get("snapshots", [0])))
        if not empty or status not in ("running", b"running") or text is None:
            return None
        return scenario_from_text(text.decode() if isinstance(text, bytes) else str(text),
                                  source=str(path))
    except (OSError, ValueError, ScenarioError):
        return None


def run_to_file(scenario, path: str | Path, action: str) -> None:
    """Do a planned action: run (``run``, ``restart``: over a file without a checkpoint),
    continue (``resume``, ``extend``) or nothing (``reuse``); no progress bar."""
    from ringsim.engine.runner import run

    if action in ("run", "restart"):
        run(scenario, output=path, force=action == "restart", progress=False)
    elif action in ("resume", "extend"):
        run(scenario, output=path, resume=True, progress=False)
    elif action != "reuse":
        raise ValueError(f"unknown action {action!r}")


class LabelledStream(io.TextIOBase):
    """A text stream that starts every line with a label and a colon (the run file a worker
    is on), so that the guard warnings of parallel workers say which run they come from."""

    def __init__(self, stream, label: str):
        self.stream = stream
        self.label = label
        self.at_line_start = True

    def write(self, text: str) -> int:
        pieces = []
        for piece in text.splitlines(keepends=True):
            if self.at_line_start and piece.strip():
                pieces.append(f"{self.label}: ")
            pieces.append(piece)
            self.at_line_start = piece.endswith(("\n", "\r"))
        self.stream.write("".join(pieces))
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return False


# --- executors --------------------------------------------------------------------------------

#: Linux's prctl option that sends a signal to a process when its parent ends.
_PR_SET_PDEATHSIG = 1
#: In a worker process: the pid of the process that made the pool, and the worker's
#: parent at its start (the same with the fork start method).
_POOL_OWNER: tuple[int, int] | None = None


def _quiet_worker(owner: int) -> None:
    """Worker processes ignore SIGINT between tasks, so that Ctrl-C never kills an idle
    worker, and end on SIGTERM (the handler of the parent they were forked from is not
    theirs); a run installs its own handlers and stops at a checkpoint (``engine.stop``).

    On Linux a worker gets SIGTERM when its parent ends (``PR_SET_PDEATHSIG``), and every
    worker checks before and after each task that its parent and ``owner`` (the pid of the
    process that made the pool) are still there (`_worker_task`), so no worker outlives a
    killed sweep or study."""
    global _POOL_OWNER
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _POOL_OWNER = (owner, os.getppid())
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    if _owner_gone():   # it ended before the prctl call
        os._exit(1)


def _owner_gone() -> bool:
    """In a worker: True if the process that made the pool has ended (the worker's parent
    changed, or that pid no longer exists)."""
    if _POOL_OWNER is None:
        return False
    owner, parent = _POOL_OWNER
    if os.getppid() != parent:
        return True
    try:
        os.kill(owner, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def _worker_task(fn: Callable[[Any], Any], task: Any) -> Any:
    """``fn(task)`` in a pool worker; a worker whose pool's owner is gone starts no task
    and exits after the one it ran (nobody would read the result; its run stopped at a
    checkpoint on the parent-death signal)."""
    if _owner_gone():
        os._exit(1)
    result = fn(task)
    if _owner_gone():
        os._exit(1)
    return result


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGTERM raises KeyboardInterrupt in this (main) thread while the pool runs."""
    def handler(signum, frame):
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:   # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_local(fn: Callable[[Any], Any], tasks: Sequence[Any], workers: int,
              report: Callable[[Any], None],
              failed: Callable[[Any, BaseException], Any]) -> None:
    """``fn(task)`` for every task in ``workers`` local processes; ``report`` receives each
    result as it arrives (``failed(task, exc)`` for a task that raised).

    On SIGINT or SIGTERM the tasks not started are dropped, the worker processes (the
    children of this process) are sent SIGTERM until they have ended (a run stops after the
    step in progress with a checkpoint, ``engine.stop``; an idle worker ends), and
    KeyboardInterrupt is raised.  SIGTERM, not SIGINT: an idle worker ignores SIGINT.
    A worker whose parent is gone exits (`_quiet_worker`).
    """
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_quiet_worker,
                               initargs=(os.getpid(),))
    try:
        with _sigterm_as_interrupt():
            futures = {pool.submit(_worker_task, fn, task): task for task in tasks}
            _collect(futures_completed(futures), futures, report, failed)
    except KeyboardInterrupt:
        pool.shutdown(wait=False, cancel_futures=True)
        _stop_children()
        raise
    pool.shutdown(wait=True)


def _collect(completed: Iterable[Any], task_of: Mapping[Any, Any],
             report: Callable[[Any], None],
             failed: Callable[[Any, BaseException], Any]) -> None:
    """``report`` the result of every future as it completes (``failed(task, exc)`` for a
    task that raised); ``task_of`` maps a future to its task."""
    for future in completed:
        try:
            result = future.result()
        except Exception as exc:  # noqa: BLE001 - any failure of one task is reported
            result = failed(task_of[future], exc)
        report(result)


def _stop_children(poll: float = 0.2) -> None:
    """Send SIGTERM to this process's children until none is left: a run stops after the
    step in progress, an idle worker ends, and a worker that took a queued task meanwhile
    gets the next signal (poll [s])."""
    while children := multiprocessing.active_children():
        for child in children:
            with contextlib.suppress(OSError):
                if child.pid is not None:
                    os.kill(child.pid, signal.SIGTERM)
        time.sleep(poll)


def dask_client(address: str):
    """A connected ``dask.distributed.Client``; InputError if Dask is missing or the
    scheduler cannot be reached."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError("<command line>", "--scheduler", "Dask is not installed: "
                         "pip install ringsim[dask]") from None
    try:
        return Client(address)
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError("<command line>", "--scheduler",
                         f"cannot connect to the Dask scheduler {address!r} ({exc})") from None


def run_dask(client, fn: Callable[[Any], Any], tasks: Sequence[Any],
             report: Callable[[Any], None],
             failed: Callable[[Any, BaseException], Any]) -> None:
    """``fn(task)`` for every task on the Dask cluster of ``client`` (``pure=False``: each
    task runs even if an equal one ran before); ``report`` and ``failed`` as in
    `run_local`."""
    from dask.distributed import as_completed

    futures = client.map(fn, list(tasks), pure=False)
    by_future = dict(zip(futures, tasks, strict=True))
    try:
        _collect(as_completed(futures), by_future, report, failed)
    except KeyboardInterrupt:   # tasks not started are dropped; running ones go on
        client.cancel(futures)
        raise
