"""Per-size-bin diagnostics of a broad size distribution (``ringsim analyze``).

* the velocity ellipsoid of each bin: rms radial, azimuthal and vertical velocity
  sigma_x, sigma_y, sigma_z [m/s] about the sheet's mass-weighted mean velocity (the run
  file's ``size_bin_sigma_*`` series), window means with autocorrelation-corrected errors;
* the vertical segregation of small and large particles (Cuzzi, Durisen, Burns & Hamill
  1979, Icarus 38, 54): the thickness H = rms z [m] about the sheet's mass-weighted mean
  height of the particles in the lowest and in the highest third of the radius range in
  log r (``small``: r < r_min (r_max / r_min)^(1/3), ``large``: r > r_min
  (r_max / r_min)^(2/3)), each number-weighted within its group, over the window's
  snapshots, beside the whole ring's thickness by number, mass and cross section;
* the law's eps for pairs of each bin with each bin, from the sampled collisions the run
  file sums per pair of bins when ``output.log_collisions`` > 0
  (``size_bin_pair_collisions``, ``size_bin_pair_epsilon_sum``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ringsim import quantities
from ringsim.analysis import timeseries, window

#: The velocity ellipsoid's axes and their time series.
AXES = ("sigma_x", "sigma_y", "sigma_z")


def _value(mean: float, stderr: float, units: str) -> dict:
    return {"mean": float(mean), "stderr": float(stderr), "units": units}


#: The per-bin window means `add_ellipsoid` adds: the velocity ellipsoid and, with
#: friction, each bin's rotational over translational energy.
BIN_SERIES = (*AXES, "rotational_energy_ratio")


def add_ellipsoid(rows: list[dict], ts: dict, start: int) -> None:
    """Add ``sigma_x``, ``sigma_y``, ``sigma_z`` [m/s] and, with friction,
    ``rotational_energy_ratio`` [1] (window means of rows ``start:`` with
    autocorrelation-corrected errors) to each per-size-bin row of an equilibrium; nothing
    for run files without the series (NaN rows, written before a series existed in a
    file continued with ``--resume``, are dropped by ``autocorrelated_mean``)."""
    for name in BIN_SERIES:
        key = f"size_bin_{name}"
        if key not in ts or ts[key].shape[1] != len(rows):
            continue
        for k, row in enumerate(rows):
            mean, stderr, _ = timeseries.autocorrelated_mean(np.asarray(ts[key][start:, k],
                                                                        float))
            row[name] = _value(mean, stderr, quantities.unit(key))


def _group_thickness(snaps: list[dict], members: np.ndarray) -> tuple[float, float]:
    """Mean over snapshots of the members' rms z [m] about each snapshot's mass-weighted
    mean height, and the standard error of that mean (NaN from one snapshot: no error can
    be had from one sample)."""
    values = []
    for s in snaps:
        z_ref = float(np.average(s["z"], weights=s["mass"]))
        values.append(math.sqrt(float(np.mean((s["z"][members] - z_ref) ** 2))))
    v = np.asarray(values)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 \
        else math.nan


def vertical_segregation(run, start: int) -> dict | None:
    """The thickness of the small- and the large-particle layer (module docstring) over the
    snapshots at or after row ``start`` (the last snapshot if none is: ``in_window``
    False); None for a run of one radius.

    Returns
    -------
    dict with ``small`` and ``large`` ({``r_low``, ``r_high`` [m], ``n`` [count],
    ``thickness`` {mean, stderr, units [m]}}), ``ratio`` H_small / H_large with its
    propagated error, ``definition`` and ``units``.
    """
    indices, in_window = window.window_snapshot_indices(run, start)
    snaps = [run.snapshot(i) for i in indices]
    radius = snaps[0]["radius"]
    r_min, r_max = float(radius.min()), float(radius.max())
    if not r_max > r_min:
        return None
    cut = r_min * (r_max / r_min) ** np.array([1.0 / 3.0, 2.0 / 3.0])
    out: dict = {}
    for name, members, low, high in (("small", radius < cut[0], r_min, cut[0]),
                                     ("large", radius > cut[1], cut[1], r_max)):
        mean, stderr = (_group_thickness(snaps, members) if members.any()
                        else (math.nan, math.nan))
        out[name] = {"r_low": float(low), "r_high": float(high), "n": int(members.sum()),
                     "thickness": _value(mean, stderr, quantities.unit("thickness"))}
    a, b = out["small"]["thickness"], out["large"]["thickness"]
    ratio = a["mean"] / b["mean"] if b["mean"] > 0 else math.nan
    rel = math.hypot(a["stderr"] / a["mean"] if a["mean"] else 0.0,
                     b["stderr"] / b["mean"] if b["mean"] else 0.0)
    out["ratio"] = _value(ratio, abs(ratio) * rel, quantities.unit("ratio"))
    out["definition"] = ("rms z about the sheet's mass-weighted mean height, number-weighted "
                         "within each group; small: the lowest third of the radius range in "
                         "log r, large: the highest third; "
                         + (f"mean over the window's {len(snaps)} snapshot(s)" if in_window
                            else "from the last snapshot, which lies before the window "
                            "(none lies in it)"))
    out["in_window"] = in_window
    out["units"] = {"r_low": "m", "r_high": "m", "n": "count"}
    return out


def pair_epsilon(run, start: int) -> dict:
    """The law's mean eps and the count of sampled collisions per pair of size bins over rows
    ``start:`` (row: bin of the smaller partner, column: of the larger; NaN where none),
    or ``{"status": "off", "reason": ...}`` when the run file holds no such sums."""
    ts = run.timeseries
    if "size_bin_pair_collisions" not in ts:
        reason = ("output.log_collisions is 0: no collisions were sampled"
                  if run.scenario.output.log_collisions == 0 else
                  "the run has one size bin, or its file predates the per-pair sums")
        return {"status": "off", "reason": reason}
    edges = np.asarray(ts["size_bin_edges"], float)
    n = edges.size - 1
    counts = np.sum(ts["size_bin_pair_collisions"][start:], axis=0).reshape(n, n)
    sums = np.sum(ts["size_bin_pair_epsilon_sum"][start:], axis=0).reshape(n, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(counts > 0, sums / counts, np.nan)
    return {"status": "on", "edges": edges.tolist(), "counts": counts.astype(int).tolist(),
            "mean_epsilon": mean.tolist(),
            "sample": (f"the last {run.scenario.output.log_collisions} collisions of each "
                       "output interval (output.log_collisions)"),
            "layout": "row: size bin of the smaller partner, column: of the larger",
            "units": {"edges": "m", "counts": "count", "mean_epsilon": "dimensionless"}}


def pooled_pair_means(counts: Sequence, means: Sequence) -> tuple[list, list]:
    """Sampled collisions of several runs pooled per pair of size bins: the counts added and
    the mean eps weighted by each run's count (NaN where no run sampled the pair; a run's
    NaN mean counts only where its count is 0).

    Parameters
    ----------
    counts : sequence of (n, n) arrays [count]
        One per run.
    means : sequence of (n, n) arrays [dimensionless]
        The runs' mean eps, NaN or None where not sampled.
    """
    n = np.asarray(counts, float)
    m = np.asarray([[[math.nan if x is None else x for x in row] for row in table]
                    for table in means], float)
    total = np.sum(n, axis=0)
    sums = np.sum(np.where(n > 0, m, 0.0) * n, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(total > 0, sums / total, np.nan)
    return total.astype(int).tolist(), mean.tolist()


def _fmt(value: dict | None, scale: float = 1.0) -> str:
    if not value or not math.isfinite(value["mean"]):
        return "n/a"
    if not math.isfinite(value["stderr"]):
        return f"{value['mean'] * scale:.4g} (one sample: no error)"
    return f"{value['mean'] * scale:.4g} ± {value['stderr'] * scale:.2g}"


def _thickness_by_weighting(eq: dict) -> str:
    """The ring's thickness under each weighting, in metres, named."""
    parts = [f"{weighting} {_fmt(eq.get(key))}" for weighting, key in
             (("number", "thickness"), ("mass", "thickness_mass_weighted"),
              ("cross section", "thickness_cross_section_weighted")) if key in eq]
    return "  thickness H (rms z) by weighting [m]: " + ", ".join(parts)


def size_bin_lines(eq: dict) -> list[str]:
    """The lines ``analyze`` prints: each bin's velocity ellipsoid, the small- and
    large-particle layers beside the thickness by weighting, the eps of pairs of bins."""
    lines = []
    bins = eq.get("per_size_bin") or []
    if bins and "sigma_x" in bins[0]:
        speed = quantities.QUANTITY["size_bin_sigma_x"]
        spin = "rotational_energy_ratio" in bins[0]
        lines.append(f"  velocity ellipsoid per size bin [{speed.shown}], number-weighted"
                     + (", and each bin's E_rot / E_tr (by mass)" if spin else "") + ":")
        lines.append("    r [m]              sigma_x (radial)    sigma_y (azimuthal) "
                     "sigma_z (vertical)" + ("  E_rot / E_tr" if spin else ""))
        for b in bins:
            lines.append((f"    {b['r_low']:7.3g} - {b['r_high']:<7.3g}   " + " ".join(
                f"{_fmt(b.get(axis), speed.scale):<19}" for axis in AXES)
                + (f" {_fmt(b.get('rotational_energy_ratio'))}" if spin else "")).rstrip())
    seg = eq.get("vertical_segregation")
    if seg:
        lines.append("  vertical segregation (Cuzzi et al. 1979): " + seg["definition"])
        for name in ("small", "large"):
            g = seg[name]
            lines.append(f"    {name + ' particles':<16} r in {g['r_low']:.3g}-{g['r_high']:.3g}"
                         f" m ({g['n']} particles): H = {_fmt(g['thickness'])} m")
        lines.append(f"    H_small / H_large = {_fmt(seg['ratio'])}")
        lines.append(_thickness_by_weighting(eq))
    lines += _pair_lines(eq.get("pair_epsilon"))
    return lines


def _pair_lines(pair: dict | None) -> list[str]:
    """The table of mean eps (and counts) of pairs of size bins, or why there is none."""
    if not pair:
        return []
    if pair["status"] != "on":
        return [f"  eps of pairs of size bins: not available ({pair['reason']})"]
    edges = pair["edges"]
    lines = [f"  mean eps of the law (sampled collisions) per pair of size bins; "
             f"{pair['layout']}; {pair['sample']}:",
             "    r [m]            " + " ".join(f"{f'{lo:.3g}-{hi:.3g}':>16}" for lo, hi in
                                               zip(edges[:-1], edges[1:], strict=True))]
    for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        cells = []
        for j in range(len(edges) - 1):
            n, e = pair["counts"][i][j], pair["mean_epsilon"][i][j]
            cells.append(f"{f'{e:.3f} ({n})' if n else '-':>16}")
        lines.append(f"    {f'{lo:.3g}-{hi:.3g}':<16} " + " ".join(cells))
    return lines
