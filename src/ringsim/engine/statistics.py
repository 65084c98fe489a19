"""The C resolver's collision statistics (``struct rs_stats``): read as numbers, saved and
restored field by field, and laid out as the run file's histograms.

The resolver accumulates, since its creation or the last reset:

* ``count``, ``n_floored`` (collisions whose impulse ``minimum_collision_velocity``
  raised), ``mean_epsilon`` and ``mean_vn`` [m/s] (NaN before the first collision);
* ``histograms``: normal impact speed [m/s] (``v_n``, 90 log bins from 1e-7 to 1e2 m/s)
  and dissipation 1 - eps (``one_minus_epsilon``, 40 log bins from 1e-4 to 1; eps = 1
  in the underflow, eps = 0 in the last bin), with under/overflow counts;
* ``log``: every ``log_every``-th collision (``t`` [s], ``v_n`` [m/s], ``R_bar`` [m],
  ``M_bar`` [kg], the law's ``epsilon``), the most recent ``log_capacity``, oldest first;
* ``multi_encounters``: resolved collisions in which one partner had already been
  deflected earlier in the step (by a partner of at least 10% of that pair's mass,
  ``MULTI_ENCOUNTER_MASS_SHARE``); over ``count``, how often swept-path detection's
  straight paths are stretched (``dt: auto`` keeps it near or below 1%);
* ``outside_speeds``, ``outside_sizes``: collisions outside the speeds and reduced radii
  the law's parameters were measured over; with friction the dissipation in the
  tangential and normal directions [J] and the sliding collisions
  (``native.FRICTION_STATISTICS``);
* ``speeds_below`` / ``_above``, ``sizes_below`` / ``_above``, ``masses_below`` /
  ``_above``: collisions below and above the measured speeds, reduced radii and reduced
  masses, ``critically_damped``: collisions whose law gives eps = 0 because its
  damping ratio xi >= 1, and ``inside_all``: collisions inside all three measured ranges
  at once (``native.RANGE_STATISTICS``).

``ResolverHandle.stats`` reads them with `summary`; ``stats_state``/``set_stats`` save and
restore them with `saved`, `checked` and `restore`, so that a checkpoint restores the
statistics of the open output interval bit for bit.  The friction and range fields are
restored as zero from a checkpoint that does not hold them, ``inside_all`` as `UNCOUNTED`.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ringsim.engine.native import (
    FRICTION_STATISTICS,
    LOG_DTYPE,
    ONE_MINUS_EPSILON_BIN_EDGES,
    RANGE_STATISTICS,
    VN_BIN_EDGES,
)
from ringsim.physics.pair_bins import pair_bin_sums

#: The counters of the law's measured range a run file's row holds, each as the time
#: series ``law_<name>``.
LAW_RANGE_COUNTERS = ("outside_speeds", "outside_sizes", *RANGE_STATISTICS)

#: ``inside_all`` restored from a checkpoint that lacks it: far below any count, so that the
#: open interval's row stays negative (not counted) whatever it adds.
UNCOUNTED = -(2**62)

#: numpy type of each scalar ctypes type of the statistics struct.
_NUMPY_TYPES = {ctypes.c_int64: np.int64, ctypes.c_double: np.float64}


def summary(stats: ctypes.Structure, log: np.ndarray, log_every: int) -> dict[str, Any]:
    """The statistics of the struct ``stats`` as numbers, with the sampled ``log`` (oldest
    first) and its stride ``log_every`` (the dict of ``ResolverHandle.stats``)."""
    count = int(stats.count)
    histograms = {
        "v_n": {
            "edges": VN_BIN_EDGES.copy(),
            "counts": np.ctypeslib.as_array(stats.vn_hist).copy(),
            "underflow": int(stats.vn_underflow),
            "overflow": int(stats.vn_overflow),
            "units": "m/s",
        },
        "one_minus_epsilon": {
            "edges": ONE_MINUS_EPSILON_BIN_EDGES.copy(),
            "counts": np.ctypeslib.as_array(stats.eps_hist).copy(),
            "underflow": int(stats.eps_underflow),
            "overflow": 0,
            "units": "1",
        },
    }
    return {
        "count": count,
        "n_floored": int(stats.n_floored),
        "mean_epsilon": stats.sum_epsilon / count if count else math.nan,
        "mean_vn": stats.sum_vn / count if count else math.nan,
        "sum_epsilon": float(stats.sum_epsilon),
        "sum_vn": float(stats.sum_vn),
        "histograms": histograms,
        "log": log,
        "log_written": int(stats.log_written),
        "log_every": log_every,
        **{name: getattr(stats, name) for name in ("multi_encounters", "outside_speeds",
                                                   "outside_sizes", *FRICTION_STATISTICS,
                                                   *RANGE_STATISTICS)},
    }


def law_rows(stats: Mapping[str, Any], edges: np.ndarray | None, density: float,
             log_capacity: int) -> dict[str, Any]:
    """The run-file row entries of the law's range (``law_<name>`` of `LAW_RANGE_COUNTERS`)
    and, with size bins [m] and a collision log (``log_capacity`` > 0), the interval's
    sampled collisions per pair of size bins (``size_bin_pair_collisions`` and
    ``size_bin_pair_epsilon_sum``, ``physics.pair_bins.pair_bin_sums``; particles of one
    ``density`` [kg/m^3])."""
    row: dict[str, Any] = {f"law_{name}": int(stats[name]) for name in LAW_RANGE_COUNTERS}
    log = stats["log"]
    if edges is not None and log_capacity > 0:
        counts, sums = pair_bin_sums(log["R_bar"], log["M_bar"], log["epsilon"], density,
                                     edges)
        row["size_bin_pair_collisions"], row["size_bin_pair_epsilon_sum"] = counts, sums
    return row


def resolver_rows(stats: Mapping[str, Any], edges: np.ndarray | None, density: float,
                  log_capacity: int) -> dict[str, Any]:
    """The run-file row entries of the C resolver's statistics beyond the count and the
    means: multiple encounters, the law's range (`law_rows`), the histograms and the
    normal dissipation [J]; none for statistics without histograms (REBOUND's resolver,
    ``engine.hardsphere``, which does not tally them)."""
    if "histograms" not in stats:
        return {}
    return {"multi_encounters": int(stats["multi_encounters"]),
            **law_rows(stats, edges, density, log_capacity),
            "one_minus_epsilon_histogram": with_outer_bins(stats["histograms"]
                                                           ["one_minus_epsilon"]),
            "impact_speed_histogram": with_outer_bins(stats["histograms"]["v_n"]),
            "normal_dissipation": float(stats["normal_dissipation"])}


def checked_log(log_capacity: Any, log_every: Any) -> tuple[int, int]:
    """``log_capacity`` (entries kept, >= 0) and ``log_every`` (stride, >= 1) as ints;
    ValueError naming the argument otherwise."""
    if isinstance(log_capacity, bool) or not isinstance(log_capacity, (int, np.integer)) \
            or log_capacity < 0:
        raise ValueError(f"log_capacity: must be an integer >= 0, got {log_capacity!r}")
    if isinstance(log_every, bool) or not isinstance(log_every, (int, np.integer)) \
            or log_every < 1:
        raise ValueError(f"log_every: must be an integer >= 1, got {log_every!r}")
    return int(log_capacity), int(log_every)


def log_buffer(address: int, capacity: int) -> np.ndarray:
    """The C ring buffer of ``capacity`` log entries at ``address`` as a writable numpy
    view of :data:`LOG_DTYPE` (empty without a log)."""
    if capacity == 0:
        return np.zeros(0, dtype=LOG_DTYPE)
    raw = (ctypes.c_char * (capacity * LOG_DTYPE.itemsize)).from_address(address)
    # numpy's stubs do not list ctypes arrays among frombuffer's buffers
    return np.frombuffer(raw, dtype=LOG_DTYPE)  # type: ignore[call-overload]


def oldest_first(entries: np.ndarray, written: int) -> np.ndarray:
    """The logged collisions of the ring buffer ``entries``, of which ``written`` were ever
    logged, oldest first (a copy)."""
    capacity = entries.size
    if capacity == 0 or written == 0:
        return np.zeros(0, dtype=LOG_DTYPE)
    if written <= capacity:
        return entries[:written].copy()
    return np.roll(entries, -(written % capacity)).copy()


def histogram_edges() -> dict[str, np.ndarray]:
    """Edges of the run file's histograms: the resolver's bins plus an underflow bin from
    0 (and for speeds an overflow bin to infinity)."""
    return {"one_minus_epsilon_histogram": np.concatenate([[0.0], ONE_MINUS_EPSILON_BIN_EDGES]),
            "impact_speed_histogram": np.concatenate([[0.0], VN_BIN_EDGES, [np.inf]])}


def with_outer_bins(histogram: dict) -> np.ndarray:
    """Counts of one of `summary`'s histograms as the run file stores them: the underflow
    first (and the overflow last when the edges end below infinity)."""
    counts = [np.array([histogram["underflow"]]), np.asarray(histogram["counts"])]
    if histogram["units"] == "m/s":
        counts.append(np.array([histogram["overflow"]]))
    return np.concatenate(counts).astype(np.int64)


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
        elif name == "inside_all":
            # a checkpoint from before the joint count: the open interval's count is
            # unknown, so its row is written negative and left out (analysis.law_range)
            value = np.asarray(UNCOUNTED, _NUMPY_TYPES[ctype])
        elif name in FRICTION_STATISTICS or name in RANGE_STATISTICS:
            # a checkpoint from before friction or before the split ranges
            value = np.zeros((), _NUMPY_TYPES[ctype])
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
