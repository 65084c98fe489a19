"""What the ``ringsim`` command line reads and prints through: stdout that survives its
reader going away, and an argument parser whose usage errors are bad input.

A reader that closes stdout early (``ringsim analyze RUN.h5 --plots figs | head``) does not
stop a command: the rest of what it prints is discarded, its files (figures, JSON, run
files) are still written, and the exit status is the command's own (0 on success).  The
closed pipe is not an error of ringsim: a shell script with ``set -o pipefail`` is not
failed by ``head`` taking the lines it wanted.
"""

from __future__ import annotations

import argparse
import io
import os

from ringsim.errors import InputError


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


class Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as bad input (status 2) in one line."""

    def error(self, message):
        raise InputError("<command line>", self.prog, message)
