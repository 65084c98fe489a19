"""How often a particle meets two partners within one step: a straight-path prediction.

It is compared with the resolver's measured ``multi_encounters / count`` of a run file.
It predicts only the second contacts that are already on course at the start of a step,
so it is a lower bound of the measured fraction (docs/validation.md, "Time-ordered
contacts in line mode"; the line-mode check itself is ``studies/validation-line-mode``).
Line mode's ``dt: auto`` (``engine.timestep.auto_dt``) does not use it: the time-ordered
detector resolves multiple encounters exactly.  A deflection counts when the partner
carries at least ``mass_share`` of the pair's mass: pass the resolver's
``engine.timestep.MULTI_ENCOUNTER_MASS_SHARE`` to compare with its counter.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

#: Window of the contact prediction the line-mode comparison used [steps of 1e-3 orbit].
MULTI_ENCOUNTER_WINDOW_STEPS = 16


def predicted_contacts(x: Any, y: Any, z: Any, vx: Any, vy: Any, vz: Any, radius: Any,
                       mass: Any, Omega: float, window: float,
                       mass_share: float) -> tuple[np.ndarray, np.ndarray]:
    """Contacts each particle would make within ``window`` on straight paths.

    Every pair that does not overlap now, approaches, and whose straight relative path
    reaches contact within ``window`` counts once for each of its two particles; it also
    counts as a deflection of a particle whose partner carries at least ``mass_share`` of
    the pair's mass.  Positions are taken as they
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
    mass_share : float [1]
        The share of the pair's mass a deflecting partner carries at least.

    Returns
    -------
    contacts, deflections : int arrays [count per particle]
    """
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
    hit = _contact_time(pos[j] - pos[i], vel[j] - vel[i], radius[i] + radius[j]) <= window
    i, j = i[hit], j[hit]
    np.add.at(contacts, i, 1)
    np.add.at(contacts, j, 1)
    total = mass[i] + mass[j]
    np.add.at(deflections, i[mass[j] >= mass_share * total], 1)
    np.add.at(deflections, j[mass[i] >= mass_share * total], 1)
    return contacts, deflections


def _contact_time(d: np.ndarray, u: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Time [s] until the pairs of separations ``d`` [m] and relative velocities ``u``
    [m/s] (rows) come within ``reach`` [m] on straight paths; inf for a pair that overlaps
    now, recedes or misses."""
    a = np.einsum("ij,ij->i", u, u)
    b = np.einsum("ij,ij->i", d, u)
    c = np.einsum("ij,ij->i", d, d) - reach**2
    discriminant = b * b - a * c
    hit = (c > 0.0) & (b < 0.0) & (discriminant >= 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(hit, (-b - np.sqrt(np.where(hit, discriminant, 0.0))) / a, np.inf)


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


def multi_encounter_rate(arrays: Mapping[str, Any], Omega: float, max_window: float,
                         mass_share: float) -> float:
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
    mass_share : float [1]
        As for :func:`predicted_contacts`.
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
                                               Omega, window, mass_share)
    evidence = float(np.sum(deflections))
    if evidence <= 4.0:
        return 0.0
    fraction = multi_encounter_fraction(contacts, deflections, radius)
    return fraction * (1.0 - 2.0 / math.sqrt(evidence)) / window
