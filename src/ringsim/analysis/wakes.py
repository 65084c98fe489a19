"""Self-gravity wakes and the gravitational viscosity, from one snapshot.

Shear-periodic boundary: the radial images of the box are shifted in y by the shear offset
s(t) (``ringsim.physics.selfgravity.shear_offset``).  The surface density is therefore
gridded in sheared coordinates (x, y' = y + alpha x, alpha = s / Lx), in which the box is
exactly doubly periodic at any t; a Fourier mode (kx, ky) of that grid is the physical plane
wave of wave vector (kx + alpha ky, ky).  No window or remapping in time is needed.

Conventions: x radial (outward), y azimuthal (direction of orbital motion), shear flow
vy = -1.5 Omega x.  A wake crest is a line k . r = const; its pitch angle is the angle
between the crest and the azimuthal (y) direction, atan(k_y / k_x) in degrees, positive for
*trailing* crests (dy/dx < 0 along the crest: the outer end lags, as the shear makes it) and
negative for leading ones.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import binom

from ringsim.physics.constants import G_SI

#: Chance that a random sheet's strongest mode is called a wake in one snapshot.
FALSE_ALARM = 1e-3
#: Chance that a window of random sheets is said to hold a wake (`mean_wake`).
WINDOW_FALSE_ALARM = 1e-2
#: The numbers of a snapshot's dominant mode, None without a significant wake.
MODE_KEYS = ("mode_m", "mode_n", "kx", "ky", "wavelength", "wavelength_err", "pitch_angle_deg",
             "pitch_angle_err_deg", "azimuthal_mode")


def sheared_grid_spectrum(x, y, mass, Lx, Ly, shift, n=128):
    """Surface-density contrast spectrum of a snapshot on an n x n sheared grid.

    Parameters
    ----------
    x, y : array [m]
        Positions in the box [-Lx/2, Lx/2) x [-Ly/2, Ly/2).
    mass : array [kg]
    Lx, Ly : float [m]
    shift : float [m]
        Shear offset of the radial images at the snapshot's time.
    n : int
        Cells per side.

    Returns
    -------
    dict: ``sigma`` (n, n) surface density [kg/m^2] in sheared coordinates; ``power``
    |delta_k|^2 of the contrast delta = Sigma / <Sigma> - 1 per mode, cloud-in-cell window
    divided out [dimensionless]; ``kx``, ``ky`` physical wave-vector components [1/m] of every
    mode; ``shot`` the Poisson (shot-noise) level of ``power`` for these masses,
    sum(m^2) / M^2 [dimensionless].
    """
    x = np.asarray(x, dtype=float)
    mass = np.asarray(mass, dtype=float)
    alpha = shift / Lx
    gx = ((np.asarray(x) + 0.5 * Lx) / Lx % 1.0) * n
    gy = ((np.asarray(y) + alpha * x + 0.5 * Ly) / Ly % 1.0) * n
    sigma = np.zeros(n * n)
    ix0 = np.floor(gx).astype(np.int64)
    iy0 = np.floor(gy).astype(np.int64)
    fx, fy = gx - ix0, gy - iy0
    for dx, wx in ((0, 1.0 - fx), (1, fx)):
        for dy, wy in ((0, 1.0 - fy), (1, fy)):
            node = ((ix0 + dx) % n) * n + (iy0 + dy) % n
            sigma += np.bincount(node, weights=wx * wy * mass, minlength=n * n)
    sigma = sigma.reshape(n, n) / (Lx * Ly / n**2)
    total = mass.sum()
    delta_hat = np.fft.fft2(sigma) * (Lx * Ly / n**2) / total
    w = np.sinc(np.fft.fftfreq(n)) ** 2
    delta_hat /= w[:, None] * w[None, :]
    delta_hat[0, 0] = 0.0
    kxg = 2.0 * np.pi * np.fft.fftfreq(n, Lx / n)
    kyg = 2.0 * np.pi * np.fft.fftfreq(n, Ly / n)
    kx = kxg[:, None] + alpha * kyg[None, :]
    ky = np.broadcast_to(kyg[None, :], kx.shape).copy()
    return {"sigma": sigma, "power": np.abs(delta_hat) ** 2, "kx": kx, "ky": ky,
            "shot": float(np.sum(mass**2) / total**2)}


def wake_statistics(x, y, mass, Lx, Ly, shift, n=128, false_alarm=FALSE_ALARM):
    """The dominant shear-periodic mode of a snapshot's surface density.

    The modes a shear-periodic box holds at the snapshot's time are those of the sheared
    grid (module docstring): integers (m, n), wave vector k_y = 2 pi n / Ly, k_x = 2 pi (m +
    n s / Ly) / Lx, s the shear offset (1.5 Omega Lx t mod Ly).  The dominant mode is the
    largest |delta_k|^2 below the grid's Nyquist band (|k| < pi n / (2 L)); its wavelength
    2 pi / |k| and pitch atan(k_y / k_x) are that one mode's, a wave the box holds (lambda =
    Ly sin(pitch) / |n|).  Under pure Poisson noise (a random sheet of the same masses, the
    wake-free reference) each |delta_k|^2 / shot is exponentially distributed, so the
    largest of n_modes independent modes exceeds the peak with the chance ``p_value = 1 -
    (1 - exp(-peak / shot))^n_modes``; the wake is ``significant`` when p_value <
    ``false_alarm``.  Without it the mode's numbers (`MODE_KEYS`) are None.

    Parameters
    ----------
    x, y : array [m]
    mass : array [kg]
    Lx, Ly, shift : float [m]
    n : int
        Grid cells per side.
    false_alarm : float [dimensionless]

    Returns
    -------
    dict: ``mode_m``, ``mode_n`` (signs chosen so that k_x > 0, or k_y > 0 where k_x = 0),
    ``kx``, ``ky`` [1/m], ``wavelength`` [m], ``pitch_angle_deg`` [deg] (sign convention in
    the module docstring) and their errors (`wave_of`, half the modes' spacing);
    ``azimuthal_mode`` (|n|: 1 is the longest non-axisymmetric wave the box holds);
    ``peak_amplitude`` (A of Sigma = <Sigma> (1 + A cos(k.r)), shot noise subtracted),
    ``amplitude`` and ``poisson_amplitude`` (`_contrast`); ``significance`` (peak / shot),
    ``p_value``, ``significant``.
    """
    spec = sheared_grid_spectrum(x, y, mass, Lx, Ly, shift, n)
    power, kx, ky, shot = spec["power"], spec["kx"], spec["ky"], spec["shot"]
    k = np.hypot(kx, ky)
    band = (k > 0) & (k < 0.5 * np.pi * n / max(Lx, Ly))
    p = np.where(band, power, 0.0)
    peak_idx = np.unravel_index(np.argmax(p), p.shape)
    peak = float(p[peak_idx])
    n_modes = int(np.count_nonzero(band)) // 2
    significance = peak / shot
    p_value = float(-np.expm1(n_modes * np.log1p(-np.exp(-significance))))
    out = _contrast(spec["sigma"], np.asarray(mass, dtype=float), n)
    out.update({"peak_amplitude": float(2.0 * np.sqrt(max(peak - shot, 0.0))),
                "significance": float(significance), "p_value": p_value,
                "significant": bool(p_value < false_alarm)})
    if not out["significant"]:
        out.update(dict.fromkeys(MODE_KEYS))
        return out
    m_index, n_index = (int(i) if i <= n // 2 else int(i) - n for i in peak_idx)
    k0 = (float(kx[peak_idx]), float(ky[peak_idx]))
    sign = 1 if (k0[0] > 0 or (k0[0] == 0 and k0[1] > 0)) else -1
    out.update({"mode_m": sign * m_index, "mode_n": sign * n_index, "kx": sign * k0[0],
                "ky": sign * k0[1], "azimuthal_mode": abs(n_index)})
    out.update(wave_of(out["kx"], out["ky"], 0.5 * 2.0 * np.pi / max(Lx, Ly)))
    return out


def _contrast(sigma: np.ndarray, mass: np.ndarray, n: int) -> dict:
    """``amplitude``, the rms contrast of the surface density ``sigma`` [kg/m^2] on its n x
    n grid, and ``poisson_amplitude``, its expectation for a uniform random sheet of the
    masses ``mass`` [kg] [dimensionless]."""
    contrast = sigma / sigma.mean() - 1.0
    cell_mass = mass.sum() / n**2
    # CIC spreads each particle over 4 cells: the variance of a cell's mass is reduced by
    # the sum of squared weights, 4/9 on average
    return {"amplitude": float(np.sqrt(np.mean(contrast**2))),
            "poisson_amplitude": float(np.sqrt(4.0 / 9.0 * np.sum(mass**2) / n**2)
                                       / cell_mass)}


def wave_of(kx: float, ky: float, dk: float) -> dict:
    """Wavelength [m] and pitch [deg] of the wave vector (kx, ky) [1/m] with the
    uncertainty dk [1/m] on each component: ``wavelength``, ``wavelength_err``,
    ``pitch_angle_deg`` and ``pitch_angle_err_deg`` (first-order propagation)."""
    k = float(np.hypot(kx, ky))
    pitch = float(np.degrees(np.arctan(ky / kx))) if kx != 0 else float(np.sign(ky) * 90.0)
    return {"wavelength": 2.0 * np.pi / k, "wavelength_err": 2.0 * np.pi * dk / k**2,
            "pitch_angle_deg": pitch, "pitch_angle_err_deg": float(np.degrees(dk / k))}


def mean_wake(per_snapshot: list[dict], dk: float, false_alarm: float = FALSE_ALARM,
              window_false_alarm: float = WINDOW_FALSE_ALARM) -> dict:
    """The wake of a window of snapshots: the mean wave vector of their significant modes.

    The wave vectors (k_x > 0) are averaged component by component and the wavelength
    and pitch are those of the mean vector, not means of wavelengths and pitches.  Every
    snapshot's mode is one the box holds; with one |n| throughout, the mean is one too
    (k_y = 2 pi n / Ly, and k_x sweeps all values as the shear offset runs through a cycle).
    The window holds a wake when the count of significant snapshots is one that random
    sheets reach with a chance below ``window_false_alarm`` (binomial tail with
    probability ``false_alarm`` per snapshot); otherwise wavelength and pitch are None.

    Parameters
    ----------
    per_snapshot : list of `wake_statistics` results
    dk : float [1/m]
        Spacing of the box's modes (2 pi / max(Lx, Ly)): half of it is the error of a
        single snapshot's wave vector.
    false_alarm, window_false_alarm : float [dimensionless]

    Returns
    -------
    dict: ``significant`` (the window holds a wake), ``significant_snapshots``,
    ``window_p_value``, ``kx``, ``ky`` [1/m] and their errors ``kx_err``, ``ky_err``,
    ``wavelength`` [m], ``wavelength_err``, ``pitch_angle_deg`` [deg],
    ``pitch_angle_err_deg``, ``amplitude`` (mean ``peak_amplitude`` of the significant
    snapshots) and ``amplitude_err``, ``mode_n`` (the most common |n|) and
    ``mode_n_fraction`` (its share of the significant snapshots).
    """
    waked = [s for s in per_snapshot if s["significant"]]
    count, total = len(waked), len(per_snapshot)
    p_window = float(binom.sf(count - 1, total, false_alarm)) if count else 1.0
    out: dict = {"significant": bool(count and p_window < window_false_alarm),
                 "significant_snapshots": count, "window_p_value": p_window}
    keys = ("kx", "ky", "kx_err", "ky_err", "wavelength", "wavelength_err",
            "pitch_angle_deg", "pitch_angle_err_deg", "amplitude", "amplitude_err",
            "mode_n", "mode_n_fraction")
    if not out["significant"]:
        out.update(dict.fromkeys(keys))
        return out
    k = np.array([[s["kx"], s["ky"]] for s in waked])
    amp = np.array([s["peak_amplitude"] for s in waked])
    mean = k.mean(axis=0)
    err = k.std(axis=0, ddof=1) / np.sqrt(count) if count > 1 else np.full(2, 0.5 * dk)
    wave = wave_of(float(mean[0]), float(mean[1]), 0.0)
    kk = float(np.hypot(*mean))
    wave["wavelength_err"] = float(2.0 * np.pi * np.hypot(mean[0] * err[0], mean[1] * err[1])
                                   / kk**3)
    wave["pitch_angle_err_deg"] = float(np.degrees(np.hypot(mean[1] * err[0],
                                                            mean[0] * err[1]) / kk**2))
    modes, counts = np.unique([s["azimuthal_mode"] for s in waked], return_counts=True)
    out.update(wave)
    out.update({"kx": float(mean[0]), "ky": float(mean[1]), "kx_err": float(err[0]),
                "ky_err": float(err[1]), "amplitude": float(amp.mean()),
                "amplitude_err": float(amp.std(ddof=1) / np.sqrt(count)) if count > 1
                else math.nan,
                "mode_n": int(modes[np.argmax(counts)]),
                "mode_n_fraction": float(counts.max() / count)})
    return out


def vertical_stress_factor(z, mass, k, n_pairs=20000, seed=0):
    """Reduction of the gravitational stress of horizontal wave number k by the layer's
    thickness, relative to a thin sheet [dimensionless].

    For a layer whose vertical profile does not depend on horizontal position, the z-integral
    of g_x g_y of a mode is the thin sheet's times <exp(-k d) (1 + k d)> over mass-weighted
    pairs of vertical separation d (from the z-integral of exp(-k|z - z1|) exp(-k|z - z2|)).
    Estimated from ``n_pairs`` random pairs (seeded).

    Parameters
    ----------
    z : array [m]
    mass : array [kg]
    k : array [1/m]
    """
    rng = np.random.default_rng(seed)
    z = np.asarray(z, dtype=float)
    p = np.asarray(mass, dtype=float) / np.sum(mass)
    d = np.abs(z[rng.choice(z.size, n_pairs, p=p)] - z[rng.choice(z.size, n_pairs, p=p)])
    hist, edges = np.histogram(d, bins=64, range=(0.0, max(float(d.max()), 1e-300)))
    centres = 0.5 * (edges[1:] + edges[:-1])
    w = hist / hist.sum()
    kd = np.asarray(k, dtype=float)[..., None] * centres
    return np.sum(w * np.exp(-kd) * (1.0 + kd), axis=-1)


def gravitational_viscosity(pos, mass, Lx, Ly, Omega, shift, n=128, G=G_SI):
    """Gravitational (torque) viscosity nu_grav [m^2/s] of one snapshot.

    The angular-momentum flux that self-gravity carries across a radial line (Daisaka,
    Tanaka & Ida 2001's gravitational torque term), averaged over the box.  Written as the
    pair sum it is (1 / (2 Lx Ly)) sum_i sum_j (x_i - x_j) F_y(i <- j) over all pairs and
    images (each pair carries the y-force times the radial separation for the fraction of
    radial lines between them), and nu_grav = flux / (1.5 Omega Sigma), the normalisation of
    the translational (2 <u_x u_y> / 3 Omega) and collisional viscosities.  That sum over a
    shear-periodic sheet converges only conditionally, so it is evaluated here as the
    equivalent Maxwell stress of the field, mode by mode of the surface density on the
    sheared grid:

        flux = pi G sum_{k != 0} |Sigma_k|^2 kx ky / |k|^3 * f(|k|)

    with f the layer-thickness factor of :func:`vertical_stress_factor` (1 for a thin
    sheet).  Positive: outward transport (trailing wakes, kx ky > 0; Lynden-Bell & Kalnajs
    1972).  Limits: structure finer than two grid cells (n cells per side) is not seen; the
    granular torque of close pairs is left out; Poisson noise adds a scatter of zero mean.

    Parameters
    ----------
    pos : array (N, 3) [m]
    mass : array (N,) [kg]
    Lx, Ly : float [m]
    Omega : float [1/s]
    shift : float [m]
        Shear offset at the snapshot's time.
    n : int
        Grid cells per side.
    """
    pos = np.asarray(pos, dtype=float)
    mass = np.asarray(mass, dtype=float)
    spec = sheared_grid_spectrum(pos[:, 0], pos[:, 1], mass, Lx, Ly, shift, n)
    kx, ky = spec["kx"], spec["ky"]
    k = np.hypot(kx, ky)
    band = (k > 0) & (k < 0.5 * np.pi * n / max(Lx, Ly))
    sigma0 = float(np.sum(mass)) / (Lx * Ly)
    kb = k[band]
    factor = vertical_stress_factor(pos[:, 2], mass, kb)
    flux = np.pi * G * sigma0**2 * np.sum(spec["power"][band] * kx[band] * ky[band]
                                          / kb**3 * factor)
    return float(flux / (1.5 * Omega * sigma0))


def wave_viscosity(Sigma1, kx, ky, Sigma0, Omega, G):
    """Gravitational viscosity [m^2/s] of a thin sheet with a sinusoidal density wave.

    Sigma = Sigma0 + Sigma1 cos(kx x + ky y): the Maxwell stress of the wave's field,
    integrated over z, gives the flux pi G Sigma1^2 kx ky / (2 k^3) and nu = flux / (1.5
    Omega Sigma0): positive for trailing waves (kx ky > 0).

    Parameters
    ----------
    Sigma1, Sigma0 : float [kg/m^2]
    kx, ky : float [1/m]
    Omega : float [1/s]
    G : float [m^3 kg^-1 s^-2]
    """
    k = np.hypot(kx, ky)
    flux = np.pi * G * Sigma1**2 * kx * ky / (2.0 * k**3)
    return flux / (1.5 * Omega * Sigma0)
