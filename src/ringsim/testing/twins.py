"""Pure-Python twins of the C code, for tests: the resolver (``sim.collision_resolve =
twin``) and the overlap count of the outputs (`count_overlaps_numpy`); and
`run_file_datasets`, with which tests compare run files bit for bit.

What the twin checks, and what it does not: it re-implements, operation by operation, the
C resolver's collision geometry (overlap and approach tests, the contact on the swept
path, the normal impulse, REBOUND's minimum collision velocity and momentum-flux
bookkeeping), so that a simulation resolved by either must evolve bit for bit alike.  It
does NOT carry its own copy of the restitution laws: eps is evaluated by the C library's
own ``rs_epsilon_array`` through a private, never-installed `ResolverHandle` with the same
parameters.  So each law exists once in C and once in numpy
(``ringsim.physics.restitution``, the only Python dispatch), and the tests compare those
two (to 1e-14, and to 2 ulp for the Tabor solver), while the twin tests the impulse
geometry independently.  Calling the numpy laws instead would tie the twin's bit-identity
to numpy's vectorised ``exp``/``log``/``pow`` agreeing with libm to the last bit, which
numpy does not promise.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np
import rebound

from ringsim.engine.native import _LIB, LOG_DTYPE
from ringsim.engine.resolver import ResolverHandle, _validated
from ringsim.engine.spins import checked_friction
from ringsim.physics.selfgravity import radial_images

# Normal speeds below this many round-off units of the summed |velocity components| are
# treated as not approaching (as in the C; keeps eps = 0 pairs from resolving twice).
_ROUNDOFF_SPEED = 64.0 * np.finfo(float).eps
# REBOUND's collision search modes that report swept-path contacts (line, linetree).
_SWEPT_PATH_MODES = (rebound.simulation.COLLISIONS["line"],
                     rebound.simulation.COLLISIONS["linetree"])


class PythonReferenceResolver:
    """Pure-Python twin of the C resolver, for testing: ``sim.collision_resolve = ref``.

    Same collision geometry and the same floating-point operations in the same order as
    ``rs_resolver.c`` (Python floats and ``math`` call the same libm), with eps from the C
    law (see the module docstring), so a simulation resolved by either evolves
    identically to round-off.  It records every collision in
    :attr:`log` (tuples t [s], v_n [m/s], R_bar [m], M_bar [kg], eps).  An exception
    inside a call is appended to :attr:`errors` and the collision is left unresolved
    (returns 0; particles are never removed).

    Parameters
    ----------
    restitution, friction, inertia_factor :
        As for :func:`install_resolver`.  With friction the twin keeps the spins in
        :attr:`spins` and applies ``rs_tangential_impulse``'s operations in its order.
    """

    def __init__(self, restitution: Mapping[str, Any],
                 friction: Mapping[str, Any] | None = None, inertia_factor: float = 0.4):
        self.model, self.parameters = _validated(restitution)
        self.friction_model, self.friction_parameters, self.inertia_factor = \
            checked_friction(friction, inertia_factor)
        #: Stored spins [rad/s] by particle index, relative to the rotating frame, x, y in
        #: the axes it had at t = 0 (rows of 3; as the C's array; :meth:`rotating_spins`).
        self.spins: list[list[float]] = []
        self.tangential_dissipation = 0.0
        self.normal_dissipation = 0.0
        self.n_sliding = 0
        # The law, evaluated by the C library (never installed in a simulation).
        self._law = ResolverHandle({"model": self.model, **self.parameters})
        self._arguments = [ctypes.c_double() for _ in range(4)]   # v, R_bar, M_bar, eps
        self.count = 0
        self.n_floored = 0
        self.sum_epsilon = 0.0
        self.sum_vn = 0.0
        self.log: list[tuple[float, float, float, float, float]] = []
        self.errors: list[Exception] = []
        self._memory: set[tuple[int, int]] = set()     # pairs resolved in this step
        self._memory_step: tuple[int, int] | None = None

    def epsilon(self, v: float, R_bar: float, M_bar: float) -> float:
        """The law's eps for one pair, evaluated by the C library (``rs_epsilon_array``).

        Parameters
        ----------
        v : float [m/s]
            Normal impact speed (sign ignored).
        R_bar : float [m]
        M_bar : float [kg]
        """
        speed, radius, mass, out = self._arguments
        speed.value, radius.value, mass.value = v, R_bar, M_bar
        _LIB.rs_epsilon_array(self._law.address, 1, ctypes.byref(speed), ctypes.byref(radius),
                              ctypes.byref(mass), ctypes.byref(out))
        return out.value

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
                self._apply_impulse(sim, c, p1, p2, gb, dx, dy, dz, math.sqrt(distance2), dvx,
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
            resolved = self._apply_impulse(sim, c, p1, p2, gb, cx, cy, cz, contact, dvx, dvy,
                                           dvz, back_time)
        elif overlapping:
            resolved = self._apply_impulse(sim, c, p1, p2, gb, dx, dy, dz, math.sqrt(distance2),
                                           dvx, dvy, dvz, 0.0)
        else:
            return
        if resolved:
            self._memory.add(key)

    def _apply_impulse(self, sim: rebound.Simulation, c: Any, p1: Any, p2: Any, gb: Any,
                       dx: float, dy: float, dz: float, distance: float, dvx: float,
                       dvy: float, dvz: float, back_time: float) -> bool:
        """rs_apply_impulse: the contact at separation (dx, dy, dz) [m], relative velocity
        (dvx, dvy, dvz) [m/s], back_time [s] before the end of the step; True if resolved."""
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
        separation_change, floored = _floored_separation_change(
            sim, p1.r, p2.r, distance, (1.0 + eps) * impact_speed)
        self.normal_dissipation += 0.5 * M_bar * separation_change * (
            2.0 * impact_speed - separation_change)

        old_vy_outer = p1.vy if dx > 0.0 else p2.vy
        jx = separation_change * (dx / distance)
        jy = separation_change * (dy / distance)
        jz = separation_change * (dz / distance)
        share2 = m1 / total_mass
        share1 = m2 / total_mass
        if self.friction_model != "none":
            jtx, jty, jtz = self._rough_impulse(
                sim, c, p1.r, p2.r, share1, share2, M_bar, separation_change,
                (dx, dy, dz, distance), (dvx, dvy, dvz), back_time)
            jx += jtx
            jy += jty
            jz += jtz
        _kick(p1, p2, share1, share2, jx, jy, jz, back_time)
        if dx > 0.0:
            sim.collisions_plog += -abs(dx) * (old_vy_outer - p1.vy) * m1
        else:
            sim.collisions_plog += -abs(dx) * (old_vy_outer - p2.vy) * m2
        sim.collisions_log_n += 1
        self._record(sim.t, impact_speed, R_bar, M_bar, eps, floored)
        return True

    def _rough_impulse(self, sim: rebound.Simulation, c: Any, R1: float, R2: float,
                       share1: float, share2: float, M_bar: float, separation_change: float,
                       separation: tuple[float, float, float, float],
                       velocity: tuple[float, float, float], back_time: float
                       ) -> tuple[float, float, float]:
        """rs_apply_impulse's rough-sphere branch: the stored spins of the pair turned into
        the rotating frame's axes at the contact time, the tangential impulse applied to
        them (:meth:`_tangential_impulse`), and stored back; returns j_t [m/s]."""
        while len(self.spins) < sim.N:
            self.spins.append([0.0, 0.0, 0.0])
        theta = sim.OMEGA * (sim.t - back_time)     # rs_spin_frame_angle
        cos, sin = math.cos(theta), math.sin(theta)
        w1 = _to_rotating(self.spins[c.p1], cos, sin)
        w2 = _to_rotating(self.spins[c.p2], cos, sin)
        jt = self._tangential_impulse(w1, w2, R1, R2, share1, share2, M_bar,
                                      separation_change, *separation, *velocity)
        self.spins[c.p1] = _from_rotating(w1, cos, sin)
        self.spins[c.p2] = _from_rotating(w2, cos, sin)
        return jt

    def _record(self, t: float, impact_speed: float, R_bar: float, M_bar: float, eps: float,
                floored: bool) -> None:
        """rs_record: the statistics and the log of one collision."""
        self.count += 1
        self.n_floored += int(floored)
        self.sum_epsilon += eps
        self.sum_vn += impact_speed
        self.log.append((t, impact_speed, R_bar, M_bar, eps))

    def _tangential_impulse(self, w1: list[float], w2: list[float], R1: float, R2: float,
                            share1: float, share2: float, M_bar: float,
                            separation_change: float, dx: float, dy: float, dz: float,
                            distance: float, dvx: float, dvy: float, dvz: float
                            ) -> tuple[float, float, float]:
        """rs_tangential_impulse: jt per reduced mass [m/s]; turns w1, w2 in place."""
        k = self.inertia_factor
        nx, ny, nz = dx / distance, dy / distance, dz / distance
        lever = distance / (R1 + R2)
        a1 = R1 * lever
        a2 = R2 * lever
        sx = a1 * w1[0] + a2 * w2[0]
        sy = a1 * w1[1] + a2 * w2[1]
        sz = a1 * w1[2] + a2 * w2[2]
        gx = dvx - (sy * nz - sz * ny)
        gy = dvy - (sz * nx - sx * nz)
        gz = dvz - (sx * ny - sy * nx)
        gn = gx * nx + gy * ny + gz * nz
        gtx, gty, gtz = gx - gn * nx, gy - gn * ny, gz - gn * nz
        f_t = 1.0 / (1.0 + lever * lever * (share1 / k + share2 / k))
        gt2 = gtx * gtx + gty * gty + gtz * gtz
        if self.friction_model == "constant":
            coefficient = (1.0 + self.friction_parameters["beta"]) * f_t
        else:
            stick = (1.0 + self.friction_parameters["beta0"]) * f_t
            gt = math.sqrt(gt2)
            limit = self.friction_parameters["mu"] * separation_change
            coefficient = limit / gt if stick * gt > limit else stick
            self.n_sliding += int(stick * gt > limit)
        jtx, jty, jtz = -(coefficient * gtx), -(coefficient * gty), -(coefficient * gtz)
        cx = ny * jtz - nz * jty
        cy = nz * jtx - nx * jtz
        cz = nx * jty - ny * jtx
        f1 = lever * share1 / (k * R1)
        f2 = lever * share2 / (k * R2)
        for w, f in ((w1, f1), (w2, f2)):
            w[0] -= f * cx
            w[1] -= f * cy
            w[2] -= f * cz
        self.tangential_dissipation += 0.5 * M_bar * coefficient * (
            2.0 - coefficient / f_t) * gt2
        return jtx, jty, jtz

    def rotating_spins(self, sim: rebound.Simulation) -> np.ndarray:
        """Spins of all particles in the rotating frame's axes at ``sim.t``, (N, 3)
        [rad/s], as ``rs_spins_read`` computes them."""
        theta = sim.OMEGA * sim.t
        cos, sin = math.cos(theta), math.sin(theta)
        stored = self.spins + [[0.0, 0.0, 0.0]] * (sim.N - len(self.spins))
        return np.array([_to_rotating(w, cos, sin) for w in stored[:sim.N]]).reshape(-1, 3)

    def stats(self) -> dict[str, Any]:
        """count, n_floored, mean_epsilon, mean_vn [m/s] and the full log (LOG_DTYPE)."""
        count = self.count
        return {
            "count": count,
            "n_floored": self.n_floored,
            "mean_epsilon": self.sum_epsilon / count if count else math.nan,
            "mean_vn": self.sum_vn / count if count else math.nan,
            "log": np.array(self.log, dtype=LOG_DTYPE),
            "tangential_dissipation": self.tangential_dissipation,
            "n_sliding": self.n_sliding,
            "normal_dissipation": self.normal_dissipation,
        }


def _floored_separation_change(sim: rebound.Simulation, R1: float, R2: float,
                               distance: float, separation_change: float
                               ) -> tuple[float, bool]:
    """rs_apply_impulse's floor: the separation speed [m/s] raised to REBOUND's minimum
    collision velocity (scaled with the radii and the overlap), and whether it was."""
    r_min = R2 if R1 > R2 else R1
    r_max = R2 if R1 < R2 else R1
    w = sim.minimum_collision_velocity
    v_floor = r_min * w
    v_floor *= 1.0 - (distance - r_max) / r_min
    if v_floor > r_max * w:
        v_floor = r_max * w
    if separation_change < v_floor:
        return v_floor, True
    return separation_change, False


def _kick(p1: Any, p2: Any, share1: float, share2: float, jx: float, jy: float, jz: float,
          back_time: float) -> None:
    """rs_apply_impulse's update: the impulse j (per reduced mass, [m/s]) on both particles'
    velocities and, for a contact back_time [s] before the end of the step, the positions
    the new velocities reach in the rest of it."""
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


def _to_rotating(s: list[float], cos: float, sin: float) -> list[float]:
    """rs_spin_to_rotating: stored spin -> the rotating frame's axes at angle theta."""
    return [cos * s[0] + sin * s[1], cos * s[1] - sin * s[0], s[2]]


def _from_rotating(w: list[float], cos: float, sin: float) -> list[float]:
    """rs_spin_from_rotating, the inverse of :func:`_to_rotating`."""
    return [cos * w[0] - sin * w[1], cos * w[1] + sin * w[0], w[2]]


#: Particles searched at once by `count_overlaps_numpy`: bounds its transient memory (about 150
#: bytes per particle at N = 3e5, 940 if all were searched at once).
OVERLAP_CHUNK = 1 << 13


def count_overlaps_numpy(arrays: dict[str, np.ndarray], Lx: float, Ly: float, shift: float,
                         fraction: float) -> int:
    """Pairs overlapping by more than ``fraction`` of the smaller radius: the numpy twin of
    ``rs_count_overlaps``, the C count behind ``engine.box.count_overlaps``.

    Candidates within twice the largest radius come from scipy's cKDTree over the particles
    and their shear-periodic radial images (`physics.selfgravity.radial_images`; periodic in
    y); a pair is tested as the C tests it: the lower index's particle against the higher
    index's particle or image, differences of the coordinates as given, y wrapped, the
    squares summed x + y + z.

    Parameters
    ----------
    arrays : particle arrays: x, y, z [m], radius [m]
    Lx, Ly : float [m]
    shift : float [m]
        Shear offset of the radial images, 1.5 Omega Lx t.
    fraction : float [dimensionless]
    """
    from scipy.spatial import cKDTree

    r = arrays["radius"]
    if r.size < 2:
        return 0
    reach = 2.0 * float(r.max())
    index, px, py, pz = radial_images(arrays["x"], arrays["y"], arrays["z"], Lx, shift, reach)
    pos = np.column_stack([px - px.min(), np.mod(py + 0.5 * Ly, Ly), pz - pz.min()])
    order = np.argsort(pos[:, 0], kind="stable")   # chunks of neighbours: compact trees
    tree = cKDTree(pos, boxsize=[1e300, Ly, 1e300])
    deep_pairs = [np.zeros((0, 2), dtype=np.int64)]
    for start in range(0, order.size, OVERLAP_CHUNK):
        chunk = order[start:start + OVERLAP_CHUNK]
        found = cKDTree(pos[chunk], boxsize=[1e300, Ly, 1e300]).sparse_distance_matrix(
            tree, reach, output_type="ndarray")
        p, q = chunk[found["i"]], found["j"]
        once = p < q   # each tree pair once (it is found from both of its chunks)
        p, q = p[once], q[once]
        keep = index[p] < index[q]  # the lower index's particle first (originals come first)
        p, q = p[keep], q[keep]
        dx, dy, dz = px[p] - px[q], py[p] - py[q], pz[p] - pz[q]
        dy -= Ly * np.round(dy / Ly)
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        ri, rj = r[index[p]], r[index[q]]
        deep = ri + rj - dist > fraction * np.minimum(ri, rj)
        deep_pairs.append(np.column_stack([index[p][deep], index[q][deep]]))
    return int(np.unique(np.concatenate(deep_pairs), axis=0).shape[0])


def run_file_datasets(path) -> dict[str, object]:
    """Every dataset of a run file by its name, as bytes (object arrays as the repr of
    their values), for comparing files with ``==``; external links to part files
    (``store.bulk``) followed.  Without ``/checkpoint``: REBOUND's binary embeds wall-clock
    timings (compare the state it loads instead).
    """
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name != "checkpoint":
                data = obj[...]
                out[name] = repr(data.tolist()) if data.dtype.kind == "O" else data.tobytes()
        f.visititems(visit)
        snapshots = f.get("snapshots", {})
        for name in snapshots:   # visititems does not follow external links
            if isinstance(snapshots.get(name, getlink=True), h5py.ExternalLink):
                snapshots[name].visititems(
                    lambda key, obj, name=name: visit(f"snapshots/{name}/{key}", obj))
    return out
