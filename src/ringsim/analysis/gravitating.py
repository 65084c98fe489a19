"""The equilibrium numbers of a self-gravitating run (``ringsim analyze``).

What a ring dynamicist reads for a self-gravitating sheet, beside the equilibrium of
``analysis.equilibrium``:

* ``r_h`` (mean pair), ``lambda_cr`` [m]: the run's own numbers, stored by ``ringsim run``
  in the file's root attributes (``engine.gravity.sheet_gravity``), constants of the run
  (stderr 0); computed from the first snapshot with the same ``physics.gravity`` functions
  for files that lack them;
* ``toomre_Q``: the window mean of the run's Toomre Q series (``toomre_Q`` rows, Q =
  sigma_x Omega / (3.36 G Sigma), sigma_x number-weighted), autocorrelation-corrected stderr
  as every time series;
* ``toomre_Q_mass``: Q from the mass-weighted sigma_x of each snapshot inside the window
  (:func:`mass_weighted_toomre_q`), mean and standard error over those snapshots.  For a
  size distribution it is the one that says whether the ring is gravitationally unstable:
  the mass, and so Sigma, sits in the large particles, which are the coolest, so it can lie
  well below the number-weighted Q (docs/gravity.md, 4c); for identical particles both are
  the same;
* ``wake_wavelength`` [m], ``wake_pitch_angle`` [deg], ``wake_amplitude``: the wake of the
  equilibrium window (``analysis.wakes.mean_wake``): the dominant shear-periodic mode of each
  snapshot inside the window (``analysis.wakes.wake_statistics``), its wave vector averaged
  over the snapshots with a significant wake, and the wavelength and pitch of that mean
  vector, with errors propagated from the components' standard errors (snapshots treated
  as independent: they are ``output.snapshot_every`` apart, an orbit or more, while wakes
  live about an orbit).  Where the window holds no significant wake the three are null
  (``{"mean": null, "stderr": null}``) and ``wake_significant`` is false;
* ``gravitational_viscosity`` [m^2/s]: ``analysis.wakes.gravitational_viscosity`` of the same
  snapshots, mean and stderr over them (0 for a run with ``gravity_solver: slab``, whose
  forces are vertical: no torque acted);
* ``energy_balance``: the sheet's energy balance with the gravitational viscosity
  (:func:`energy_balance`): viscous heating by the shear, collisional dissipation, the rate
  of change of the random kinetic energy, and their closure.

``wake_significant`` says whether the window holds a wake against the random-sheet
reference, ``wake_significant_fraction`` in how many of the window's snapshots it was
significant, ``wake_mode_n`` the most common number of wavelengths along y of the
significant modes.  ``wake_box_length_fraction`` says in how many of those the mode is the
longest non-axisymmetric wave the box holds (one wavelength along y).  For such a mode the
box ties wavelength and pitch, lambda = Ly sin(theta): a wake lambda_cr apart at 20-25 deg
is 2.4-2.9 lambda_cr long in y, more than a box of 2.1 lambda_cr holds.  It is common and
not by itself a defect; only a larger box says whether the box changed c and H
(docs/gravity.md, 5, "Box-long wakes").
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.analysis import timeseries, wakes
from ringsim.analysis.snapshot import dispersion_tensor
from ringsim.analysis.window import window_snapshot_indices
from ringsim.physics import gravity as patch
from ringsim.physics.restitution import epsilon_for_pair
from ringsim.physics.selfgravity import shear_offset
from ringsim.quantities import GRAVITY, QUANTITY, table_rows, unit

#: Gravity quantities of the equilibrium (declared in ``ringsim.quantities``): key ->
#: (label, JSON unit, unit shown, scale).
GRAVITY_QUANTITIES = table_rows(GRAVITY)
#: Below this mass-weighted Toomre Q ``analyze`` warns that a slab run of identical
#: particles misses what matters; ``SLAB_MIN_Q_MASS_SIZES`` for a size distribution.  Each
#: is the lowest Q (rounded down) at which the slab's c and H were measured within its
#: error budget against P3M and the tree (docs/gravity.md, 4c, "Where the slab may be used").
SLAB_MIN_Q_MASS = 5.0
SLAB_MIN_Q_MASS_SIZES = 8.0
#: The energy-balance keys of `GRAVITY_QUANTITIES` (NaN where they cannot be measured).
ENERGY_KEYS = ("viscous_heating", "collisional_dissipation", "kinetic_energy_change",
               "energy_closure", "energy_closure_without_gravity")
#: Log-spaced points per impact-speed bin at which the restitution law is evaluated for the
#: bin's mean dissipated energy (bins are a factor 10^0.1 wide; eps varies across them).
BIN_SUBSAMPLES = 16


def _value(mean: float, stderr: float, units: str) -> dict:
    return {"mean": float(mean), "stderr": float(stderr), "units": units}


def _over_snapshots(values: list[float], own_error: float, units: str) -> dict:
    """Mean and standard error over snapshots (one snapshot: its own error)."""
    if not values:
        return _value(math.nan, math.nan, units)
    a = np.asarray(values, dtype=float)
    stderr = float(np.std(a, ddof=1) / math.sqrt(a.size)) if a.size > 1 else own_error
    return _value(float(np.mean(a)), stderr, units)


def run_constants(run) -> dict:
    """r_h, Sigma [kg/m^2] and lambda_cr [m] of a gravitating run: its root attributes, or
    computed from the first snapshot for files written before they were stored."""
    attrs = run.attrs
    if "lambda_cr" in attrs:
        return {"r_h": float(attrs["r_h"]), "Sigma": float(attrs["Sigma"]),
                "lambda_cr": float(attrs["lambda_cr"])}
    sc = run.scenario
    first = run.snapshot(0)
    Sigma = patch.surface_density(float(np.sum(first["mass"])), float(attrs["Lx"]),
                                  float(attrs["Ly"]))
    planet = sc.planet
    r_h = (math.nan if planet.GM is None else
           patch.mean_pair_hill_parameter(first["radius"], sc.particles.density, planet.GM,
                                          planet.a))
    return {"r_h": r_h, "Sigma": Sigma,
            "lambda_cr": float(patch.toomre_wavelength(Sigma, sc.orbital_frequency))}


def snapshot_wakes(snap: dict, Lx: float, Ly: float, Omega: float) -> dict:
    """``wake_statistics`` and ``gravitational_viscosity`` [m^2/s] of one snapshot.

    Parameters
    ----------
    snap : dict with x, y, z [m], mass [kg], t [s]
    Lx, Ly : float [m]
    Omega : float [1/s]
    """
    shift = shear_offset(Omega, Lx, Ly, float(snap["t"]))
    stats = wakes.wake_statistics(snap["x"], snap["y"], snap["mass"], Lx, Ly, shift)
    pos = np.column_stack([snap["x"], snap["y"], snap["z"]])
    stats["gravitational_viscosity"] = wakes.gravitational_viscosity(pos, snap["mass"], Lx, Ly,
                                                                     Omega, shift)
    return stats


def mass_weighted_toomre_q(snap: dict, Sigma: float, Omega: float) -> float:
    """Toomre Q [dimensionless] of one snapshot from its mass-weighted radial velocity
    dispersion: sigma_x^2 = sum m (w_x - <w_x>_m)^2 / sum m, with w the velocity relative
    to the shear flow, in ``physics.gravity.toomre_q``.

    Parameters
    ----------
    snap : dict with x [m], vx, vy, vz [m/s], mass [kg]
    Sigma : float [kg/m^2]
    Omega : float [1/s]
    """
    W = dispersion_tensor(snap["x"], snap["vx"], snap["vy"], snap["vz"], Omega,
                          weights=snap["mass"])
    return float(patch.toomre_q(math.sqrt(W[0, 0]), Sigma, Omega))


def bin_means(counts: np.ndarray, edges: np.ndarray, f) -> np.ndarray:
    """Mean of f(v) over each bin of a speed histogram [units of f].

    Within a bin the density per ln v is taken as a power law whose slope is that of the
    neighbouring bins' counts (flat where they are empty), as the histogram's own best
    guess; f is evaluated at `BIN_SUBSAMPLES` log-spaced points per bin.

    Parameters
    ----------
    counts : array (n_bins,) of counts
    edges : array (n_bins + 1,) [m/s], finite, > 0
    f : callable, array of speeds [m/s] -> array
    """
    counts = np.asarray(counts, dtype=float)
    lo, hi = edges[:-1], edges[1:]
    width = np.log(hi / lo)
    centre = 0.5 * (np.log(lo) + np.log(hi))
    log_density = np.full(counts.size, np.nan)
    filled = counts > 0
    log_density[filled] = np.log(counts[filled] / width[filled])
    left = np.concatenate([[0], np.arange(counts.size - 1)])
    right = np.concatenate([np.arange(1, counts.size), [counts.size - 1]])
    gap = centre[right] - centre[left]
    slope = (log_density[right] - log_density[left]) / np.where(gap > 0, gap, 1.0)
    slope = np.where(np.isfinite(slope), slope, 0.0)
    u = (np.arange(BIN_SUBSAMPLES) + 0.5) / BIN_SUBSAMPLES
    ln_v = np.log(lo)[:, None] + width[:, None] * u[None, :]
    weight = np.exp(slope[:, None] * (ln_v - centre[:, None]))
    return np.sum(weight * f(np.exp(ln_v)), axis=1) / np.sum(weight, axis=1)


def dissipation_rates(ts: dict, restitution: dict, radius: np.ndarray, mass: np.ndarray,
                      area: float) -> np.ndarray | None:
    """Kinetic energy the collisions dissipate per unit area and time in every output
    interval [W/m^2] (NaN for row 0); None unless the particles are identical.

    A collision of identical particles at normal speed v_n dissipates (1 - eps^2) (M_bar/2)
    v_n^2 with M_bar = m/2 the reduced mass, eps the scenario's law at (v_n, R_bar = r/2,
    M_bar): summed over the interval's impact-speed histogram (``bin_means``; the underflow
    bin [0, 1e-7 m/s] counts at v^2 = edge^2 / 3, the overflow bin at its lower edge).  With
    a size distribution the histogram does not say which pair hit, so no rate is given.

    Parameters
    ----------
    ts : the run's time series (``impact_speed_histogram`` and its bin edges [m/s], t [s])
    restitution : the scenario's restitution section (``Scenario.restitution_dict``)
    radius : array [m]
    mass : array [kg]
    area : float [m^2]
    """
    if np.ptp(radius) > 0 or np.ptp(mass) > 0:
        return None
    r, m = float(radius[0]), float(mass[0])

    def loss(v):
        eps = np.asarray(epsilon_for_pair(restitution, v, 0.5 * r, 0.5 * m), dtype=float)
        return (1.0 - eps**2) * v**2

    edges = np.asarray(ts["impact_speed_bin_edges"], dtype=float)
    hist = np.asarray(ts["impact_speed_histogram"], dtype=float)
    inner = bin_means(hist[:, 1:-1].sum(axis=0), edges[1:-1], loss)
    per_bin = np.concatenate([loss(np.array([edges[1]])) / 3.0, inner,
                              loss(np.array([edges[-2]]))])
    dt = np.diff(np.asarray(ts["t"], dtype=float), prepend=np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        return 0.25 * m * (hist @ per_bin) / (area * dt)


def energy_balance(run, start: int, viscosities: dict) -> dict:
    """The energy balance of a gravitating sheet over the window from row ``start``.

    The shear does work on every stress that carries angular momentum outward: per unit
    area (3/2 Omega) x (momentum flux Sigma nu (3/2) Omega) = (9/4) Omega^2 Sigma nu, with
    nu = nu_trans + nu_coll + nu_grav (the gravitational torque, Daisaka, Tanaka & Ida
    2001).  It goes into random motion and is dissipated by the collisions:

        heating = dissipation + d/dt (random kinetic energy) + d/dt (self-gravity energy)

    ``kinetic_energy_change`` is (3/2) Sigma d(c^2)/dt from a straight-line fit to the
    window (its standard error from the fit's residuals, which are correlated: a lower
    bound); the change of the self-gravity energy is not measured (zero in a steady
    state).  ``energy_closure`` = heating / (dissipation + kinetic change);
    ``energy_closure_without_gravity`` the same with nu_grav left out of the heating (what
    a balance that ignored the gravitational torque would give).

    Parameters
    ----------
    run : Run
    start : int
        First row of the window.
    viscosities : dict with ``translational_viscosity``, ``collisional_viscosity``,
        ``gravitational_viscosity``, each {"mean", "stderr"} [m^2/s]
    """
    ts = run.timeseries
    sc = run.scenario
    Omega = sc.orbital_frequency
    first = run.snapshot(0)
    area = float(run.attrs["Lx"]) * float(run.attrs["Ly"])
    Sigma = float(np.sum(first["mass"])) / area
    names = ("translational_viscosity", "collisional_viscosity", "gravitational_viscosity")
    nu = sum(viscosities[k]["mean"] for k in names)
    nu_err = math.sqrt(sum(viscosities[k]["stderr"] ** 2 for k in names))
    factor = 2.25 * Omega**2 * Sigma
    out = {"viscous_heating": _value(factor * nu, factor * nu_err, unit("viscous_heating"))}
    rates = dissipation_rates(ts, sc.restitution_dict(), first["radius"], first["mass"], area)
    rows = slice(max(start, 1), None)
    t = np.asarray(ts["t"], dtype=float)[rows]
    if rates is None or t.size < 3 or sc.friction is not None:
        out.update({key: _value(math.nan, math.nan, unit(key)) for key in ENERGY_KEYS[1:]})
        return out
    mean, stderr, _ = timeseries.autocorrelated_mean(rates[rows])
    out["collisional_dissipation"] = _value(mean, stderr, unit("collisional_dissipation"))
    energy = 1.5 * Sigma * np.asarray(ts["velocity_dispersion"], dtype=float)[rows] ** 2
    coef, cov = np.polyfit(t - t.mean(), energy, 1, cov=True)
    out["kinetic_energy_change"] = _value(coef[0], math.sqrt(cov[0, 0]),
                                          unit("kinetic_energy_change"))
    sink = mean + coef[0]
    ratio = factor * nu / sink
    ratio_err = abs(ratio) * math.hypot(nu_err / nu if nu else math.nan,
                                        math.hypot(stderr, math.sqrt(cov[0, 0])) / sink)
    out["energy_closure"] = _value(ratio, ratio_err, unit("energy_closure"))
    nu_local = nu - viscosities["gravitational_viscosity"]["mean"]
    out["energy_closure_without_gravity"] = _value(factor * nu_local / sink,
                                                   ratio_err * nu_local / nu,
                                                   unit("energy_closure_without_gravity"))
    return out


def gravity_equilibrium(run, start: int, viscosities: dict | None = None) -> dict:
    """The gravity entries of a run's equilibrium (module docstring), from row ``start``.

    ``viscosities``: the equilibrium's ``translational_viscosity`` and
    ``collisional_viscosity`` (window means {"mean", "stderr"} [m^2/s]) for the energy
    balance; without them its entries are NaN.

    Returns
    -------
    dict of the `GRAVITY_QUANTITIES` keys (each ``{"mean", "stderr", "units"}``) plus
    ``wake_snapshots`` (how many snapshots were analysed), ``wake_significant`` and
    ``wake_mode_n`` (`window_wake`), ``wake_significant_fraction``,
    ``wake_box_length_fraction`` and ``gravity_solver`` (the run's, "" for files that do not say).
    """
    ts = run.timeseries
    const = run_constants(run)
    Omega = run.scenario.orbital_frequency
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    indices, _ = window_snapshot_indices(run, start)
    snaps = [run.snapshot(i) for i in indices]
    per = [snapshot_wakes(snap, Lx, Ly, Omega) for snap in snaps]
    out: dict[str, object] = {"r_h": _value(const["r_h"], 0.0, unit("r_h")),
                              "lambda_cr": _value(const["lambda_cr"], 0.0, unit("lambda_cr"))}
    if "toomre_Q" in ts:
        mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(ts["toomre_Q"][start:]))
        out["toomre_Q"] = _value(mean, stderr, unit("toomre_Q"))
    else:
        out["toomre_Q"] = _value(math.nan, math.nan, unit("toomre_Q"))
    out["toomre_Q_mass"] = _over_snapshots(
        [mass_weighted_toomre_q(snap, const["Sigma"], Omega) for snap in snaps], math.nan,
        unit("toomre_Q_mass"))
    out.update(window_wake(per, Lx, Ly))
    out["gravitational_viscosity"] = _over_snapshots(
        [s["gravitational_viscosity"] for s in per], math.nan, unit("gravitational_viscosity"))
    if str(run.attrs.get("gravity_solver", "")) == "slab":
        # the slab solver has no horizontal force: no gravitational torque acted
        out["gravitational_viscosity"] = _value(0.0, 0.0, unit("gravitational_viscosity"))
    if viscosities is not None:
        out.update(energy_balance(run, start, {**viscosities, "gravitational_viscosity":
                                               out["gravitational_viscosity"]}))
    else:
        out.update({key: _value(math.nan, math.nan, unit(key)) for key in ENERGY_KEYS})
    out["wake_snapshots"] = len(per)
    out["gravity_solver"] = str(run.attrs.get("gravity_solver", ""))
    out["wake_significant_fraction"] = float(np.mean([s["significant"] for s in per]))
    waked = [s["azimuthal_mode"] == 1 for s in per if s["significant"]]
    out["wake_box_length_fraction"] = float(np.mean(waked)) if waked else 0.0
    return out


def window_wake(per: list[dict], Lx: float, Ly: float) -> dict:
    """The wake entries of an equilibrium from the window's `snapshot_wakes`
    (``wakes.mean_wake``): ``wake_wavelength`` [m], ``wake_pitch_angle`` [deg] and
    ``wake_amplitude``, each {"mean", "stderr", "units"} with null mean and stderr where
    the window holds no significant wake, ``wake_significant`` and ``wake_mode_n``."""
    wake = wakes.mean_wake(per, 2.0 * np.pi / max(Lx, Ly))
    out: dict[str, object] = {}
    for key, mean, err in (("wake_wavelength", "wavelength", "wavelength_err"),
                           ("wake_pitch_angle", "pitch_angle_deg", "pitch_angle_err_deg"),
                           ("wake_amplitude", "amplitude", "amplitude_err")):
        out[key] = {"mean": wake[mean], "stderr": wake[err], "units": unit(key)}
    out["wake_significant"] = wake["significant"]
    out["wake_mode_n"] = wake["mode_n"]
    return out


def gravity_table_lines(eq: dict) -> list[str]:
    """Rows of the plain-text equilibrium table for a gravitating run (empty otherwise)."""
    if "lambda_cr" not in eq:
        return []
    lines = []
    balance = math.isfinite(eq["energy_closure"]["mean"])
    for key in GRAVITY_QUANTITIES:
        if key in ENERGY_KEYS and not balance:
            continue  # no balance measured: the run's one balance is analysis.spins'
        q = QUANTITY[key]
        value = eq[key]
        if value["mean"] is None:  # a wake entry of a window without a significant wake
            lines.append(f"  {q.table_label:<42} none (no significant wake)")
            continue
        mean = value["mean"] * q.scale
        text = "n/a" if not math.isfinite(mean) else (
            f"{mean:.4g}" if not value["stderr"] else f"{mean:.4g} ± {value['stderr']:.2g}")
        if key == "r_h" and not math.isfinite(mean):
            text = "unknown (planet given by Omega only)"
        lines.append(f"  {q.table_label:<42} {text}")
    q_mass = eq["toomre_Q_mass"]["mean"]
    sizes = bool(eq.get("per_size_bin"))
    q_min = SLAB_MIN_Q_MASS_SIZES if sizes else SLAB_MIN_Q_MASS
    if eq.get("gravity_solver") == "slab" and q_mass < q_min:
        lines.append(f"  WARNING: slab solver at mass-weighted Q = {q_mass:.3g} < {q_min:g}"
                     f"{' (a size distribution)' if sizes else ''}: the modes it leaves out "
                     "(wakes, encounters) matter here (docs/gravity.md 4c); run with "
                     "gravity_solver p3m")
    seen = (f"{eq['wake_snapshots']} snapshots, significant wake in "
            f"{100 * eq['wake_significant_fraction']:.0f} %")
    if eq.get("wake_significant", True) and eq["wake_wavelength"]["mean"] is not None:
        ratio = eq["wake_wavelength"]["mean"] / eq["lambda_cr"]["mean"]
        mode = (f"; {eq['wake_mode_n']} wavelength(s) along y" if eq.get("wake_mode_n")
                else "")
        lines.append(f"  {'wake wavelength / lambda_cr':<42} {ratio:.3g} ({seen}{mode})")
    else:
        lines.append(f"  {'wake':<42} none significant against a random sheet ({seen}): "
                     "no wavelength or pitch")
    if eq["wake_significant_fraction"] > 0.0 and "wake_box_length_fraction" in eq:
        lines.append(f"  {'wakes one wavelength along y (box-long)':<42} "
                     f"{100 * eq['wake_box_length_fraction']:.0f} % of the snapshots with a "
                     "wake (then lambda = Ly sin(pitch): the box ties them)")
    return lines
