"""Collisions of rough spheres: normal restitution, tangential restitution, Coulomb friction.

Pure numpy, SI units, vectorised over many collisions.  The normal coefficient of
restitution ``eps_n`` comes from any law of :mod:`ringsim.physics.restitution` (Dilley's
pair-dependent eps unchanged); this module adds what happens along the contact plane and
to the spins, and the spin diagnostics of a run.  The temperatures of a gas of such
spheres (homogeneous cooling, the collisional balance of rotation in a ring) are
:mod:`ringsim.physics.spin_temperature`.

Conventions (declared here once)
--------------------------------
* Pair (1, 2); ``dr = r1 - r2`` (with REBOUND's ghost-box offset added to particle 1), the
  unit normal ``n = dr / |dr|`` points from 2 to 1, ``dv = v1 - v2``.  Approaching pairs
  have ``dv . n < 0``; the impact speed is ``v_n = -dv . n > 0``.
* Spin ``w`` [rad/s] is the angular velocity of a particle about its own centre,
  **measured relative to the rotating frame of the shearing sheet** (x radially outward,
  y along the orbital motion, z along the orbital angular momentum, as REBOUND's sheet).
  w = 0 is synchronous rotation (the particle keeps one face to the planet); the spin
  relative to inertial space is ``w + Omega z_hat`` (:func:`inertial_spin`).  ringsim
  stores the rotating-frame spin because the sheet's velocities are rotating-frame
  velocities: the contact-point velocity of a particle is then ``v + w x arm`` with no
  frame term, so the collision rule below is the same as in an inertial box.  Both spins
  are constant between collisions (no torque acts on a sphere).  w_z > 0 is rotation in
  the sense of the orbital motion as seen in the rotating frame; the shear flow
  vy = -(3/2) Omega x has vorticity -(3/2) Omega z_hat, so a sphere turning with the
  local mean flow (half its vorticity) has w_z = -(3/4) Omega (inertial +Omega/4).
* Contact point: on the centre line, dividing ``|dr|`` in the ratio R1 : R2, i.e. at the
  lever arms ``a1 = R1 lam``, ``a2 = R2 lam`` from the centres with
  ``lam = |dr| / (R1 + R2)`` (1 at exact contact, slightly below 1 for the overlaps of
  the tree search).  With ``a1 + a2 = |dr|`` the impulse conserves the total angular
  momentum (spins plus orbital) exactly, also for overlapping pairs.
* Relative velocity of the contact points (of 1 with respect to 2):
  ``g = dv - (a1 w1 + a2 w2) x n``, its tangential part ``g_t = g - (g . n) n``.
* Moment of inertia ``I = k m R^2``; ``k = 2/5`` is a solid sphere.

Collision rule
--------------
The impulse ``J`` acts on particle 1 at the contact point (``-J`` on 2).  In units of the
reduced mass M_bar = m1 m2/(m1 + m2), ``j = J / M_bar`` is a velocity::

    normal       j_n = (1 + eps_n) v_n n                  g_n' = -eps_n g_n
    tangential   j_t = -(1 + beta) f_t g_t                g_t' = -beta g_t
    velocities   v1' = v1 + m2/(m1+m2) j,   v2' = v2 - m1/(m1+m2) j,   j = j_n + j_t
    spins        w1' = w1 - lam m2/(m1+m2) / (k1 R1) (n x j_t)
                 w2' = w2 - lam m1/(m1+m2) / (k2 R2) (n x j_t)

with the tangential mass factor ``f_t = M_t / M_bar = 1 / (1 + lam^2 (m2/(m1+m2)/k1 +
m1/(m1+m2)/k2))`` (= k/(1+k) = 2/7 for equal k = 2/5 at contact), from
1/M_t = 1/m1 + 1/m2 + a1^2/I1 + a2^2/I2.  ``beta`` is

* ``constant``: a constant tangential restitution in [-1, 1] (beta = -1 smooth spheres,
  the behaviour without a friction section; beta = 0 the contact point stops; beta = 1
  perfectly rough, the tangential contact velocity reversed without loss), the model of
  Huthmann & Zippelius (1997) and Luding et al. (1998);
* ``coulomb``: Walton's (1993) model as written by Luding et al. (1998): the
  tangential impulse that would give the sticking value beta0 (default 0: the contact
  point comes to rest), bounded by Coulomb's law |J_t| <= mu |J_n|:

      beta = min(beta0, -1 + mu (1 + eps_n) v_n / (f_t |g_t|))

  i.e. sticking (beta = beta0) for steep impacts and sliding with |J_t| = mu |J_n| for
  grazing ones (for equal spheres at contact, f_t = k/(1+k) and this is Luding's
  -1 + mu (1 + eps_n)(1 + 1/k) cot(gamma), gamma the impact angle).

Energy lost (closed form; the impulse acts on the mean of the contact velocities before
and after, J . (g + g')/2):

    Delta E = -1/2 M_bar (1 - eps_n^2) v_n^2 - 1/2 M_bar f_t (1 - beta^2) |g_t|^2.

beta = -1 gives j_t = 0 exactly, so velocities and spins are bit-for-bit those of the
smooth-sphere resolver (:func:`collision_impulse` follows ``rs_resolver.c``'s arithmetic for
the normal part).

References
----------
Walton, O. R. 1993, in Particulate Two-Phase Flow, ed. M. C. Roco (Butterworth), 884-911.
Huthmann, M. & Zippelius, A. 1997, Phys. Rev. E 56, R6275.
Luding, S., Huthmann, M., McNamara, S. & Zippelius, A. 1998, Phys. Rev. E 58, 3416.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ringsim import quantities
from ringsim.physics.laws import DIMENSIONLESS, Law, LawTable, MeasuredRange, Parameter

FloatArray = NDArray[np.float64]

#: Moment-of-inertia factor k of a homogeneous solid sphere, I = k m R^2.
SOLID_SPHERE_INERTIA = 0.4

#: The moment-of-inertia factor k, I = k m R^2 (scenario key ``particles.inertia_factor``):
#: 2/5 a homogeneous solid sphere, up to 2/3 a thin spherical shell (all mass at the surface).
INERTIA_FACTOR = Parameter(
    "inertia_factor", DIMENSIONLESS, default=SOLID_SPHERE_INERTIA, lower=0.0,
    upper=2.0 / 3.0, upper_closed=True,
    meaning="k in the moment of inertia I = k m R² (used with a friction section only)",
    source="2/5 homogeneous solid sphere; 2/3 thin shell, the largest for a sphere whose "
           "density does not grow outward")

_LUDING = "Luding, Huthmann, McNamara & Zippelius 1998, PRE 58, 3416"
_NOT_MEASURED = MeasuredRange(speeds=None, sizes=None,
                              source="a model parameter, not fitted to ring-particle data")

#: The friction models of a scenario's optional ``friction:`` section and the only
#: declaration of their parameters (see ringsim.physics.laws).  Code 0 of the C library
#: (RS_FRICTION_NONE) is no section: smooth spheres.  The C ``struct rs_resolver`` has
#: ``friction[3]``.  Each law's function is :func:`collision_impulse`, the one rule.
FRICTION = LawTable("friction", n_slots=3, laws=[
    Law("constant", code=1, function=lambda *a, **k: collision_impulse(*a, **k),
        formula="g_t' = −β g_t (tangential contact velocity), j_t = −(1 + β) f_t g_t",
        source="Huthmann & Zippelius 1997, PRE 56, R6275; " + _LUDING,
        measured=_NOT_MEASURED,
        parameters=(
            Parameter("beta", DIMENSIONLESS, lower=-1.0, upper=1.0, lower_closed=True,
                      upper_closed=True, slot=0, example=0.0,
                      meaning="tangential coefficient of restitution: g_t' = −β g_t (−1 "
                              "smooth, 0 the contact point stops, 1 perfectly rough)",
                      source="Huthmann & Zippelius 1997; " + _LUDING +
                             " (example 0: the middle of the range)"),
        )),
    Law("coulomb", code=2, function=lambda *a, **k: collision_impulse(*a, **k),
        formula="β = min(β0, −1 + μ (1 + ε_n) v_n / (f_t g_t)): sticking, or sliding "
                "with J_t = μ J_n (magnitudes)",
        source="Walton 1993, in Particulate Two-Phase Flow, 884; " + _LUDING,
        measured=_NOT_MEASURED,
        parameters=(
            Parameter("mu", DIMENSIONLESS, lower=0.0, lower_closed=True, slot=0,
                      example=0.5, meaning="Coulomb friction coefficient: J_t ≤ μ J_n (magnitudes)",
                      source="Walton 1993; " + _LUDING + " (example 0.5)"),
            Parameter("beta0", DIMENSIONLESS, default=0.0, lower=-1.0, upper=1.0,
                      lower_closed=True, upper_closed=True, slot=1,
                      meaning="tangential restitution of sticking contacts (0: the contact "
                              "point comes to rest)",
                      source="Walton 1993; " + _LUDING),
        )),
])


def friction_parameters(friction: Mapping[str, object] | None) -> tuple[str, dict[str, float]]:
    """Validate a ``friction`` mapping against `FRICTION`; return (model, parameters with
    defaults filled).

    ``None`` (no friction section) is smooth spheres, returned as ``("constant",
    {"beta": -1.0})``.  Raises ValueError starting with the offending key.
    """
    if friction is None:
        return "constant", {"beta": -1.0}
    model = friction.get("model")
    if model in FRICTION.names:
        law = FRICTION[model]
        for key, value in friction.items():
            if key in law.names:
                try:
                    law[key].check(value)
                except ValueError as exc:
                    raise ValueError(f"{key}: {exc}") from None
    law, params = FRICTION.resolve(friction)
    return law.name, params


class Impulse(NamedTuple):
    """Velocity and spin changes of a batch of collisions, and what the rule used.

    All arrays have one row per collision.
    """
    dv1: FloatArray            #: (n, 3) velocity change of particle 1 [m/s]
    dv2: FloatArray            #: (n, 3) velocity change of particle 2 [m/s]
    dw1: FloatArray            #: (n, 3) spin change of particle 1 [rad/s]
    dw2: FloatArray            #: (n, 3) spin change of particle 2 [rad/s]
    impact_speed: FloatArray   #: (n,) v_n = -dv . n before the collision [m/s]
    g_t: FloatArray            #: (n, 3) tangential contact velocity before [m/s]
    tangential_factor: FloatArray  #: (n,) f_t = M_t / M_bar [-]
    beta: FloatArray           #: (n,) tangential restitution applied [-]
    sliding: NDArray[np.bool_]     #: (n,) Coulomb bound active (False for constant)


def _rows(name: str, value: ArrayLike, n: int | None = None) -> FloatArray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3) or (3,), got {np.shape(value)}")
    if n is not None and a.shape[0] != n:
        a = np.broadcast_to(a, (n, 3))
    return a


def collision_impulse(dr: ArrayLike, dv: ArrayLike, w1: ArrayLike, w2: ArrayLike,
                      R1: ArrayLike, R2: ArrayLike, m1: ArrayLike, m2: ArrayLike,
                      eps_n: ArrayLike, friction: Mapping[str, object] | None = None,
                      k1: ArrayLike = SOLID_SPHERE_INERTIA,
                      k2: ArrayLike = SOLID_SPHERE_INERTIA,
                      separation_change: ArrayLike | None = None) -> Impulse:
    """The impulse of colliding rough spheres, as velocity and spin changes.

    Arithmetic in the order of ``rs_resolver.c``: ``rs_apply_impulse`` for the normal
    part, ``rs_tangential_impulse`` for the tangential part and the spins.  With
    ``friction=None`` or beta = -1 the velocity changes are bit-for-bit the smooth
    resolver's and the spin changes are exactly zero.  The caller selects the
    approaching pairs (v_n > 0); the rule is applied as given.

    Parameters
    ----------
    dr : array (n, 3) [m]
        Separation r1 - r2 at the contact (ghost offset included).
    dv : array (n, 3) [m/s]
        Relative velocity v1 - v2 (ghost offset included).
    w1, w2 : array (n, 3) [rad/s]
        Spins, relative to the rotating frame of the sheet (module docstring).
    R1, R2 : array (n,) [m]
        Radii, > 0.
    m1, m2 : array (n,) [kg]
        Masses, m1 + m2 > 0.
    eps_n : array (n,) [-]
        Normal coefficient of restitution of each pair, in [0, 1].
    friction : mapping or None
        ``{"model": "constant", "beta": B}`` or ``{"model": "coulomb", "mu": M}``
        (optional ``beta0``); None is smooth spheres.
    k1, k2 : array (n,) [-]
        Moment-of-inertia factors, I = k m R^2, > 0 (2/5: solid sphere).
    separation_change : array (n,) [m/s], optional
        The normal relative-velocity change (1 + eps_n) v_n, if the caller raised it
        (REBOUND's minimum_collision_velocity); the Coulomb bound uses the normal
        impulse actually applied.
    """
    model, params = friction_parameters(friction)
    dr, dv, w1, w2, (R1, R2, m1, m2, eps_n, k1, k2) = _batch(dr, dv, w1, w2, R1, R2, m1, m2,
                                                             eps_n, k1, k2)
    normal = _normal_impulse(dr, dv, m1, m2, eps_n, separation_change)
    tangential = _tangential_impulse(model, params, normal, dv, w1, w2, R1, R2, k1, k2)
    (nx, ny, nz), sep, (jtx, jty, jtz) = normal.n, normal.separation_change, tangential.j_t
    j = [sep * nx + jtx, sep * ny + jty, sep * nz + jtz]
    dv1 = np.stack([normal.share1 * jc for jc in j], axis=1)
    dv2 = np.stack([-(normal.share2 * jc) for jc in j], axis=1)
    return Impulse(dv1, dv2, tangential.dw1, tangential.dw2, normal.impact_speed,
                   tangential.g_t, tangential.tangential_factor, tangential.beta,
                   tangential.sliding)


def _batch(dr: ArrayLike, dv: ArrayLike, w1: ArrayLike, w2: ArrayLike, *per_pair: ArrayLike
           ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, list[FloatArray]]:
    """The arguments of :func:`collision_impulse` as one batch of n collisions: dr, dv, w1
    and w2 as (n, 3) rows, every other argument as an (n,) array."""
    dr = _rows("dr", dr)
    n = dr.shape[0]
    return (dr, _rows("dv", dv, n), _rows("w1", w1, n), _rows("w2", w2, n),
            [np.broadcast_to(np.asarray(a, dtype=float), (n,)) for a in per_pair])


class _Normal(NamedTuple):
    """The normal part of a batch of collisions (one entry per collision)."""
    distance: FloatArray           #: |dr| [m]
    n: tuple[FloatArray, FloatArray, FloatArray]   #: unit normal dr / |dr|, by component
    impact_speed: FloatArray       #: v_n = -dv . n [m/s]
    separation_change: FloatArray  #: (1 + eps_n) v_n, or the caller's raised value [m/s]
    share1: FloatArray             #: m2 / (m1 + m2) [-]
    share2: FloatArray             #: m1 / (m1 + m2) [-]


def _normal_impulse(dr: FloatArray, dv: FloatArray, m1: FloatArray, m2: FloatArray,
                    eps_n: FloatArray, separation_change: ArrayLike | None) -> _Normal:
    """The normal part of the rule: ``rs_apply_impulse``'s operations, in its order."""
    (dx, dy, dz), (dvx, dvy, dvz) = dr.T, dv.T
    distance = np.sqrt(dx * dx + dy * dy + dz * dz)
    v_n = (dvx * dx + dvy * dy + dvz * dz) / distance
    impact_speed = -v_n
    sep = (1.0 + eps_n) * impact_speed if separation_change is None else \
        np.broadcast_to(np.asarray(separation_change, dtype=float), impact_speed.shape)
    total_mass = m1 + m2
    return _Normal(distance, (dx / distance, dy / distance, dz / distance), impact_speed,
                   sep, m2 / total_mass, m1 / total_mass)


class _Tangential(NamedTuple):
    """The tangential part of a batch of collisions (one entry or row per collision)."""
    j_t: tuple[FloatArray, FloatArray, FloatArray]  #: tangential impulse / M_bar [m/s]
    dw1: FloatArray                 #: (n, 3) spin change of particle 1 [rad/s]
    dw2: FloatArray                 #: (n, 3) spin change of particle 2 [rad/s]
    g_t: FloatArray                 #: (n, 3) tangential contact velocity before [m/s]
    tangential_factor: FloatArray   #: f_t = M_t / M_bar [-]
    beta: FloatArray                #: tangential restitution applied [-]
    sliding: NDArray[np.bool_]      #: Coulomb bound active


def _tangential_impulse(model: str, params: Mapping[str, float], normal: _Normal,
                        dv: FloatArray, w1: FloatArray, w2: FloatArray, R1: FloatArray,
                        R2: FloatArray, k1: FloatArray, k2: FloatArray) -> _Tangential:
    """The tangential part of the rule and the spin changes: ``rs_tangential_impulse``'s
    operations, in its order.  Only the tangential impulse has a torque (n x j_n = 0
    exactly in the mathematics, not in floating point, so it is left out)."""
    nx, ny, nz = normal.n
    share1, share2 = normal.share1, normal.share2
    lever = normal.distance / (R1 + R2)
    gtx, gty, gtz = _tangential_contact_velocity(dv, w1, w2, R1 * lever, R2 * lever,
                                                 nx, ny, nz)
    tangential_factor = 1.0 / (1.0 + lever * lever * (share1 / k1 + share2 / k2))
    coefficient, beta, sliding = _tangential_coefficient(
        model, params, tangential_factor, normal.separation_change, gtx, gty, gtz)
    jtx, jty, jtz = -(coefficient * gtx), -(coefficient * gty), -(coefficient * gtz)
    cx, cy, cz = ny * jtz - nz * jty, nz * jtx - nx * jtz, nx * jty - ny * jtx
    dw1 = _spin_change(lever * share1 / (k1 * R1), cx, cy, cz)
    dw2 = _spin_change(lever * share2 / (k2 * R2), cx, cy, cz)
    return _Tangential((jtx, jty, jtz), dw1, dw2, np.stack([gtx, gty, gtz], axis=1),
                       tangential_factor, beta, sliding)


def _tangential_contact_velocity(dv: FloatArray, w1: FloatArray, w2: FloatArray,
                                 a1: FloatArray, a2: FloatArray, nx: FloatArray,
                                 ny: FloatArray, nz: FloatArray
                                 ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """g_t of g = dv - (a1 w1 + a2 w2) x n, component by component as the C will do."""
    sx = a1 * w1[:, 0] + a2 * w2[:, 0]
    sy = a1 * w1[:, 1] + a2 * w2[:, 1]
    sz = a1 * w1[:, 2] + a2 * w2[:, 2]
    gx = dv[:, 0] - (sy * nz - sz * ny)
    gy = dv[:, 1] - (sz * nx - sx * nz)
    gz = dv[:, 2] - (sx * ny - sy * nx)
    gn = gx * nx + gy * ny + gz * nz
    return gx - gn * nx, gy - gn * ny, gz - gn * nz


def _spin_change(factor: FloatArray, cx: FloatArray, cy: FloatArray, cz: FloatArray
                 ) -> FloatArray:
    """-factor (n x j_t) as an (n, 3) array [rad/s]."""
    return np.stack([-(factor * cx), -(factor * cy), -(factor * cz)], axis=1)


def _tangential_coefficient(model: str, params: Mapping[str, float],
                            tangential_factor: FloatArray, sep: FloatArray, gtx: FloatArray,
                            gty: FloatArray, gtz: FloatArray
                            ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """c in j_t = -c g_t, the beta it gives, and whether Coulomb's bound is active."""
    if model == "constant":
        beta = np.full(tangential_factor.shape, params["beta"])
        return (1.0 + params["beta"]) * tangential_factor, beta, np.zeros(beta.shape, bool)
    stick = (1.0 + params["beta0"]) * tangential_factor
    g_t = np.sqrt(gtx * gtx + gty * gty + gtz * gtz)
    limit = params["mu"] * sep
    sliding = stick * g_t > limit        # False for g_t = 0: nothing to resist
    safe = np.where(sliding, g_t, 1.0)
    coefficient = np.where(sliding, limit / safe, stick)
    beta = np.where(sliding, coefficient / tangential_factor - 1.0, params["beta0"])
    return coefficient, beta, sliding


def collide(x1: ArrayLike, v1: ArrayLike, w1: ArrayLike, x2: ArrayLike, v2: ArrayLike,
            w2: ArrayLike, R1: ArrayLike, R2: ArrayLike, m1: ArrayLike, m2: ArrayLike,
            eps_n: ArrayLike, friction: Mapping[str, object] | None = None,
            k1: ArrayLike = SOLID_SPHERE_INERTIA, k2: ArrayLike = SOLID_SPHERE_INERTIA
            ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """New velocities and spins (v1', w1', v2', w2') of colliding rough spheres.

    Positions x [m], velocities v [m/s] and spins w [rad/s] as (n, 3) arrays in one
    frame (particle 1 already shifted into its ghost box); other arguments as for
    :func:`collision_impulse`.
    """
    x1, v1, w1, x2, v2, w2 = (np.atleast_2d(np.asarray(a, dtype=float))
                              for a in (x1, v1, w1, x2, v2, w2))
    imp = collision_impulse(x1 - x2, v1 - v2, w1, w2, R1, R2, m1, m2, eps_n, friction,
                            k1, k2)
    return v1 + imp.dv1, w1 + imp.dw1, v2 + imp.dv2, w2 + imp.dw2


def coulomb_beta(mu: float, eps_n: ArrayLike, impact_speed: ArrayLike, g_t: ArrayLike,
                 tangential_factor: ArrayLike, beta0: float = 0.0) -> FloatArray:
    """Tangential restitution of Walton's Coulomb model (Luding et al. 1998).

    beta = min(beta0, -1 + mu (1 + eps_n) v_n / (f_t |g_t|)); beta0 where |g_t| = 0.

    Parameters
    ----------
    mu : float [-]
        Friction coefficient, >= 0.
    eps_n : array [-]
        Normal restitution.
    impact_speed : array [m/s]
        v_n > 0.
    g_t : array [m/s]
        |g_t|, the tangential contact speed before the collision.
    tangential_factor : array [-]
        f_t = M_t / M_bar.
    beta0 : float [-]
        Tangential restitution of sticking contacts.
    """
    g = np.asarray(g_t, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        sliding = -1.0 + mu * (1.0 + np.asarray(eps_n)) * np.asarray(impact_speed) / (
            np.asarray(tangential_factor) * g)
    return np.where(g > 0.0, np.minimum(beta0, sliding), beta0)


def energy_loss(M_bar: ArrayLike, impact_speed: ArrayLike, eps_n: ArrayLike, g_t: ArrayLike,
                beta: ArrayLike, tangential_factor: ArrayLike) -> FloatArray:
    """Kinetic energy (translation + rotation) a collision dissipates, closed form [J].

    Delta E = 1/2 M_bar (1 - eps_n^2) v_n^2 + 1/2 M_bar f_t (1 - beta^2) |g_t|^2 >= 0.

    Parameters
    ----------
    M_bar : array [kg]
        Reduced mass.
    impact_speed : array [m/s]
        v_n.
    eps_n : array [-]
        Normal restitution (the effective one, (separation change)/v_n - 1, if the normal
        impulse was raised).
    g_t : array [m/s]
        |g_t| before the collision.
    beta : array [-]
        Tangential restitution applied (:func:`coulomb_beta` for Coulomb friction).
    tangential_factor : array [-]
        f_t = M_t / M_bar.
    """
    M_bar, v, e, g, b, f = (np.asarray(a, dtype=float) for a in
                            (M_bar, impact_speed, eps_n, g_t, beta, tangential_factor))
    return 0.5 * M_bar * ((1.0 - e * e) * v * v + f * (1.0 - b * b) * g * g)


# --- rotational energy and spin ---------------------------------------------------------------

def moment_of_inertia(m: ArrayLike, R: ArrayLike, k: ArrayLike = SOLID_SPHERE_INERTIA
                      ) -> FloatArray:
    """I = k m R^2 [kg m^2] for mass m [kg], radius R [m], factor k [-]."""
    return np.asarray(k, dtype=float) * np.asarray(m, dtype=float) * np.asarray(R, float) ** 2


def rotational_energy(m: ArrayLike, R: ArrayLike, w: ArrayLike,
                      k: ArrayLike = SOLID_SPHERE_INERTIA) -> FloatArray:
    """1/2 I |w|^2 per particle [J]; m [kg], R [m], w (n, 3) [rad/s] in the sheet frame."""
    w = np.atleast_2d(np.asarray(w, dtype=float))
    return 0.5 * moment_of_inertia(m, R, k) * np.sum(w * w, axis=1)


def inertial_spin(w: ArrayLike, Omega: float) -> FloatArray:
    """Spin relative to inertial space, w + Omega z_hat [rad/s].

    Parameters
    ----------
    w : array (n, 3) [rad/s]
        Spin relative to the rotating frame of the sheet (as ringsim stores it).
    Omega : float [1/s]
        Orbital frequency of the sheet.
    """
    out = np.array(w, dtype=float, copy=True)
    out[..., 2] += Omega
    return out


def spin_statistics(w: ArrayLike, Omega: float, weights: ArrayLike | None = None
                    ) -> dict[str, float]:
    """Spin distribution in units of Omega, in the rotating frame of the sheet.

    Returns ``mean_abs`` <|w|>/Omega, ``rms`` sqrt(<|w|^2>)/Omega and ``mean_z`` <w_z>/Omega
    (w_z > 0: rotation in the sense of the orbital motion relative to the rotating frame;
    add 1 for the inertial frame, see :func:`inertial_spin`; synchronous rotation is 0, a
    sphere turning with the mean shear flow -3/4).

    Parameters
    ----------
    w : array (n, 3) [rad/s]
        Spins relative to the rotating frame.
    Omega : float [1/s]
        Orbital frequency.
    weights : array (n,), optional
        Weights of the particles (e.g. mass or cross section); equal by default.
    """
    w = np.atleast_2d(np.asarray(w, dtype=float))
    wts = None if weights is None else np.asarray(weights, dtype=float)
    size = np.sqrt(np.sum(w * w, axis=1))
    return {"mean_abs": float(np.average(size, weights=wts)) / Omega,
            "rms": math.sqrt(float(np.average(size * size, weights=wts))) / Omega,
            "mean_z": float(np.average(w[:, 2], weights=wts)) / Omega}


#: The spin rows of a run's time series (runs with friction): key -> unit (ringsim.quantities).
SPIN_ROW_UNITS = quantities.units(quantities.SPIN_ROW)


def spin_row(m: ArrayLike, R: ArrayLike, w: ArrayLike, k: float, Omega: float,
             translational_energy: float) -> dict[str, float]:
    """The spin numbers of one output (:data:`SPIN_ROW_UNITS`).

    ``rotational_energy`` sum 1/2 k m R^2 |w|^2 [J] with w relative to the rotating frame
    (so a sphere that keeps one face to the planet has none); ``rotational_energy_ratio``
    that over ``translational_energy`` (0 if that is 0); ``mean_spin_z`` <w_z>/Omega and
    ``rms_spin`` sqrt(<|w|^2>)/Omega, number-weighted (:func:`spin_statistics`: w_z > 0
    prograde in the rotating frame, an inertially non-rotating particle shows -1).

    Parameters
    ----------
    m : array (n,) [kg]
    R : array (n,) [m]
    w : array (n, 3) [rad/s]
        Spins relative to the rotating frame, in its axes.
    k : float [-]
        Moment-of-inertia factor.
    Omega : float [1/s]
    translational_energy : float [J]
        Kinetic energy of the velocities relative to the shear flow, e.g. 3/2 sum(m)
        c_m^2 with c_m the mass-weighted velocity dispersion.
    """
    e_rot = float(np.sum(rotational_energy(m, R, w, k)))
    stats = spin_statistics(w, Omega)
    return {"rotational_energy": e_rot,
            "rotational_energy_ratio": e_rot / translational_energy if translational_energy
            > 0.0 else 0.0,
            "mean_spin_z": stats["mean_z"], "rms_spin": stats["rms"]}
