"""Freely cooling gas of rough spheres in a periodic box: the homogeneous cooling state.

The reference simulation of :mod:`ringsim.physics.friction` against the closed form of
:mod:`ringsim.physics.spin_temperature`, not part of a ring run (tests/test_friction.py
runs it; docs/friction.md, "Homogeneous cooling state of rough spheres").  Identical
spheres (radius R, mass m, I = k m R^2) fly freely in a cubic periodic box without shear
or gravity; pairs that came into contact during a time step are found with scipy's
periodic k-d tree and resolved at their contact, found on the straight relative path as
ringsim's swept-path ("line") search does: the impulse of
:func:`ringsim.physics.friction.collision_impulse` is applied along the normal at contact
and both particles move on with their new velocities for the rest of the step.

With constant eps_n and beta the dynamics is scale free: multiplying every velocity and
spin by the same factor only changes the clock.  The run therefore rescales (v, w) after
each step to restore the starting energy, keeping the time step a fixed fraction of the
collision time, and measures time in collisions per particle.  T_rot / T_tr is unchanged
by the rescaling and relaxes to the value of
:func:`ringsim.physics.spin_temperature.hcs_temperature_ratio`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ringsim.physics import friction as fr

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class CoolingRun:
    """The history of one cooling run (one sample per time step)."""

    collisions_per_particle: FloatArray   #: cumulative, 2 x collisions / N [-]
    temperature_ratio: FloatArray         #: T_rot / T_tr [-]
    n_particles: int
    volume_fraction: float                #: N (4/3) pi R^3 / L^3 [-]
    eps_n: float
    friction: Mapping[str, object]
    inertia_factor: float
    multi_contacts: int                   #: contacts of a particle already hit in its step

    def converged_ratio(self, after_collisions: float) -> tuple[float, float]:
        """Mean T_rot / T_tr after ``after_collisions`` collisions per particle, and its
        standard error.

        The samples are correlated over several collisions per particle (the ratio
        relaxes slowly); the error uses the integrated autocorrelation time, summed over
        a window of five times its running estimate (Sokal's rule).
        """
        late = self.temperature_ratio[self.collisions_per_particle >= after_collisions]
        if late.size < 64:
            raise ValueError(f"only {late.size} samples after {after_collisions} collisions "
                             "per particle")
        x = late - late.mean()
        spectrum = np.fft.rfft(x, 2 * x.size)
        acf = np.fft.irfft(spectrum * np.conj(spectrum))[:x.size]
        acf /= acf[0]
        tau = 1.0 + 2.0 * np.cumsum(acf[1:])
        window = np.argmax(np.arange(1, x.size) >= 5.0 * tau)
        tau_int = max(float(tau[window]), 1.0)
        return float(late.mean()), float(late.std() * math.sqrt(tau_int / late.size))


def _place(rng: np.random.Generator, n: int, radius: float, box: float) -> FloatArray:
    """n non-overlapping centres [m] in a periodic cube of side ``box``, by rejection."""
    positions = np.empty((n, 3))
    placed = 0
    while placed < n:
        trial = rng.uniform(0.0, box, 3)
        d = positions[:placed] - trial
        d -= box * np.round(d / box)
        if np.all(np.sum(d * d, axis=1) > (2.0 * radius) ** 2):
            positions[placed] = trial
            placed += 1
    return positions


def _temperatures(v: FloatArray, w: FloatArray, mass: float, inertia: float
                  ) -> tuple[float, float]:
    """T_tr = m <v^2>/3 and T_rot = I <w^2>/3 [J]."""
    return (mass * float(np.mean(np.sum(v * v, axis=1))) / 3.0,
            inertia * float(np.mean(np.sum(w * w, axis=1))) / 3.0)


def _start(rng: np.random.Generator, n: int, radius: float, box: float, mass: float,
           inertia: float, ratio_start: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Positions [m], velocities (unit variance, at rest on average) [m/s] and spins
    [rad/s] of a Maxwellian start with T_rot / T_tr = ``ratio_start``."""
    x = _place(rng, n, radius, box)
    v = rng.normal(0.0, 1.0, (n, 3))
    v -= v.mean(axis=0)
    t_tr, _ = _temperatures(v, np.zeros_like(v), mass, inertia)
    w = rng.normal(0.0, math.sqrt(ratio_start * t_tr / inertia), (n, 3))
    return x, v, w


def cool_rough_gas(n_particles: int, volume_fraction: float, eps_n: float,
                   friction: Mapping[str, object], ratio_start: float,
                   collisions_per_particle: float, seed: int,
                   inertia_factor: float = fr.SOLID_SPHERE_INERTIA, radius: float = 1.0,
                   density: float = 900.0, step_fraction: float = 0.25) -> CoolingRun:
    """Cool a homogeneous gas of rough spheres; return T_rot / T_tr against collisions.

    Parameters
    ----------
    n_particles : int
        Number of spheres.
    volume_fraction : float [-]
        N (4/3) pi R^3 / L^3; dilute (<~ 0.05) where the kinetic theory holds.
    eps_n : float [-]
        Constant normal restitution.
    friction : mapping
        The friction model (see :func:`ringsim.physics.friction.friction_parameters`).
    ratio_start : float [-]
        T_rot / T_tr of the Maxwellian start.
    collisions_per_particle : float [-]
        Run length.
    seed : int
        Seed of the generator for positions, velocities and spins.
    inertia_factor : float [-]
        k in I = k m R^2.
    radius : float [m]
    density : float [kg/m^3]
    step_fraction : float [-]
        Time step in units of R / v_rms.  Contacts are found on the swept paths, so a
        step may be a fair fraction of the free time; it must keep the relative path per
        step well below the Verlet skin (2R) and few particles with two contacts in one
        step (``multi_contacts``).
    """
    mass = density * 4.0 / 3.0 * math.pi * radius**3
    inertia = inertia_factor * mass * radius**2
    box = (n_particles * 4.0 / 3.0 * math.pi * radius**3 / volume_fraction) ** (1.0 / 3.0)
    x, v, w = _start(np.random.default_rng(seed), n_particles, radius, box, mass, inertia,
                     ratio_start)
    energy = 1.5 * n_particles * sum(_temperatures(v, w, mass, inertia))

    collisions = 0
    multi = 0
    history: list[tuple[float, float]] = []
    neighbours = _Neighbours(box, 2.0 * radius, skin=2.0 * radius)
    while 2.0 * collisions / n_particles < collisions_per_particle:
        dt = step_fraction * radius / math.sqrt(np.mean(np.sum(v * v, axis=1)))
        x += v * dt
        x = np.mod(x, box)
        x[x >= box] = 0.0           # np.mod can round up to the box side
        resolved, repeated = _resolve_step(x, v, w, neighbours.candidates(x), box,
                                           radius, mass, eps_n, friction, inertia_factor, dt)
        collisions, multi = collisions + resolved, multi + repeated
        t_tr, t_rot = _temperatures(v, w, mass, inertia)
        scale = math.sqrt(energy / (1.5 * n_particles * (t_tr + t_rot)))
        v *= scale
        w *= scale
        history.append((2.0 * collisions / n_particles, t_rot / t_tr))
    c, r = np.array(history).T
    return CoolingRun(c, r, n_particles, volume_fraction, eps_n, dict(friction),
                      inertia_factor, multi)


class _Neighbours:
    """Verlet list: pairs closer than ``cutoff + skin``, rebuilt with scipy's periodic k-d
    tree once some particle has moved skin/2 since the last build (so no pair within
    ``cutoff`` is missed)."""

    def __init__(self, box: float, cutoff: float, skin: float):
        self.box, self.cutoff, self.skin = box, cutoff, skin
        self.pairs = np.empty((0, 2), dtype=np.int64)
        self.built_at: FloatArray | None = None

    def candidates(self, x: FloatArray) -> NDArray[np.int64]:
        if self.built_at is not None:
            moved = x - self.built_at
            moved -= self.box * np.round(moved / self.box)
            if np.max(np.sum(moved * moved, axis=1)) <= (0.5 * self.skin) ** 2:
                return self.pairs
        self.pairs = cKDTree(x, boxsize=self.box).query_pairs(self.cutoff + self.skin,
                                                              output_type="ndarray")
        self.built_at = x.copy()
        return self.pairs


def _resolve_step(x: FloatArray, v: FloatArray, w: FloatArray, candidates: NDArray[np.int64],
                  box: float, radius: float, mass: float, eps_n: float,
                  friction: Mapping[str, object], inertia_factor: float, dt: float
                  ) -> tuple[int, int]:
    """Resolve the contacts of the last step in place; return (count, repeated contacts).

    A pair collided if its straight relative path over the step came within a diameter
    (swept-path search, as ringsim's line mode: grazing passes are not missed) or if it
    overlaps and approaches at the end.  Each pair is resolved at most once per step, at
    its first contact; a particle's second contact in one step is resolved afterwards
    from its new velocity (counted as repeated, as ringsim's multi_encounters).
    """
    diameter = 2.0 * radius
    done: set[tuple[int, int]] = set()
    hit = np.zeros(x.shape[0], dtype=bool)
    count = repeated = 0
    pending = candidates
    while pending.size:
        i, j = pending[:, 0], pending[:, 1]
        dr = x[i] - x[j]
        dr -= box * np.round(dr / box)
        dv = v[i] - v[j]
        back, touched = _contact_time(dr, dv, diameter, dt)
        pending, dr, dv, back = pending[touched], dr[touched], dv[touched], back[touched]
        if pending.size == 0:
            break
        # One contact per particle per round, the rest wait for the next round.
        first = _disjoint(pending)
        batch, later = pending[first], pending[~first]
        back = back[first]
        contact = dr[first] - back[:, None] * dv[first]
        i, j = batch[:, 0], batch[:, 1]
        imp = fr.collision_impulse(contact, dv[first], w[i], w[j], radius, radius, mass,
                                   mass, eps_n, friction, inertia_factor, inertia_factor)
        v[i] += imp.dv1
        v[j] += imp.dv2
        w[i] += imp.dw1
        w[j] += imp.dw2
        x[i] = np.mod(x[i] + back[:, None] * imp.dv1, box)
        x[j] = np.mod(x[j] + back[:, None] * imp.dv2, box)
        repeated += int(np.sum(hit[i]) + np.sum(hit[j]))
        hit[i] = hit[j] = True
        count += batch.shape[0]
        done.update(zip(i.tolist(), j.tolist(), strict=True))
        pending = np.array([p for p in later.tolist() if tuple(p) not in done],
                           dtype=np.int64).reshape(-1, 2)
    x[x >= box] = 0.0
    return count, repeated


def _disjoint(pairs: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Greedy mask of pairs sharing no particle with an earlier selected pair."""
    used: set[int] = set()
    keep = np.zeros(pairs.shape[0], dtype=bool)
    for row, (a, b) in enumerate(pairs.tolist()):
        if a not in used and b not in used:
            keep[row] = True
            used.update((a, b))
    return keep


def _contact_time(dr: FloatArray, dv: FloatArray, diameter: float, dt: float
                  ) -> tuple[FloatArray, NDArray[np.bool_]]:
    """First contact on the straight relative path of the last step.

    Returns s [s], the time before the step's end at which |dr - s dv| = diameter, and
    whether the pair collided: s in (0, dt], or (overlapping since before the step) an
    approaching overlap at the end, resolved where it is (s = 0).
    """
    a = np.sum(dv * dv, axis=1)
    b = np.sum(dr * dv, axis=1)
    gap = np.sum(dr * dr, axis=1) - diameter * diameter
    disc = b * b - a * gap
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (b + np.sqrt(np.maximum(disc, 0.0))) / a
    swept = (a > 0.0) & (disc >= 0.0) & (s > 0.0) & (s <= dt)
    overlapping = (gap < 0.0) & (b < 0.0) & ~swept
    return np.where(swept, s, 0.0), swept | overlapping
