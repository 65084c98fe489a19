"""Soft-sphere contact models behind the restitution laws, integrated numerically.

These integrate the equations of motion of the deformation alpha of a colliding pair
(Dilley 1993, eq. 3.1: M_bar alpha'' = -F) so that the closed forms used by ringsim can be
checked against the model they come from:

* the linear spring-dashpot of eq. (5.1), F = k alpha + beta alpha', whose restitution
  coefficient is eq. (5.6)/(5.9);
* the elastic Hertz contact of eq. (3.3), F = k sqrt(R_bar) alpha^(3/2), whose time of
  maximum deformation is eq. (3.6).

Both start at alpha = 0 with alpha' = v and are integrated with scipy's DOP853 at tight
tolerances in time units of the natural contact time, so results are accurate to ~1e-10.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

#: Coefficient of eq. (3.6): t_max = 1.609 (M_bar / (k sqrt(R_bar)))^(2/5) v^(-1/5).
HERTZ_TMAX_COEFFICIENT = 1.609


@dataclass(frozen=True)
class ContactResult:
    """Outcome of one integrated contact.

    Attributes
    ----------
    epsilon : float [dimensionless]
        -alpha'(end) / v.
    contact_time : float [s]
        Duration from first touch until alpha returns to 0.
    t_max : float [s]
        Time of maximum deformation (alpha' = 0).
    alpha_max : float [m]
        Maximum deformation.
    """

    epsilon: float
    contact_time: float
    t_max: float
    alpha_max: float


def _integrate(accel, v: float, time_scale: float, length_scale: float) -> ContactResult:
    """Integrate alpha'' = accel(alpha, alpha') from (0, v) until alpha returns to 0.

    The state is scaled by ``length_scale`` and ``time_scale`` so that the tolerances are
    relative to the natural size of the contact.
    """
    vs = length_scale / time_scale

    def rhs(s, y):
        alpha, rate = y[0] * length_scale, y[1] * vs
        return [y[1], accel(alpha, rate) * time_scale / vs]

    def separated(s, y):
        return y[0]

    # solve_ivp reads these attributes of an event function, which mypy does not know
    separated.terminal = True  # type: ignore[attr-defined]
    separated.direction = -1  # type: ignore[attr-defined]

    def turning(s, y):
        return y[1]

    sol = solve_ivp(rhs, (0.0, 100.0), [0.0, v / vs], method="DOP853", rtol=1e-13,
                    atol=1e-16, events=[separated, turning], dense_output=True)
    if sol.t_events[0].size == 0:
        raise RuntimeError("the pair did not separate within 100 contact times")
    s_end = sol.t_events[0][0]
    rate_end = sol.y_events[0][0][1] * vs
    s_max = sol.t_events[1][0]
    alpha_max = sol.sol(s_max)[0] * length_scale
    return ContactResult(epsilon=-rate_end / v, contact_time=s_end * time_scale,
                         t_max=s_max * time_scale, alpha_max=alpha_max)


def spring_dashpot_contact(k: float, beta: float, M_bar: float, v: float) -> ContactResult:
    """Integrate the damped linear contact of eq. (5.1): M_bar alpha'' = -k alpha - beta alpha'.

    Contact ends when alpha returns to 0 (the dashpot force may be attractive before then,
    as the paper notes for sticky frosts).

    Parameters
    ----------
    k : float [N/m]
        Spring constant.
    beta : float [N s/m]
        Dashpot constant (underdamped: beta < 2 sqrt(k M_bar)).
    M_bar : float [kg]
        Reduced mass.
    v : float [m/s]
        Impact speed, > 0.
    """
    omega0 = np.sqrt(k / M_bar)
    if beta >= 2.0 * np.sqrt(k * M_bar):
        raise ValueError("beta: the contact is overdamped and never separates")
    return _integrate(lambda a, r: -(k * a + beta * r) / M_bar, v, 1.0 / omega0, v / omega0)


def spring_dashpot_epsilon(k: float, beta: float, M_bar: float) -> float:
    """Closed form of eq. (5.6): eps = exp(-pi / (2 omega tau)).

    Parameters
    ----------
    k : float [N/m]
    beta : float [N s/m]
    M_bar : float [kg]
    """
    omega0 = np.sqrt(k / M_bar)
    tau = M_bar / beta
    omega = omega0 * np.sqrt(1.0 - 1.0 / (2.0 * omega0 * tau) ** 2)
    return float(np.exp(-np.pi / (2.0 * omega * tau)))


def hertz_contact(k: float, R_bar: float, M_bar: float, v: float) -> ContactResult:
    """Integrate the elastic Hertz contact of eq. (3.3): M_bar alpha'' = -k sqrt(R_bar) alpha^1.5.

    Parameters
    ----------
    k : float [N/m^2]
        Elastic constant of eq. (3.3).
    R_bar : float [m]
        Reduced radius.
    M_bar : float [kg]
        Reduced mass.
    v : float [m/s]
        Impact speed, > 0.
    """
    stiffness = k * np.sqrt(R_bar)
    alpha_max = (5.0 * M_bar * v**2 / (4.0 * stiffness)) ** 0.4
    return _integrate(lambda a, r: -stiffness * np.maximum(a, 0.0) ** 1.5 / M_bar, v,
                      alpha_max / v, alpha_max)


def hertz_t_max(k: float, R_bar: float, M_bar: float, v: float) -> float:
    """Time of maximum deformation of a Hertz contact, eq. (3.6).

    Parameters
    ----------
    k : float [N/m^2]
    R_bar : float [m]
    M_bar : float [kg]
    v : float [m/s]
    """
    return HERTZ_TMAX_COEFFICIENT * (M_bar / (k * np.sqrt(R_bar))) ** 0.4 * v ** -0.2
