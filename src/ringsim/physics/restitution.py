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
  (Dilley)                 xi = xi0 (R/2.5 cm)^-0.2 (M/M_ref)^-kappa   (5.14)-(5.16)
                                (v/1 cm/s)^p
inverse                    xi = |ln eps| / sqrt(pi^2 + ln^2 eps)       (5.10)
equal-density pairs        (ringsim.physics.dilley_spheres)             (5.17)-(5.21)
Andrews plastic model      eps^2 = [-2 + sqrt(30 u^2 - 5)] / (3 u^2)   (4.3)
generalized Tabor          eps = u^-(1-2q) ((1 - q eps^2)/(1 - q))^q   (4.10), (4.8)
Bridges et al. (1984)      eps = min(1, (v/v_c)^-0.234)                Nature 309, 333
=========================  ==========================================  ==============

(u = |v|/v_c.)  Two misprints of the paper are corrected here: eq. (5.10) lacks the square
on ln(eps) in its denominator, and the text below (4.10) says q = 1/2 where eq. (4.8)
needs q = 3/8.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ringsim.physics.laws import DIMENSIONLESS, Law, LawTable, MeasuredRange, Parameter

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
#: Mass exponent of the Dilley law: 0 unless a scenario sets it (the paper discusses 0.1).
DILLEY_KAPPA = 0.0
#: Bridges et al. (1984) power law: critical speed [m/s] and exponent.
BRIDGES_V_C = 7.7e-5
BRIDGES_EXPONENT = 0.234
#: Hardness exponent of Tabor's case of eq. (4.10), eq. (4.8).
TABOR_Q = 0.375
#: Critical speed of Dilley's Fig. 1a curve c (Andrews and Tabor fits to Hatzes et al.) [m/s].
FIG1A_V_C = 0.0809e-2

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


def _parameters(model: str, **values: float) -> tuple[float, ...]:
    """The values checked against the declaration `RESTITUTION` (ValueError naming the
    parameter), in the order given."""
    checked = RESTITUTION[model].checked(values)
    return tuple(checked[name] for name in values)


def dilley_xi(v: ArrayLike, R_bar: ArrayLike, M_bar: ArrayLike, xi0: float = DILLEY_XI0,
              p: float = DILLEY_P, kappa: float = DILLEY_KAPPA,
              reference_mass: float = M_REF) -> FloatArray | float:
    """Damping ratio of the viscous-dissipation model, eqs. (5.14)-(5.16).

    xi = xi0 (R_bar / 2.5 cm)^-0.2 (M_bar / M_ref)^-kappa (|v| / 1 cm/s)^p, M_ref = 60 g

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
    reference_mass : float [kg]
        M_ref, the reduced mass at which the mass factor is 1, > 0: 60 g, the 2.5 cm ice
        sphere (eq. 5.16); the pendulum's effective mass in the experiments may have been
        up to 600 g (sect. 2, 5), which changes xi by (M_ref / 60 g)^kappa.
    """
    xi0, p, kappa, m_ref = _parameters("dilley", xi0=xi0, p=p, kappa=kappa,
                                       reference_mass=reference_mass)
    speed = _speed(v)
    r = _array("R_bar", R_bar, positive=True)
    m = _array("M_bar", M_bar, positive=True)
    xi = xi0 * (r / R_REF) ** -RADIUS_EXPONENT * (m / m_ref) ** -kappa * (speed / V_REF) ** p
    return _result(xi)


def dilley_epsilon(v: ArrayLike, R_bar: ArrayLike, M_bar: ArrayLike, xi0: float = DILLEY_XI0,
                   p: float = DILLEY_P, kappa: float = DILLEY_KAPPA,
                   reference_mass: float = M_REF) -> FloatArray | float:
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
    reference_mass : float [kg]
        See :func:`dilley_xi`.
    """
    return epsilon_from_xi(dilley_xi(v, R_bar, M_bar, xi0=xi0, p=p, kappa=kappa,
                                     reference_mass=reference_mass))


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
    v_c, exponent = _parameters("bridges", v_c=v_c, exponent=exponent)
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
    (v_c,) = _parameters("andrews", v_c=v_c)
    u = np.maximum(_speed(v) / v_c, 1.0)
    # eq. (4.3) divided through by u^2, in w = 1/u: finite up to u = inf (eps -> 0)
    w = 1.0 / u
    eps = np.sqrt((w * np.sqrt(30.0 - 5.0 * w * w) - 2.0 * w * w) / 3.0)
    return _result(np.where(u > 1.0, eps, 1.0))


def tabor_epsilon(v: ArrayLike, v_c: float, q: float = TABOR_Q) -> FloatArray | float:
    """Generalized Tabor (1948) model, eq. (4.10); q = 3/8 is eq. (4.8).

    eps = u^-(1-2q) ((1 - q eps^2) / (1 - q))^q for u = |v|/v_c > 1, eps = 1 for u <= 1.
    The implicit equation is solved by the rule of :func:`_solve_tabor`, the same as the
    C library's (numpy and C agree to 2 ulp, tests/test_parameters.py).

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed.
    v_c : float [m/s]
        Speed at which eps = 1.
    q : float [dimensionless]
        Hardness exponent, 0 < q < 1/2.
    """
    v_c, q = _parameters("tabor", v_c=v_c, q=q)
    u = np.maximum(_speed(v) / v_c, 1.0)
    # A = u^-(1-2q) by the C library's pow (libm), element by element: numpy's vectorised
    # power may differ in the last bit, which the solver would carry into eps.
    amplitude = np.asarray(_LIBM_POW(u, -(1.0 - 2.0 * q)), dtype=float)
    eps = _solve_tabor(amplitude, q)
    return _result(np.where(u > 1.0, eps, 1.0))


_LIBM_POW = np.frompyfunc(math.pow, 2, 1)
#: Relative step and bracket width at which the Tabor solver stops (RS_TABOR_TOLERANCE in C).
TABOR_TOLERANCE = 1e-15
#: Most iterations of the Tabor solver (RS_TABOR_MAX_ITERATIONS in C).
TABOR_MAX_ITERATIONS = 200


def _solve_tabor(amplitude: FloatArray, q: float) -> FloatArray:
    """Root e of eq. (4.10) for each A = u^-(1-2q) in ``amplitude``.

    The rule, shared with ``rs_tabor_epsilon`` in ringsim/csrc/rs_resolver.c: write
    e = A (1 + s).  g(s) = log1p(s) - q log1p(q (1 - e^2)/(1 - q)) (eq. 4.10 divided by A,
    in logarithms; no cancellation for large u) increases with s and changes sign on the
    bracket [lo, hi] = [0, min(1/A, (1-q)^-q) - 1]; start at its midpoint.  Each
    iteration: evaluate g; g < 0 sets lo = s, g > 0 sets hi = s, anything else (an exact
    root) stops.  Newton step d = -g/g' (g' = 1/(1 + s) + 2 q^2 A e / (1 - q e^2)): if
    |d| <= TABOR_TOLERANCE (1 + s), take it and stop (converged: round-off may put s + d
    on the edge of the bracket); else take s + d if it lies strictly inside (lo, hi), the
    midpoint otherwise, and stop if the bracket is now no wider than TABOR_TOLERANCE
    (1 + s).  At most TABOR_MAX_ITERATIONS iterations; return A (1 + s).  Every element
    stops on its own, as the scalar C loop does.
    """
    a = np.array(amplitude, dtype=float)
    lo = np.zeros(a.shape)
    with np.errstate(divide="ignore"):   # A = 0 (u^-(1-2q) underflowed): 1/A = inf
        hi = np.minimum(1.0 / a, (1.0 - q) ** -q) - 1.0
    s = 0.5 * (lo + hi)
    active = np.ones(a.shape, dtype=bool)
    for _ in range(TABOR_MAX_ITERATIONS):
        if not np.any(active):
            break
        e = a * (1.0 + s)
        g = np.log1p(s) - q * np.log1p(q * (1.0 - e * e) / (1.0 - q))
        lo = np.where(active & (g < 0.0), s, lo)
        hi = np.where(active & (g > 0.0), s, hi)
        active &= (g < 0.0) | (g > 0.0)
        step = -g / (1.0 / (1.0 + s) + 2.0 * q * q * a * e / (1.0 - q * e * e))
        newton = s + step
        converged = np.abs(step) <= TABOR_TOLERANCE * (1.0 + s)
        inside = (newton > lo) & (newton < hi)
        s = np.where(active, np.where(converged | inside, newton, 0.5 * (lo + hi)), s)
        active &= ~converged & (hi - lo > TABOR_TOLERANCE * (1.0 + s))
    return a * (1.0 + s)


def constant_epsilon(v: ArrayLike, epsilon: float) -> FloatArray | float:
    """A constant coefficient of restitution, whatever the speed.

    Parameters
    ----------
    v : array [m/s]
        Normal impact speed (only its shape is used).
    epsilon : float [dimensionless], in [0, 1]
    """
    (epsilon,) = _parameters("constant", epsilon=epsilon)
    return _result(np.full(np.shape(_speed(v)), epsilon))


# --- the declaration: every law, once ----------------------------------------------------------

_D93 = "Dilley (1993)"
_HATZES = MeasuredRange(
    speeds=(1e-4, 5e-2), sizes=(0.025, 0.20), masses=(0.060, 0.600), source="Hatzes et al. "
    "(1988, MNRAS 231, 1091): ice spheres against an ice brick, radii of curvature 2.5-20 cm, "
    "0.01-5 cm/s, fitted by Dilley (1993) sect. 5; mass not varied, an effective mass with the "
    "disc pendulum's inertia (sect. 2, 5): 60 g (2.5 cm ice sphere) the least, 600 g assumed")

#: Where the plastic laws were applied: no measured range of their own.
_FIG1A_COMPARISON = MeasuredRange(
    speeds=None, sizes=None,
    source=f"not stated: {_D93} sect. 4 applies it above v_c and compares it with the Hatzes "
           "et al. (1988) data (Fig. 1a)")

#: The restitution laws a scenario's ``restitution`` section can choose, and the only
#: declaration of their parameters (see ringsim.physics.laws).  The C library's
#: ``struct rs_resolver`` has ``param[4]`` (RS_LAW_PARAMS).
RESTITUTION = LawTable("restitution", n_slots=4, laws=[
    Law("dilley", code=0, function=dilley_epsilon, uses_pair=True,
        formula="ε = exp(−πξ/√(1−ξ²)) for ξ < 1, else 0; ξ = xi0 (R̄/2.5 cm)^−0.2 "
                "(M̄/M_ref)^−κ (v/1 cm/s)^p, M_ref = 60 g",
        source=f"{_D93} eqs. (5.9), (5.14)-(5.16)", measured=_HATZES,
        parameters=(
            Parameter("xi0", DIMENSIONLESS, default=DILLEY_XI0, lower=0.0, slot=0,
                      meaning="damping ratio ξ of the reference pair (R̄ = 2.5 cm, "
                              "M̄ = M_ref) at v = 1 cm/s",
                      source=f"{_D93} eq. (5.11), fit to Hatzes et al. (1988)"),
            Parameter("p", DIMENSIONLESS, default=DILLEY_P, lower=0.0, slot=1,
                      meaning="speed exponent: ξ ∝ v^p (p > 0: dissipation grows with "
                              "speed)",
                      source=f"{_D93} eq. (5.11), fit to Hatzes et al. (1988)"),
            Parameter("kappa", DIMENSIONLESS, default=DILLEY_KAPPA, slot=2,
                      meaning="extra mass exponent: ξ ∝ M̄^−κ",
                      source=f"{_D93} eq. (5.16); not constrained by the data "
                             "(the paper discusses 0 and 0.1)"),
            Parameter("reference_mass", "kg", default=M_REF, lower=0.0, slot=3,
                      implicit_at_default=True,
                      meaning="reduced mass M_ref at which the mass factor (M̄/M_ref)^−κ is "
                              "1; 600 g gives the pendulum's largest effective mass",
                      source=f"{_D93} eq. (5.16) and sect. 2, 5: the 60 g 2.5 cm sphere; the "
                             "pendulum's effective mass may have been up to 600 g"),
        )),
    Law("bridges", code=1, function=bridges_epsilon,
        formula="ε = min(1, (v/v_c)^−exponent)",
        source="Bridges, Hatzes & Lin (1984), Nature 309, 333",
        measured=MeasuredRange(speeds=None, sizes=None, masses=None, source=(
            "not checked here: frost-covered ice spheres on a disc pendulum, an effective mass "
            f"({_D93} sect. 2); its follow-up, Hatzes et al. (1988): spheres of 5 cm diameter, "
            "0.015-2 cm/s in Hill et al. (2015, A&A 573, A49) Table 2")),
        parameters=(
            Parameter("v_c", "m/s", default=BRIDGES_V_C, lower=0.0, slot=0,
                      meaning="speed below which collisions are elastic",
                      source="Bridges et al. (1984): 0.0077 cm/s"),
            Parameter("exponent", DIMENSIONLESS, default=BRIDGES_EXPONENT, lower=0.0,
                      slot=1, meaning="slope of the power law",
                      source="Bridges et al. (1984)"),
        )),
    Law("constant", code=2, function=constant_epsilon,
        formula="ε = epsilon at every speed",
        source="–",
        measured=MeasuredRange(speeds=None, sizes=None, source="not a measured law"),
        parameters=(
            Parameter("epsilon", DIMENSIONLESS, lower=0.0, upper=1.0, lower_closed=True,
                      upper_closed=True, slot=0, example=0.5,
                      meaning="the same ε for every collision",
                      source="– (example 0.5: the middle of the range)"),
        )),
    Law("andrews", code=3, function=andrews_epsilon,
        formula="ε² = [−2 + √(30u² − 5)]/(3u²) for u = v/v_c > 1, else 1",
        source=f"Andrews (1930) as in {_D93} eq. (4.3)",
        measured=_FIG1A_COMPARISON,
        parameters=(
            Parameter("v_c", "m/s", lower=0.0, slot=0, example=FIG1A_V_C,
                      meaning="speed of first plastic yield",
                      source=f"{_D93} eq. (4.2); example: Fig. 1a curve c"),
        )),
    Law("tabor", code=4, function=tabor_epsilon,
        formula="ε = u^−(1−2q) ((1 − qε²)/(1 − q))^q for u = v/v_c > 1, else 1",
        source=f"Tabor (1948) generalized in {_D93} eqs. (4.8), (4.10)",
        measured=_FIG1A_COMPARISON,
        parameters=(
            Parameter("v_c", "m/s", lower=0.0, slot=0, example=FIG1A_V_C,
                      meaning="speed at which ε = 1",
                      source=f"{_D93} eq. (4.10); example: Fig. 1a curve c"),
            Parameter("q", DIMENSIONLESS, default=TABOR_Q, lower=0.0, upper=0.5, slot=1,
                      meaning="hardness exponent (3/8: Tabor's case)",
                      source=f"{_D93} eq. (4.8)"),
        )),
])


# --- dispatch by the scenario's restitution section ------------------------------------------

def model_parameters(restitution: Mapping[str, object]) -> tuple[str, dict[str, float]]:
    """Validate a ``restitution`` mapping against `RESTITUTION`; return (model, parameters
    with defaults filled).

    Raises ValueError naming the offending key for an unknown model, an unknown, missing or
    out-of-range parameter.
    """
    law, params = RESTITUTION.resolve(restitution)
    return law.name, params


def epsilon_for_pair(restitution: Mapping[str, object], v: ArrayLike, R_bar: ArrayLike | None,
                     M_bar: ArrayLike | None) -> FloatArray | float:
    """Coefficient of restitution of any law, given a scenario's ``restitution`` section.

    The one dispatch from a law's name to its function (`RESTITUTION`).

    Parameters
    ----------
    restitution : mapping
        ``{"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}`` and the like
        (models and parameters as declared in `RESTITUTION`; missing optional parameters
        take their defaults).
    v : array [m/s]
        Normal impact speed.
    R_bar : array [m] or None
        Reduced radius of the pair: read by laws with ``uses_pair`` only, None for others.
    M_bar : array [kg] or None
        Reduced mass of the pair, as ``R_bar`` (``Law.evaluate`` refuses a None it needs).
    """
    law, params = RESTITUTION.resolve(restitution)
    return law.evaluate(params, v, R_bar, M_bar)
