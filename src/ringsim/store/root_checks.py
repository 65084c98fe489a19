"""The box a run file states, checked before it is used: the root attributes ``Omega``
[1/s], ``Lx`` and ``Ly`` [m], ``root_size`` [m] (positive, finite numbers) and
``N_root_x``, ``N_root_y`` (whole numbers from 1 to `MAX_ROOT_BOXES`).

A file with a non-finite or non-positive box (NaN, inf, 0, a negative size, a text) is bad
input: `check_box` raises `RunFileError` naming the file and the attribute, before an
analysis or a start from the file computes anything from it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ringsim.errors import excerpt
from ringsim.store.runfile import RunFileError

#: Most root boxes along a side of a sheet (ringsim's boxes have a few to a few hundred).
MAX_ROOT_BOXES = 10**6
_LENGTHS = ("Omega", "Lx", "Ly", "root_size")
_COUNTS = ("N_root_x", "N_root_y")


def _number(value: object) -> float:
    """The value as a float; NaN for anything that is not a real number (bool, text)."""
    if isinstance(value, (bool, np.bool_)):
        return math.nan
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    return math.nan


def check_box(attrs: Mapping[str, object], path) -> None:
    """Raise `RunFileError` if a box attribute present in ``attrs`` is not a finite
    positive number (counts: a whole number in [1, MAX_ROOT_BOXES])."""
    for name in _LENGTHS + _COUNTS:
        if name not in attrs:
            continue
        value = attrs[name]
        x = _number(value)
        good = math.isfinite(x) and x > 0
        if good and name in _COUNTS:
            good = x == math.floor(x) and x <= MAX_ROOT_BOXES
        if not good:
            allowed = (f"a whole number from 1 to {MAX_ROOT_BOXES}" if name in _COUNTS
                       else "a finite number > 0")
            raise RunFileError(path, f"the attribute {name} is {excerpt(value)} ({allowed})",
                               name)
