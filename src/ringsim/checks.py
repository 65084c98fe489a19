"""Argument checks shared by the pure numpy functions (ValueError naming the argument)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def finite_array(name: str, value: ArrayLike) -> FloatArray:
    a = np.asarray(value, dtype=float)
    if a.ndim != 1:
        a = a.reshape(-1)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


def same_length(**arrays: FloatArray) -> int:
    lengths = {name: a.size for name, a in arrays.items()}
    n = next(iter(lengths.values()))
    if any(size != n for size in lengths.values()):
        raise ValueError(f"arrays must have equal lengths, got {lengths}")
    if n == 0:
        raise ValueError("no particles")
    return n


def positive(name: str, value: float) -> float:
    x = float(value)
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return x


def nonnegative_array(name: str, value: ArrayLike) -> FloatArray:
    a = finite_array(name, value)
    if np.any(a < 0.0):
        raise ValueError(f"{name} must be >= 0")
    return a

