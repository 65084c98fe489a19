"""stdout of the ``ringsim`` command that survives its reader going away.

``ringsim analyze RUN.h5 --plots figs | head`` closes the pipe after a few lines; the rest
of what the command prints is discarded, and its files are still written (cli.py's
docstring).
"""

from __future__ import annotations

import io
import os


class ClosedPipeSafeStdout(io.TextIOBase):
    """stdout that survives its reader going away: after the first BrokenPipeError the
    file descriptor is pointed at /dev/null (so the interpreter's final flush is quiet too)
    and the rest of the output is dropped."""

    def __init__(self, stream):
        self.stream = stream
        self.reader_gone = False

    def write(self, text: str) -> int:
        if not self.reader_gone:
            try:
                self.stream.write(text)
                if "\n" in text:
                    self.stream.flush()
            except BrokenPipeError:
                self._drop()
        return len(text)

    def flush(self) -> None:
        if not self.reader_gone:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self._drop()

    def _drop(self) -> None:
        self.reader_gone = True
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, self.stream.fileno())
        finally:
            os.close(devnull)

    def isatty(self) -> bool:
        return self.stream.isatty()

    def fileno(self) -> int:
        return self.stream.fileno()
