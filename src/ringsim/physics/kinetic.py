"""Dilute-ring kinetic theory (Goldreich & Tremaine 1978) and the kinetic dispersion estimate.

The critical coefficient of restitution eps_cr(tau) comes from GT78's model, a triaxial
Gaussian velocity distribution of identical smooth spheres (:func:`gt78_steady_state`), which
reproduces their eps_cr -> 0.627 for tau -> 0.  The dilute-ring estimate of the velocity
dispersion (:func:`kinetic_dispersion_estimate`) balances viscous heating against
collisional dissipation: the ring is in thermal balance where the impact-averaged eps of the
scenario's law equals eps_cr(tau).

References
----------
Goldreich, P. & Tremaine, S. 1978, Icarus 34, 227 ("The velocity dispersion in Saturn's rings").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import lru_cache
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from ringsim.checks import FloatArray, nonnegative_array, positive
from ringsim.physics.constants import TWO_PI
from ringsim.physics.restitution import epsilon_for_pair

# Nodes of the trapezoid rule in y = ln(s lambda_mean) for the Gaussian speed moments below;
# the integrands are analytic in a strip |Im y| < pi and decay like exp(-|y|/2), so the rule
# with step 0.25 is exact to rounding.
_LOG_S = np.arange(-80.0, 80.0, 0.25)
_LOG_S_STEP = 0.25

#: Largest residual [dimensionless moments of order 0.1-1] at which the moment equations
#: count as solved.  MINPACK's own verdict is not used: with the tight step tolerance below
#: it can report "xtol too small, no further improvement" (status 3) at the root itself,
#: depending on the last bits of numpy's exp / log1p, which differ between instruction sets
#: (with and without AVX-512).  The residuals at the roots, from the dilute limit to
#: tau = 2, are a few 1e-15 on either instruction set: 1e-12 is hundreds of times that.
ROOT_RESIDUAL = 1e-12


def _is_root(sol: optimize.OptimizeResult) -> bool:
    """Whether ``optimize.root``'s result solves the equations: its residuals, not its
    status, within ``ROOT_RESIDUAL``."""
    fun = np.asarray(sol.fun, dtype=float)
    return bool(np.all(np.isfinite(fun)) and np.max(np.abs(fun)) <= ROOT_RESIDUAL)


def _gaussian_speed_moments(variances: FloatArray) -> tuple[FloatArray, float]:
    """E[|g| g_k^2] (k = 1..3) and E[|g|] for g ~ N(0, diag(variances)).

    Uses |g| = (4 pi)^(-1/2) int_0^inf (1 - exp(-s g^2)) s^(-3/2) ds and the Gaussian
    E[g_k^2 exp(-s g^2)] = lam_k / (1 + 2 s lam_k) prod_m (1 + 2 s lam_m)^(-1/2).
    """
    lam = np.asarray(variances, dtype=float)
    s = np.exp(_LOG_S)[:, None] / lam.mean()
    log1p = np.log1p(2.0 * s * lam[None, :])
    half = 0.5 * log1p.sum(axis=1, keepdims=True)
    # expm1 keeps the small-s end (where 1 - exp(...) ~ s) accurate.
    weight = _LOG_S_STEP / (2.0 * math.sqrt(math.pi)) / np.sqrt(s)
    moments = np.sum(-np.expm1(-half - log1p) * lam[None, :] * weight, axis=0)
    mean_speed = float(np.sum(-np.expm1(-half[:, 0]) * weight[:, 0]))
    return moments, mean_speed


def _gt78_collision_term(W: FloatArray, epsilon: float, tau: float) -> tuple[FloatArray, float]:
    """Collisional rate of change of W, in units of Omega W (W is dimensionless here).

    For identical smooth spheres of radius r with constant epsilon, a Gaussian velocity
    distribution of covariance W and a Gaussian vertical profile of scale height
    H = sqrt(W_zz)/Omega, the change per particle and unit time is

        dW/dt|coll = tau (1 + eps) / (2 sqrt(pi) H)
                     * E_g[ |g| ( -(3 - eps)/4 g g^T + (1 + eps)/12 |g|^2 I ) ],

    g ~ N(0, 2W) the relative velocity.  Returns that (divided by Omega) and the impact
    rate per particle divided by Omega, 2 tau E|g| / (sqrt(pi) H Omega).
    """
    lam, Q = np.linalg.eigh(2.0 * W)
    moments, mean_speed = _gaussian_speed_moments(np.clip(lam, 1e-300, None))
    M = -(3.0 - epsilon) / 4.0 * (Q * moments) @ Q.T + (1.0 + epsilon) / 12.0 * moments.sum() \
        * np.eye(3)
    H = math.sqrt(W[2, 2])
    rate = tau / (2.0 * math.sqrt(math.pi) * H)
    return rate * (1.0 + epsilon) * M, 4.0 * rate * mean_speed


def _gt78_residuals(p: FloatArray, tau: float) -> list[float]:
    """Steady-state moment equations of the shearing sheet, W_xx = 1."""
    a, b, s, eps = p
    W = np.array([[1.0, s, 0.0], [s, a, 0.0], [0.0, 0.0, b]])
    C, _ = _gt78_collision_term(W, eps, tau)
    # dW/dt from Hill's equations (dw_x/dt = 2 Omega w_y, dw_y/dt = -Omega w_x / 2) + collisions;
    # vertically, <vz^2> = Omega^2 <z^2> leaves only the collision term.
    return [4.0 * s + C[0, 0], -s + C[1, 1], 2.0 * a - 0.5 + C[0, 1], C[2, 2]]


@lru_cache(maxsize=1)
def _gt78_dilute_limit() -> tuple[float, float]:
    """tau -> 0 solution (a = 1/4, s = 0): W_zz/W_xx and eps_cr(0)."""
    def residuals(p: FloatArray) -> list[float]:
        b, eps = p
        moments, _ = _gaussian_speed_moments(2.0 * np.array([1.0, 0.25, b]))
        M = -(3.0 - eps) / 4.0 * moments + (1.0 + eps) / 12.0 * moments.sum()
        return [M[0] + 4.0 * M[1], M[2]]
    sol = optimize.root(residuals, [0.5, 0.6], tol=1e-14)
    if not _is_root(sol):
        raise RuntimeError(f"GT78 dilute limit did not converge: {sol.message}")
    return float(sol.x[0]), float(sol.x[1])


@lru_cache(maxsize=256)
def _gt78_solution(tau: float) -> tuple[float, float, float, float, float]:
    b0, eps0 = _gt78_dilute_limit()
    guess = np.array([0.25, b0, 0.0, eps0])
    if tau == 0.0:
        return 0.25, float(b0), 0.0, float(eps0), 0.0
    # Continuation in log tau from the dilute limit keeps the solver on the physical branch.
    steps = np.geomspace(min(1e-3, tau), tau, max(2, int(np.ceil(np.log10(tau / 1e-3) * 4)) + 1))
    for t_step in steps:
        sol = optimize.root(_gt78_residuals, guess, args=(float(t_step),), tol=1e-13)
        if not _is_root(sol) or not np.all(sol.x[:2] > 0.0):
            raise RuntimeError(f"GT78 steady state not found at tau={t_step:g}: {sol.message}")
        guess = sol.x
    a, b, s, eps = guess
    _, impact_rate = _gt78_collision_term(np.array([[1.0, s, 0.0], [s, a, 0.0], [0.0, 0.0, b]]),
                                          eps, tau)
    return float(a), float(b), float(s), float(eps), float(impact_rate)


def gt78_steady_state(optical_depth: float) -> dict[str, float]:
    """Steady state of a dilute ring of identical smooth spheres with constant eps (GT78).

    Solves the second-moment equations of the shearing sheet for a triaxial Gaussian
    velocity distribution (Goldreich & Tremaine 1978, Icarus 34, 227): Hill's equations
    plus the exact collision integrals of smooth hard spheres with a constant coefficient
    of restitution eps, a Gaussian vertical profile of scale height sqrt(W_zz)/Omega, no
    self-gravity, and no finite-size (non-local) terms.  The equations are homogeneous in
    the dispersion, so the steady state fixes only eps (the critical value eps_cr at which
    heating by the shear balances dissipation) and the shape of the tensor, not its scale.
    For tau -> 0 this gives eps_cr = 0.6270 and W_yy/W_xx = 1/4 (the epicyclic ratio),
    GT78's values; Spaute & Greenberg (1987, Icarus 70, 289) likewise find random motions
    of smooth spheres grow for eps > 0.63.  eps_cr rises with tau (0.651 at 0.25, 0.812 at 1).

    Limits: dilute ring only -- particles small compared with the scale height and mean
    free path (c >> r Omega); dense rings need finite-size terms (Araki & Tremaine 1986),
    which raise the heating and let rings with eps < eps_cr settle near c ~ 2-3 r Omega.

    Equations (W_xx = 1, Omega = 1): 4 W_xy + C_xx = 0, -W_xy + C_yy = 0,
    2 W_yy - W_xx/2 + C_xy = 0, C_zz = 0, with the collision term C of
    ``_gt78_collision_term``; the Gaussian speed moments are exact 1-D integrals.

    Parameters
    ----------
    optical_depth : float [dimensionless]
        tau = N pi r^2 / area, >= 0.

    Returns
    -------
    dict
        ``epsilon_critical``; ``sigma_yy_over_xx``, ``sigma_zz_over_xx``,
        ``sigma_xy_over_xx`` (tensor shape); ``impacts_per_orbit`` (collisions per particle
        per orbit); ``viscosity_Omega_over_c2`` = nu_trans Omega / c^2 with c^2 = trace/3.
    """
    tau = float(optical_depth)
    if not (math.isfinite(tau) and tau >= 0.0):
        raise ValueError(f"optical_depth must be finite and >= 0, got {optical_depth!r}")
    a, b, s, eps, impact_rate = _gt78_solution(tau)
    c2 = (1.0 + a + b) / 3.0
    return {
        "optical_depth": tau,
        "epsilon_critical": eps,
        "sigma_yy_over_xx": a,
        "sigma_zz_over_xx": b,
        "sigma_xy_over_xx": s,
        "impacts_per_orbit": TWO_PI * impact_rate,
        "viscosity_Omega_over_c2": 2.0 * s / 3.0 / c2,
    }


def critical_epsilon(optical_depth: float) -> float:
    """GT78 critical coefficient of restitution eps_cr(tau) [dimensionless].

    A dilute ring of identical smooth spheres with constant eps heats without bound for
    eps > eps_cr(tau) and cools (collapses towards a monolayer) for eps < eps_cr(tau).
    eps_cr rises from 0.6270 at tau -> 0 (GT78) towards 1 at large tau; see
    ``gt78_steady_state`` for the model.

    Parameters
    ----------
    optical_depth : float [dimensionless]
    """
    return gt78_steady_state(optical_depth)["epsilon_critical"]


# Gauss-Legendre panels on s = v_n / (2c) in [0, 9] for the impact-speed averages
# (exp(-81) makes the tail negligible); many short panels keep the error at kinks of eps(v)
# (Bridges' v_c, Andrews' v_c) small, and fixed nodes keep the average continuous in c.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_S_EDGES = np.linspace(0.0, 9.0, 1201)
_S_NODES = ((_S_EDGES[:-1, None] + _S_EDGES[1:, None]) / 2.0
            + (np.diff(_S_EDGES)[:, None] / 2.0) * _GL_X[None, :]).ravel()
_S_WEIGHTS = ((np.diff(_S_EDGES)[:, None] / 2.0) * _GL_W[None, :]).ravel()


def effective_epsilon(restitution: Mapping[str, object], velocity_dispersion: float,
                      R_bar: float, M_bar: float, weighting: str = "energy") -> float:
    """Impact-averaged coefficient of restitution for an isotropic Maxwellian [dimensionless].

    With a 1-D dispersion c, the relative velocity of a pair is Gaussian with variance 2c^2
    per component; a collision's normal speed u is then distributed with the flux weight,
    p(u) ~ u exp(-u^2 / 4c^2).  Returns sqrt(<eps(u)^2>), the average taken with

    * ``weighting="energy"`` (default): collisions weighted by their normal kinetic energy,
      ~ u^3 exp(-u^2/4c^2) -- the eps of a constant-eps ring losing energy at the same rate,
      the one to compare with eps_cr;
    * ``weighting="collision"``: every collision equally, ~ u exp(-u^2/4c^2).

    Parameters
    ----------
    restitution : mapping
        A scenario's restitution section (``ringsim.restitution.epsilon_for_pair``).
    velocity_dispersion : float [m/s]
        c, > 0.
    R_bar : float [m]
        Reduced radius of the colliding pair.
    M_bar : float [kg]
        Reduced mass of the colliding pair.
    weighting : {"energy", "collision"}
    """
    c = positive("velocity_dispersion", velocity_dispersion)
    if weighting == "energy":
        kernel = _S_NODES**3
    elif weighting == "collision":
        kernel = _S_NODES.copy()
    else:
        raise ValueError(f"weighting must be 'energy' or 'collision', got {weighting!r}")
    weights = _S_WEIGHTS * kernel * np.exp(-_S_NODES**2)
    eps = np.asarray(epsilon_for_pair(restitution, 2.0 * c * _S_NODES, R_bar, M_bar), dtype=float)
    return float(math.sqrt(np.dot(weights, eps * eps) / np.sum(weights)))


class _Balance(TypedDict):
    """One thermal balance of `_balances`: the velocity dispersion [m/s] and its stability."""

    velocity_dispersion: float
    stable: bool


def _balances(excess, c_min: float, c_max: float,
              n_scan: int) -> tuple[list[_Balance], np.ndarray]:
    """Roots of ``excess(ln c)`` (eps_eff - eps_cr) bracketed by a log-spaced scan of c over
    [c_min, c_max] [m/s] and refined by Brent's method; a root is stable where the excess
    falls through zero as c grows (hotter -> more dissipative).  Returns the roots and the
    scanned excess."""
    log_c = np.linspace(math.log(c_min), math.log(c_max), n_scan)
    f = np.array([excess(x) for x in log_c])
    roots: list[_Balance] = []
    for i in range(log_c.size - 1):
        if f[i] == 0.0:
            roots.append({"velocity_dispersion": math.exp(log_c[i]),
                          "stable": bool(f[i + 1] < 0.0 or (i > 0 and f[i - 1] > 0.0))})
        elif f[i] * f[i + 1] < 0.0:
            x = optimize.brentq(excess, log_c[i], log_c[i + 1], xtol=1e-14, rtol=1e-15,
                                maxiter=200)
            roots.append({"velocity_dispersion": math.exp(x), "stable": bool(f[i] > 0.0)})
    return roots, f


def _balance_reason(c: float, r_Omega: float, eps_cr: float) -> str:
    """The text of a stable thermal balance at c [m/s] (r_Omega [m/s]: the radius times
    Omega), with a note where the dilute approximation fails."""
    note = "" if c > 10.0 * r_Omega else (
        "; c < 10 r Omega, where the dilute (local) approximation fails")
    return (f"thermal balance at c = {c:.4g} m/s = {c / r_Omega:.4g} r Omega "
            f"(eps_eff = eps_cr = {eps_cr:.4f}){note}")


def representative_particle(radius: ArrayLike, mass: ArrayLike) -> tuple[float, float, float]:
    """One consistent particle for a size distribution: the mean radius <r> [m], the mass of
    a sphere of that radius at the particles' bulk density [kg], and that density
    sum m / sum 4/3 pi r^3 [kg/m^3].  (The mean mass belongs to a larger sphere, since
    <r^3> > <r>^3.)

    Parameters
    ----------
    radius : float or array [m]
    mass : float or array [kg]
    """
    radii = nonnegative_array("radius", np.atleast_1d(radius))
    masses = nonnegative_array("mass", np.atleast_1d(mass))
    r = positive("radius", float(np.mean(radii)))
    density = positive("mass", float(np.sum(masses))) / float(np.sum(4.0 / 3.0 * math.pi
                                                                      * radii**3))
    return r, positive("mass", density * 4.0 / 3.0 * math.pi * r**3), density


def _no_balance(has_roots: bool, excess: np.ndarray, eps_cr: float, c_min: float,
                c_max: float) -> tuple[str, str]:
    """Status and reason of a dilute ring without a stable thermal balance."""
    if has_roots:
        return "unstable", ("only unstable balances (eps_eff rises through eps_cr with c): the "
                            "ring either collapses or heats without bound depending on its "
                            "initial c")
    if np.all(excess < 0.0):
        return "collapse", (f"eps_eff < eps_cr = {eps_cr:.4f} at every c in [{c_min:g}, "
                            f"{c_max:g}] m/s: collisions dissipate more than the shear "
                            "supplies; the dilute ring collapses (to a near-monolayer held up "
                            "by finite-size effects, not modelled here)")
    return "heating", (f"eps_eff > eps_cr = {eps_cr:.4f} at every c in [{c_min:g}, {c_max:g}] "
                       "m/s: no thermal balance, the velocity dispersion grows without bound")


def kinetic_dispersion_estimate(restitution: Mapping[str, object], radius: ArrayLike,
                                mass: ArrayLike, optical_depth: float, Omega: float, *,
                                c_min: float = 1e-10, c_max: float = 1e3,
                                n_scan: int = 131,
                                weighting: str = "energy") -> dict[str, object]:
    """Equilibrium velocity dispersion of a dilute ring from kinetic energy balance.

    Assumptions (as in Goldreich & Tremaine 1978): dilute ring (no finite-size, non-local
    heating or transport -- valid while c >> r Omega), identical smooth spheres (no
    spin), no self-gravity, and for the velocity dependence of eps an isotropic Maxwellian
    of impact velocities.  A size distribution is represented by one consistent particle
    (`representative_particle`; with the mean MASS instead, a mass-dependent law such as
    Dilley's kappa > 0 moves the estimate by tens of per cent): R_bar = <r>/2, M_bar = m/2.
    The ring is in thermal equilibrium at the c where the impact-averaged eps
    (``effective_epsilon``) equals GT78's eps_cr(tau) (``critical_epsilon``; `_balances`).

    Parameters
    ----------
    restitution : mapping
        A scenario's restitution section.
    radius : float or array [m]
    mass : float or array [kg]
    optical_depth : float [dimensionless]
    Omega : float [1/s]
    c_min, c_max : float [m/s]
        Range searched.
    n_scan : int
        Scan points (log-spaced).
    weighting : {"energy", "collision"}
        See ``effective_epsilon``.

    Returns
    -------
    dict
        ``status``: "equilibrium", "collapse" (eps_eff < eps_cr at every c: the dilute ring
        cools until finite-size effects, not modelled here, stop it), "heating"
        (eps_eff > eps_cr at every c: no thermal balance, c grows without bound), or
        "unstable" (only unstable balances); ``reason`` (text);
        ``velocity_dispersion`` [m/s] (lowest stable root, NaN otherwise);
        ``velocity_dispersion_rOmega`` (c / (r Omega)); ``epsilon_critical``;
        ``effective_epsilon`` (at c, NaN if none); ``roots`` (list of
        {"velocity_dispersion", "stable"}); ``radius`` [m], ``mass`` [kg] (of the
        representative particle), ``representative`` (text), ``R_bar`` [m],
        ``M_bar`` [kg], ``optical_depth``, ``weighting``; ``gt78`` (``gt78_steady_state``).
    """
    r, m, density = representative_particle(radius, mass)
    Omega = positive("Omega", Omega)
    scan = _scan_range(c_min, c_max, n_scan)
    steady = gt78_steady_state(optical_depth)
    R_bar, M_bar = r / 2.0, m / 2.0
    result: dict[str, object] = {
        "epsilon_critical": steady["epsilon_critical"], "radius": r, "mass": m,
        "R_bar": R_bar, "M_bar": M_bar, "optical_depth": float(optical_depth),
        "weighting": weighting, "gt78": steady,
        "representative": (f"one particle of the mean radius {r:.4g} m and its own mass "
                           f"{m:.4g} kg at the bulk density {density:.4g} kg/m^3"),
    }
    result.update(_thermal_balance(restitution, R_bar, M_bar, weighting,
                                   steady["epsilon_critical"], r * Omega, scan))
    return result


def _thermal_balance(restitution: Mapping[str, object], R_bar: float, M_bar: float,
                     weighting: str, eps_cr: float, r_Omega: float,
                     scan: tuple[float, float, int]) -> dict[str, object]:
    """Where the impact-averaged eps of a pair (R_bar [m], M_bar [kg]) equals eps_cr: the
    entries ``roots``, ``status``, ``reason``, ``velocity_dispersion`` [m/s],
    ``velocity_dispersion_rOmega`` and ``effective_epsilon`` of
    `kinetic_dispersion_estimate` (NaN without a stable balance).  r_Omega [m/s]: the
    radius times Omega; scan: (c_min [m/s], c_max [m/s], points)."""
    def excess(log_c: float) -> float:
        return effective_epsilon(restitution, math.exp(log_c), R_bar, M_bar, weighting) - eps_cr

    c_min, c_max, n_scan = scan
    roots, f = _balances(excess, c_min, c_max, n_scan)
    out: dict[str, object] = {"roots": roots, "velocity_dispersion": math.nan,
                              "velocity_dispersion_rOmega": math.nan,
                              "effective_epsilon": math.nan}
    stable = [root for root in roots if root["stable"]]
    if stable:
        c = float(stable[0]["velocity_dispersion"])
        out.update(status="equilibrium", velocity_dispersion=c,
                   velocity_dispersion_rOmega=c / r_Omega,
                   effective_epsilon=effective_epsilon(restitution, c, R_bar, M_bar, weighting),
                   reason=_balance_reason(c, r_Omega, eps_cr))
    else:
        status, reason = _no_balance(bool(roots), f, eps_cr, c_min, c_max)
        out.update(status=status, reason=reason)
    return out


def _scan_range(c_min: float, c_max: float, n_scan: int) -> tuple[float, float, int]:
    """The checked scan of `kinetic_dispersion_estimate`: (c_min [m/s], c_max [m/s], points)
    with 0 < c_min < c_max and at least 2 points, else ValueError."""
    c_min = positive("c_min", c_min)
    c_max = positive("c_max", c_max)
    if c_max <= c_min or int(n_scan) < 2:
        raise ValueError("need c_min < c_max and n_scan >= 2")
    return c_min, c_max, int(n_scan)
