"""Dimensionless numbers of a self-gravitating ring patch: pure numpy functions, SI units.

The numbers a ring dynamicist reads first for a self-gravitating sheet:

* the Hill-radius parameter of a pair, r_h = R_Hill / (r1 + r2) with the pair's mutual Hill
  radius R_Hill = ((m1 + m2) / (3 M_p))^(1/3) a (Ohtsuki 1993; Salo 1995; Daisaka, Tanaka &
  Ida 2001).  For two identical spheres of density rho it is
  r_h = (2 m / 3 M_p)^(1/3) a / (2 r) = (8 pi rho / (9 M_p))^(1/3) a / 2, independent of r;
* the surface density Sigma, the Toomre critical wavelength lambda_cr = 4 pi^2 G Sigma /
  Omega^2 and Toomre's Q = sigma_x Omega / (3.36 G Sigma) (the stellar-disk form, with the
  epicyclic frequency kappa = Omega of a Keplerian disk);
* a particle's surface escape speed sqrt(2 G m / r);
* how many lambda_cr the box spans, with the advice "at least 2, better 4": a wake lambda_cr
  apart at the published 15-30 deg pitch is 2-4 lambda_cr long azimuthally (no published
  box-size recommendation could be read, docs/gravity.md section 7).

The planet's mass is M_p = GM / G: ``GM`` is the number users give (it is known far better
than G or M_p separately).
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.physics.constants import G_SI

#: Toomre's factor for a stellar (collisionless) disk: Q = sigma kappa / (3.36 G Sigma).
TOOMRE_STELLAR = 3.36
#: Fewer lambda_cr across the box than this: wakes cannot form properly (warn).
WAKE_BOX_WARN = 2.0
#: At least this many lambda_cr across the box are advised for wake statistics.
WAKE_BOX_ADVISED = 4.0


def orbital_frequency(GM: float, a: float) -> float:
    """Keplerian orbital frequency Omega = sqrt(GM / a^3) [1/s].

    Parameters
    ----------
    GM : float [m^3/s^2]
        Gravitational parameter of the planet.
    a : float [m]
        Orbital radius of the patch.
    """
    if not (GM > 0.0 and a > 0.0):
        raise ValueError(f"GM and a must be positive, got GM={GM!r}, a={a!r}")
    return math.sqrt(GM / a**3)


def sphere_mass(radius, density):
    """Mass 4/3 pi rho r^3 [kg] of a homogeneous sphere.

    Parameters
    ----------
    radius : array [m]
    density : array [kg/m^3]
    """
    radius = np.asarray(radius, dtype=float)
    return 4.0 / 3.0 * np.pi * np.asarray(density, dtype=float) * radius**3


def hill_parameter(r1, r2, density, GM: float, a: float, G: float = G_SI):
    """Hill-radius parameter r_h of a pair of spheres [dimensionless].

    r_h = ((m1 + m2) / (3 M_p))^(1/3) a / (r1 + r2), with M_p = GM / G: the pair's mutual Hill
    radius in units of the sum of the radii.  r_h < ~0.7: gravity cannot hold a touching pair
    against the tide; r_h > ~1.2: pairs stick (aggregation); see docs/gravity.md.

    Parameters
    ----------
    r1, r2 : array [m]
        Radii of the two particles (broadcast).
    density : array [kg/m^3]
        Internal density of the particles (solid ice: 900).
    GM : float [m^3/s^2]
    a : float [m]
        Orbital radius.
    G : float [m^3 kg^-1 s^-2]
    """
    r1 = np.asarray(r1, dtype=float)
    r2 = np.asarray(r2, dtype=float)
    if np.any(~np.isfinite(r1)) or np.any(r1 <= 0) or np.any(~np.isfinite(r2)) or np.any(r2 <= 0):
        raise ValueError("radii must be positive and finite")
    planet_mass = GM / G
    m = sphere_mass(r1, density) + sphere_mass(r2, density)
    return np.cbrt(m / (3.0 * planet_mass)) * a / (r1 + r2)


def mean_pair_hill_parameter(radii, density, GM: float, a: float, G: float = G_SI,
                             bins: int = 64) -> float:
    """Mean r_h over all pairs of particles drawn from ``radii`` [dimensionless].

    The mean is number-weighted over pairs: the average of :func:`hill_parameter` over two
    particles drawn independently from the number distribution of ``radii`` (computed on
    ``bins`` logarithmic radius bins at the bins' mean radii, exact for one or a few distinct
    radii).  For identical particles it is the pair value (8 pi rho / 9 M_p)^(1/3) a / 2; a
    broad size distribution raises it: a small sphere on a large one has r_h up to
    2^(2/3) = 1.59 times the identical-pair value (a test particle on the surface of a big
    one).

    Parameters
    ----------
    radii : array [m]
    density : float [kg/m^3]
    GM : float [m^3/s^2]
    a : float [m]
    """
    radii = np.asarray(radii, dtype=float).ravel()
    values = np.unique(radii)
    if values.size <= bins:
        centres, counts = values, np.array([np.count_nonzero(radii == v) for v in values])
    else:
        edges = np.geomspace(radii.min(), radii.max() * (1 + 1e-12), bins + 1)
        idx = np.clip(np.searchsorted(edges, radii, side="right") - 1, 0, bins - 1)
        counts = np.bincount(idx, minlength=bins)
        sums = np.bincount(idx, weights=radii, minlength=bins)
        keep = counts > 0
        centres, counts = sums[keep] / counts[keep], counts[keep]
    w = counts / counts.sum()
    rh = hill_parameter(centres[:, None], centres[None, :], density, GM, a, G)
    return float(np.sum(w[:, None] * w[None, :] * rh))


def surface_density(total_mass: float, Lx: float, Ly: float) -> float:
    """Surface density Sigma = M / (Lx Ly) [kg/m^2] of a box.

    Parameters
    ----------
    total_mass : float [kg]
    Lx, Ly : float [m]
    """
    return float(total_mass) / (Lx * Ly)


def surface_density_from_tau(optical_depth, density, r2_mean, r3_mean):
    """Surface density [kg/m^2] of a ring of dynamical optical depth tau.

    Sigma = tau * (4/3) rho <r^3> / <r^2>, the moments number-weighted.

    Parameters
    ----------
    optical_depth : array [dimensionless]
    density : array [kg/m^3]
    r2_mean : array [m^2]
    r3_mean : array [m^3]
    """
    return np.asarray(optical_depth) * 4.0 / 3.0 * np.asarray(density) * r3_mean / r2_mean


def toomre_wavelength(Sigma, Omega, G: float = G_SI):
    """Toomre's critical wavelength lambda_cr = 4 pi^2 G Sigma / Omega^2 [m].

    Parameters
    ----------
    Sigma : array [kg/m^2]
    Omega : array [1/s]
    """
    return 4.0 * np.pi**2 * G * np.asarray(Sigma) / np.asarray(Omega) ** 2


def toomre_q(sigma_x, Sigma, Omega, G: float = G_SI):
    """Toomre parameter Q = sigma_x Omega / (3.36 G Sigma) [dimensionless].

    The stellar-disk form (Toomre 1964), as used for ring particle simulations (Salo 1995;
    Salo, Schmidt & Spahn 2001), with the epicyclic frequency of a Keplerian disk, kappa =
    Omega.  (A fluid disk would use pi instead of 3.36.)

    Parameters
    ----------
    sigma_x : array [m/s]
        Radial velocity dispersion (rms of vx).
    Sigma : array [kg/m^2]
    Omega : array [1/s]
    """
    return np.asarray(sigma_x) * np.asarray(Omega) / (TOOMRE_STELLAR * G * np.asarray(Sigma))


def toomre_dispersion(Q, Sigma, Omega, G: float = G_SI):
    """Radial velocity dispersion [m/s] at which a sheet has Toomre parameter Q (the inverse
    of :func:`toomre_q`): sigma_x = Q 3.36 G Sigma / Omega.

    Parameters
    ----------
    Q : array [dimensionless]
    Sigma : array [kg/m^2]
    Omega : array [1/s]
    """
    return np.asarray(Q) * TOOMRE_STELLAR * G * np.asarray(Sigma) / np.asarray(Omega)


def escape_speed(radius, density, G: float = G_SI):
    """Escape speed sqrt(2 G m / r) from the surface of a sphere [m/s].

    Parameters
    ----------
    radius : array [m]
    density : array [kg/m^3]
    """
    radius = np.asarray(radius, dtype=float)
    return np.sqrt(2.0 * G * sphere_mass(radius, density) / radius)


def wake_box_spans(Lx: float, Ly: float, lambda_cr: float) -> dict:
    """How many lambda_cr the box spans, and the advice for wake-forming runs.

    Wakes are nearly azimuthal structures with radial spacing about lambda_cr and azimuthal
    extent several lambda_cr, so the smaller of Lx / lambda_cr and Ly / lambda_cr decides.

    Parameters
    ----------
    Lx, Ly : float [m]
    lambda_cr : float [m]

    Returns
    -------
    dict with ``x`` and ``y`` (box / lambda_cr), ``smallest``, ``level`` ("warn" below
    WAKE_BOX_WARN, "advise" below WAKE_BOX_ADVISED, else "ok") and a one-line ``message``.
    """
    nx, ny = Lx / lambda_cr, Ly / lambda_cr
    smallest = min(nx, ny)
    if smallest < WAKE_BOX_WARN:
        level = "warn"
        message = (f"the box spans only {smallest:.2g} lambda_cr (< {WAKE_BOX_WARN:g}): "
                   f"self-gravity wakes cannot form properly; enlarge n_particles")
    elif smallest < WAKE_BOX_ADVISED:
        level = "advise"
        message = (f"the box spans {smallest:.2g} lambda_cr; at least {WAKE_BOX_ADVISED:g} "
                   f"are advised for wake statistics")
    else:
        level = "ok"
        message = f"the box spans {smallest:.2g} lambda_cr"
    return {"x": nx, "y": ny, "smallest": smallest, "level": level, "message": message}
