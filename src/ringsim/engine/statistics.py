"""Saving and restoring the C resolver's statistics (``struct rs_stats``) field by field.

``ResolverHandle.stats_state``/``set_stats`` use these so a checkpoint restores the
statistics of the open output interval bit for bit.  The friction fields appended to the
struct (``native.FRICTION_STATISTICS``) are restored as zero from checkpoints written
before they existed.
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping
from typing import Any

import numpy as np

from ringsim.engine.native import FRICTION_STATISTICS

#: numpy type of each scalar ctypes type of the statistics struct.
_NUMPY_TYPES = {ctypes.c_int64: np.int64, ctypes.c_double: np.float64}


def _fields(stats: ctypes.Structure) -> list[tuple[str, Any]]:
    """(name, ctypes type) of every field of the struct."""
    return [(field[0], field[1]) for field in stats._fields_]


def saved(stats: ctypes.Structure) -> dict[str, np.ndarray]:
    """Every field of the struct as a numpy array (scalars 0-d), copied."""
    state = {}
    for name, ctype in _fields(stats):
        value = getattr(stats, name)
        if issubclass(ctype, ctypes.Array):
            state[name] = np.ctypeslib.as_array(value).copy()
        else:
            state[name] = np.array(value, dtype=_NUMPY_TYPES[ctype])
    return state


def checked(stats: ctypes.Structure, state: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The fields of ``state`` for the struct, each with its shape; ValueError naming the
    first missing or misshapen field (friction fields missing: zero)."""
    values = {}
    for name, ctype in _fields(stats):
        if name in state:
            value = np.asarray(state[name])
        elif name in FRICTION_STATISTICS:
            value = np.zeros((), _NUMPY_TYPES[ctype])   # a checkpoint from before friction
        else:
            raise ValueError(f"statistics: {name} missing")
        expected = (ctype._length_,) if issubclass(ctype, ctypes.Array) else ()
        if value.shape != expected:
            raise ValueError(f"statistics: {name} has shape {value.shape}, "
                             f"expected {expected}")
        values[name] = value
    return values


def restore(stats: ctypes.Structure, values: Mapping[str, np.ndarray]) -> None:
    """Write checked values (:func:`checked`) into the struct."""
    for name, ctype in _fields(stats):
        if issubclass(ctype, ctypes.Array):
            np.ctypeslib.as_array(getattr(stats, name))[...] = values[name]
        else:
            setattr(stats, name, values[name].item())
