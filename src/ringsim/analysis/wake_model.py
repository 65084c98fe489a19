"""The observers' model of self-gravity wakes: opaque bars with gaps, fitted to tau_n(B, phi).

Colwell et al. (2006, GRL 33, L07201; 2007, Icarus 190, 127) model the wakes as infinitely
long, parallel bars of rectangular cross-section: height H, width W, one every lambda = W + S
(S the gap between neighbours), opaque, with a gap of normal optical depth tau_G between them
("granola bars").  Seen along a line of sight at opening angle B whose horizontal direction
makes the angle phi - phi_W with the bars' long axis, a bar hides its own width and the strip
of the gap its height shades, H |sin(phi - phi_W)| / tan B, so that

    T = max(S/lambda - (H/lambda) |sin(phi - phi_W)| / tan B, 0) exp(-tau_G / sin B),
    tau_n = -sin B ln T.

The transmission peaks where the line of sight runs along the bars (phi = phi_W, mod 180 deg).
Conventions here: phi and phi_W are azimuths from +x (radial, outward) toward +y (orbital
motion); a trailing wake of pitch theta (``analysis.wakes``: angle from the azimuthal
direction, > 0 trailing) has its long axis at phi_W = 90 deg + theta, i.e. 90 - theta from
the radial direction on the trailing side, the angle Hedman et al. (2007, AJ 133, 2624)
report (64-72 deg in the A ring).

The fit (``fit_bar_model``) is a bounded weighted least-squares fit (scipy.optimize.
least_squares) of the four parameters S/lambda, H/lambda, tau_G and phi_W to tau_n with its
standard errors; the parameter errors are from the covariance (J^T J)^-1, scaled by the
reduced chi^2 when it exceeds 1.  H/W = (H/lambda) / (1 - S/lambda) with its error
propagated through the covariance.
"""

from __future__ import annotations

import math

import numpy as np

#: Floor of the model's transmission (keeps tau_n finite where the bars close every gap).
T_FLOOR = 1e-6
#: Parameter names of the fit, in order, and their units.
PARAMETERS = ("gap_fraction", "height_over_wavelength", "gap_optical_depth",
              "wake_orientation_deg")


def bar_transmission(elevation_deg, azimuth_deg, gap_fraction, height_over_wavelength,
                     gap_optical_depth, wake_orientation_deg):
    """Transmission [dimensionless] of the bar model (module docstring).

    Parameters
    ----------
    elevation_deg, azimuth_deg : array [deg]
        B and phi of the lines of sight.
    gap_fraction : float [dimensionless]
        S / lambda.
    height_over_wavelength : float [dimensionless]
        H / lambda.
    gap_optical_depth : float [dimensionless]
        tau_G, normal optical depth of the gaps.
    wake_orientation_deg : float [deg]
        phi_W, azimuth of the bars' long axis.
    """
    B = np.radians(np.asarray(elevation_deg, dtype=float))
    dphi = np.radians(np.asarray(azimuth_deg, dtype=float) - wake_orientation_deg)
    open_part = gap_fraction - height_over_wavelength * np.abs(np.sin(dphi)) / np.tan(B)
    return np.maximum(open_part, 0.0) * np.exp(-gap_optical_depth / np.sin(B))


def bar_optical_depth(elevation_deg, azimuth_deg, *parameters):
    """tau_n = -sin B ln T [dimensionless] of the bar model (``bar_transmission``'s
    arguments), with T floored at ``T_FLOOR``."""
    T = np.maximum(bar_transmission(elevation_deg, azimuth_deg, *parameters), T_FLOOR)
    return -np.sin(np.radians(np.asarray(elevation_deg, dtype=float))) * np.log(T)


def fit_bar_model(elevation_deg, azimuth_deg, tau_n, tau_n_err) -> dict:
    """Fit the bar model to measured normal optical depths.

    Parameters
    ----------
    elevation_deg, azimuth_deg : array [deg]
    tau_n, tau_n_err : array [dimensionless]
        Normal optical depths and their standard errors; non-finite ones are left out.

    Returns
    -------
    dict: each of ``PARAMETERS`` and ``height_over_width`` as
    ``{"value", "stderr", "units"}``, ``wake_angle_from_radial_deg`` (180 - phi_W, trailing
    wakes 0-90 deg),
    ``chi2``, ``reduced_chi2``, ``n_points``, ``success``.
    """
    from scipy.optimize import least_squares

    B, phi, tau, err = (np.asarray(v, dtype=float) for v in (elevation_deg, azimuth_deg,
                                                             tau_n, tau_n_err))
    good = np.isfinite(tau) & np.isfinite(err) & (err > 0)
    B, phi, tau, err = B[good], phi[good], tau[good], err[good]
    if tau.size < 5:
        return {"success": False, "n_points": int(tau.size),
                "message": "fewer than 5 finite views: no fit"}

    def residuals(p):
        return (bar_optical_depth(B, phi, *p) - tau) / err

    lower, upper = [1e-4, 0.0, 0.0, -90.0], [1.0, 5.0, 5.0, 270.0]
    best = None
    for start in range(0, 180, 20):
        p0 = [0.5, 0.1, max(float(np.min(tau)) * 0.5, 0.01), float(start)]
        res = least_squares(residuals, p0, bounds=(lower, upper))
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    return _fit_result(best, tau.size)


def _fit_result(res, n: int) -> dict:
    """Parameters with errors from a least_squares result over ``n`` points."""
    chi2 = float(2.0 * res.cost)
    dof = max(n - len(PARAMETERS), 1)
    jtj = res.jac.T @ res.jac
    cov = np.linalg.pinv(jtj) * max(chi2 / dof, 1.0)
    err = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    g, h, tau_g, phi_w = (float(v) for v in res.x)
    phi_w = phi_w % 180.0
    out: dict[str, object] = {
        name: {"value": v, "stderr": float(e),
               "units": "deg" if name.endswith("_deg") else "dimensionless"}
        for name, v, e in zip(PARAMETERS, (g, h, tau_g, phi_w), err, strict=True)}
    width = 1.0 - g
    # H/W = h / (1 - g): gradient (1 / (1 - g), h / (1 - g)^2) in (h, g)
    grad = np.array([h / width**2, 1.0 / width, 0.0, 0.0])
    out["height_over_width"] = {"value": h / width,
                                "stderr": float(math.sqrt(max(grad @ cov @ grad, 0.0))),
                                "units": "dimensionless"}
    out["wake_angle_from_radial_deg"] = {"value": 180.0 - phi_w, "stderr": float(err[3]),
                                         "units": "deg"}
    out.update({"chi2": chi2, "reduced_chi2": chi2 / dof, "n_points": int(n),
                "success": bool(res.success)})
    return out


def view_dependence(elevation_deg, azimuth_deg, tau_n, tau_n_err) -> dict | None:
    """How the fit depends on which opening angles it is given: the fit repeated with the
    views of each B left out in turn (a jackknife over the opening angles).

    The fit's own errors (scaled by the square root of the reduced chi^2 where it exceeds
    1) do not hold this dependence; when the bar model does not describe the sheet (no
    wakes, or wakes that are not bars), leaving out one B moves the parameters by far more.
    Returns None with fewer than three opening angles.

    Returns
    -------
    dict: ``left_out_deg`` (the B of each refit), and for ``height_over_width``,
    ``gap_optical_depth`` and ``wake_angle_from_radial_deg`` the refits' ``values``, their
    ``min`` and ``max`` and the jackknife standard error
    sqrt((n - 1) / n sum (x_i - mean)^2) (``jackknife_stderr``), with ``units``; NaN for a
    refit that failed (too few views, or the optimiser did not converge).  The angles are
    not unwrapped: a wake near the radial direction (0 or 180 deg) would inflate their
    spread.
    """
    B, phi, tau, err = (np.asarray(v, dtype=float) for v in (elevation_deg, azimuth_deg,
                                                             tau_n, tau_n_err))
    angles = sorted(set(B.tolist()))
    if len(angles) < 3:
        return None
    fits = [fit_bar_model(B[B != b], phi[B != b], tau[B != b], err[B != b]) for b in angles]
    out: dict[str, object] = {"left_out_deg": angles}
    for key in ("height_over_width", "gap_optical_depth", "wake_angle_from_radial_deg"):
        values = np.array([f[key]["value"] if f.get("success") and key in f
                           else math.nan for f in fits])
        ok = values[np.isfinite(values)]
        n = ok.size
        out[key] = {"values": values.tolist(),
                    "min": float(ok.min()) if n else math.nan,
                    "max": float(ok.max()) if n else math.nan,
                    "jackknife_stderr": float(math.sqrt((n - 1) / n * np.sum(
                        (ok - ok.mean()) ** 2))) if n > 1 else math.nan,
                    "units": "deg" if key.endswith("_deg") else "dimensionless"}
    return out
