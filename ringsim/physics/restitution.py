"""Coefficients of restitution of icy spheres: the laws of Dilley (1993) and its comparisons.

Every function takes and returns SI units (v [m/s], R [m], M [kg]), broadcasts over
numpy arrays, uses the magnitude |v| of a signed impact speed, and returns epsilon in
[0, 1].  Equation numbers refer to

    Dilley, J. P. 1993, "Energy loss in collisions of icy spheres: loss mechanism and
    size-mass dependence", Icarus 105, 225-234.

=========================  ==========================================  ==============
law                        formula                                     paper
=========================  ==========================================  ==============
reduced mass / radius      M1 M2/(M1+M2),  R1 R2/(R1+R2)               (3.2), (3.4)
viscous dissipation        eps = exp(-pi xi / sqrt(1 - xi^2))          (5.9)
  (Dilley)                 xi = xi0 (R/2.5 cm)^-0.2 (M/60 g)^-kappa    (5.14)-(5.16)
                                (v/1 cm/s)^p
inverse                    xi = |ln eps| / sqrt(pi^2 + ln^2 eps)       (5.10)
equal-density pairs        xi = xi0 f(delta, kappa) r1^(-3 kappa-0.2)  (5.17)-(5.21)
Andrews plastic model      eps^2 = [-2 + sqrt(30 u^2 - 5)] / (3 u^2)   (4.3)
generalized Tabor          eps = u^-(1-2q) ((1 - q eps^2)/(1 - q))^q   (4.10), (4.8)
Bridges et al. (1984)      eps = min(1, (v/v_c)^-0.234)                Nature 309, 333
=========================  ==========================================  ==============

(u = |v|/v_c.)  Two misprints of the paper are corrected here: eq. (5.10) lacks the square
on ln(eps) in its denominator, and the text below (4.10) says q = 1/2 where eq. (4.8)
needs q = 3/8.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Reference radius of the Dilley law, the 2.5 cm sphere of Hatzes et al. (1988) [m].
R_REF = 0.025
#: Reference mass of the Dilley law, the 60 g ice sphere of radius 2.5 cm [kg].
M_REF = 0.060
#: Reference impact speed of the Dilley law [m/s].
V_REF = 0.01
#: Density of the reference sphere, 60 g / (4/3 pi (2.5 cm)^3) [kg/m^3].
RHO_REF = M_REF / (4.0 / 3.0 * np.pi * R_REF**3)
#: Exponent of the reduced radius in xi, from Hertz contact time (eq. 5.12).
RADIUS_EXPONENT = 0.2

#: Parameters of the Dilley (1993) fit to the Hatzes et al. (1988) data (eq. 5.11).
DILLEY_XI0 = 0.16
DILLEY_P = 0.65
#: Bridges et al. (1984) power law: critical speed [m/s] and exponent.
BRIDGES_V_C = 7.7e-5
BRIDGES_EXPONENT = 0.234

#: Parameter names and defaults of each model, as in the scenario's ``restitution`` section.
MODEL_PARAMETERS: dict[str, dict[str, float | None]] = {
    "dilley": {"xi0": DILLEY_XI0, "p": DILLEY_P, "kappa": 0.0},
    "bridges": {"v_c": BRIDGES_V_C, "exponent": BRIDGES_EXPONENT},
    "constant": {"epsilon": None},
    "andrews": {"v_c": None},
    "tabor": {"v_c": None, "q": 0.375},
}

FloatArray = NDArray[np.float64]


def _array(name: str, value: ArrayLike, *, allow_inf: bool = False,
           positive: bool = False) -> FloatArray:
    """Convert ``value`` to a float array and check it is a valid size or mass.

    Raises ValueError naming ``name`` for NaN, negative values, infinities (unless
    ``allow_inf``) and zeros (if ``positive``).
    """
    arr = np.asarray(value, dtype=float)
    if np.any(np.isnan(arr)):
        raise ValueError(f"{name} must not be NaN")
    if not allow_inf and np.any(np.isinf(arr)):
        raise ValueError(f"{name} must be finite")
    if np.any(arr < 0):
        raise ValueError(f"{name} must be >= 0")
    if positive and np.any(arr == 0):
        raise ValueError(f"{name} must be > 0")
    return arr


def _speed(v: ArrayLike) -> FloatArray:
    """|v| as a float array; raises ValueError if v is not finite."""
    arr = np.asarray(v, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError("v must be finite")
    return np.abs(arr)


def _scalar(name: str, value: float, *, low: float | None = None, high: float | None = None,
            low_open: bool = True, high_open: bool = True) -> float:
    """A finite real parameter inside the given interval, else ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    x = float(value)
    if not np.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x}")
    if low is not None and (x <= low if low_open else x < low):
        raise ValueError(f"{name} must be {'>' if low_open else '>='} {low}, got {x}")
    if high is not None and (x >= high if high_open else x > high):
        raise ValueError(f"{name} must be {'<' if high_open else '<='} {high}, got {x}")
    return x


def _result(eps: FloatArray) -> FloatArray | float:
    """Return a Python float for 0-d results, the array otherwise."""
    return float(eps) if np.ndim(eps) == 0 else eps


# --- pair geometry -------------------------------------------------------------------------

def reduced_radius(R1: ArrayLike, R2: ArrayLike) -> FloatArray | float:
    """Reduced radius R1 R2 / (R1 + R2) of a colliding pair (eq. 3.4).

    Parameters
    ----------
    R1, R2 : array [m]
        Radii (radii of curvature at the contact point). ``np.inf`` stands for a flat
        wall, giving the other radius.

    Returns
    -------
    R_bar : array [m]
    """
    return _result(_reduced("R1", R1, "R2", R2))


def reduced_mass(M1: ArrayLike, M2: ArrayLike) -> FloatArray | float:
    """Reduced mass M1 M2 / (M1 + M2) of a colliding pair (eq. 3.2).

    Parameters
    ----------
    M1, M2 : array [kg]
        Masses. ``np.inf`` stands for a massive brick, giving the other mass.

    Returns
    -------
    M_bar : array [kg]
    """
    return _result(_reduced("M1", M1, "M2", M2))


def _reduced(name1: str, a: ArrayLike, name2: str, b: ArrayLike) -> FloatArray:
    """a b / (a + b), where an infinite partner gives the other value (both: ValueError)."""
    x = _array(name1, a, allow_inf=True)
    y = _array(name2, b, allow_inf=True)
    if np.any(np.isinf(x) & np.isinf(y)):
        raise ValueError(f"{name1} and {name2} must not both be infinite")
    with np.errstate(invalid="ignore", divide="ignore"):
        finite = x * y / (x + y)
    return np.where(np.isinf(y), x, np.where(np.isinf(x), y, finite))


# --- viscous dissipation: Dilley (1993) section 5 --------------------------------------------

def epsilon_from_xi(xi: ArrayLike) -> FloatArray | float:
    """Coefficient of restitution of the damped oscillator, eq. (5.9).

    eps = exp(-pi xi / sqrt(1 - xi^2)) for 0 <= xi < 1.  For xi >= 1 the contact is
    critically damped or overdamped: the pair does not rebound and eps = 0.

    Parameters
    ----------
    xi : array [dimensionless]
        Damping ratio 1/(2 omega_0 tau), >= 0.
    """
    x = _array("xi", xi, allow_inf=True)
    under = x < 1.0
    xs = np.where(under, x, 0.0)
    eps = np.where(under, np.exp(-np.pi * xs / np.sqrt(1.0 - xs * xs)), 0.0)
    return _result(eps)


def xi_from_epsilon(eps: ArrayLike) -> FloatArray | float:
    """Damping ratio of a coefficient of restitution, the inverse of eq. (5.9) (eq. 5.10).

    xi = |ln eps| / sqrt(pi^2 + (ln eps)^2); eps = 0 gives xi = 1 (the paper's eq. 5.10
    misprints (ln eps)^2 as ln eps in the denominator).

    Parameters
    ----------
    eps : array [dimensionless], in [0, 1]
    """
    e = np.asarray(eps, dtype=float)
    if not np.all(np.isfinite(e)) or np.any((e < 0) | (e > 1)):
        raise ValueError("eps must lie in [0, 1]")
    log_eps = np.log(np.where(e > 0, e, 1.0))
    xi = np.where(e > 0, -log_eps / np.sqrt(np.pi**2 + log_eps**2), 1.0)
    return _result(xi)


def _dilley_parameters(xi0: float, p: float, kappa: float) -> tuple[float, float, float]:
    return (_scalar("xi0", xi0, low=0.0), _scalar("p", p, low=0.0), _scalar("kappa", kappa))


def dilley_xi(v: ArrayLike, R_bar: ArrayLike, M_bar: ArrayLike, xi0: float = DILLEY_XI0,
              p: float = DILLEY_P, kappa: float = 0.0) -> FloatArray | float:
    """Damping ratio of the viscous-dissipation model, eqs. (5.14)-(5.16).

    xi = xi0 (R_bar / 2.5 cm)^-0.2 (M_bar / 60 g)^-kappa (|v| / 1 cm/s)^p

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed (sign ignored).
    R_bar : array [m]
        Reduced radius of the pair (:func:`reduced_radius`), > 0.
    M_bar : array [kg]
        Reduced mass of the pair (:func:`reduced_mass`), > 0.
    xi0 : float [dimensionless]
        xi of the reference pair at 1 cm/s, > 0 (0.16 fits Hatzes et al. 1988).
    p : float [dimensionless]
        Speed exponent, > 0 (0.65 fits Hatzes et al. 1988).
    kappa : float [dimensionless]
        Mass exponent, unconstrained by experiment (the paper discusses 0 and 0.1).
    """
    xi0, p, kappa = _dilley_parameters(xi0, p, kappa)
    speed = _speed(v)
    r = _array("R_bar", R_bar, positive=True)
    m = _array("M_bar", M_bar, positive=True)
    xi = xi0 * (r / R_REF) ** -RADIUS_EXPONENT * (m / M_REF) ** -kappa * (speed / V_REF) ** p
    return _result(xi)


def dilley_epsilon(v: ArrayLike, R_bar: ArrayLike, M_bar: ArrayLike, xi0: float = DILLEY_XI0,
                   p: float = DILLEY_P, kappa: float = 0.0) -> FloatArray | float:
    """Coefficient of restitution of the viscous-dissipation model, eq. (5.9) with (5.15).

    eps = exp(-pi xi / sqrt(1 - xi^2)) with xi from :func:`dilley_xi`.  Above the speed
    where xi reaches 1 the model predicts no rebound at all and eps = 0 (the paper notes
    this may mark the breakdown of the model at large speeds).

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed (sign ignored).
    R_bar : array [m]
        Reduced radius of the pair, > 0.
    M_bar : array [kg]
        Reduced mass of the pair, > 0.
    xi0, p, kappa : float [dimensionless]
        See :func:`dilley_xi`.
    """
    return epsilon_from_xi(dilley_xi(v, R_bar, M_bar, xi0=xi0, p=p, kappa=kappa))


def dilley_f(delta: ArrayLike, kappa: float) -> FloatArray | float:
    """Size-ratio factor f(delta, kappa) = (1 + delta)^0.2 (1 + delta^3)^kappa, eq. (5.20).

    Parameters
    ----------
    delta : array [dimensionless]
        R1/R2 <= 1, the radius of the smaller sphere over that of the larger (eq. 5.18).
    kappa : float [dimensionless]
        Mass exponent.
    """
    kappa = _scalar("kappa", kappa)
    d = _array("delta", delta)
    if np.any(d > 1):
        raise ValueError("delta must be <= 1 (R1 is the smaller radius)")
    return _result((1.0 + d) ** RADIUS_EXPONENT * (1.0 + d**3) ** kappa)


def dilley_xi_equal_density(v: ArrayLike, R1: ArrayLike, delta: ArrayLike,
                            xi0: float = DILLEY_XI0, p: float = DILLEY_P, kappa: float = 0.0,
                            density: float = RHO_REF) -> FloatArray | float:
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
        See :func:`dilley_xi`.
    density : float [kg/m^3]
        Material density of both spheres.
    """
    xi0, p, kappa = _dilley_parameters(xi0, p, kappa)
    rho = _scalar("density", density, low=0.0)
    speed = _speed(v)
    r1 = _array("R1", R1, positive=True) / R_REF
    f = dilley_f(delta, kappa)
    xi = (xi0 * f * r1 ** (-3.0 * kappa - RADIUS_EXPONENT) * (rho / RHO_REF) ** -kappa
          * (speed / V_REF) ** p)
    return _result(xi)


# --- velocity-only laws ---------------------------------------------------------------------

def bridges_epsilon(v: ArrayLike, v_c: float = BRIDGES_V_C,
                    exponent: float = BRIDGES_EXPONENT) -> FloatArray | float:
    """Bridges et al. (1984) power law eps = min(1, (|v|/v_c)^-exponent).

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed.
    v_c : float [m/s]
        Speed below which collisions are elastic (7.7e-5 m/s in Bridges et al. 1984).
    exponent : float [dimensionless]
        Power-law index (0.234).
    """
    v_c = _scalar("v_c", v_c, low=0.0)
    exponent = _scalar("exponent", exponent, low=0.0)
    u = _speed(v) / v_c
    with np.errstate(divide="ignore"):
        eps = np.where(u > 1.0, np.power(np.maximum(u, 1.0), -exponent), 1.0)
    return _result(eps)


def andrews_epsilon(v: ArrayLike, v_c: float) -> FloatArray | float:
    """Andrews (1930) plastic-deformation model, eq. (4.3).

    eps^2 = [-2 + sqrt(30 u^2 - 5)] / (3 u^2) for u = |v|/v_c > 1, and eps = 1 for u <= 1.

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed.
    v_c : float [m/s]
        Critical speed of first plastic yield, eq. (4.2).
    """
    v_c = _scalar("v_c", v_c, low=0.0)
    u = np.maximum(_speed(v) / v_c, 1.0)
    u2 = u * u
    eps = np.sqrt((-2.0 + np.sqrt(30.0 * u2 - 5.0)) / (3.0 * u2))
    return _result(np.where(u > 1.0, eps, 1.0))


def tabor_epsilon(v: ArrayLike, v_c: float, q: float = 0.375) -> FloatArray | float:
    """Generalized Tabor (1948) model, eq. (4.10); q = 3/8 is eq. (4.8).

    eps = u^-(1-2q) ((1 - q eps^2) / (1 - q))^q for u = |v|/v_c > 1, eps = 1 for u <= 1.
    The implicit equation has one root in [A, A (1-q)^-q] with A = u^-(1-2q); it is solved
    by Newton's method on ln eps, safeguarded by bisection, to a residual below 1e-13.

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed.
    v_c : float [m/s]
        Speed at which eps = 1.
    q : float [dimensionless]
        Hardness exponent, 0 < q < 1/2.
    """
    v_c = _scalar("v_c", v_c, low=0.0)
    q = _scalar("q", q, low=0.0, high=0.5)
    u = np.maximum(_speed(v) / v_c, 1.0)
    amplitude = u ** -(1.0 - 2.0 * q)
    eps = _solve_tabor(amplitude, q)
    return _result(np.where(u > 1.0, eps, 1.0))


def _solve_tabor(amplitude: FloatArray, q: float) -> FloatArray:
    """Root of g(e) = ln e - ln A - q ln((1 - q e^2)/(1 - q)) on [A, A (1-q)^-q]; g' > 0."""
    lo = np.array(amplitude, dtype=float)
    hi = np.minimum(lo * (1.0 - q) ** -q, 1.0)
    log_a = np.log(lo)
    eps = 0.5 * (lo + hi)
    for _ in range(100):
        g = np.log(eps) - log_a - q * np.log((1.0 - q * eps * eps) / (1.0 - q))
        lo = np.where(g < 0, eps, lo)
        hi = np.where(g > 0, eps, hi)
        dg = 1.0 / eps + 2.0 * q * q * eps / (1.0 - q * eps * eps)
        newton = eps - g / dg
        inside = (newton > lo) & (newton < hi)
        new = np.where(inside, newton, 0.5 * (lo + hi))
        if np.all(np.abs(new - eps) <= 1e-16 * np.maximum(eps, 1e-300)):
            eps = new
            break
        eps = new
    return eps


def constant_epsilon(v: ArrayLike, epsilon: float) -> FloatArray | float:
    """A constant coefficient of restitution, whatever the speed.

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed (only its shape is used).
    epsilon : float [dimensionless], in [0, 1]
    """
    epsilon = _scalar("epsilon", epsilon, low=0.0, high=1.0, low_open=False, high_open=False)
    return _result(np.full(np.shape(_speed(v)), epsilon))


# --- dispatch by the scenario's restitution section ------------------------------------------

def model_parameters(restitution: Mapping[str, object]) -> tuple[str, dict[str, float]]:
    """Validate a ``restitution`` mapping; return (model, parameters with defaults filled).

    Raises ValueError naming the offending key for an unknown model, an unknown or
    missing parameter.
    """
    if "model" not in restitution:
        raise ValueError("model: missing (one of " + ", ".join(MODEL_PARAMETERS) + ")")
    model = restitution["model"]
    if model not in MODEL_PARAMETERS:
        raise ValueError(f"model: unknown restitution model {model!r} "
                         f"(one of {', '.join(MODEL_PARAMETERS)})")
    allowed = MODEL_PARAMETERS[model]
    params: dict[str, float] = {}
    for key, value in restitution.items():
        if key == "model":
            continue
        if key not in allowed:
            raise ValueError(f"{key}: not a parameter of model {model!r} "
                             f"(allowed: {', '.join(allowed)})")
        params[key] = _scalar(key, value)
    for key, default in allowed.items():
        if key not in params:
            if default is None:
                raise ValueError(f"{key}: required by model {model!r}")
            params[key] = default
    return model, params


def epsilon_for_pair(restitution: Mapping[str, object], v: ArrayLike, R_bar: ArrayLike,
                     M_bar: ArrayLike) -> FloatArray | float:
    """Coefficient of restitution of any law, given a scenario's ``restitution`` section.

    Parameters
    ----------
    restitution : mapping
        ``{"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}`` and the like
        (models dilley, bridges, constant, andrews, tabor; missing optional parameters
        take their defaults).
    v : array [m/s]
        Normal impact speed.
    R_bar : array [m]
        Reduced radius of the pair (used by dilley only).
    M_bar : array [kg]
        Reduced mass of the pair (used by dilley only).
    """
    model, params = model_parameters(restitution)
    if model == "dilley":
        return dilley_epsilon(v, R_bar, M_bar, **params)
    if model == "bridges":
        return bridges_epsilon(v, **params)
    if model == "constant":
        return constant_epsilon(v, **params)
    if model == "andrews":
        return andrews_epsilon(v, **params)
    return tabor_epsilon(v, **params)
