"""Runtime invariants of a shearing-sheet run, checked at every time-series output.

A run whose state breaks one of them stops (``runner.Runner``) instead of writing garbage.

1. **Finite state**: every position [m] and velocity [m/s] is finite.
2. **Particle count**: the sheet keeps the number of particles it started with (shear-
   periodic boundaries wrap particles, never remove them).
3. **Momentum of the sheet in the frame of the shear flow** (runs without self-gravity).
   In Hill's equations, x'' = 2 Omega y' + 3 Omega^2 x, y'' = -2 Omega x', z'' = -Omega^2 z,
   the velocity relative to the shear flow, u = vx, w = vy + 3/2 Omega x, obeys
   u' = 2 Omega w, w' = -Omega u / 2: a free epicycle of frequency Omega.  Averaged with
   the masses as weights, U = <u>, W = <w> evolve the same way, and so do Z = <z> and
   Vz = <vz> as a free vertical oscillation.  Nothing else changes them:

   * a collision applies equal and opposite impulses J n to the two particles, also when
     one of them is a ghost image (the ghost box's velocity offset enters the relative
     velocity, hence J, but not the momentum balance), so sum m v is unchanged; in the
     swept-path modes the particles are moved on by dv * (rest of the step), equal and
     opposite in m dx, so sum m x is unchanged as well;
   * wrapping across the radial boundary shifts x by -+Lx and vy by +-3/2 Omega Lx, which
     leaves w unchanged; wrapping in y changes neither u nor w;
   * REBOUND's SEI integrator solves the epicycle and the vertical oscillation exactly
     (rotations), so the step size does not enter.

   Between two outputs (t0 -> t, phase phi = Omega (t - t0)) the prediction is
   U = U0 cos phi + 2 W0 sin phi, W = W0 cos phi - U0 sin phi / 2,
   Z = Z0 cos phi + Vz0 / Omega sin phi, Vz = Vz0 cos phi - Omega Z0 sin phi, and the
   residual is the largest of |dU|, |dW|, |dVz|, Omega |dZ| [m/s].

   Tolerance (round-off): every floating-point operation on a particle's velocity errs by
   at most eps/2 of the largest velocity-like magnitude V = max(|vx|, |vy|, |vz|,
   3/2 Omega |x|, Omega |z|) over the particles (eps = 2.2e-16).  A step applies a bounded
   number of operations to every particle, a collision to two particles, so the mass-
   weighted means drift by at most a few eps V per step and per collision, summed
   worst-case (coherently) over the interval: tolerance = MOMENTUM_ROUNDOFF_FACTOR *
   eps * V * (n_steps + n_collisions + log2 N), the last term for the summation of the
   means.  Random round-off grows like the square root instead, so the residuals of
   ordinary runs stay far below this tolerance (docs/run_file.md, "Runtime invariants"),
   while a change of one particle's velocity by dv shows up as m dv / M.

   Self-gravity (Barnes-Hut tree forces) is not pairwise antisymmetric, so the momentum
   invariant is not checked in gravitating runs; 1 and 2 still are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Operations per particle-step (or per collision) whose round-off the tolerance allows.
MOMENTUM_ROUNDOFF_FACTOR = 32.0
_EPS = float(np.finfo(float).eps)


class InvariantViolation(RuntimeError):
    """The run's state broke an invariant; the message says which and by how much."""


@dataclass(frozen=True)
class SheetMomentum:
    """Mass-weighted means of the motion relative to the shear flow at time ``t``.

    Attributes
    ----------
    t : float [s]
    u : float [m/s]
        <vx>.
    w : float [m/s]
        <vy + 3/2 Omega x>.
    z : float [m]
        <z>.
    vz : float [m/s]
        <vz>.
    """

    t: float
    u: float
    w: float
    z: float
    vz: float

    def as_attributes(self) -> dict:
        """For the checkpoint (``momentum_t`` [s], ``momentum_u`` [m/s], ...)."""
        return {f"momentum_{k}": float(getattr(self, k)) for k in ("t", "u", "w", "z", "vz")}

    @classmethod
    def from_attributes(cls, attrs) -> SheetMomentum | None:
        """Inverse of :meth:`as_attributes` (None if the checkpoint has none)."""
        try:
            return cls(*(float(attrs[f"momentum_{k}"]) for k in ("t", "u", "w", "z", "vz")))
        except KeyError:
            return None


def sheet_momentum(arrays: dict, Omega: float, t: float) -> SheetMomentum:
    """:class:`SheetMomentum` of particle arrays (``x`` [m], ``vx`` [m/s], ``mass`` [kg] ...).

    Parameters
    ----------
    arrays : dict of 1-D arrays (``sheet.particle_arrays``)
    Omega : float [1/s]
    t : float [s]
    """
    m = arrays["mass"]
    total = m.sum()

    def mean(values):
        return float(np.dot(m, values) / total)

    return SheetMomentum(t=float(t), u=mean(arrays["vx"]),
                         w=mean(arrays["vy"] + 1.5 * Omega * arrays["x"]),
                         z=mean(arrays["z"]), vz=mean(arrays["vz"]))


def predicted(reference: SheetMomentum, Omega: float, t: float) -> SheetMomentum:
    """The free epicycle and vertical oscillation of ``reference`` carried to time ``t`` [s]."""
    phase = Omega * (t - reference.t)
    c, s = math.cos(phase), math.sin(phase)
    return SheetMomentum(t=t, u=reference.u * c + 2.0 * reference.w * s,
                         w=reference.w * c - 0.5 * reference.u * s,
                         z=reference.z * c + reference.vz / Omega * s,
                         vz=reference.vz * c - Omega * reference.z * s)


def momentum_residual(now: SheetMomentum, reference: SheetMomentum, Omega: float) -> float:
    """Largest deviation [m/s] of ``now`` from the prediction of ``reference``."""
    p = predicted(reference, Omega, now.t)
    return max(abs(now.u - p.u), abs(now.w - p.w), abs(now.vz - p.vz),
               Omega * abs(now.z - p.z))


def momentum_tolerance(arrays: dict, Omega: float, n_steps: int, n_collisions: int) -> float:
    """Round-off bound [m/s] of :func:`momentum_residual` over one interval (module doc).

    Parameters
    ----------
    arrays : dict of 1-D arrays [m, m/s]
    Omega : float [1/s]
    n_steps : int
        Steps in the interval.
    n_collisions : int
        Collisions resolved in the interval.
    """
    scale = max(float(np.max(np.abs(arrays[k]))) for k in ("vx", "vy", "vz"))
    scale = max(scale, 1.5 * Omega * float(np.max(np.abs(arrays["x"]))),
                Omega * float(np.max(np.abs(arrays["z"]))))
    terms = n_steps + n_collisions + math.log2(max(2, arrays["x"].size))
    return MOMENTUM_ROUNDOFF_FACTOR * _EPS * scale * terms


def check_state(arrays: dict, n_particles: int, t: float) -> None:
    """Invariants 1 and 2: finite state, unchanged particle count; InvariantViolation if not.

    Parameters
    ----------
    arrays : dict of 1-D arrays [m, m/s]
    n_particles : int
        The number the run started with.
    t : float [s]
        Time of the state (for the message).
    """
    n = arrays["x"].size
    if n != n_particles:
        raise InvariantViolation(f"particle count changed from {n_particles} to {n} "
                                 f"(t = {t:.6g} s)")
    for key in ("x", "y", "z", "vx", "vy", "vz"):
        bad = np.flatnonzero(~np.isfinite(arrays[key]))
        if bad.size:
            raise InvariantViolation(f"{key} of {bad.size} particle(s) not finite (first: "
                                     f"particle {int(bad[0])}, {key} = "
                                     f"{arrays[key][bad[0]]!r}; t = {t:.6g} s)")


def check_momentum(now: SheetMomentum, reference: SheetMomentum, Omega: float,
                   tolerance: float) -> float:
    """Invariant 3; returns the residual [m/s], InvariantViolation if above ``tolerance``."""
    residual = momentum_residual(now, reference, Omega)
    if not residual <= tolerance:
        raise InvariantViolation(
            f"momentum of the sheet relative to the shear flow not conserved between "
            f"t = {reference.t:.6g} s and {now.t:.6g} s: residual {residual:.3g} m/s, "
            f"round-off tolerance {tolerance:.3g} m/s")
    return residual
