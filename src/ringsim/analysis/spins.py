"""Spins and the energy budget of a sheet with rough particles (``ringsim analyze``).

Conventions (``physics.friction``): spins w [rad/s] relative to the rotating frame of the
sheet, in its axes (x radially outward, y along the orbit, z along the orbital angular
momentum); w_z > 0 turns in the sense of the orbital motion as seen in the rotating frame;
w = 0 is synchronous rotation (one face to the planet); a particle that does not rotate in
inertial space shows w_z = -Omega; one turning with the mean shear flow -(3/4) Omega.
Spin numbers are in units of Omega, number-weighted.

The energy budget of the sheet (every run with the ``normal_dissipation`` row): per output
interval and unit area, shear heating (9/4) Omega^2 Sigma nu_trans + (3/2) Omega
d(collisions_plog)/dt / A (Wisdom & Tremaine 1988; the collisional flux from REBOUND's
y-momentum bookkeeping, which includes the tangential impulses), against the dissipation
the resolver counts: normal (1/2 M_bar J (2 v_n - J) per collision) plus tangential
(translation and rotation, 1/2 M_bar f_t (1 - beta^2) |g_t|^2).  In a steady state they
are equal.
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.analysis import timeseries
from ringsim.physics import friction as fr
from ringsim.physics.spin_temperature import collisional_spin_ratio
from ringsim.quantities import QUANTITY, unit

#: The frame and sign convention, written with the numbers.
SPIN_CONVENTION = ("w relative to the rotating frame of the sheet, in its axes (z along the "
                   "orbital angular momentum); w_z > 0 prograde; synchronous rotation 0; "
                   "an inertially non-rotating particle -1 Omega; turning with the mean "
                   "shear flow -0.75 Omega; number-weighted")


def _value(mean: float, stderr: float, units: str) -> dict:
    return {"mean": float(mean), "stderr": float(stderr), "units": units}


def _window(values: np.ndarray, start: int, units: str) -> dict:
    mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(values[start:], float))
    return _value(mean, stderr, units)


def energy_budget(run, start: int) -> dict | None:
    """Shear heating against normal + tangential dissipation [W/m^2] over rows start:.

    None for run files without the ``normal_dissipation`` row.  Returns ``heating``,
    ``normal_dissipation``, ``tangential_dissipation`` (each {mean, stderr, units}),
    ``ratio`` heating / (normal + tangential) with its stderr, and ``tangential_share``
    of the dissipation.
    """
    ts = run.timeseries
    if "normal_dissipation" not in ts or ts["t"].size <= start + 1:
        return None
    Omega = run.scenario.orbital_frequency
    area = float(run.attrs["Lx"]) * float(run.attrs["Ly"])
    sigma = float(np.sum(run.snapshot(0)["mass"])) / area
    dt = np.diff(ts["t"], prepend=np.nan)
    dplog = np.diff(ts["collisions_plog"], prepend=np.nan)
    heating = (2.25 * Omega**2 * sigma * ts["translational_viscosity"]
               + 1.5 * Omega * dplog / (area * dt))
    normal = ts["normal_dissipation"] / (area * dt)
    tangential = ts.get("tangential_dissipation", np.zeros_like(normal)) / (area * dt)
    start = max(start, 1)
    out = {key: _window(values, start, unit(f"energy_budget.{key}")) for key, values in
           (("heating", heating), ("normal_dissipation", normal),
            ("tangential_dissipation", tangential))}
    h, d = out["heating"], _window(normal + tangential, start,
                                   unit("energy_budget.normal_dissipation"))
    ratio = h["mean"] / d["mean"] if d["mean"] > 0 else math.nan
    out["ratio"] = _value(ratio, abs(ratio) * math.hypot(h["stderr"] / h["mean"],
                                                          d["stderr"] / d["mean"])
                          if d["mean"] > 0 and h["mean"] != 0 else math.nan,
                          unit("energy_budget.ratio"))
    share = out["tangential_dissipation"]["mean"] / d["mean"] if d["mean"] > 0 else math.nan
    out["tangential_share"] = _value(share, 0.0, unit("energy_budget.tangential_share"))
    return out


def spin_equilibrium(run, start: int, edges: np.ndarray | None) -> dict | None:
    """The spin numbers of a run with friction over rows start: (None without friction).

    ``rotational_energy_fraction`` E_rot/E_tr (E_tr relative to the shear flow, from the
    mass-weighted dispersion), ``mean_spin_z`` and ``rms_spin`` [Omega] (time series
    averages with autocorrelation-corrected errors), ``sliding_fraction`` (Coulomb),
    ``collisional_spin_ratio`` (the closed form for constant beta,
    ``physics.spin_temperature.collisional_spin_ratio``; None for Coulomb), ``convention`` and
    ``per_size_bin`` (:func:`spin_size_bins`).
    """
    ts = run.timeseries
    if "rotational_energy_ratio" not in ts:
        return None
    sc = run.scenario
    friction = sc.friction_dict()
    k = float(sc.particles.inertia_factor)
    out = {"rotational_energy_fraction": _window(ts["rotational_energy_ratio"], start,
                                                 unit("rotational_energy_fraction")),
           **{key: _window(ts[key], start, unit(key)) for key in
              ("mean_spin_z", "rms_spin", "rotational_energy")},
           "friction": friction, "inertia_factor": k, "convention": SPIN_CONVENTION}
    collisions = float(np.sum(ts["collisions"][start:]))
    out["sliding_fraction"] = _value(float(np.sum(ts["sliding_collisions"][start:]))
                                     / collisions if collisions else math.nan, 0.0,
                                     unit("sliding_fraction"))
    out["collisional_spin_ratio"] = (collisional_spin_ratio(friction["beta"], k)
                                     if friction["model"] == "constant" else None)
    out["per_size_bin"] = spin_size_bins(run, float(ts["t"][min(start, ts["t"].size - 1)]),
                                         edges, k)
    return out


def spin_size_bins(run, t_start: float, edges: np.ndarray | None, k: float) -> list[dict]:
    """Translational and rotational energy per particle [J] and spins [Omega] per size
    bin, averaged over the snapshots at or after ``t_start`` [s] (one bin if ``edges`` is
    None).  E_tr per particle relative to the shear flow and the bin's mass-weighted mean
    velocity is not subtracted (the sheet's mean drift is zero)."""
    Omega = run.scenario.orbital_frequency
    snaps = [run.snapshot(i) for i in range(run.n_snapshots)]
    snaps = [s for s in snaps if s["t"] >= t_start and "wx" in s] or \
        [s for s in snaps[-1:] if "wx" in s]
    if not snaps:
        return []
    radius = snaps[0]["radius"]
    edges = np.array([radius.min(), radius.max()]) if edges is None else np.asarray(edges)
    index = np.clip(np.searchsorted(edges, radius, side="right") - 1, 0, edges.size - 2)
    sums = np.zeros((edges.size - 1, 5))
    for s in snaps:
        u2 = s["vx"] ** 2 + (s["vy"] + 1.5 * Omega * s["x"]) ** 2 + s["vz"] ** 2
        w = np.stack([s["wx"], s["wy"], s["wz"]], axis=1)
        columns = np.stack([0.5 * s["mass"] * u2, fr.rotational_energy(s["mass"], radius, w, k),
                            np.sum(w * w, axis=1), s["wz"], np.ones_like(radius)], axis=1)
        for j in range(5):
            sums[:, j] += np.bincount(index, weights=columns[:, j], minlength=edges.size - 1)
    bins = []
    for b in range(edges.size - 1):
        n = sums[b, 4]
        if n == 0:
            continue
        e_tr, e_rot = sums[b, 0] / n, sums[b, 1] / n
        bins.append({"r_low": float(edges[b]), "r_high": float(edges[b + 1]),
                     "n": int(round(n / len(snaps))), "translational_energy": e_tr,
                     "rotational_energy": e_rot,
                     "rotational_energy_fraction": e_rot / e_tr if e_tr > 0 else math.nan,
                     "rms_spin": math.sqrt(sums[b, 2] / n) / Omega,
                     "mean_spin_z": sums[b, 3] / n / Omega})
    return bins


def _fmt(value: dict) -> str:
    return f"{value['mean']:.4g} ± {value['stderr']:.2g}"


def spin_table_lines(eq: dict) -> list[str]:
    """The lines ``analyze`` prints for the spins and the energy budget."""
    lines = []
    b = eq.get("energy_budget")
    if b:
        heating, ratio = QUANTITY["energy_budget.heating"], QUANTITY["energy_budget.ratio"]
        shown = QUANTITY["energy_budget.normal_dissipation"].shown
        lines.append(f"  {heating.table_label:<42} {_fmt(b['heating'])}")
        lines.append(f"  {f'dissipation normal + tangential [{shown}]':<42} "
                     f"{_fmt(b['normal_dissipation'])} + {_fmt(b['tangential_dissipation'])}")
        lines.append(f"  {ratio.table_label:<42} {_fmt(b['ratio'])}")
    s = eq.get("spin")
    if not s:
        return lines
    reference = s["collisional_spin_ratio"]
    lines.append(f"  {QUANTITY['rotational_energy_fraction'].table_label:<42} "
                 f"{_fmt(s['rotational_energy_fraction'])}"
                 + (f" (collisional balance, closed form: {reference:.4g})"
                    if reference is not None else ""))
    for key in ("mean_spin_z", "rms_spin"):
        lines.append(f"  {QUANTITY[key].table_label:<42} {_fmt(s[key])}")
    if s["friction"]["model"] == "coulomb":
        lines.append(f"  {QUANTITY['sliding_fraction'].table_label:<42} "
                     f"{s['sliding_fraction']['mean']:.3g}")
    lines.append(f"  spins: {s['convention']}")
    if s["per_size_bin"]:
        lines.append("  per size bin:   r [m]            n     E_tr [J]    E_rot [J]   "
                     "E_rot/E_tr  rms w/Omega  <w_z>/Omega")
        for r in s["per_size_bin"]:
            lines.append(f"    {r['r_low']:7.3g} - {r['r_high']:<7.3g} {r['n']:8d}   "
                         f"{r['translational_energy']:<11.4g} {r['rotational_energy']:<11.4g} "
                         f"{r['rotational_energy_fraction']:<11.4g} {r['rms_spin']:<12.4g} "
                         f"{r['mean_spin_z']:.4g}")
    return lines
