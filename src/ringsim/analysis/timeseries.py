"""Time-series statistics: MSER-5 transient, autocorrelation-corrected means, stationarity.

The equilibrium of a series (:func:`stationary_mean`) truncates the start-up transient with
MSER-5 (White 1997; White, Cobb & Spratt 2000), estimates the standard error of the mean
with the integrated autocorrelation time and Sokal's automatic window (Madras & Sokal 1988;
Sokal 1997), and refuses to call a series equilibrated if the kept window still drifts or
holds fewer than ``min_effective_samples`` independent samples.  Plain numpy arrays in any
unit; nothing here knows what the series means.

References
----------
Madras, N. & Sokal, A. D. 1988, J. Stat. Phys. 50, 109.
Sokal, A. D. 1997, in Functional Integration, NATO ASI Series B 361, 131 (Plenum).
White, K. P. 1997, Simulation 69, 323 (MSER truncation heuristic).
White, K. P., Cobb, M. J. & Spratt, S. C. 2000, Proc. Winter Simulation Conf., 755 (MSER-5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ringsim.checks import FloatArray

# --- equilibrium of a time series -------------------------------------------------------------

@dataclass(frozen=True)
class EquilibriumResult:
    """Equilibrium value of a time series.

    Attributes
    ----------
    mean : float
        Mean over the equilibrium window [units of the series].
    stderr : float
        Standard error of that mean, corrected for autocorrelation [units of the series].
    start_index : int
        First sample of the window (end of the transient, MSER-5).
    start_time : float
        Time of that sample [units of series_t, s for ringsim].
    n_effective : float
        Window length / integrated autocorrelation time: independent samples.
    in_equilibrium : bool
        False if the window is too short or still drifts (see ``reason``).
    reason : str
        Why it is (or is not) in equilibrium.
    autocorrelation_time : float
        Integrated autocorrelation time tau_int [samples].
    slope : float
        Least-squares slope over the window [series units per unit of series_t].
    slope_stderr : float
        Its autocorrelation-corrected standard error.
    relative_drift : float
        |slope| * window duration / |mean| [dimensionless].
    """

    mean: float
    stderr: float
    start_index: int
    start_time: float
    n_effective: float
    in_equilibrium: bool
    reason: str
    autocorrelation_time: float = math.nan
    slope: float = math.nan
    slope_stderr: float = math.nan
    relative_drift: float = math.nan


def mser_truncation(values: ArrayLike, batch_size: int = 5, max_fraction: float = 0.5) -> int:
    """Truncation point of the initial transient by MSER-m (MSER-5 for batch_size = 5).

    The series is cut into batches of ``batch_size`` samples (an incomplete last batch is
    dropped); with batch means Y_1..Y_k, the statistic

        MSER(d) = sum_{j > d} (Y_j - mean(Y_{d+1..k}))^2 / (k - d)^2

    is minimised over d = 0 .. floor(max_fraction k) (White 1997; White, Cobb & Spratt
    2000, who restrict d to the first half of the run).

    Parameters
    ----------
    values : array
        The series (uniformly sampled).
    batch_size : int
        m; 5 is the published MSER-5 choice.
    max_fraction : float
        Largest fraction of the batches that may be discarded.

    Returns
    -------
    int
        Index of the first sample after the transient.
    """
    y = np.asarray(values, dtype=float).reshape(-1)
    m = int(batch_size)
    if m < 1:
        raise ValueError("batch_size must be >= 1")
    k = y.size // m
    if k < 2:
        return 0
    batches = y[: k * m].reshape(k, m).mean(axis=1)
    batches = batches - batches.mean()  # shift-invariant; avoids cancellation
    # Tail sums from d to the end, for every d.
    s1 = np.cumsum(batches[::-1])[::-1]
    s2 = np.cumsum((batches * batches)[::-1])[::-1]
    remaining = np.arange(k, 0, -1, dtype=float)
    sse = np.clip(s2 - s1 * s1 / remaining, 0.0, None)
    d_max = min(int(math.floor(max_fraction * k)), k - 2)
    stat = sse[: d_max + 1] / remaining[: d_max + 1] ** 2
    return int(np.argmin(stat)) * m


def _autocovariance(y: FloatArray) -> FloatArray:
    """Autocovariance (biased, 1/n) of y at lags 0..n-1, by FFT."""
    n = y.size
    d = y - y.mean()
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(d, n=size)
    return np.fft.irfft(f * np.conjugate(f), n=size)[:n] / n


def integrated_autocorrelation_time(values: ArrayLike, window_factor: float = 5.0) -> float:
    """Integrated autocorrelation time tau_int = 1 + 2 sum_t rho(t) [samples].

    The sum is cut at the smallest window M with M >= window_factor * tau_int(M)
    (Sokal's automatic windowing; Madras & Sokal 1988; Sokal 1997).  The variance of the
    mean of n samples is then var * tau_int / n.  Returns 1 for a constant series and never
    less than 1 (anticorrelation is not credited).

    Parameters
    ----------
    values : array
        Uniformly sampled series.
    window_factor : float
        Sokal's c (5 for nearly exponential autocorrelations).
    """
    y = np.asarray(values, dtype=float).reshape(-1)
    if y.size < 2:
        return 1.0
    acov = _autocovariance(y)
    if not acov[0] > 0.0:
        return 1.0
    taus = 2.0 * np.cumsum(acov / acov[0]) - 1.0
    lags = np.arange(y.size)
    ok = lags >= window_factor * taus
    window = int(np.argmax(ok)) if np.any(ok) else y.size - 1
    return float(max(taus[window], 1.0))


def autocorrelated_mean(values: ArrayLike,
                        window_factor: float = 5.0) -> tuple[float, float, float]:
    """Mean of a stationary series and its standard error, corrected for autocorrelation.

    stderr = sqrt(var tau_int / n) with ``integrated_autocorrelation_time``; no transient
    is removed (see ``stationary_mean`` for that).  Non-finite samples are dropped.

    Parameters
    ----------
    values : array
        Uniformly sampled series [any unit].
    window_factor : float
        Sokal's window constant c.

    Returns
    -------
    (mean, stderr, n_effective)
        Mean and standard error [units of the series]; n_effective = n / tau_int.  For
        fewer than 2 samples the standard error is NaN.
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan, 0.0
    if v.size < 2:
        return float(v[0]), math.nan, 1.0
    tau = integrated_autocorrelation_time(v, window_factor)
    return float(np.mean(v)), math.sqrt(float(np.var(v)) * tau / v.size), v.size / tau


def _drift(tw: FloatArray, vw: FloatArray, mean: float,
           window_factor: float) -> tuple[float, float, float]:
    """OLS slope of a window [series units per unit of tw], its autocorrelation-corrected
    standard error, and the fitted change over the window relative to |mean| (or to the
    standard deviation for a zero mean)."""
    n = vw.size
    dt = tw - tw.mean()
    sxx = float(np.dot(dt, dt))
    if not (sxx > 0.0 and n > 2):
        return 0.0, math.nan, 0.0
    slope = float(np.dot(dt, vw - mean) / sxx)
    resid = vw - mean - slope * dt
    tau_res = integrated_autocorrelation_time(resid, window_factor)
    slope_err = math.sqrt(float(np.dot(resid, resid)) / (n - 2) / sxx * tau_res)
    scale = abs(mean) if mean != 0.0 else math.sqrt(float(np.var(vw)))
    drift = abs(slope) * float(tw[-1] - tw[0]) / scale if scale > 0.0 else 0.0
    return slope, slope_err, drift


def _drift_problems(slope: float, slope_err: float, drift: float, trend_sigma: float,
                    max_relative_drift: float, time_unit: str, value_unit: str = ""
                    ) -> list[str]:
    """The drift verdict of `stationary_mean`: a slope beyond ``trend_sigma`` standard
    errors (or a noiseless line) AND a change beyond ``max_relative_drift``."""
    significant = slope_err > 0.0 and abs(slope) > trend_sigma * slope_err
    if slope_err == 0.0 and slope != 0.0:
        significant = True  # a noiseless straight line
    if not (significant and drift > max_relative_drift):
        return []
    sigmas = abs(slope) / slope_err if slope_err > 0.0 else math.inf
    per = f"{value_unit} per {time_unit}" if value_unit else f"per {time_unit}"
    return [f"still drifting: slope {slope:.3g} {per} is {sigmas:.1f} sigma, "
            f"a change of {100 * drift:.1f}% over the window"]


def stationary_mean(series_t: ArrayLike, series_values: ArrayLike, *,
                    min_fraction: float = 0.5, batch_size: int = 5,
                    min_effective_samples: float = 20.0, trend_sigma: float = 3.0,
                    max_relative_drift: float = 0.05, window_factor: float = 5.0,
                    time_unit: str = "time unit", value_unit: str = "") -> EquilibriumResult:
    """Equilibrium mean and its standard error of a time series, with a drift test.

    1. The transient is cut by MSER-5 (``mser_truncation``), discarding at most
       1 - ``min_fraction`` of the samples.
    2. Over the kept window, the mean and its standard error sqrt(var tau_int / n) with the
       integrated autocorrelation time (``integrated_autocorrelation_time``).
    3. Not in equilibrium when (a) the window holds fewer than ``min_effective_samples``
       effective samples n / tau_int; or (b) a straight-line fit over the window has a
       slope beyond ``trend_sigma`` times its standard error (the OLS error inflated by
       sqrt(tau_int) of the residuals) AND the fitted change over the window exceeds
       ``max_relative_drift`` times |mean|; or (c) MSER put the truncation at its limit,
       i.e. the transient may not be over.

    Non-finite samples are dropped first.  The series should be sampled uniformly in time.

    Parameters
    ----------
    series_t : array
        Sample times [s] (any unit; ``start_time`` and ``slope`` use it).
    series_values : array
        The quantity [any unit].
    min_fraction : float
        Smallest fraction of the series kept as the equilibrium window (0 < f <= 1).
    batch_size : int
        MSER batch size (5: MSER-5).
    min_effective_samples : float
        Fewest independent samples for an equilibrium verdict.
    trend_sigma : float
        Significance of a slope, in standard errors, to count as a drift.
    max_relative_drift : float
        Largest tolerated fitted change over the window relative to |mean|.
    window_factor : float
        Sokal's window constant c.
    time_unit, value_unit : str
        Units of ``series_t`` (e.g. "orbit") and ``series_values`` (e.g. "mm/s"), named in
        the drift message.
    """
    t, v = _finite_samples(series_t, series_values, min_fraction)
    if v.size < 3:
        return _too_short(t, v)
    start, at_limit = _transient_end(v, batch_size, min_fraction)
    tw, vw = t[start:], v[start:]
    mean, stderr, n_eff = autocorrelated_mean(vw, window_factor)
    slope, slope_err, drift = _drift(tw, vw, mean, window_factor)
    problems = (_drift_problems(slope, slope_err, drift, trend_sigma, max_relative_drift,
                                time_unit, value_unit)
                + _window_problems(at_limit, n_eff, min_fraction, min_effective_samples))
    reason = "; ".join(problems) if problems else (
        f"stationary after sample {start}: {n_eff:.0f} effective samples, "
        f"drift {100 * drift:.1f}% over the window")
    return EquilibriumResult(mean=mean, stderr=stderr, start_index=int(start),
                             start_time=float(t[start]), n_effective=float(n_eff),
                             in_equilibrium=not problems, reason=reason,
                             autocorrelation_time=vw.size / n_eff, slope=slope,
                             slope_stderr=slope_err, relative_drift=drift)


def _finite_samples(series_t: ArrayLike, series_values: ArrayLike, min_fraction: float
                    ) -> tuple[FloatArray, FloatArray]:
    """The samples of `stationary_mean` whose time and value are both finite, after its
    argument checks (equal lengths, 0 < min_fraction <= 1)."""
    t = np.asarray(series_t, dtype=float).reshape(-1)
    v = np.asarray(series_values, dtype=float).reshape(-1)
    if t.size != v.size:
        raise ValueError("series_t and series_values must have equal lengths")
    if not 0.0 < min_fraction <= 1.0:
        raise ValueError("min_fraction must lie in (0, 1]")
    keep = np.isfinite(t) & np.isfinite(v)
    return t[keep], v[keep]


def _too_short(t: FloatArray, v: FloatArray) -> EquilibriumResult:
    """The verdict of `stationary_mean` on fewer than 3 finite samples: not in equilibrium,
    the mean of what there is, no standard error."""
    return EquilibriumResult(
        mean=float(np.mean(v)) if v.size else math.nan, stderr=math.nan, start_index=0,
        start_time=float(t[0]) if t.size else math.nan, n_effective=float(v.size),
        in_equilibrium=False, reason=f"too short: {v.size} finite samples")


def _window_problems(at_limit: bool, n_eff: float, min_fraction: float,
                     min_effective_samples: float) -> list[str]:
    """The window verdicts of `stationary_mean`: the transient may not be over (MSER at
    its limit), or too few effective samples after it."""
    problems = []
    if at_limit:
        problems.append("transient may not be over: MSER truncation at its limit "
                        f"({100 * (1 - min_fraction):.0f}% of the series)")
    if n_eff < min_effective_samples:
        problems.append(f"too short: {n_eff:.1f} effective samples after the transient "
                        f"(need {min_effective_samples:g})")
    return problems


def _transient_end(v: FloatArray, batch_size: int, min_fraction: float) -> tuple[int, bool]:
    """The first sample after the transient (`mser_truncation`, discarding at most
    1 - min_fraction of the series) and whether MSER put it at that limit."""
    start = mser_truncation(v, batch_size=batch_size, max_fraction=1.0 - min_fraction)
    k = v.size // int(batch_size)
    at_limit = start > 0 and start // int(batch_size) >= min(
        int(math.floor((1.0 - min_fraction) * k)), k - 2)
    return start, at_limit
