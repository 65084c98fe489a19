"""ringsim's swept-sphere sheet detector (``csrc/rs_sheet_detect.c``) seen from Python: its
counters and a search without resolution, for tests and diagnostics.

The detector is the collision search of ``collision_detection="line"``: it runs inside
REBOUND's step as ``post_timestep_modifications`` of a simulation with ringsim's resolver
(``engine.resolver.ResolverHandle``), finds the pairs whose straight paths within the step
touch, and resolves them at their first contact in time order.  Its counters live in the
resolver's C struct; ``ResolverHandle.order_stats``, ``detector_stats`` and
``detect_pairs`` read them through the functions here.  Its threads are set with
``engine.native.set_detector_threads``.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np
import rebound

from ringsim.engine.native import _LIB, DETECTOR_ERRORS


def order_counters(address: int) -> dict[str, int]:
    """Counters of the time-ordered resolution of the resolver at ``address`` since its
    creation.

    Returns
    -------
    dict with ``resolved`` (contacts resolved), ``rescheduled`` (of which timed on a
    path changed earlier in the same step), ``rechecks`` (one per particle and
    collision), ``wide_rechecks`` (of which wider than the largest pair distance s),
    ``span_limited`` (of which cut at the largest search span) and ``saturated``
    (particles that reached the most contacts per step).  All zero before the first
    search or without the sheet detector.
    """
    out = (ctypes.c_int64 * 6)()
    _LIB.rs_sheet_order_counters(address, out)
    names = ("resolved", "rescheduled", "rechecks", "wide_rechecks", "span_limited",
             "saturated")
    return dict(zip(names, (int(v) for v in out), strict=True))


def search_counters(address: int) -> dict[str, Any]:
    """Counters of the search of the resolver at ``address`` since its creation.

    Returns
    -------
    dict with ``steps`` (searches run), ``candidates`` (pairs whose straight paths
    were tested), ``reports`` (pairs passed to the resolver), ``cells`` and
    ``cell_size`` [m] of the last search's grid (all its classes' cells; the least
    cell side of its class of the largest reaches), ``error`` (text; "none" if the last
    search succeeded), ``half_shell`` (whether the last search looked at each pair
    of the primary box from one side only, rs_sheet_detect.c Method 3) and ``classes``
    (the reach classes of the last search, each with its own grid, Method 2a; 1: one
    grid).  All zero before the first search or without ``collision_detection="line"``.
    """
    counters = (ctypes.c_int64 * 7)()
    cell_size = ctypes.c_double()
    _LIB.rs_sheet_detector_counters(address, counters, ctypes.byref(cell_size))
    return {"steps": int(counters[0]), "candidates": int(counters[1]),
            "reports": int(counters[2]), "cells": int(counters[3]),
            "cell_size": float(cell_size.value), "half_shell": bool(counters[5]),
            "classes": int(counters[6]),
            "error": DETECTOR_ERRORS.get(int(counters[4]), f"code {int(counters[4])}")}


#: Most reach classes of the detector's search (RS_MAX_CLASSES in rs_sheet_detect.c).
MAX_CLASSES = 8


def set_classes(address: int, classes: int) -> int:
    """Let the sheet detector of the resolver at ``address`` sort its particles into at
    most ``classes`` reach classes, each with its own cell grid (rs_sheet_detect.c, Method
    2a; the default is `MAX_CLASSES`); 1 searches all particles in one grid.

    The pairs found and every result do not depend on it: it changes the cost only.
    Returns the number set; ValueError outside 1 to `MAX_CLASSES`.
    """
    if (isinstance(classes, bool) or not isinstance(classes, (int, np.integer))
            or not 1 <= classes <= MAX_CLASSES):
        raise ValueError(f"classes: must be an integer from 1 to {MAX_CLASSES}, "
                         f"got {classes!r}")
    done = int(_LIB.rs_sheet_set_classes(address, int(classes)))
    if done < 1:
        raise MemoryError("could not allocate the sheet detector")
    return done


#: Steps a neighbour list of the detector is built to last by default (RS_LIST_STEPS in
#: rs_sheet_detect.c, Method 9).
LIST_STEPS = 10


def set_lists(address: int, steps: int) -> int:
    """Let the sheet detector of the resolver at ``address`` keep a neighbour list built to
    last ``steps`` steps (rs_sheet_detect.c, Method 9; the default is `LIST_STEPS`); 0
    searches the cells at every step.

    The pairs found and every result do not depend on it: it changes the cost only.
    Returns the number set; ValueError outside 0 to 1000.
    """
    if (isinstance(steps, bool) or not isinstance(steps, (int, np.integer))
            or not 0 <= steps <= 1000):
        raise ValueError(f"steps: must be an integer from 0 to 1000, got {steps!r}")
    done = int(_LIB.rs_sheet_set_lists(address, int(steps)))
    if done < 0:
        raise MemoryError("could not allocate the sheet detector")
    return done


def list_counters(address: int) -> dict[str, int]:
    """Counters of the detector's neighbour lists (rs_sheet_detect.c, Method 9) since its
    creation: ``builds`` (lists built), ``steps`` (steps searched through a list),
    ``fallbacks`` (re-checks after a collision that searched the cells while a list was
    on), ``pairs`` (pairs in the last list), ``list_steps`` (the steps a list is built
    to last, 0: no lists) and ``wide_checks`` (unlisted partners whose deviation in the
    step the list's margin did not cover, re-checked one by one).  All zero before the
    first search."""
    out = (ctypes.c_int64 * 6)()
    _LIB.rs_sheet_list_counters(address, out)
    names = ("builds", "steps", "fallbacks", "pairs", "list_steps", "wide_checks")
    return dict(zip(names, (int(v) for v in out), strict=True))


def detect_pairs(sim: rebound.Simulation) -> tuple[np.ndarray, np.ndarray]:
    """The detector's search on the current state of ``sim`` (no resolution).

    The pairs whose straight paths over the last step (``dt_last_done``, current
    velocities) came within the sum of their radii.

    Returns
    -------
    pairs : int array (n, 2)
        Particle indices (p1 < p2).
    offsets : array (n, 6) [m, m, m, m/s, m/s, m/s]
        Ghost-box offset of p1 (x, y, z, vx, vy, vz), as in ``struct reb_collision``.
    """
    sim_address = ctypes.addressof(sim)
    capacity = 0
    while True:
        pairs = np.zeros((max(capacity, 1), 2), dtype=np.int64)
        offsets = np.zeros((max(capacity, 1), 6))
        found = _LIB.rs_sheet_detect_pairs(
            sim_address, capacity, pairs.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)),
            offsets.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
        if found < 0:
            raise ValueError("sheet detector: " + DETECTOR_ERRORS.get(-found - 1, "error"))
        if found <= capacity:
            return pairs[:found].copy(), offsets[:found].copy()
        capacity = int(found)
