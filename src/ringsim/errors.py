"""Exceptions that mean "the user's input is wrong" (exit status 2 on the command line)."""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: a missing file, an invalid value, a refused overwrite.

    Parameters
    ----------
    file : str
        The file concerned (or "<command line>").
    key : str
        The key, option or item concerned.
    message : str
        What is wrong, in one line.
    """

    def __init__(self, file: str, key: str, message: str):
        self.file = str(file)
        self.key = key
        self.problem = message
        super().__init__(f"{self.file}: {key}: {message}")

    def __reduce__(self):
        # Exceptions are pickled via their args; ours has three (sweep points run in
        # worker processes, which send their errors back).
        return (type(self), (self.file, self.key, self.problem))
