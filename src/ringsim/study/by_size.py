"""A study's numbers by particle size: what a run's summary keeps of them, and the report's
section that compares them between cases.

For a run of more than one radius the summary keeps (`size_summary`) each size bin's
velocity dispersion and thickness over the equilibrium window with the bin edges, the
thickness under each weighting (by number, by mass, by optical depth), the thickness of the
small- and the large-particle layer, and the shares of the impacts outside the speeds,
reduced radii and reduced masses the restitution law was measured over.  The report
(`by_size_report`) gives, per ratio of two cases with the same size bins, the ratio of c and
H in every bin; per case the thicknesses, the shares of impacts, and whether the ring is as
thin as Saturn's dense rings (`SATURN_FULL_THICKNESS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from ringsim.analysis import budget, compare, size_bins

#: Full vertical thickness of Saturn's dense rings [m]: "a few to about ten metres"; the
#: A ring's self-gravity wakes have height/width 0.15-0.37 (Colwell et al. 2006, GRL 33,
#: L07201) and H ~ 6 m for wakes ~60 m apart (Hedman et al. 2007, AJ 133, 2624).
SATURN_FULL_THICKNESS = 10.0
#: Full thickness of a uniform layer of rms height H: 2 sqrt(3) H.
FULL_PER_RMS = 2.0 * math.sqrt(3.0)
#: The thicknesses kept, by weighting (every particle alike, by its mass, by its cross
#: section as an occultation): summary key -> equilibrium key.
WEIGHTINGS = {"number": "thickness", "mass": "thickness_mass_weighted",
              "optical_depth": "thickness_cross_section_weighted"}
#: The law-range shares kept (fractions of the equilibrium window's impacts).
LAW_SHARES = ("outside_speeds", "speeds_below", "speeds_above", "outside_sizes",
              "sizes_below", "sizes_above", "outside_masses", "masses_below", "masses_above",
              "critically_damped", "inside_all")


def _number(x) -> float:
    return math.nan if x is None else float(x)


def _kept(value: Mapping | None) -> dict | None:
    return budget.replica_value(value) if value else None


def size_summary(eq: Mapping) -> dict | None:
    """The ``by_size`` entry of a run's summary from its equilibrium
    (``analysis.equilibrium.equilibrium``); None for a run of one radius."""
    bins = eq.get("per_size_bin") or []
    segregation = eq.get("vertical_segregation")
    if len(bins) < 2 or segregation is None:
        return None
    law = eq.get("law_range") or {}
    return {
        "bins": [{"r_low": b["r_low"], "r_high": b["r_high"], "n": b["n"],
                  "mean_mass": _number(b["mean_mass"]["mean"]),
                  "velocity_dispersion": _kept(b["velocity_dispersion"]),
                  "thickness": _kept(b["thickness"])} for b in bins],
        "thickness": {w: _kept(eq.get(key)) for w, key in WEIGHTINGS.items()},
        "layers": {name: {"r_low": segregation[name]["r_low"],
                          "r_high": segregation[name]["r_high"],
                          "thickness": _kept(segregation[name]["thickness"])}
                   for name in ("small", "large")},
        "law_range": {key: _number(law.get(key)) for key in LAW_SHARES} if law else None,
        "law_masses": law.get("masses") if law else None,
        "pair_epsilon": _pair_epsilon(eq.get("pair_epsilon")),
        "units": {"r_low": "m", "r_high": "m", "n": "count", "mean_mass": "kg",
                  "law_range": "fraction of impacts", "law_masses": "kg",
                  "pair_epsilon": "dimensionless (mean), count"},
    }


def _pair_epsilon(pair: Mapping | None) -> dict | None:
    """The law's mean eps and the sampled collisions of each pair of size bins (row: the
    smaller partner's bin), or None when the run sampled no collisions."""
    if not pair or pair.get("status") != "on":
        return None
    return {"mean": pair["mean_epsilon"], "counts": pair["counts"]}


def _seed_mean(values: Sequence[Mapping | None]) -> dict | None:
    read = [_kept(v) for v in values]      # a summary's null is NaN
    kept = [v for v in read if v is not None and math.isfinite(v["mean"])]
    return budget.replica_mean(kept) if kept else None


def bin_edges(entry: Mapping) -> list[tuple[float, float]]:
    """The (r_low, r_high) [m] of each size bin of a ``by_size`` entry."""
    return [(b["r_low"], b["r_high"]) for b in entry["bins"]]


def ratio_with_stat(a: Mapping | None, b: Mapping | None) -> dict | None:
    """a / b (``analysis.compare.ratio``) with its error as ``stat``; None without both."""
    if a is None or b is None or not b["mean"]:
        return None
    r = compare.ratio(dict(a), dict(b))
    return {"mean": r["mean"], "stat": r["stderr"], "units": r["units"]}


def case_by_size(summaries: Sequence[Mapping]) -> dict | None:
    """The seed means of a case's ``by_size`` entries; None if a run has none or the runs'
    size bins differ."""
    found = [s.get("by_size") for s in summaries]
    entries: list[Mapping] = [e for e in found if e is not None]
    if not entries or len(entries) < len(found):
        return None
    edges = [bin_edges(e) for e in entries]
    if any(e != edges[0] for e in edges):
        return None
    shares = [_mass_shares(e["bins"]) for e in entries]
    bins = []
    for k, (low, high) in enumerate(edges[0]):
        bins.append({"r_low": low, "r_high": high,
                     "mean_mass": entries[0]["bins"][k]["mean_mass"],
                     "n": sum(e["bins"][k]["n"] for e in entries) / len(entries),
                     "mass_share": _spread([share[k] for share in shares]),
                     **{q: _seed_mean([e["bins"][k][q] for e in entries])
                        for q in ("velocity_dispersion", "thickness")}})
    law = [e["law_range"] for e in entries if e["law_range"]]
    return {
        "bins": bins,
        "thickness": {w: _seed_mean([e["thickness"][w] for e in entries]) for w in WEIGHTINGS},
        "layers": {name: _seed_mean([e["layers"][name]["thickness"] for e in entries])
                   for name in ("small", "large")},
        "law_range": _law_shares(law) if law else None,
        "law_masses": entries[0].get("law_masses"),
        "pair_epsilon": _pooled_pairs([e.get("pair_epsilon") for e in entries]),
    }


def _mass_shares(bins: Sequence[Mapping]) -> list[float]:
    """Each size bin's share of the sheet's mass (its count times its mean mass)."""
    masses = [b["n"] * _number(b["mean_mass"]) for b in bins]
    total = sum(masses)
    return [m / total if total > 0 else math.nan for m in masses]


def _spread(values: Sequence[float]) -> dict:
    """The mean over the seeds and its standard error (NaN with one seed)."""
    mean = sum(values) / len(values)
    err = (math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1) / len(values))
           if len(values) > 1 else math.nan)
    return {"mean": mean, "stderr": err, "units": "fraction of the mass"}


def _law_shares(law: Sequence[Mapping]) -> dict:
    """The seeds' mean of each share of `LAW_SHARES`; ``inside_all`` over the seeds that
    counted it (summaries made before the count have none), with ``inside_all_seeds``,
    how many, of ``seeds``."""
    counted = [v for v in (_number(x.get("inside_all")) for x in law) if math.isfinite(v)]
    inside = sum(counted) / len(counted) if counted else math.nan
    return {**{key: inside if key == "inside_all" else sum(_number(x.get(key)) for x in law)
               / len(law) for key in LAW_SHARES},
            "inside_all_seeds": len(counted), "seeds": len(law)}


def _pooled_pairs(pairs: Sequence[Mapping | None]) -> dict | None:
    """The seeds' mean eps per pair of size bins, each seed weighted by its sampled
    collisions; None unless every seed sampled collisions."""
    given = [p for p in pairs if p is not None]
    if not given or len(given) < len(pairs):
        return None
    counts, means = size_bins.pooled_pair_means([p["counts"] for p in given],
                                                 [p["mean"] for p in given])
    return {"mean": means, "counts": counts}


#: Fewest sampled collisions of a pair of size bins in each case for its eps ratio.
MIN_PAIR_COLLISIONS = 20


def _pair_ratio(a: Mapping | None, b: Mapping | None) -> list | None:
    if a is None or b is None:
        return None
    return [[x / y if n >= MIN_PAIR_COLLISIONS and m >= MIN_PAIR_COLLISIONS and y else
             math.nan for x, y, n, m in zip(ra, rb, na, nb, strict=True)]
            for ra, rb, na, nb in zip(a["mean"], b["mean"], a["counts"], b["counts"],
                                      strict=True)]


def _paired_bins(num: Mapping[int, Mapping], den: Mapping[int, Mapping]) -> list[dict]:
    """Per size bin, the seed-paired ratio of c and of H: each common seed's bin ratio
    (`ratio_with_stat`) combined over the seeds as a case's seeds are
    (``budget.replica_mean``)."""
    common = [s for s in sorted(set(num) & set(den))
              if num[s].get("by_size") and den[s].get("by_size")]
    n_bins = len(num[common[0]]["by_size"]["bins"]) if common else 0
    out = []
    for k in range(n_bins):
        entry = {}
        for q in ("velocity_dispersion", "thickness"):
            found = [ratio_with_stat(_kept(num[s]["by_size"]["bins"][k][q]),
                                     _kept(den[s]["by_size"]["bins"][k][q])) for s in common]
            values = [{"mean": r["mean"], "stderr": r["stat"], "units": r["units"]}
                      for r in found if r is not None and math.isfinite(r["mean"])]
            entry[q] = (budget.replica_mean(values) if values else
                        {"mean": math.nan, "stderr": math.nan, "n_replicas": 0})
        out.append(entry)
    return out


def by_size_report(cases: Mapping[str, Sequence[Mapping]],
                   ratios: Sequence[Sequence[str]],
                   seeds: Mapping[str, Sequence[int]] | None = None) -> dict:
    """The report's ``by_size``: per case its `case_by_size` and whether it is as thin as
    Saturn's rings; per ratio the ratio of c and H in every size bin (cases with the same
    bins only), and with ``seeds`` (each case's seeds, in the order of its summaries) also
    their seed-paired ratio in every bin (``paired``), the ratios over the seeds both cases
    ran where they ran different ones (``seeds``, as the report's ratios)."""
    per_case = {case: case_by_size(summaries) for case, summaries in cases.items()}
    for entry in per_case.values():
        if entry is None:
            continue
        tau = entry["thickness"]["optical_depth"]
        full = FULL_PER_RMS * tau["mean"] if tau else math.nan
        entry["full_thickness_optical_depth"] = {"mean": full, "units": "m"}
        entry["as_thin_as_saturn"] = bool(full <= SATURN_FULL_THICKNESS)
    out_ratios = []
    for num, den in ratios:
        a, b = per_case.get(num), per_case.get(den)
        common = None
        if seeds is not None:
            common = budget.common_replicas(seeds[num], seeds[den])
            if common and a is not None and b is not None:
                # the other seeds are other realisations (``study.report.common_seeds``)
                a, b = (case_by_size([s for k, s in zip(seeds[c], cases[c], strict=True)
                                      if k in common]) for c in (num, den))
        if a is None or b is None or bin_edges(a) != bin_edges(b):
            continue
        bins = [{"r_low": x["r_low"], "r_high": x["r_high"],
                 **{q: ratio_with_stat(x[q], y[q]) for q in ("velocity_dispersion", "thickness")}}
                for x, y in zip(a["bins"], b["bins"], strict=True)]
        if seeds is not None:
            paired = _paired_bins(dict(zip(seeds[num], cases[num], strict=True)),
                                  dict(zip(seeds[den], cases[den], strict=True)))
            for entry, pair in zip(bins, paired, strict=True):
                entry["paired"] = pair
        out_ratios.append({"numerator": num, "denominator": den, "bins": bins,
                           "seeds": common,
                           "pair_epsilon": _pair_ratio(a.get("pair_epsilon"),
                                                       b.get("pair_epsilon"))})
    return {"cases": {c: e for c, e in per_case.items() if e is not None},
            "ratios": out_ratios,
            "saturn": {"full_thickness_m": SATURN_FULL_THICKNESS,
                       "rule": "as thin as Saturn's dense rings when the full thickness of "
                               "a uniform layer of the run's optical-depth-weighted rms "
                               "height, 2 sqrt(3) H, is at most 10 m",
                       "source": "Colwell et al. 2006 (GRL 33, L07201): wake height/width "
                                 "0.15-0.37; Hedman et al. 2007 (AJ 133, 2624): H ~ 6 m"}}


def plus_minus(value: Mapping | None, scale: float = 1.0, digits: int = 3) -> str:
    """``mean ± error`` of a ``{mean, stderr}`` (or ``stat``) entry times ``scale``, the
    mean to ``digits`` significant digits; "–" without a finite mean."""
    if value is None or not math.isfinite(value["mean"]):
        return "–"
    error = budget.shown_error(value["mean"], value.get("stderr", value.get("stat", math.nan)))
    shown = f"{value['mean'] * scale:.{digits}g}"
    return shown + (f" ± {error * scale:.2g}" if error is not None and math.isfinite(error)
                    else " (no error)")


def _share(x: float) -> str:
    return "–" if not math.isfinite(x) else f"{100.0 * x:.1f} %"


def by_size_lines(section: Mapping) -> list[str]:
    """The report's Markdown section "By size" (nothing when no case has size bins)."""
    cases = section.get("cases") or {}
    if not cases:
        return []
    saturn = section["saturn"]
    lines = ["## By size", "",
             "Thickness H (rms z [m]) of each case under each weighting, of its small- and "
             "large-particle layers (lowest and highest third of the radius range in log r), "
             "and the full thickness 2√3 H of a uniform layer with the optical-depth-weighted "
             f"H, against Saturn's dense rings ({saturn['rule']}; {saturn['source']}).", ""]
    lines += ["| case | H by number [m] | H by mass [m] | H by optical depth [m] | small layer "
              "[m] | large layer [m] | 2√3 H (optical depth) [m] | as thin as Saturn's |",
              "|---|---|---|---|---|---|---|---|"]
    for case, e in cases.items():
        t, layers = e["thickness"], e["layers"]
        full = e["full_thickness_optical_depth"]["mean"]
        lines.append(f"| {case} | {plus_minus(t['number'])} | {plus_minus(t['mass'])} | "
                     f"{plus_minus(t['optical_depth'])} | {plus_minus(layers['small'])} | "
                     f"{plus_minus(layers['large'])} | {full:.3g} | "
                     f"{'yes' if e['as_thin_as_saturn'] else 'no'} |")
    lines += ["", "Impacts of the equilibrium window outside what the restitution law was "
              "measured over (fractions of impacts; reduced masses below the measured range "
              "are the pairs lighter than its reference mass, where κ > 0 makes collisions "
              "less elastic, not more):", "",
              "| case | speeds below / above | sizes below / above | masses below / above | "
              "ξ ≥ 1 (ε = 0) | inside all three at once |", "|---|---|---|---|---|---|"]
    for case, e in cases.items():
        law = e["law_range"]
        if law is None:
            lines.append(f"| {case} | – | – | – | – | – |")
            continue
        lines.append(f"| {case} | {_share(law['speeds_below'])} / {_share(law['speeds_above'])}"
                     f" | {_share(law['sizes_below'])} / {_share(law['sizes_above'])} | "
                     f"{_share(law['masses_below'])} / {_share(law['masses_above'])} | "
                     f"{_share(law['critically_damped'])} | "
                     f"{_inside_all(law)} |")
    lines += ["", "Inside all three at once: the impacts whose speed, reduced radius and "
              "reduced mass all lie where the law was measured, the mean over the seeds "
              "whose summaries counted them ('–': none did; summaries made before the "
              "resolver counted them have no count)."]
    lines += _population_lines(cases)
    for ratio in section.get("ratios", []):
        lines += _bin_ratio_lines(ratio) + _pair_lines(ratio)
    return lines + [""]


def _population_lines(cases: Mapping[str, Mapping]) -> list[str]:
    """Each size bin's particles and share of the mass, one table per set of bin edges:
    where a few large particles hold most of the mass, the seeds' realisations of them
    differ in surface density, and the mass-weighted field is grainy."""
    groups: dict[tuple, list[str]] = {}
    for case, e in cases.items():
        groups.setdefault(tuple((b["r_low"], b["r_high"]) for b in e["bins"]), []).append(case)
    lines = []
    for edges, names in groups.items():
        lines += ["", "Particles in each size bin and the bin's share of the mass (mean over "
                  "the seeds, with its standard error):", "",
                  "| case | " + " | ".join(f"{lo:.3g}–{hi:.3g} m" for lo, hi in edges) + " |",
                  "|---|" + "---|" * len(edges)]
        for case in names:
            lines.append(f"| {case} | " + " | ".join(
                f"{_count(b['n'])} ({_percent(b['mass_share'])})"
                for b in cases[case]["bins"]) + " |")
    return lines


def _count(n: float) -> str:
    """A seed mean of counts: whole above 100, three figures below."""
    return f"{n:.0f}" if n >= 100 else f"{n:.3g}"


def _percent(share: Mapping) -> str:
    mean, err = 100.0 * share["mean"], 100.0 * share["stderr"]
    return f"{mean:.3g} ± {err:.2g} %" if math.isfinite(err) else f"{mean:.3g} %"


def _bin_ratio_lines(ratio: Mapping) -> list[str]:
    """The ratio of c and H in each size bin, of the seed means and, where two or more
    seeds are common to both cases, seed-paired."""
    paired = any(b.get("paired", {}).get("velocity_dispersion", {}).get("n_replicas", 0)
                 > 1 for b in ratio["bins"])
    head = "| size bin [m] | c ratio | H ratio |" + (
        " c ratio, seed-paired | H ratio, seed-paired |" if paired else "")
    seeds = ratio.get("seeds")
    over = ("" if seeds is None else f"; over the seeds both cases ran, {seeds}" if seeds
            else "; the cases share no seed: of different realisations")
    lines = ["", f"Ratio {ratio['numerator']} / {ratio['denominator']} in each size bin "
             "(statistical errors" + over
             + ("; seed-paired: the mean of each common seed's ratio, "
                "combined as a case's seeds are" if paired else "") + "):",
             "", head, "|---|---|---|" + ("---|---|" if paired else "")]
    for b in ratio["bins"]:
        row = (f"| {b['r_low']:.3g}–{b['r_high']:.3g} | {plus_minus(b['velocity_dispersion'])} | "
               f"{plus_minus(b['thickness'])} |")
        if paired:
            row += "".join(f" {plus_minus(b['paired'][q])} |"
                           for q in ("velocity_dispersion", "thickness"))
        lines.append(row)
    return lines


def _inside_all(law: Mapping) -> str:
    """The share inside all three ranges, with how many seeds counted it where not all."""
    share = _share(_number(law.get("inside_all")))
    seeds, counted = law.get("seeds"), law.get("inside_all_seeds")
    if seeds is None or counted in (None, 0) or counted == seeds:
        return share
    return f"{share} ({counted} of {seeds} seeds)"


def _pair_lines(ratio: Mapping) -> list[str]:
    """The eps ratio per pair of size bins: below 1 where the numerator's law makes the
    pair less elastic (pairs lighter than the reference mass for kappa > 0)."""
    table = ratio.get("pair_epsilon")
    if table is None:
        return []
    labels = [f"{b['r_low']:.3g}–{b['r_high']:.3g}" for b in ratio["bins"]]
    lines = ["", f"The law's mean ε, {ratio['numerator']} / {ratio['denominator']}, for "
             "pairs of size bins (row: the smaller partner's bin [m], column: the larger's; "
             f"sampled collisions, '–' where either case has fewer than "
             f"{MIN_PAIR_COLLISIONS}; below 1: less elastic):", "",
             "| smaller \\ larger | " + " | ".join(labels) + " |",
             "|---|" + "---|" * len(labels)]
    for label, row in zip(labels, table, strict=True):
        lines.append(f"| {label} | " + " | ".join(
            "–" if not math.isfinite(x) else f"{x:.3f}" for x in row) + " |")
    return lines
