"""The rings against Cassini: what a study keeps of a gravitating run's synthetic occultations
and the table that holds them against the published wake parameters (docs/studies.md,
"Against Cassini").

The summary of every self-gravitating run keeps ``occultation`` (`occultation_summary`):
``ringsim observe``'s default views (``analysis.observe``: B = 3.45, 10, 20, 45, 90 deg, phi
every 15 deg, 1 % in tau_n) through every snapshot of the run's equilibrium window, condensed
to the bar model's fit (Colwell et al. 2006), the azimuthal asymmetry of tau_n and the peak
transmission at each B, the geometric optical depth, and ``analyze``'s wake verdict.

The report's ``against_cassini`` (`against_cassini`) averages them over each case's seeds
(``analysis.budget.replica_mean``, as the equilibria) and applies `RULE`: a case is
consistent with a ring when the 2-sigma interval of each quantity the rule names for it
overlaps the published range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ringsim.analysis import budget

#: Opening angle [deg] of the asymmetry the table shows: the VIMS occultations of Mira that
#: Hedman et al. (2007, AJ 133, 2624) analyse were at B = 3.45 deg.
ASYMMETRY_ELEVATION = 3.45

#: The published ranges, each with its ring, bounds (None: open) and source.  Checked against
#: the papers' abstracts (the search tool returned no more of them).
PUBLISHED: dict[str, dict[str, Any]] = {
    "A_height_over_width": {
        "ring": "A", "quantity": "height_over_width", "low": 0.15, "high": 0.37,
        "units": "dimensionless", "text": "0.15-0.37, rising outward",
        "source": "Colwell et al. 2006, GRL 33, L07201 (abstract; UVIS stellar occultations)"},
    "A_wake_angle": {
        "ring": "A", "quantity": "wake_angle_from_radial_deg", "low": 64.0, "high": 72.0,
        "units": "deg", "text": "trailing 64-72 deg from radial",
        "source": "Hedman et al. 2007, AJ 133, 2624 (abstract; VIMS occultations of Mira)"},
    "A_peak_transmission": {
        "ring": "A", "quantity": "peak_transmission", "low": None, "high": None,
        "units": "dimensionless", "text": "about 0.08 at B = 3.45 deg near 129 000 km",
        "source": "Hedman et al. 2007, AJ 133, 2624 (abstract); shown, not in the rule: "
                  "it depends on the ring's optical depth and radius"},
    "B_height_over_width": {
        "ring": "B", "quantity": "height_over_width", "low": None, "high": 0.1,
        "units": "dimensionless", "text": "< 0.1 for most of the ring",
        "source": "Colwell et al. 2007, Icarus 190, 127 (abstract; UVIS stellar occultations)"},
    "B_gap_optical_depth": {
        "ring": "B", "quantity": "gap_optical_depth", "low": None, "high": 0.5,
        "units": "dimensionless", "text": "typically < 0.5",
        "source": "Colwell et al. 2007, Icarus 190, 127 (abstract)"},
}
#: The published ranges the verdict uses, per ring.
RULE_RANGES = {"A ring": ("A_height_over_width", "A_wake_angle"),
               "B ring": ("B_height_over_width", "B_gap_optical_depth")}
#: The rule, in words (report.json and report.md say it).
RULE = ("a case is consistent with a ring when analyze finds a significant wake in the "
        "equilibrium window of every seed measured, the bar model was fitted, and the "
        "interval mean +- 2 stderr (over the seeds; each seed's bar-model errors are the "
        "fit's, scaled by the square root of its reduced chi^2 where that is above 1, so "
        "that they hold the model's misfit to the views) of each quantity the ring's published "
        "values constrain overlaps the published range: for the A ring H/W and the wake "
        "angle from radial, for the B ring H/W and the gap optical depth; excluded when it "
        "is consistent with neither; the azimuthal asymmetry and the peak transmission are "
        "shown beside them (no published amplitude of tau_n over azimuth was found: the "
        "occultation papers publish the bar model's parameters and the peak transmission)")
#: The viewing geometry, in words.
GEOMETRY = ("ringsim observe's defaults through every snapshot of each run's equilibrium "
            "window: opening angles B = 3.45, 10, 20, 45, 90 deg, azimuths every 15 deg from "
            "radial toward orbital motion, 1 % relative error of tau_n per view and "
            "snapshot; the bar model of Colwell et al. 2006 fitted to all 120 views; the "
            "asymmetry (max - min) / mean of tau_n over azimuth and the peak transmission "
            "at B = 3.45 deg (the VIMS geometry of Hedman et al. 2007)")

#: The table's quantities, from the fit or the asymmetry, each {"mean", "stderr", "units"}.
QUANTITIES = ("height_over_width", "gap_optical_depth", "wake_angle_from_radial_deg",
              "asymmetry_amplitude", "peak_transmission", "geometric_optical_depth")
#: The bar model's parameters among `QUANTITIES`: they describe wakes, so a case's mean
#: holds only the seeds with a significant wake and a fit (a fit to views of a ring
#: without wakes is unconstrained: its H/W can be anything).
BAR_MODEL = ("height_over_width", "gap_optical_depth", "wake_angle_from_radial_deg")
#: What a gravitating run's summary keeps of ``analyze``'s gravity quantities (``gravity``):
#: Toomre Q from the number- and from the mass-weighted radial velocity dispersion of the
#: window's snapshots, Toomre's critical wavelength and the mean pair's Hill parameter.  In
#: a ring of many sizes the small particles hold the number and the large, cooler ones the
#: mass, so the two Q differ by a factor of a few; the mass-weighted one is the Q of the
#: mass a wake would be made of.
GRAVITY = ("toomre_Q", "toomre_Q_mass", "lambda_cr", "r_h")
#: Units of a summary's ``occultation`` numbers not given beside them.
UNITS = {"snapshots": "count", "snapshot_orbits": "orbits", "elevations_deg": "deg",
         "azimuths": "count", "fit_reduced_chi2": "dimensionless",
         "precision": "relative standard error of tau_n per view and snapshot"}


def _value(mean, stderr, units: str) -> dict:
    return {"mean": float(mean), "stderr": float(stderr), "units": units}


def _asymmetry(views: Sequence[Mapping], elevation: float) -> dict:
    """At one B: the relative amplitude (max - min) / mean of tau_n over phi with the error
    of max and min added in quadrature over the mean (NaN when a view let no ray through:
    its tau_n is only a lower bound), and the largest transmission with its error and
    azimuth (NaN at B = 90 deg)."""
    row = [v for v in views if v["elevation_deg"] == elevation]
    tau = np.array([v["normal_optical_depth"] for v in row], dtype=float)
    err = np.array([v["normal_optical_depth_stderr"] for v in row], dtype=float)
    T = np.array([v["transmission"] for v in row], dtype=float)
    hi, lo, peak = int(np.argmax(tau)), int(np.argmin(tau)), int(np.argmax(T))
    amplitude = (_value((tau[hi] - tau[lo]) / np.mean(tau),
                        math.hypot(err[hi], err[lo]) / np.mean(tau), "dimensionless")
                 if np.all(np.isfinite(tau)) and np.all(np.isfinite(err))
                 else _value(math.nan, math.nan, "dimensionless"))
    return {"elevation_deg": float(elevation), "asymmetry_amplitude": amplitude,
            "peak_transmission": _value(T[peak], row[peak]["transmission_stderr"],
                                        "dimensionless"),
            # a vertical ray has no azimuth (analysis.observe.asymmetry)
            "peak_transmission_azimuth_deg": float(row[peak]["azimuth_deg"] % 180.0)
            if elevation < 90.0 else math.nan}


def condense(obs: Mapping, wake_significant: bool | None) -> dict:
    """A summary's ``occultation`` from ``analysis.observe.observe``'s result and
    ``analyze``'s wake verdict of the equilibrium window."""
    views = obs["views"]
    elevations = sorted({float(v["elevation_deg"]) for v in views})
    fit = obs["bar_model"]
    fitted = bool(fit.get("success")) and "height_over_width" in fit
    out: dict[str, object] = {
        "snapshots": len(obs["snapshots"]),
        "snapshot_orbits": [float(o) for o in obs["snapshot_orbits"]],
        "elevations_deg": elevations,
        "azimuths": len({float(v["azimuth_deg"]) for v in views}),
        "precision": obs["precision"],
        "geometric_optical_depth": _value(obs["geometric_optical_depth"], 0.0,
                                          "dimensionless"),
        "fitted": fitted, "wake_significant": wake_significant,
        "asymmetry": [_asymmetry(views, b) for b in elevations]}
    for key in ("height_over_width", "gap_optical_depth", "gap_fraction",
                "wake_angle_from_radial_deg"):
        part = fit.get(key) if fitted else None
        out[key] = _value(part["value"], part["stderr"], part["units"]) if part else \
            _value(math.nan, math.nan, "deg" if key.endswith("_deg") else "dimensionless")
    out["fit_reduced_chi2"] = float(fit["reduced_chi2"]) if fitted else math.nan
    out["units"] = dict(UNITS)
    return out


def occultation_summary(run, wake_significant: bool | None) -> dict:
    """The ``occultation`` of a run's summary: ``ringsim observe``'s defaults over the
    equilibrium window (``analysis.observe.observe``), condensed by `condense`."""
    from ringsim.analysis.observe import observe

    return condense(observe(run), wake_significant)


def kept_occultation(run, wake_significant: bool | None, old: Mapping | None) -> dict:
    """The ``occultation`` of a run's summary: ``old`` (the summary's own, as a summary
    remade to add `gravity` has it) when it observed the snapshots of the window
    ``analyze`` finds now, with the same wake verdict and ``observe``'s views and precision
    of today, since its rays are seeded (``analysis.observe.RAY_SEED``) and the views would
    come out the same; else `occultation_summary`.  A change of the ray tracer itself is
    not seen here: ``--resummarise`` observes anew."""
    from ringsim.analysis import observe

    if old is not None and old.get("wake_significant") == wake_significant and (
            old.get("elevations_deg") == sorted(observe.DEFAULT_ELEVATIONS)
            and old.get("azimuths") == len(observe.DEFAULT_AZIMUTHS)
            and old.get("precision") == observe.DEFAULT_PRECISION):
        period = run.scenario.orbital_period
        orbits = [float(run.snapshot_times[i]) / period
                  for i in observe.window_snapshots(run)[0]]
        if orbits == old.get("snapshot_orbits"):
            return dict(old)
    return occultation_summary(run, wake_significant)


def gravity_summary(eq: Mapping) -> dict:
    """The ``gravity`` of a gravitating run's summary: ``analyze``'s `GRAVITY` quantities
    of the equilibrium window, each ``{"mean", "stderr", "units"}``."""
    return {key: dict(eq[key]) for key in GRAVITY}


def lacks_gravity(summary: Mapping) -> bool:
    """A gravitating run's summary made before summaries kept `gravity_summary`."""
    return is_gravitating(summary) and "gravity" not in summary


def is_gravitating(summary: Mapping) -> bool:
    """Whether the summary's run had self-gravity (``sheet.gravity``)."""
    return bool(summary.get("scenario", {}).get("sheet", {}).get("gravity"))


def lacks_occultation(summary: Mapping) -> bool:
    """A gravitating run's summary made before summaries kept the occultations."""
    return is_gravitating(summary) and "occultation" not in summary


def _seed_value(summary: Mapping, quantity: str) -> dict:
    """One seed's ``{"mean", "stderr", "units"}`` of a table quantity, null read as NaN."""
    occ = summary["occultation"]
    entry = occ.get(quantity)
    if quantity in ("asymmetry_amplitude", "peak_transmission"):
        rows = [r for r in occ["asymmetry"] if r["elevation_deg"] == ASYMMETRY_ELEVATION]
        entry = rows[0][quantity] if rows else None
    if entry is None:
        return _value(math.nan, math.nan, "dimensionless")
    return budget.replica_value(entry)


def _overlaps(value: Mapping, published: Mapping) -> bool:
    mean, err = value["mean"], value["stderr"]
    if not (math.isfinite(mean) and math.isfinite(err)):
        return False
    low = -math.inf if published["low"] is None else published["low"]
    high = math.inf if published["high"] is None else published["high"]
    return mean - 2.0 * err <= high and mean + 2.0 * err >= low


def verdict(entry: Mapping, measured: Sequence[Mapping]) -> str:
    """The case's column "consistent with" by `RULE`."""
    if not measured:
        return "not measured"
    if not all(s["occultation"]["wake_significant"] for s in measured):
        return "no significant wake"
    if not all(s["occultation"]["fitted"] for s in measured):
        return "no bar-model fit"
    rings = [ring for ring, keys in RULE_RANGES.items()
             if all(_overlaps(entry[PUBLISHED[k]["quantity"]], PUBLISHED[k]) for k in keys)]
    return " and ".join(rings) if rings else "excluded"


def describe_case(summary: Mapping) -> dict:
    """κ, size distribution, friction and optical depth of a case, from one of its
    summaries' scenario (the optical depth of a run started from a file, whose scenario
    has none: the run's own, as ``ringsim analyze`` gives it)."""
    scenario = summary["scenario"]
    sizes = scenario["particles"]["size_distribution"]
    friction = scenario.get("friction")
    return {"kappa": scenario.get("restitution", {}).get("kappa"),
            "size_distribution": ", ".join(f"{k} {v}" for k, v in sizes.items()),
            "friction": (", ".join(f"{k} {v}" for k, v in friction.items())
                         if friction else "none"),
            "optical_depth": scenario["sheet"].get("optical_depth",
                                                   summary.get("optical_depth")),
            "gravity": is_gravitating(summary)}


def case_cassini(members: Sequence[Mapping]) -> dict:
    """One case's row: what it is, its seed means of `QUANTITIES` (null without a measured
    seed; the `BAR_MODEL` parameters null without a seed with a significant wake and a
    fit), the counts of both kinds of seed, and its verdict; where a seed's summary holds
    ``gravity``, the seed means of `GRAVITY` over those seeds, with their count
    (``seeds_with_gravity`` of ``n_seeds``)."""
    entry: dict[str, object] = describe_case(members[0])
    if not entry["gravity"]:
        entry.update({"seeds_measured": 0, "verdict": "no wakes (no self-gravity)"})
        return entry
    measured = [s for s in members if "occultation" in s]
    waking = [s for s in measured
              if s["occultation"]["wake_significant"] and s["occultation"]["fitted"]]
    for quantity in QUANTITIES:
        seeds = waking if quantity in BAR_MODEL else measured
        entry[quantity] = (budget.replica_mean([_seed_value(s, quantity) for s in seeds])
                           if seeds else None)
    entry["seeds_measured"] = len(measured)
    entry["seeds_with_wake"] = len(waking)
    with_gravity = [s["gravity"] for s in members if "gravity" in s]
    if with_gravity:
        entry.update({key: budget.replica_mean([budget.replica_value(g[key])
                                                for g in with_gravity]) for key in GRAVITY})
        entry["seeds_with_gravity"] = len(with_gravity)
        entry["n_seeds"] = len(members)
    chi2 = [float(c) for s in waking
            if (c := s["occultation"].get("fit_reduced_chi2")) is not None]
    entry["fit_reduced_chi2_max"] = max(chi2) if chi2 else None
    entry["verdict"] = verdict(entry, measured)
    return entry


def against_cassini(cases: Mapping[str, Sequence[Mapping]]) -> dict | None:
    """``report.json``'s ``against_cassini`` from the summaries of each case (None when no
    case has self-gravity)."""
    if not any(is_gravitating(s) for members in cases.values() for s in members):
        return None
    return {"rule": RULE, "published": PUBLISHED,
            "asymmetry_elevation_deg": ASYMMETRY_ELEVATION,
            "geometry": GEOMETRY,
            "cases": {case: case_cassini(members) for case, members in cases.items()}}

