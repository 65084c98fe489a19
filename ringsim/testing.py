"""The pure-Python twin of the C resolver, for tests (``sim.collision_resolve = twin``)."""

from __future__ import annotations

import ctypes
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import rebound

from ringsim.engine.native import LOG_DTYPE
from ringsim.engine.resolver import _validated
from ringsim.physics import restitution as rs

# Normal speeds below this many round-off units of the summed |velocity components| are
# treated as not approaching (as in the C; keeps eps = 0 pairs from resolving twice).
_ROUNDOFF_SPEED = 64.0 * np.finfo(float).eps
# REBOUND's collision search modes that report swept-path contacts (line, linetree).
_SWEPT_PATH_MODES = (rebound.simulation.COLLISIONS["line"],
                     rebound.simulation.COLLISIONS["linetree"])

def _dilley_epsilon(v: float, R_bar: float, M_bar: float, xi0: float, p: float,
                    kappa: float) -> float:
    xi = (xi0 * math.pow(R_bar / rs.R_REF, -rs.RADIUS_EXPONENT)
          * math.pow(M_bar / rs.M_REF, -kappa) * math.pow(v / rs.V_REF, p))
    if not xi < 1.0:
        return 0.0
    return math.exp(-math.pi * xi / math.sqrt(1.0 - xi * xi))


def _bridges_epsilon(v: float, v_c: float, exponent: float) -> float:
    u = v / v_c
    return math.pow(u, -exponent) if u > 1.0 else 1.0


def _andrews_epsilon(v: float, v_c: float) -> float:
    u = v / v_c
    if not u > 1.0:
        return 1.0
    u2 = u * u
    return math.sqrt((-2.0 + math.sqrt(30.0 * u2 - 5.0)) / (3.0 * u2))


def _tabor_epsilon(v: float, v_c: float, q: float) -> float:
    u = v / v_c
    if not u > 1.0:
        return 1.0
    amplitude = math.pow(u, -(1.0 - 2.0 * q))
    log_amplitude = math.log(amplitude)
    lo = amplitude
    hi = amplitude * math.pow(1.0 - q, -q)
    if hi > 1.0:
        hi = 1.0
    eps = 0.5 * (lo + hi)
    for _ in range(200):
        g = math.log(eps) - log_amplitude - q * math.log((1.0 - q * eps * eps) / (1.0 - q))
        if g < 0.0:
            lo = eps
        elif g > 0.0:
            hi = eps
        else:
            break
        dg = 1.0 / eps + 2.0 * q * q * eps / (1.0 - q * eps * eps)
        newton = eps - g / dg
        nxt = newton if lo < newton < hi else 0.5 * (lo + hi)
        step = abs(nxt - eps)
        eps = nxt
        if step <= 1e-15 * eps or not hi - lo > 1e-15 * eps:
            break
    return eps


class PythonReferenceResolver:
    """Pure-Python twin of the C resolver, for testing: ``sim.collision_resolve = ref``.

    Same physics and the same floating-point operations in the same order as
    ``rs_resolver.c`` (Python floats and ``math`` call the same libm), so a simulation
    resolved by either evolves identically to round-off.  It records every collision in
    :attr:`log` (tuples t [s], v_n [m/s], R_bar [m], M_bar [kg], eps).  An exception
    inside a call is appended to :attr:`errors` and the collision is left unresolved
    (returns 0; particles are never removed).

    Parameters
    ----------
    restitution : mapping
        As for :func:`install_resolver`.
    """

    def __init__(self, restitution: Mapping[str, Any]):
        self.model, self.parameters = _validated(restitution)
        self.count = 0
        self.n_floored = 0
        self.sum_epsilon = 0.0
        self.sum_vn = 0.0
        self.log: list[tuple[float, float, float, float, float]] = []
        self.errors: list[Exception] = []
        self._memory: set[tuple[int, int]] = set()     # pairs resolved in this step
        self._memory_step: tuple[int, int] | None = None

    def epsilon(self, v: float, R_bar: float, M_bar: float) -> float:
        """The law's eps for one pair, scalar arithmetic as in C.

        Parameters
        ----------
        v : float [m/s]
            Normal impact speed, >= 0.
        R_bar : float [m]
        M_bar : float [kg]
        """
        prm = self.parameters
        if self.model == "dilley":
            return _dilley_epsilon(v, R_bar, M_bar, prm["xi0"], prm["p"], prm["kappa"])
        if self.model == "bridges":
            return _bridges_epsilon(v, prm["v_c"], prm["exponent"])
        if self.model == "constant":
            return prm["epsilon"]
        if self.model == "andrews":
            return _andrews_epsilon(v, prm["v_c"])
        return _tabor_epsilon(v, prm["v_c"], prm["q"])

    def __call__(self, sim_pointer: Any, collision: Any) -> int:
        try:
            self._resolve(sim_pointer.contents, collision)
        except Exception as exc:    # recorded: an exception cannot cross the C callback
            self.errors.append(exc)
        return 0

    def _resolve(self, sim: rebound.Simulation, c: Any) -> None:
        particles = sim.particles
        p1 = particles[c.p1]
        p2 = particles[c.p2]
        gb = c.gb
        dx = p1.x + gb.x - p2.x
        dy = p1.y + gb.y - p2.y
        dz = p1.z + gb.z - p2.z
        sum_radii = p1.r + p2.r
        distance2 = dx * dx + dy * dy + dz * dz
        dvx = p1.vx + gb.vx - p2.vx
        dvy = p1.vy + gb.vy - p2.vy
        dvz = p1.vz + gb.vz - p2.vz
        overlapping = distance2 < sum_radii * sum_radii

        if sim._collision not in _SWEPT_PATH_MODES:
            if overlapping:
                self._apply_impulse(sim, p1, p2, gb, dx, dy, dz, math.sqrt(distance2), dvx,
                                    dvy, dvz, 0.0)
            return

        step = (ctypes.addressof(sim), sim.steps_done)   # as the C: per simulation and step
        if self._memory_step != step:
            self._memory_step = step
            self._memory.clear()
        key = (min(c.p1, c.p2), max(c.p1, c.p2))
        if key in self._memory:
            return
        a = dvx * dvx + dvy * dvy + dvz * dvz
        b = dx * dvx + dy * dvy + dz * dvz
        gap = distance2 - sum_radii * sum_radii
        discriminant = b * b - a * gap
        back_time = 0.0
        if a > 0.0 and discriminant >= 0.0:
            back_time = (b + math.sqrt(discriminant)) / a
        if 0.0 < back_time <= sim.dt_last_done:
            cx = dx - back_time * dvx
            cy = dy - back_time * dvy
            cz = dz - back_time * dvz
            contact = math.sqrt(cx * cx + cy * cy + cz * cz)
            resolved = self._apply_impulse(sim, p1, p2, gb, cx, cy, cz, contact, dvx, dvy,
                                           dvz, back_time)
        elif overlapping:
            resolved = self._apply_impulse(sim, p1, p2, gb, dx, dy, dz, math.sqrt(distance2),
                                           dvx, dvy, dvz, 0.0)
        else:
            return
        if resolved:
            self._memory.add(key)

    def _apply_impulse(self, sim: rebound.Simulation, p1: Any, p2: Any, gb: Any, dx: float,
                       dy: float, dz: float, distance: float, dvx: float, dvy: float,
                       dvz: float, back_time: float) -> bool:
        v_n = (dvx * dx + dvy * dy + dvz * dz) / distance
        speed_scale = (abs(p1.vx) + abs(p1.vy) + abs(p1.vz) + abs(gb.vx) + abs(gb.vy)
                       + abs(gb.vz) + abs(p2.vx) + abs(p2.vy) + abs(p2.vz))
        if not -v_n > _ROUNDOFF_SPEED * speed_scale:
            return False
        m1 = p1.m
        m2 = p2.m
        total_mass = m1 + m2
        if not total_mass > 0.0:
            return False
        R_bar = p1.r * p2.r / (p1.r + p2.r)
        M_bar = m1 * m2 / total_mass
        impact_speed = -v_n
        eps = self.epsilon(impact_speed, R_bar, M_bar)

        separation_change = (1.0 + eps) * impact_speed
        r_min = p2.r if p1.r > p2.r else p1.r
        r_max = p2.r if p1.r < p2.r else p1.r
        w = sim.minimum_collision_velocity
        v_floor = r_min * w
        v_floor *= 1.0 - (distance - r_max) / r_min
        if v_floor > r_max * w:
            v_floor = r_max * w
        floored = separation_change < v_floor
        if floored:
            separation_change = v_floor

        old_vy_outer = p1.vy if dx > 0.0 else p2.vy
        jx = separation_change * (dx / distance)
        jy = separation_change * (dy / distance)
        jz = separation_change * (dz / distance)
        share2 = m1 / total_mass
        share1 = m2 / total_mass
        p2.vx = p2.vx - share2 * jx
        p2.vy = p2.vy - share2 * jy
        p2.vz = p2.vz - share2 * jz
        p1.vx = p1.vx + share1 * jx
        p1.vy = p1.vy + share1 * jy
        p1.vz = p1.vz + share1 * jz
        if back_time > 0.0:
            p2.x = p2.x - back_time * (share2 * jx)
            p2.y = p2.y - back_time * (share2 * jy)
            p2.z = p2.z - back_time * (share2 * jz)
            p1.x = p1.x + back_time * (share1 * jx)
            p1.y = p1.y + back_time * (share1 * jy)
            p1.z = p1.z + back_time * (share1 * jz)
        if dx > 0.0:
            sim.collisions_plog += -abs(dx) * (old_vy_outer - p1.vy) * m1
        else:
            sim.collisions_plog += -abs(dx) * (old_vy_outer - p2.vy) * m2
        sim.collisions_log_n += 1

        self.count += 1
        self.n_floored += int(floored)
        self.sum_epsilon += eps
        self.sum_vn += impact_speed
        self.log.append((sim.t, impact_speed, R_bar, M_bar, eps))
        return True

    def stats(self) -> dict[str, Any]:
        """count, n_floored, mean_epsilon, mean_vn [m/s] and the full log (LOG_DTYPE)."""
        count = self.count
        return {
            "count": count,
            "n_floored": self.n_floored,
            "mean_epsilon": self.sum_epsilon / count if count else math.nan,
            "mean_vn": self.sum_vn / count if count else math.nan,
            "log": np.array(self.log, dtype=LOG_DTYPE),
        }
