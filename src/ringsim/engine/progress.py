"""Progress of a run on the terminal (a tqdm bar) or in a log (plain lines)."""

from __future__ import annotations

import sys
import time

#: A progress line is written at most this often [s of wall time] when stderr is not a
#: terminal (a log file or a pipe gets plain lines instead of a carriage-return bar).
PROGRESS_LOG_INTERVAL = 30.0


class ProgressLog:
    """The part of tqdm's interface the run loop uses, writing a plain line to stderr at
    most every ``interval`` seconds and one at the end."""

    def __init__(self, name: str, total: float, initial: float, interval: float,
                 stream=None):
        self.name, self.total, self.n = name, total, initial
        self.interval = interval
        self.stream = stream if stream is not None else sys.stderr
        self.postfix = ""
        self.start = self.last = time.monotonic()

    def update(self, delta: float) -> None:
        self.n += delta
        if time.monotonic() - self.last >= self.interval:
            self._write()

    def set_postfix_str(self, text: str) -> None:
        self.postfix = text

    def close(self) -> None:
        self._write()

    def _write(self) -> None:
        self.last = time.monotonic()
        elapsed = int(self.last - self.start)
        fraction = self.n / self.total if self.total else 1.0
        extra = f", {self.postfix}" if self.postfix else ""
        self.stream.write(f"{self.name}: {self.n:.2f}/{self.total:g} orbits "
                          f"({fraction:.0%}) after {elapsed // 3600}:{elapsed // 60 % 60:02d}:"
                          f"{elapsed % 60:02d}{extra}\n")
        self.stream.flush()


def progress_bar(scenario, done_orbits: float):
    """A tqdm bar on a terminal; plain lines every PROGRESS_LOG_INTERVAL s otherwise."""
    if not sys.stderr.isatty():
        return ProgressLog(scenario.name, scenario.integration.orbits, done_orbits,
                            PROGRESS_LOG_INTERVAL)
    from tqdm import tqdm

    return tqdm(total=scenario.integration.orbits, initial=done_orbits, unit="orbit",
                mininterval=0.5, desc=scenario.name, bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                "{n:.2f}/{total:g} orbits [{elapsed}<{remaining}{postfix}]")
