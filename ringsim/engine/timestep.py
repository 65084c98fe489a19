"""The time-step policy: ``dt: auto`` for tree and line collision detection, and its checks."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

#: Largest allowed time step [orbits] (resolves the epicycle).
DT_MAX_ORBITS = 1e-3

#: Largest fraction of collisions in which a partner has a second contact in the same step
#: that ``dt: auto`` accepts in line mode (``ringsim.sheet.auto_dt``).
MULTI_ENCOUNTER_TARGET = 0.01
#: Window of the contact prediction of ``dt: auto`` in line mode [steps of 1e-3 orbit].
MULTI_ENCOUNTER_WINDOW_STEPS = 16
#: A collision deflects a particle when its partner carries at least this share of the
#: pair's mass (its velocity then changes by at least this share of the relative-velocity
#: change); RS_DEFLECTING_MASS_SHARE in rs_resolver.c.
MULTI_ENCOUNTER_MASS_SHARE = 0.1


def predicted_contacts(x: Any, y: Any, z: Any, vx: Any, vy: Any, vz: Any, radius: Any,
                       mass: Any, Omega: float,
                       window: float) -> tuple[np.ndarray, np.ndarray]:
    """Contacts each particle would make within ``window`` on straight paths.

    Every pair that does not overlap now, approaches, and whose straight relative path
    reaches contact within ``window`` counts once for each of its two particles; it also
    counts as a deflection of a particle whose partner carries at least
    :data:`MULTI_ENCOUNTER_MASS_SHARE` of the pair's mass.  Positions are taken as they
    are (no periodic images: pairs straddling the box edges are missed, a fraction of
    about the search radius over the box size).

    Parameters
    ----------
    x, y, z : arrays [m]
    vx, vy, vz : arrays [m/s]
        Velocities in the frame of the sheet (shear flow vy = -1.5 Omega x included).
    radius : array [m]
    mass : array [kg]
    Omega : float [1/s]
        Orbital frequency; the search is widened by speeds relative to the shear flow.
    window : float [s]

    Returns
    -------
    contacts, deflections : int arrays [count per particle]
    """
    from scipy.spatial import cKDTree

    pos = np.column_stack([x, y, z]).astype(float)
    vel = np.column_stack([vx, vy, vz]).astype(float)
    radius = np.asarray(radius, dtype=float)
    mass = np.asarray(mass, dtype=float)
    contacts = np.zeros(radius.size, dtype=np.int64)
    deflections = np.zeros(radius.size, dtype=np.int64)
    if radius.size < 2:
        return contacts, deflections
    random_speed = np.sqrt(vel[:, 0] ** 2 + (vel[:, 1] + 1.5 * Omega * pos[:, 0]) ** 2
                           + vel[:, 2] ** 2)
    shear_drift = 1.5 * abs(Omega) * window
    if not shear_drift < 0.5:
        raise ValueError(f"window: 1.5 Omega window = {shear_drift:.3g} must be < 0.5")
    search = 2.0 * float(np.max(radius + window * random_speed)) / (1.0 - shear_drift)
    pairs = cKDTree(pos).query_pairs(search, output_type="ndarray")
    if pairs.size == 0:
        return contacts, deflections
    i, j = pairs[:, 0], pairs[:, 1]
    d = pos[j] - pos[i]
    u = vel[j] - vel[i]
    a = np.einsum("ij,ij->i", u, u)
    b = np.einsum("ij,ij->i", d, u)
    c = np.einsum("ij,ij->i", d, d) - (radius[i] + radius[j]) ** 2
    discriminant = b * b - a * c
    hit = (c > 0.0) & (b < 0.0) & (discriminant >= 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        t_contact = np.where(hit, (-b - np.sqrt(np.where(hit, discriminant, 0.0))) / a, np.inf)
    hit &= t_contact <= window
    i, j = i[hit], j[hit]
    np.add.at(contacts, i, 1)
    np.add.at(contacts, j, 1)
    total = mass[i] + mass[j]
    np.add.at(deflections, i[mass[j] >= MULTI_ENCOUNTER_MASS_SHARE * total], 1)
    np.add.at(deflections, j[mass[i] >= MULTI_ENCOUNTER_MASS_SHARE * total], 1)
    return contacts, deflections


def multi_encounter_fraction(contacts: Any, deflections: Any, radius: Any = None) -> float:
    """Predicted fraction of collisions in which a partner was deflected earlier in the step.

    A particle of contact rate lambda, lambda_s of them deflecting (Poisson), collides in a
    window W with probability ~ lambda W and has then on average lambda_s W other
    deflections in the same window, half of them before.  Summed over both partners of a
    collision, the fraction of collisions preceded within the window by a deflection of a
    partner is sum(lambda_s lambda) W / sum(lambda): the resolver's statistic
    ``multi_encounters / count`` for steps of length W.  The rates are pooled over
    particles of similar size (bins of 0.1 in log10 radius) - the mean counts of a bin
    estimate its rates - so that the estimate rests on all contacts of a snapshot, not on
    the few coincidences of one window.  0 without contacts.

    Parameters
    ----------
    contacts, deflections : int arrays [count per particle in one window]
        From :func:`predicted_contacts`.
    radius : array [m], optional
        Radii for pooling; all particles in one pool if omitted.
    """
    k = np.asarray(contacts, dtype=float)
    s = np.asarray(deflections, dtype=float)
    total = float(k.sum())
    if not total > 0:
        return 0.0
    if radius is None:
        groups = np.zeros(k.size, dtype=np.int64)
    else:
        log_r = np.log10(np.asarray(radius, dtype=float))
        groups = np.floor((log_r - log_r.min()) / 0.1).astype(np.int64)
    n = np.bincount(groups).astype(float)
    used = n > 0
    k_mean = np.bincount(groups, weights=k)[used] / n[used]
    s_mean = np.bincount(groups, weights=s)[used] / n[used]
    return float(np.sum(n[used] * s_mean * k_mean) / total)


def multi_encounter_rate(arrays: Mapping[str, Any], Omega: float, max_window: float) -> float:
    """Predicted ``multi_encounters / count`` per unit step length [1/s].

    The fraction for a step dt is about this rate times dt (for fractions << 1).  Contacts
    are predicted on straight paths over a window W and pooled by size
    (:func:`multi_encounter_fraction`); the rate is that fraction over W.  W is
    ``max_window`` unless the fastest particle (speed w_max relative to the shear flow)
    would then reach beyond max(3 r_max, 1/8 of the smaller horizontal extent of the
    particles), which bounds the search.  The estimate is lowered to its 2-sigma lower
    bound, (1 - 2 / sqrt(S)) for S predicted deflections (0 for S <= 4): a shorter step
    needs evidence, not the chance coincidences of a snapshot of a dilute ring.

    Parameters
    ----------
    arrays : mapping of particle arrays x, y, z [m], vx, vy, vz [m/s], radius [m], mass [kg]
    Omega : float [1/s]
    max_window : float [s]
    """
    x, y, z = (np.asarray(arrays[k], dtype=float) for k in ("x", "y", "z"))
    vx, vy, vz = (np.asarray(arrays[k], dtype=float) for k in ("vx", "vy", "vz"))
    radius = np.asarray(arrays["radius"], dtype=float)
    if radius.size < 2:
        return 0.0
    w_max = float(np.sqrt(np.max(vx**2 + (vy + 1.5 * Omega * x) ** 2 + vz**2)))
    r_max = float(radius.max())
    reach = max(3.0 * r_max, 0.125 * min(float(np.ptp(x)), float(np.ptp(y))))
    window = max_window if w_max <= 0 else min(max_window, (reach - r_max) / w_max)
    contacts, deflections = predicted_contacts(x, y, z, vx, vy, vz, radius, arrays["mass"],
                                               Omega, window)
    evidence = float(np.sum(deflections))
    if evidence <= 4.0:
        return 0.0
    fraction = multi_encounter_fraction(contacts, deflections, radius)
    return fraction * (1.0 - 2.0 / math.sqrt(evidence)) / window




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

    Line detection (swept paths, contact-time resolution) finds every crossing whatever the
    speeds, so c/r does not bound its step.  Two things do: the orbit (dt <= 1e-3 orbit, the
    straight paths of a step must stay close to the epicycles) and multiple encounters (a
    particle that meets two partners in one step has its second contact found on a path it
    no longer follows).  The fraction of collisions in which a partner was deflected earlier
    in the same step (``multi_encounters / count`` of the resolver's statistics) is predicted
    from the current state (``resolver.multi_encounter_rate``): straight paths over a
    window of up to ``resolver.MULTI_ENCOUNTER_WINDOW_STEPS`` x 1e-3 orbit give each
    particle its contacts and deflections (contacts with a partner of at least 10% of the
    pair's mass); pooled over particles of similar size they give rates lambda and
    lambda_s, and dt sum(lambda_s lambda) / sum(lambda) estimates that fraction for a step
    dt.  The step keeps it below ``resolver.MULTI_ENCOUNTER_TARGET``
    (1%).  Hot dilute rings get 1e-3 orbit; dense, cold ones a shorter step.

    Tree detection finds collisions only as overlaps at step ends: dt << r/v.
    The largest relative displacement per step, relative_speed_bound * dt, is kept below
    ``safety`` times the smallest radius, and dt <= 1e-3 orbit.

    Both: the result is rounded down to a power of two times 1e-3 orbit so that it changes
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
        from ringsim.engine.timestep import (
            MULTI_ENCOUNTER_TARGET,
            MULTI_ENCOUNTER_WINDOW_STEPS,
            multi_encounter_rate,
        )

        rate = multi_encounter_rate(arrays, Omega, MULTI_ENCOUNTER_WINDOW_STEPS * dt_max)
        if rate <= 0.0:
            return dt_max
        bound = MULTI_ENCOUNTER_TARGET / rate
    else:
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


