"""A clean stop on SIGINT (Ctrl-C) and SIGTERM: a flag the run loop reads at every output."""

from __future__ import annotations

import signal


class StopRequest:
    """Turns SIGINT (Ctrl-C) and SIGTERM into a clean stop at the next output.

    While REBOUND integrates, its own SIGINT handler stops the integration after the
    current step and the Python wrapper raises KeyboardInterrupt (caught by the loop);
    while ringsim's Python code runs (diagnostics, HDF5 writes), these handlers only set a
    flag, so a signal never interrupts a half-written file.
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
        return self

    def _handler(self, signum: int, frame: object) -> None:
        self.requested = True

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)
