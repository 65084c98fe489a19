"""A clean stop on SIGINT (Ctrl-C) and SIGTERM: a flag the run loop reads after every step.

Two handlers share the work (``csrc/rs_stop.c``):

* while ringsim's Python code runs (set-up, diagnostics, HDF5 writes), Python's handlers
  only set `StopRequest.requested`, so a signal never interrupts a half-written file;
* while REBOUND integrates, a C handler sets a flag that REBOUND's heartbeat reads after
  every step, so the integration ends after the step in progress.  The heartbeat also
  replaces the SIGINT handler REBOUND installs at the start of every integrate: REBOUND
  would drop a SIGINT that arrives between two integrations, and a second SIGINT inside
  a step would end that step half done.

Python's handlers are put back after every integrate before the C flag is read, so a
signal at any moment sets one of the two flags.
"""

from __future__ import annotations

import ctypes
import signal

import rebound

from ringsim.engine.native import _LIB

_LIB.rs_stop_arm.restype = ctypes.c_int
_LIB.rs_stop_arm.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
_LIB.rs_stop_take.restype = ctypes.c_int
_LIB.rs_stop_take.argtypes = [ctypes.c_void_p]
#: Address of REBOUND's own SIGINT counter (``volatile sig_atomic_t reb_sigint``).
_REBOUND_SIGINT = ctypes.addressof(ctypes.c_int.in_dll(rebound.clibrebound, "reb_sigint"))
#: Runs the Python handlers of signals that arrived while C code ran (raises what they
#: raise).
_check_python_signals = ctypes.pythonapi.PyErr_CheckSignals
_check_python_signals.restype = ctypes.c_int
_check_python_signals.argtypes = []


class StopRequest:
    """Turns SIGINT (Ctrl-C) and SIGTERM into a clean stop after the current step.

    Use as a context manager around a run (it installs its handlers, and puts the previous
    ones back at the end), and integrate with `integrate`.  While it is active, SIGXFSZ is
    ignored, so that a file size limit fails a write (EFBIG) instead of killing the run.
    Outside the main thread, signals are left alone and `integrate` is REBOUND's.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.requested = False
        self._previous: dict = {}

    def __enter__(self) -> StopRequest:
        for sig in self.SIGNALS:
            try:
                self._previous[sig] = signal.signal(sig, self._handler)
            except ValueError:  # not in the main thread: leave signals alone
                break
        if self._previous and hasattr(signal, "SIGXFSZ"):
            # a file size limit (ulimit -f) then fails the write (EFBIG, a clean error)
            # instead of killing the process mid-commit
            self._previous[signal.SIGXFSZ] = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        return self

    def _handler(self, signum: int, frame: object) -> None:
        self.requested = True

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)
        self._previous = {}

    def integrate(self, sim: rebound.Simulation, t_end: float) -> None:
        """``sim.integrate(t_end, exact_finish_time=0)`` [s], ended after the step in
        progress if SIGINT or SIGTERM arrives (`requested` is then True; the state is that
        of a complete step, so ``sim.t`` may be short of ``t_end``)."""
        if not self._previous:   # not active: no handlers of ours to put back
            sim.integrate(t_end, exact_finish_time=0)
            return
        address = ctypes.addressof(sim)
        if _LIB.rs_stop_arm(address, _REBOUND_SIGINT) != 0:
            raise OSError("cannot install the stop handler for SIGINT and SIGTERM")
        try:
            _check_python_signals()   # a signal caught by Python just before the C handler
            if not self.requested:
                sim.integrate(t_end, exact_finish_time=0)
        except KeyboardInterrupt:     # REBOUND's own handler, after a complete step
            self.requested = True
        finally:
            for sig in self.SIGNALS:
                signal.signal(sig, self._handler)
            if _LIB.rs_stop_take(address):
                self.requested = True
