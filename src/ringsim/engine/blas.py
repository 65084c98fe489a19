"""numpy's BLAS on one thread for the work of a run's outputs.

OpenBLAS, behind numpy's ``np.dot`` and ``@``, splits a sum of more than ~1e4 terms over
its threads (by default one per core) and adds the partial sums: the diagnostics and the
momentum invariant of a sheet of 1e5 particles then depend in the last bits on the number
of cores of the machine (measured: a mass-weighted mean of 1e5 velocities differs between 1
and 2 threads), which breaks "same scenario and seed, same bits".  Its threads also spin
for such short products: at N = 1e5 the momentum of an output cost 32 ms of CPU on 2
threads against 0.6 ms on one.  ``threadpoolctl`` limits every loaded BLAS library for the
duration of the call and restores the limits after.  Results on a one-core machine and on
runs of fewer than ~1e4 particles are unchanged.
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
