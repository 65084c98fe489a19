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
    ``collisional_spin_ratio`` (the closed form for identical spheres of constant beta,
    ``physics.spin_temperature.collisional_spin_ratio``; None for Coulomb),
    ``closed_form_applies`` (False for a size distribution, where no closed form exists:
    the table then does not show it), ``convention``, ``per_size_bin``
    (:func:`spin_size_bins`) and ``rotational_energy_fraction_random``: the spins about
    each bin's mean spin over E_tr, summed over the bins (from the window's snapshots;
    the closed form assumes no mean spin, so it is this number it compares with).
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
    radius = run.snapshot(0)["radius"]
    identical = bool(radius.min() == radius.max())
    out["collisional_spin_ratio"] = (collisional_spin_ratio(friction["beta"], k)
                                     if friction["model"] == "constant" else None)
    out["closed_form_applies"] = identical and out["collisional_spin_ratio"] is not None
    out["per_size_bin"] = spin_size_bins(run, float(ts["t"][min(start, ts["t"].size - 1)]),
                                         edges, k)
    bins = out["per_size_bin"]
    out["rotational_energy_fraction_random"] = _value(
        _ratio(sum(b["n"] * b["rotational_energy_random"] for b in bins),
               sum(b["n"] * b["translational_energy"] for b in bins)) if bins else math.nan,
        0.0, unit("spin.rotational_energy_fraction_random"))
    return out


def spin_energy_parts(m: np.ndarray, R: np.ndarray, w: np.ndarray, k: float, Omega: float,
                      index: np.ndarray, n_bins: int) -> dict[str, np.ndarray]:
    """Rotational energy of each bin [J], split into the spins about the bin's mean spin
    and the mean spin's part, in the rotating and the inertial frame.

    With I = k m R^2 and the bin's inertia-weighted mean spin <w>_I = sum I w / sum I,
    sum 1/2 I |w|^2 = sum 1/2 I |w - <w>_I|^2 + 1/2 (sum I) |<w>_I|^2 exactly.  The first
    term (``random``) is the same in both frames (the inertial spin is w + Omega z); the
    second is ``mean_rotating`` with w and ``mean_inertial`` with w + Omega z.

    Parameters
    ----------
    m : array (n,) [kg]
    R : array (n,) [m]
    w : array (n, 3) [rad/s]
        Spins relative to the rotating frame of the sheet.
    k : float [-]
        Moment-of-inertia factor.
    Omega : float [1/s]
    index : array (n,) of int
        Each particle's bin, 0 .. n_bins - 1.
    n_bins : int

    Returns
    -------
    dict of arrays (n_bins,) [J]: ``total`` (rotating frame), ``random``,
    ``mean_rotating``, ``mean_inertial``; ``inertia`` sum I [kg m^2].
    """
    inertia = fr.moment_of_inertia(m, R, k)

    def per_bin(values):
        return np.bincount(index, weights=values, minlength=n_bins)

    total_inertia = per_bin(inertia)
    moment = np.stack([per_bin(inertia * w[:, j]) for j in range(3)], axis=1)
    safe = np.where(total_inertia > 0, total_inertia, 1.0)
    mean = moment / safe[:, None]
    total = 0.5 * per_bin(inertia * np.sum(w * w, axis=1))
    mean_rotating = 0.5 * total_inertia * np.sum(mean * mean, axis=1)
    inertial = mean + np.array([0.0, 0.0, Omega])
    return {"total": total, "random": total - mean_rotating, "mean_rotating": mean_rotating,
            "mean_inertial": 0.5 * total_inertia * np.sum(inertial * inertial, axis=1),
            "inertia": total_inertia}


#: The columns `spin_size_bins` sums over a bin and its snapshots.
_COLUMNS = ("translational", "total", "random", "mean_rotating", "mean_inertial", "w2", "wz",
            "n")


def _snapshot_sums(s: dict, index: np.ndarray, n_bins: int, k: float, Omega: float
                   ) -> np.ndarray:
    """The `_COLUMNS` of one snapshot per bin, shape (n_bins, len(_COLUMNS))."""
    u2 = s["vx"] ** 2 + (s["vy"] + 1.5 * Omega * s["x"]) ** 2 + s["vz"] ** 2
    w = np.stack([s["wx"], s["wy"], s["wz"]], axis=1)
    parts = spin_energy_parts(s["mass"], s["radius"], w, k, Omega, index, n_bins)

    def per_bin(values):
        return np.bincount(index, weights=values, minlength=n_bins)

    return np.stack([per_bin(0.5 * s["mass"] * u2), parts["total"], parts["random"],
                     parts["mean_rotating"], parts["mean_inertial"],
                     per_bin(np.sum(w * w, axis=1)), per_bin(s["wz"]),
                     per_bin(np.ones_like(s["wz"]))], axis=1)


def spin_size_bins(run, t_start: float, edges: np.ndarray | None, k: float) -> list[dict]:
    """Translational and rotational energy per particle [J] and spins [Omega] per size
    bin, averaged over the snapshots at or after ``t_start`` [s] (one bin if ``edges`` is
    None).  E_tr per particle relative to the shear flow and the bin's mass-weighted mean
    velocity is not subtracted (the sheet's mean drift is zero).  E_rot is split into the
    spins about the bin's mean spin and the mean spin's part, rotating and inertial frame
    (:func:`spin_energy_parts`)."""
    Omega = run.scenario.orbital_frequency
    snaps = [run.snapshot(i) for i in range(run.n_snapshots)]
    snaps = [s for s in snaps if s["t"] >= t_start and "wx" in s] or \
        [s for s in snaps[-1:] if "wx" in s]
    if not snaps:
        return []
    radius = snaps[0]["radius"]
    edges = np.array([radius.min(), radius.max()]) if edges is None else np.asarray(edges)
    index = np.clip(np.searchsorted(edges, radius, side="right") - 1, 0, edges.size - 2)
    sums = np.sum([_snapshot_sums(s, index, edges.size - 1, k, Omega) for s in snaps], axis=0)
    col = {name: j for j, name in enumerate(_COLUMNS)}
    bins = []
    for b in range(edges.size - 1):
        n = sums[b, col["n"]]
        if n == 0:
            continue
        e = {name: sums[b, col[name]] / n for name in _COLUMNS}
        bins.append({"r_low": float(edges[b]), "r_high": float(edges[b + 1]),
                     "n": int(round(n / len(snaps))), "translational_energy": e["translational"],
                     "rotational_energy": e["total"],
                     "rotational_energy_fraction": _ratio(e["total"], e["translational"]),
                     "rotational_energy_random": e["random"],
                     "rotational_energy_mean_rotating": e["mean_rotating"],
                     "rotational_energy_mean_inertial": e["mean_inertial"],
                     "rotational_energy_fraction_random": _ratio(e["random"],
                                                                 e["translational"]),
                     "rms_spin": math.sqrt(e["w2"]) / Omega, "mean_spin_z": e["wz"] / Omega})
    return bins


def _ratio(a: float, b: float) -> float:
    return float(a / b) if b > 0 else math.nan


def _fmt(value: dict) -> str:
    return f"{value['mean']:.4g} ± {value['stderr']:.2g}"


def spin_table_lines(eq: dict, budget: bool = True) -> list[str]:
    """The lines ``analyze`` prints for the spins and (``budget``) the energy budget."""
    lines = []
    b = eq.get("energy_budget") if budget else None
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
    reference = s["collisional_spin_ratio"] if s.get("closed_form_applies") else None
    lines.append(f"  {QUANTITY['rotational_energy_fraction'].table_label:<42} "
                 f"{_fmt(s['rotational_energy_fraction'])} (mean spin included)")
    random = s.get("rotational_energy_fraction_random")
    if random:
        lines.append(f"  {'E_rot about the mean spin / E_tr':<42} {random['mean']:.4g} "
                     "(window snapshots, each size bin's mean spin removed"
                     + (f"; closed form of the collisional balance for identical spheres "
                        f"without mean spin: {reference:.4g})" if reference is not None
                        else ")"))
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
        lines += _spin_part_lines(s["per_size_bin"])
    return lines


def _spin_part_lines(bins: list[dict]) -> list[str]:
    """Per size bin, E_rot per particle about the bin's mean spin and the mean spin's part
    in the rotating and the inertial frame."""
    if "rotational_energy_random" not in bins[0]:
        return []
    lines = ["  E_rot per particle [J] about the bin's mean spin <w>_I (inertia-weighted; the "
             "same in both frames) and of <w>_I:",
             "    r [m]              about <w>_I  <w>_I rotating  <w>_I inertial  "
             "about <w>_I / E_tr"]
    for r in bins:
        lines.append(f"    {r['r_low']:7.3g} - {r['r_high']:<7.3g} "
                     f"{r['rotational_energy_random']:<12.4g} "
                     f"{r['rotational_energy_mean_rotating']:<15.4g} "
                     f"{r['rotational_energy_mean_inertial']:<15.4g} "
                     f"{r['rotational_energy_fraction_random']:.4g}")
    return lines
