"""Exceptions that mean "the user's input is wrong" (exit status 2 on the command line)."""

from __future__ import annotations

import reprlib


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


#: Largest integer shown whole in an error message [bits] (about 60 digits).
_SHOWN_INTEGER_BITS = 200


class _Excerpt(reprlib.Repr):
    """reprlib's bounded rendering, with integers sized by their bits before any text is
    made of them (a 5000-digit integer is never converted to text)."""

    def repr_int(self, x: int, level: int) -> str:
        if abs(x).bit_length() > _SHOWN_INTEGER_BITS:
            return f"<an integer of about {int(abs(x).bit_length() * 0.30103) + 1} digits>"
        return super().repr_int(x, level)


def excerpt(value: object, limit: int = 60) -> str:
    """A one-line rendering of a user's value for an error message, at most ``limit``
    characters; its cost does not grow with the value (strings, lists and mappings are
    cut before they are rendered, nested ones shown to two levels)."""
    shown = _Excerpt()
    shown.maxlevel, shown.maxstring, shown.maxother = 2, max(limit - 3, 8), limit
    shown.maxlist = shown.maxtuple = shown.maxdict = shown.maxset = 4
    text = " ".join(shown.repr(value).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def clip(text: str, limit: int = 300) -> str:
    """A text on one line, at most ``limit`` characters (its middle cut out)."""
    if len(text) > 4 * limit:           # never split the whole of a huge text
        text = text[:2 * limit] + " " + text[-2 * limit:]
    text = " ".join(text.split())
    if len(text) <= limit:
        return text
    half = (limit - 5) // 2
    return f"{text[:half]} ... {text[-half:]}"
