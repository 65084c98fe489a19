"""A run file's box and the shapes of its arrays, checked before they are used.

* `check_box`: the root attributes ``Omega`` [1/s], ``Lx`` and ``Ly`` [m], ``root_size``
  [m] (positive, finite numbers) and ``N_root_x``, ``N_root_y`` (whole numbers from 1 to
  `MAX_ROOT_BOXES`);
* `check_arrays`: every time series a number array of one row per output (``t``'s
  length; the per-bin series, ``size_bin_*`` and ``*_histogram``, ``(rows, bins)``), the
  time, step, optical depth and counts finite (counts >= 0); every snapshot's particle
  arrays numbers of one length.

A file that fails (NaN, inf, 0 or a negative box size, a text, rows of unequal lengths, a
snapshot of mismatched arrays) is bad input: `RunFileError` names the file and the item,
before ``analyze``, ``compare``, ``export`` or a start from the file computes anything.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import h5py
import numpy as np

from ringsim import quantities
from ringsim.errors import excerpt
from ringsim.store.bulk import SNAPSHOT_FIELDS, SPIN_FIELDS
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


def _is_numbers(array: np.ndarray) -> bool:
    return np.issubdtype(array.dtype, np.number) and not np.issubdtype(array.dtype,
                                                                      np.complexfloating)


#: Time series that are finite in every row a run writes (the time, the step, the optical
#: depth and the collisions' momentum transport); counts are finite and >= 0 too.
_FINITE = ("t", "orbits", "dt", "optical_depth", "collisions_plog")


def _is_count(name: str) -> bool:
    quantity = quantities.QUANTITY.get(name)
    return quantity is not None and quantity.unit == "count"


#: A count below this is `law_inside_all`'s row of an interval resumed from a checkpoint
#: without it (``engine.statistics.UNCOUNTED`` plus what the interval counted).
_UNCOUNTED_BELOW = -1e18


def _counted(name: str, values: np.ndarray) -> np.ndarray:
    """Where a count is valid: >= 0, or -1 in the rows written before the series existed
    (``store.runfile._append_rows``), or for ``law_inside_all`` not counted (below
    `_UNCOUNTED_BELOW`)."""
    ok = (values >= 0) | (values == -1)
    return ok | (values < _UNCOUNTED_BELOW) if name == "law_inside_all" else ok


def _per_bin(name: str) -> bool:
    """A time series with one column per bin (size bins, histograms): rows x bins."""
    return name.startswith("size_bin_") or name.endswith("_histogram")


def check_arrays(run) -> None:
    """Raise `RunFileError` if a time series of ``run`` (a `store.runfile.Run`) is not a
    number array with one row per output, or a snapshot's particle arrays are not number
    arrays of one length (every snapshot's datasets, from their shapes and types)."""
    series = run.timeseries
    t = series.get("t")
    if t is None or t.ndim != 1 or not _is_numbers(t) or t.size < 1:
        raise RunFileError(run.path, "the time series t is not a list of times", "t")
    for name, values in series.items():
        if name.endswith("_edges"):    # bin edges: one list, not rows
            good = values.ndim == 1 and values.size >= 2
        else:
            good = values.ndim == (2 if _per_bin(name) else 1) and values.shape[0] == t.size
        if not (good and _is_numbers(values)):
            raise RunFileError(run.path, f"the time series {name} has shape {values.shape} "
                               f"and type {values.dtype} ({t.size} rows of numbers)", name)
        if _is_count(name):
            if not bool(np.all(np.isfinite(values) & _counted(name, values))):
                raise RunFileError(run.path, f"the time series {name} holds values that are "
                                   "not finite or negative (other than a row not counted)",
                                   name)
        elif name in _FINITE and not bool(np.all(np.isfinite(values))):
            raise RunFileError(run.path, f"the time series {name} holds values that are not "
                               "finite", name)
    with h5py.File(run.path, "r") as f:   # shapes and types only: no data is read
        for i, name in enumerate(sorted(f["snapshots"])):
            _check_snapshot(run.path, i, f["snapshots"][name])


def _check_snapshot(path, i: int, group) -> None:
    """The particle datasets of one snapshot group: 1-D numbers of one length."""
    n = group["radius"].shape if "radius" in group else ()
    for name in SNAPSHOT_FIELDS + SPIN_FIELDS:
        if name not in group and name in SPIN_FIELDS:
            continue
        values = group.get(name)
        shape = getattr(values, "shape", None)
        dtype = getattr(values, "dtype", np.dtype(object))
        if shape is None or len(shape) != 1 or shape != n or shape[0] < 1 \
                or not _is_numbers(np.empty(0, dtype=dtype)):
            raise RunFileError(path, f"snapshot {i}: {name} has shape {shape} and type "
                               f"{dtype} (one number per particle, {n[0] if n else 0} "
                               "particles)", f"snapshots/{name}")
