"""The rotational temperature of a gas of rough spheres: T_rot / T_tr from kinetic theory.

Identical rough spheres (constant normal restitution eps_n, constant tangential restitution
beta, moment of inertia I = k m R^2; the collision rule of :mod:`ringsim.physics.friction`)
whose velocities and spins are independent Maxwellians of temperatures T_tr = m<v^2>/3 and
T_rot = I<w^2>/3.  Two states follow from the same two-temperature rate equations:

* the homogeneous cooling state of a free gas (:func:`hcs_temperature_ratio`, its pace
  :func:`hcs_relaxation_collisions`), checked against ``ringsim.testing.cool_rough_gas``;
* the collisional balance of rotation in a sheared ring, where the shear heats translation
  only (:func:`collisional_spin_ratio`), the optically thin reference of ring simulations
  with friction.

Pure functions of floats; docs/friction.md compares them with simulations.

References
----------
Huthmann, M. & Zippelius, A. 1997, Phys. Rev. E 56, R6275.
Luding, S., Huthmann, M., McNamara, S. & Zippelius, A. 1998, Phys. Rev. E 58, 3416.
McNamara, S. & Luding, S. 1998, Phys. Rev. E 58, 2247.
Morishima, R. & Salo, H. 2004, DPS meeting 36, #19.01.
"""

from __future__ import annotations

import math

from ringsim.physics.friction import SOLID_SPHERE_INERTIA


def hcs_coefficients(eps_n: float, beta: float, k: float = SOLID_SPHERE_INERTIA
                     ) -> tuple[float, float, float]:
    """Coefficients A, B, C of the two-temperature cooling equations of rough spheres.

    For identical rough spheres (constant eps_n and beta, I = k m R^2) in a homogeneous
    gas whose velocities and spins are independent Maxwellians of temperatures T_tr and
    T_rot (T_tr = m<v^2>/3, T_rot = I<w^2>/3), Huthmann & Zippelius (1997) and Luding et
    al. (1998) find in three dimensions

        dT_tr/dt  = G [ -A T_tr^(3/2) + B T_tr^(1/2) T_rot ]
        dT_rot/dt = G [  B T_tr^(3/2) - C T_tr^(1/2) T_rot ]

    (in two dimensions, with one rotational degree of freedom, the second line carries a
    factor 2) with eta = k (1 + beta) / (2 (1 + k)), the velocity change of a particle per
    unit tangential contact velocity, and

        A = (1 - eps_n^2)/4 + eta (1 - eta),   B = eta^2 / k,   C = (eta / k)(1 - eta / k).

    G, proportional to the Enskog collision frequency n (2R)^2 g(2R) / sqrt(m), sets the
    time scale only.  The derivation: average the energy changes of the collision rule
    (:mod:`ringsim.physics.friction`) over pairs weighted by their normal approach
    speed, with independent Maxwellian velocities and spins; the normal impulse gives the
    (1 - eps_n^2)/4 of A, the tangential impulse eta (1 - eta) of A, the transfer B
    between the temperatures and C.  ``tests/test_friction.py`` checks the ratios of
    these rates against a Monte Carlo average of
    :func:`ringsim.physics.friction.collision_impulse` over Maxwellian pairs.  The
    cooling gas is not exactly Maxwellian: simulations find T_rot/T_tr a few percent
    below :func:`hcs_temperature_ratio` (docs/friction.md, "Homogeneous cooling state").
    """
    eta = k * (1.0 + beta) / (2.0 * (1.0 + k))
    A = (1.0 - eps_n * eps_n) / 4.0 + eta * (1.0 - eta)
    B = eta * eta / k
    C = eta / k * (1.0 - eta / k)
    return A, B, C


def hcs_temperature_ratio(eps_n: float, beta: float, k: float = SOLID_SPHERE_INERTIA) -> float:
    """Asymptotic T_rot / T_tr of freely cooling rough spheres in three dimensions.

    Both temperatures decay by Haff's law, t^-2, with a fixed ratio R = T_rot / T_tr
    (Huthmann & Zippelius 1997; Luding et al. 1998; McNamara & Luding 1998).  From the
    equations of :func:`hcs_coefficients`, d ln T_rot/dt = d ln T_tr/dt gives
    B - C R = R (B R - A), i.e. B R^2 + (C - A) R - B = 0, whose positive root is

        R = [A - C + sqrt((A - C)^2 + 4 B^2)] / (2 B).

    eps_n = 1, beta = 1 (elastic, perfectly rough) gives R = 1, equipartition.  As
    beta -> -1 rotation decouples (B, C -> 0) and R depends on the start: beta = -1 is
    refused.

    Parameters
    ----------
    eps_n : float [-], in [0, 1]
    beta : float [-], in (-1, 1]
    k : float [-]
        Moment-of-inertia factor, > 0.
    """
    if not -1.0 < beta <= 1.0:
        raise ValueError(f"beta must lie in (-1, 1], got {beta}")
    A, B, C = hcs_coefficients(eps_n, beta, k)
    b = A - C
    return (b + math.sqrt(b * b + 4.0 * B * B)) / (2.0 * B)


def hcs_relaxation_collisions(eps_n: float, beta: float, k: float = SOLID_SPHERE_INERTIA
                              ) -> float:
    """Collisions per particle in which T_rot/T_tr closes 1/e of its gap to the HCS value.

    Linearising dR/dt = G T_tr^(1/2) [B - (C - A) R - B R^2] (from
    :func:`hcs_coefficients`) about R* = :func:`hcs_temperature_ratio` gives the rate
    G T_tr^(1/2) (C - A + 2 B R*).  Per collision: for Maxwellian smooth spheres each
    collision dissipates (1 - eps_n^2) T_tr on average, so dT_tr/dt = -(1 - eps_n^2)
    omega_c T_tr / 3 with omega_c the collision frequency per particle, which is
    -G A T_tr^(3/2) with A = (1 - eps_n^2)/4: G T_tr^(1/2) = (4/3) omega_c.  Slow for
    nearly smooth spheres (about 18 collisions at eps_n = 0.9, beta = -0.5; 3 at beta = 0.5).
    """
    A, B, C = hcs_coefficients(eps_n, beta, k)
    rate = 4.0 / 3.0 * (C - A + 2.0 * B * hcs_temperature_ratio(eps_n, beta, k))
    return 1.0 / rate


def collisional_spin_ratio(beta: float, k: float = SOLID_SPHERE_INERTIA) -> float:
    """E_rot / E_tr when collisions neither feed nor drain rotation on average.

    Where translation is heated by something else (a ring's shear) and rotation only
    exchanges energy in collisions, its balance 2G (B T_tr - C T_rot) = 0 gives
    R = B/C = k (1 + beta) / (2 (1 + k) - (1 + beta)); for k = 2/5 this is
    2 (1 + beta) / (14 - 5 (1 + beta)), the optically-thin prediction Morishima & Salo
    confirmed in local ring simulations (2004, DPS 36, #19.01; their e_t = -beta).
    Assumes isotropic Maxwellians with no mean spin: the shear's systematic vorticity is
    left out.
    """
    if not -1.0 <= beta <= 1.0:
        raise ValueError(f"beta must lie in [-1, 1], got {beta}")
    return k * (1.0 + beta) / (2.0 * (1.0 + k) - (1.0 + beta))
