"""A run that ends in an unexpected error leaves a file that says ``failed`` and why.

A runtime invariant is caught by the run loop itself (``Runner.fail``); any other error
inside the loop (a REBOUND integration error, an error in a gravity solver's callback, a
failed write) reaches `record_failure`, which keeps the last checkpoint, writes the rows
gathered since, a guard event and ``status = "failed"`` with the reason in ``failure``,
and lets the error go on to the caller (exit status 1 on the command line).  A full disk is
not a failure of the run: the file keeps its last commit and ``--resume`` continues it once
there is space (``store.guarded.full_disk`` says so in one line), so it is left as it is.
"""

from __future__ import annotations

import sys

from ringsim.errors import clip
from ringsim.store.guarded import DISK_FULL

#: Longest reason stored in the ``failure`` attribute [characters].
MAX_REASON_CHARS = 500


def failure_reason(error: BaseException) -> str:
    """One line: the error's type and a bounded excerpt of its message."""
    message = clip(str(error), MAX_REASON_CHARS)
    return f"{type(error).__name__}: {message}" if message else type(error).__name__


def record_failure(runner, error: Exception) -> None:
    """Mark ``runner``'s file ``failed`` with the reason of ``error`` (see module
    docstring).  A second error while writing is printed, and the first one goes on."""
    if isinstance(error, OSError) and error.errno in DISK_FULL:
        return      # nothing can be written; the last commit stays for --resume
    reason = failure_reason(error)
    try:
        runner._guard_event(f"FAILED at orbit {runner.sim.t / runner.orbit:.4f}: {reason}; "
                            "the checkpoint is the last good state before it")
        runner._commit(attributes={"status": "failed", "failure": reason})
    except Exception as secondary:   # noqa: BLE001 - printed; the first error goes on
        print(f"ringsim: the run file could not be marked failed: "
              f"{failure_reason(secondary)}", file=sys.stderr)
