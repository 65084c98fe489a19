"""The time-step policy: ``dt: auto`` for tree and line collision detection, and its checks."""

from __future__ import annotations

import math

import numpy as np

from ringsim.config.intervals import AUTO_DT_MAX_ORBITS

#: Largest allowed time step [orbits] (resolves the epicycle); declared beside the output
#: intervals' check, which counts steps with it.
DT_MAX_ORBITS = AUTO_DT_MAX_ORBITS

#: A collision deflects a particle when its partner carries at least this share of the
#: pair's mass (its velocity then changes by at least this share of the relative-velocity
#: change); RS_DEFLECTING_MASS_SHARE in rs_resolver.c, used by the resolver's
#: ``multi_encounters`` statistic.
MULTI_ENCOUNTER_MASS_SHARE = 0.1


def relative_speed_bound(arrays: dict[str, np.ndarray], Omega: float) -> float:
    """An upper estimate of the largest relative speed of touching particles [m/s].

    Twice the largest random speed relative to the shear flow, plus the shear across the
    largest pair separation (1.5 Omega (r_i + r_j)).
    """
    wx = arrays["vx"]
    wy = arrays["vy"] + 1.5 * Omega * arrays["x"]
    wz = arrays["vz"]
    w_max = float(np.sqrt(np.max(wx * wx + wy * wy + wz * wz))) if wx.size else 0.0
    return 2.0 * w_max + 3.0 * Omega * float(arrays["radius"].max())


def auto_dt(arrays: dict[str, np.ndarray], Omega: float, safety: float,
            current: float | None = None, collision_detection: str = "tree") -> float:
    """Time step [s] of ``dt: auto``.

    Line detection (swept paths, contacts resolved in time order within the step,
    ``rs_sheet_detect.c``) finds every crossing whatever the speeds, and a particle that
    meets several partners in one step has each contact found and resolved on the path it
    really follows, so neither c/r nor multiple encounters bound its step.  What does is the
    straight-path approximation of the epicycles, an error of order Omega dt: the step is
    1e-3 orbit, short enough that c and H of a dense cold ring do not depend on it
    (docs/scenario.md, ``integration.dt``).

    Tree detection finds collisions only as overlaps at step ends: dt << r/v.
    The largest relative displacement per step, relative_speed_bound * dt, is kept below
    ``safety`` times the smallest radius, and dt <= 1e-3 orbit.

    Tree: the result is rounded down to a power of two times 1e-3 orbit so that it changes
    rarely and reproducibly; it shrinks as soon as the bound requires, but grows again only
    once the bound leaves a margin of 1.5 (so that a fluctuating estimate does not make it
    flip back and forth).

    Parameters
    ----------
    arrays : particle arrays (SI)
    Omega : float [1/s]
    safety : float [dimensionless], fraction of the smallest radius (tree detection)
    current : float [s], optional
        The step in use.
    collision_detection : "tree" or "line"
    """
    dt_max = DT_MAX_ORBITS * 2.0 * math.pi / Omega
    if collision_detection == "line":
        return dt_max
    v_rel = relative_speed_bound(arrays, Omega)
    if v_rel <= 0:
        return dt_max
    bound = safety * float(arrays["radius"].min()) / v_rel

    def quantized(dt: float) -> float:
        if dt >= dt_max:
            return dt_max
        return dt_max * 2.0 ** math.floor(math.log2(dt / dt_max))

    dt = quantized(bound)
    if current is not None and dt > current:
        dt = max(current, quantized(bound / 1.5))
    return dt


def choose_dt(integration, arrays: dict[str, np.ndarray], Omega: float) -> float:
    """The scenario's time step [s]: ``dt: auto`` or a fixed step in orbits.

    Parameters
    ----------
    integration : the scenario's integration section
    arrays : particle arrays (SI) of the initial state
    Omega : float [1/s]
    """
    if integration.dt == "auto":
        return auto_dt(arrays, Omega, integration.dt_safety,
                       collision_detection=integration.collision_detection)
    return float(integration.dt) * (2.0 * math.pi / Omega)  # as SheetGeometry.orbit


def dt_violation(arrays: dict[str, np.ndarray], Omega: float, dt: float,
                 safety: float) -> float:
    """Largest relative displacement per step over ``safety`` times the smallest radius.

    Values above 1 mean end-of-step detection may miss collisions at this dt.
    """
    return relative_speed_bound(arrays, Omega) * dt / (safety * float(arrays["radius"].min()))
