"""Synthetic occultations of a run (``ringsim observe``): the numbers an observer measures.

For every line of sight (B, phi) and every chosen snapshot, rays are traced through the
shear-periodic sheet (``analysis.occultation``).  Over several snapshots the transmission of a
view is the mean of the snapshots' T; its standard error is the larger of the propagated ray
noise and the snapshot-to-snapshot scatter over sqrt(n); tau_n = -sin B ln <T> (an observer
too averages the light, not the optical depth).  The default snapshots are those of the
equilibrium window as ``analyze`` finds it (``analysis.equilibrium.stationary_window``).

From the views follow the azimuthal asymmetry at each B (the spread of tau_n over phi relative
to its mean, and the azimuth of peak transmission) and the fit of the bar model of Colwell et
al. 2006 (``analysis.wake_model``).  For a self-gravitating run the wake pitch that
``analyze`` reports (``analysis.wakes.wake_statistics``) is given beside them, with the
azimuth 90 deg + pitch along which a line of sight runs parallel to the wakes.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ringsim.analysis import occultation, tiling, wake_model, wakes, window
from ringsim.analysis.asymmetry_reference import MOST_COPIES, p_value, reference_amplitudes
from ringsim.analysis.equilibrium import stationary_window
from ringsim.errors import InputError
from ringsim.physics.selfgravity import shear_offset

#: Default opening angles [deg]: 3.45 is the VIMS Mira occultations' (Hedman et al. 2007).
DEFAULT_ELEVATIONS = (3.45, 10.0, 20.0, 45.0, 90.0)
#: Default azimuths [deg]: every 15 deg around the circle.
DEFAULT_AZIMUTHS = tuple(float(a) for a in range(0, 360, 15))
#: Default relative standard error of tau_n per view and snapshot [dimensionless].
DEFAULT_PRECISION = 0.01
#: Seed of the rays' random generator (recorded in the JSON).
RAY_SEED = 0


def window_snapshots(run) -> tuple[list[int], bool]:
    """Indices of the snapshots inside the equilibrium window ``analyze`` finds, and whether
    any is (``window.window_snapshot_indices``: the last snapshot when none is)."""
    ts = run.timeseries
    start = stationary_window(ts["orbits"], ts["velocity_dispersion"], ts["thickness"],
                              tiling.independent_from_orbit(run) or 0.0)["start"]
    return window.window_snapshot_indices(run, start)


#: The lowest opening angle [deg] a view takes.  A ray's path through the layer, and with it
#: a view's time and memory, grow as 1 / tan B (a 2 500-particle wake sheet: 5 s and 0.26 GB
#: for two views at 2 deg, 15 s and 0.44 GB at 0.5 deg, 29 s and 0.75 GB at 0.2 deg); at
#: 1e-6 deg one view ran out of memory.  Cassini's stellar occultations reach down to a few
#: degrees (B = 3.45 deg: Hedman et al. 2007, AJ 133, 2624).
LOWEST_ELEVATION_DEG = 0.5


def check_arguments(path: str, elevations, azimuths, snapshot, rays, precision,
                    n_snapshots: int, reference: int = 0) -> None:
    """InputError (exit status 2) for an argument ``observe`` cannot use."""
    for b in elevations:
        if not (math.isfinite(b) and LOWEST_ELEVATION_DEG <= b <= 90.0):
            raise InputError(path, "--elevation", f"{b:g} deg: the opening angle must lie in "
                             f"[{LOWEST_ELEVATION_DEG:g}, 90] deg")
    for a in azimuths:
        if not math.isfinite(a):
            raise InputError(path, "--azimuth", f"{a}: not a finite angle in deg")
    if snapshot is not None and not -n_snapshots <= snapshot < n_snapshots:
        raise InputError(path, "--snapshot", f"{snapshot}: the run has {n_snapshots} "
                         f"snapshots (0 to {n_snapshots - 1}, or negative from the end)")
    if rays is not None and rays < 100:
        raise InputError(path, "--rays", f"{rays}: at least 100 rays per view")
    if precision is not None and not 0.0 < precision < 1.0:
        raise InputError(path, "--precision", f"{precision:g}: a relative error in (0, 1)")
    if not 0 <= reference <= MOST_COPIES:
        raise InputError(path, "--reference", f"{reference}: 0 to {MOST_COPIES} copies")


def _combine(per_snapshot: list[dict], elevation: float) -> dict:
    """One view over several snapshots (module docstring)."""
    T = np.array([v["transmission"] for v in per_snapshot])
    err = np.array([v["transmission_stderr"] for v in per_snapshot])
    n = T.size
    stderr = math.sqrt(float(np.sum(err**2))) / n
    if n > 1:
        stderr = max(stderr, float(np.std(T, ddof=1)) / math.sqrt(n))
    rays = sum(v["rays"] for v in per_snapshot)
    return occultation.transmission_summary(float(np.mean(T)), stderr, elevation, rays)


def asymmetry(views: list[dict]) -> list[dict]:
    """Per opening angle: the smallest, largest and mean tau_n over azimuth, the relative
    amplitude (max - min) / mean [dimensionless] and the azimuth of peak transmission [deg,
    folded into [0, 180)]; NaN at B = 90 deg, where a vertical ray has no azimuth and the
    views differ only by their rays' draws."""
    out = []
    for b in sorted({v["elevation_deg"] for v in views}):
        row = [v for v in views if v["elevation_deg"] == b]
        tau = np.array([v["normal_optical_depth"] for v in row])
        finite = np.isfinite(tau)
        if not finite.any():
            continue
        peak = row[int(np.argmax([v["transmission"] for v in row]))]["azimuth_deg"]
        mean = float(np.mean(tau[finite]))
        out.append({"elevation_deg": b, "normal_optical_depth_min": float(np.min(tau)),
                    "normal_optical_depth_max": float(np.max(tau)),
                    "normal_optical_depth_mean": mean,
                    "relative_amplitude": float((np.max(tau) - np.min(tau)) / mean),
                    "peak_transmission_azimuth_deg": float(peak % 180.0) if b < 90.0
                    else math.nan,
                    "azimuths": len(row)})
    return out


def _analyze_pitch(snaps: list[dict], Lx: float, Ly: float, Omega: float) -> dict | None:
    """Mean and standard error of the wake pitch analyze reports [deg], over the snapshots
    whose wake is significant (None when none is)."""
    pitches = []
    for snap in snaps:
        stats = wakes.wake_statistics(snap["x"], snap["y"], snap["mass"], Lx, Ly,
                                      shear_offset(Omega, Lx, Ly, float(snap["t"])))
        if stats["significant"]:
            pitches.append(stats["pitch_angle_deg"])
    if not pitches:
        return None
    p = np.asarray(pitches)
    err = float(np.std(p, ddof=1) / math.sqrt(p.size)) if p.size > 1 else math.nan
    return {"mean": float(np.mean(p)), "stderr": err, "units": "deg",
            "snapshots": int(p.size),
            "parallel_azimuth_deg": float((90.0 + np.mean(p)) % 180.0)}


def _trace_views(snaps: list[dict], Lx: float, Ly: float, Omega: float, elevations,
                 azimuths, rng: np.random.Generator, rays: int | None,
                 precision: float) -> list[dict]:
    """Every view (B, phi) [deg] through the snapshots, combined over them (`_combine`);
    Lx, Ly [m], Omega [1/s]."""
    per_view: dict[tuple[float, float], list[dict]] = {}
    for snap in snaps:
        shift = shear_offset(Omega, Lx, Ly, float(snap["t"]))
        for b in elevations:
            for a in azimuths:
                per_view.setdefault((b, a), []).append(occultation.trace_view(
                    snap, Lx, Ly, shift, b, a, rng, rays=rays, precision=precision))
    return [{"elevation_deg": float(b), "azimuth_deg": float(a), **_combine(v, b)}
            for (b, a), v in per_view.items()]


def _with_reference(rows: list[dict], copies: int,
                    amplitudes: Callable[[float], list[float]]) -> list[dict]:
    """The asymmetry rows with, for ``copies`` > 0, each B's structure-free reference
    (``reference_amplitudes``, ``reference_p_value``)."""
    for row in rows if copies else []:
        ref = amplitudes(row["elevation_deg"])
        row["reference_amplitudes"] = ref
        row["reference_p_value"] = p_value(row["relative_amplitude"], ref)
    return rows


def observe(run, elevations=DEFAULT_ELEVATIONS, azimuths=DEFAULT_AZIMUTHS,
            snapshot: int | None = None, rays: int | None = None,
            precision: float | None = None, reference: int = 0) -> dict:
    """The synthetic occultations of a run (the JSON of ``ringsim observe``; docs/interface.md).

    Parameters
    ----------
    run : ringsim Run
    elevations, azimuths : sequences [deg], or None for the defaults
    snapshot : int or None
        One snapshot; None: the equilibrium window's.
    rays : int or None
        Rays per view and snapshot; None: as many as ``precision`` needs.
    precision : float or None [dimensionless]
        Relative standard error of tau_n per view and snapshot (default 0.01).
    reference : int
        Structure-free copies per opening angle for the asymmetry's p-value
        (``analysis.asymmetry_reference``; 0: none).
    """
    path = str(run.path)
    elevations = DEFAULT_ELEVATIONS if elevations is None else elevations
    azimuths = DEFAULT_AZIMUTHS if azimuths is None else azimuths
    check_arguments(path, elevations, azimuths, snapshot, rays, precision, run.n_snapshots,
                    reference)
    precision = DEFAULT_PRECISION if precision is None else precision
    indices, in_window = (window_snapshots(run) if snapshot is None
                          else ([snapshot % run.n_snapshots], None))
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    Omega = run.scenario.orbital_frequency
    rng = np.random.default_rng(RAY_SEED)
    snaps = [run.snapshot(i) for i in indices]

    def trace(some: list[dict], bs, azs) -> list[dict]:
        return _trace_views(some, Lx, Ly, Omega, bs, azs, rng, rays, precision)

    views = trace(snaps, elevations, azimuths)

    def tau_of_view(twins: list[dict], b: float, a: float) -> float:
        return trace(twins, [b], [a])[0]["normal_optical_depth"]
    period = run.scenario.orbital_period
    out: dict[str, object] = {"run": path, "snapshots": indices,
           "snapshots_in_window": in_window,
           "snapshot_orbits": [float(s["t"]) / period for s in snaps],
           "geometric_optical_depth": float(np.mean([occultation.geometric_optical_depth(
               s["radius"], Lx, Ly) for s in snaps])),
           "views": views, "azimuthal_asymmetry": _with_reference(
               asymmetry(views), reference, lambda b: reference_amplitudes(
                   snaps, Lx, Ly, b, azimuths, reference, rng, tau_of_view)),
           "ray_seed": RAY_SEED, "precision": None if rays is not None else precision,
           "rays_per_view": rays}
    columns = [np.array([v[k] for v in views]) for k in (
        "elevation_deg", "azimuth_deg", "normal_optical_depth", "normal_optical_depth_stderr")]
    out["bar_model"] = wake_model.fit_bar_model(*columns)
    out["bar_model_view_dependence"] = wake_model.view_dependence(*columns)
    out["wake_pitch_angle_deg"] = (_analyze_pitch(snaps, Lx, Ly, Omega)
                                   if run.scenario.sheet.gravity else None)
    out["units"] = UNITS
    return out


#: Units of the JSON's numbers (angles are also named ``*_deg``).
UNITS = {"geometric_optical_depth": "dimensionless", "transmission": "dimensionless",
         "normal_optical_depth": "dimensionless", "elevation_deg": "deg",
         "azimuth_deg": "deg", "snapshot_orbits": "orbits", "rays": "count",
         "precision": "relative standard error of normal_optical_depth per view and snapshot"}


def observation_table(obs: dict) -> str:
    """What ``ringsim observe`` prints: the geometric optical depth, the asymmetry per B and
    the bar model's fit."""
    lines = [f"snapshots {obs['snapshots']} (orbits "
             + ", ".join(f"{o:.3g}" for o in obs["snapshot_orbits"]) + ")",
             f"geometric optical depth sum(pi r^2)/A = {obs['geometric_optical_depth']:.4g}",
             f"{len(obs['views'])} views (B, phi); azimuthal asymmetry of tau_n:",
             "  B [deg]  tau_n min   tau_n max   mean      (max-min)/mean  peak-T phi [deg]"]
    for row in obs["azimuthal_asymmetry"]:
        lines.append(f"  {row['elevation_deg']:7.3g}  {row['normal_optical_depth_min']:9.4g}"
                     f"   {row['normal_optical_depth_max']:9.4g}"
                     f"   {row['normal_optical_depth_mean']:7.4g}"
                     f"   {row['relative_amplitude']:12.3g}"
                     + (f"    {row['peak_transmission_azimuth_deg']:6.1f}"
                        if math.isfinite(row["peak_transmission_azimuth_deg"])
                        else "    none (a vertical ray has no azimuth)"))
    for row in obs["azimuthal_asymmetry"]:
        if "reference_amplitudes" in row:
            ref = [r for r in row["reference_amplitudes"] if math.isfinite(r)]
            p = row["reference_p_value"]
            lines.append(f"  B = {row['elevation_deg']:g} deg: structure-free reference, "
                         f"{len(row['reference_amplitudes'])} copies, median amplitude "
                         + (f"{float(np.median(ref)):.3g}" if ref else "n/a")
                         + ("; p-value n/a" if p is None else f"; p-value {p:.3g}"))
    fit = obs["bar_model"]
    if fit.get("success") is not None and "height_over_width" in fit:
        def pm(key):
            return f"{fit[key]['value']:.3g} +- {fit[key]['stderr']:.2g}"
        lines.append(f"bar model (Colwell et al. 2006): H/W = {pm('height_over_width')}, "
                     f"gap tau = {pm('gap_optical_depth')}, S/lambda = {pm('gap_fraction')}, "
                     f"wake axis phi_W = {pm('wake_orientation_deg')} deg "
                     f"({pm('wake_angle_from_radial_deg')} deg from radial), "
                     f"reduced chi2 {fit['reduced_chi2']:.3g}")
        lines += _view_dependence_lines(obs.get("bar_model_view_dependence"))
    else:
        lines.append(f"bar model: no fit ({fit.get('message', 'failed')})")
    pitch = obs.get("wake_pitch_angle_deg")
    if pitch:
        lines.append(f"analyze's wake pitch {pitch['mean']:.3g} +- {pitch['stderr']:.2g} deg "
                     f"({pitch['snapshots']} snapshots): lines of sight along the wakes at "
                     f"phi = {pitch['parallel_azimuth_deg']:.1f} deg")
    elif "height_over_width" in fit:
        lines.append("analyze finds no significant wake in these snapshots: the bar model "
                     "then describes no wakes, and its parameters are not wake parameters "
                     "(a layer without wakes fits a range of H/W)")
    return "\n".join(lines)


#: Radial resolution [m] of the synthetic scan: Cassini UVIS's high-speed photometer samples
#: 5-8 m in radius (Colwell & Esposito 2004, DPS 36, 7.09) and resolves better than 20 m at
#: its 2 ms integration (Esposito, Colwell & McClintock 1998, Planet. Space Sci. 46, 1221).
UVIS_RESOLUTION = 10.0


def observation_pictures(run, obs: dict, resolution: float = UVIS_RESOLUTION) -> dict:
    """The arrays of ``observe``'s figures, from the last snapshot it used, at its lowest
    opening angle B: a radial scan across three box widths at the azimuth of peak
    transmission (``occultation.radial_scan``, bins of ``resolution`` [m]), and the sheet seen
    along the line of sight at that azimuth and 90 deg from it
    (``occultation.line_of_sight_image``).

    Returns
    -------
    dict: ``elevation_deg``, ``azimuth_deg`` (peak transmission), ``snapshot``,
    ``resolution`` [m], ``scan`` (``radial_scan``'s dict), ``images`` (list of (azimuth_deg,
    image)), ``Lx``, ``Ly`` [m].
    """
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    index = obs["snapshots"][-1]
    snap = run.snapshot(index)
    shift = shear_offset(run.scenario.orbital_frequency, Lx, Ly, float(snap["t"]))
    low = obs["azimuthal_asymmetry"][0]
    b, a = low["elevation_deg"], low["peak_transmission_azimuth_deg"]
    a = a if math.isfinite(a) else 0.0     # B = 90 deg only: every azimuth is the same
    scan = occultation.radial_scan(snap, Lx, Ly, shift, b, a, resolution, boxes=3)
    images = [(phi, occultation.line_of_sight_image(snap, Lx, Ly, shift, b, phi))
              for phi in (a, (a + 90.0) % 180.0)]
    return {"elevation_deg": b, "azimuth_deg": a, "snapshot": index, "resolution": resolution,
            "scan": scan, "images": images, "Lx": Lx, "Ly": Ly}


def _view_dependence_lines(dep: dict | None) -> list[str]:
    """The bar model's refits with each B left out, as ``observe`` prints them."""
    if not dep:
        return []
    hw = dep["height_over_width"]
    angle = dep["wake_angle_from_radial_deg"]
    return [f"  with each B left out in turn ({', '.join(f'{b:g}' for b in dep['left_out_deg'])}"
            f" deg): H/W {hw['min']:.3g}-{hw['max']:.3g} (jackknife +- "
            f"{hw['jackknife_stderr']:.2g}), angle from radial {angle['min']:.3g}-"
            f"{angle['max']:.3g} deg; the fit's errors above do not hold this"]
