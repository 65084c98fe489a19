"""Dilley's (1993) viscous-dissipation law for two spheres of one density, in the paper's
reformulation by the smaller sphere's radius and the size ratio, eqs. (5.17)-(5.21).

The same law as `ringsim.physics.restitution.dilley_xi` with R_bar and M_bar of two spheres
of one density written out: xi = xi0 f(delta, kappa) r1^(-3 kappa - 0.2) (rho/rho_ref)^-kappa
(|v|/1 cm/s)^p, r1 = R1 / 2.5 cm, delta = R1 / R2 <= 1.  SI units throughout.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ringsim.physics import restitution as rs
from ringsim.physics.restitution import FloatArray


def dilley_f(delta: ArrayLike, kappa: float) -> FloatArray | float:
    """Size-ratio factor f(delta, kappa) = (1 + delta)^0.2 (1 + delta^3)^kappa, eq. (5.20).

    Parameters
    ----------
    delta : array [dimensionless]
        R1/R2 <= 1, the radius of the smaller sphere over that of the larger (eq. 5.18).
    kappa : float [dimensionless]
        Mass exponent.
    """
    kappa = rs.RESTITUTION["dilley"]["kappa"].check(kappa)
    d = rs._array("delta", delta)
    if np.any(d > 1):
        raise ValueError("delta must be <= 1 (R1 is the smaller radius)")
    return rs._result((1.0 + d) ** rs.RADIUS_EXPONENT * (1.0 + d**3) ** kappa)


def dilley_xi_equal_density(v: ArrayLike, R1: ArrayLike, delta: ArrayLike,
                            xi0: float = rs.DILLEY_XI0, p: float = rs.DILLEY_P,
                            kappa: float = rs.DILLEY_KAPPA,
                            density: float = rs.RHO_REF,
                            reference_mass: float = rs.M_REF) -> FloatArray | float:
    """xi for two spheres of one density, in the paper's reformulation, eqs. (5.17)-(5.21).

    xi = xi0 f(delta, kappa) r1^(-3 kappa - 0.2) (rho/rho_ref)^-kappa (|v|/1 cm/s)^p with
    r1 = R1 / 2.5 cm.  The paper writes it for the density of its 60 g, 2.5 cm reference
    sphere (rho_ref = 916.7 kg/m^3), where the density factor is 1.

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed.
    R1 : array [m]
        Radius of the smaller sphere, > 0.
    delta : array [dimensionless]
        R1/R2 in [0, 1]; 0 is a sphere against a massive brick, 1 equal spheres.
    xi0, p, kappa : float [dimensionless]
        See :func:`ringsim.physics.restitution.dilley_xi`.
    density : float [kg/m^3]
        Material density of both spheres.
    reference_mass : float [kg]
        M_ref of :func:`ringsim.physics.restitution.dilley_xi`; rho_ref is that of a
        2.5 cm sphere of mass M_ref.
    """
    xi0, p, kappa, m_ref = rs._parameters("dilley", xi0=xi0, p=p, kappa=kappa,
                                          reference_mass=reference_mass)
    rho_ref = rs.RHO_REF if m_ref == rs.M_REF else m_ref / (4.0 / 3.0 * np.pi * rs.R_REF**3)
    rho = rs._scalar("density", density, low=0.0)
    speed = rs._speed(v)
    r1 = rs._array("R1", R1, positive=True) / rs.R_REF
    f = dilley_f(delta, kappa)
    xi = (xi0 * f * r1 ** (-3.0 * kappa - rs.RADIUS_EXPONENT) * (rho / rho_ref) ** -kappa
          * (speed / rs.V_REF) ** p)
    return rs._result(xi)
