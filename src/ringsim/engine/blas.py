"""numpy's BLAS on one thread for the work of a run's set-up and outputs.

OpenBLAS, behind numpy's ``np.dot`` and ``@``, splits a sum of more than ~1e4 terms over
its threads (by default one per core) and adds the partial sums in an order that depends
on their number: the diagnostics and the momentum invariant of a large sheet would then
depend in the last bits on the number of cores of the machine, which breaks "same scenario
and seed, same bits", and its threads spin for such short products (docs/performance.md,
"Per-output work").  ``threadpoolctl`` limits every loaded BLAS library for the duration of
the call and restores the limits after.  On one core, and for sums of fewer than ~1e4
terms, BLAS uses one thread anyway: there the limit changes no result.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

from threadpoolctl import threadpool_limits

F = TypeVar("F", bound=Callable)


def one_blas_thread(function: F) -> F:
    """``function`` with BLAS limited to one thread while it runs (~0.1 ms per call)."""
    @functools.wraps(function)
    def limited(*args, **kwargs):
        with threadpool_limits(limits=1, user_api="blas"):
            return function(*args, **kwargs)
    return limited  # type: ignore[return-value]
