"""The numbers of a study's report (``report.json``), computed from its run summaries alone.

The statistics are ringsim's own: each run's equilibrium is ``ringsim.equilibrium``'s
(time average over the equilibrium window, autocorrelation-corrected standard error); a
case is the mean over its seeds (``analysis.budget.replica_mean``: the error is the larger
of the propagated one and the seed-to-seed standard error of the mean); a ratio is
``analysis.compare.ratio`` of two cases (first-order propagated statistical error); the
systematic part adds the variants' relative parts in quadrature
(``analysis.budget.systematic``).  A study with self-gravitating cases also holds them
against the published Cassini wake parameters (``study.cassini``).  The report holds no
time, path or CPU time, so that identical summaries give byte-identical ``report.json``
(``runs.json_text``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from ringsim import __version__, quantities
from ringsim.analysis import budget
from ringsim.analysis.compare import ratio
from ringsim.analysis.equilibrium import NOT_IN_EQUILIBRIUM, QUANTITIES
from ringsim.study.by_size import by_size_report
from ringsim.study.cassini import against_cassini
from ringsim.study.kept import case_kept
from ringsim.study.references import reference_entries, rule
from ringsim.study.spin import case_spin
from ringsim.study.variant_sizes import variant_by_size

#: What a particle weighting of ``ringsim.quantities`` counts equally.
_WEIGHTINGS = {"number": "number: every particle counts once",
               "mass": "mass: each particle by its mass"}
#: What the equilibrium quantities count equally where their declared particle weighting
#: alone does not say it.
_OTHER_WEIGHTINGS = {
    "velocity_dispersion_rOmega": "number: c over the mean radius times Omega",
    "thickness_r": "number: H over the mean radius",
    "filling_factor": "volume: the particles' volume in the midplane slab",
    "collision_frequency": "number: collisions per particle",
    "mean_epsilon": "collision: every collision counts once",
    "collisional_viscosity": "mass: the momentum the collisions carry",
}


def weighting(quantity: str) -> str:
    """What an equilibrium quantity counts equally: what it averages over where that is
    said here, else its declared particle weighting (``ringsim.quantities``)."""
    declared = quantities.QUANTITY[quantity].weighting
    return _OTHER_WEIGHTINGS.get(quantity) or (_WEIGHTINGS[declared] if declared else "")


#: How a case's equilibrium is averaged (the report says it once).
AVERAGING = ("each run: the time average over its equilibrium window with a standard error "
             "corrected for autocorrelation (ringsim analyze); each case: the mean over its "
             "seeds, with the larger of the propagated error and the seed-to-seed standard "
             "error of the mean")
#: How the systematic part of a ratio is measured (the report says it once).
SYSTEMATICS = ("each variant reruns the cases of the ratios with the variant seeds; its "
               "part is the shift of the ratio from the same seeds' ratio without the "
               "variant, relative to that ratio, or the shift's own statistical error if "
               "larger (a smaller shift is not resolved); the parts add in quadrature; "
               "null: no variant measured it")
#: What the report says of the variants whose ``budget`` is ``range``, when it has some.
RANGES = ("; a variant whose budget is range (docs/studies.md) is not among the parts: it "
          "sets a model parameter to the other end of the range its value is known within, "
          "and the ratio without and with it over the variant seeds is given beside the "
          "ratio ('a → b with ... (range)'), its shift in the variants' shifts")


def seed_mean(summaries: Sequence[Mapping], quantity: str) -> dict:
    """The mean of one quantity over the runs of a case (``budget.replica_mean``)."""
    return budget.replica_mean([budget.replica_value(s["equilibrium"][quantity])
                                for s in summaries])


def _run_entry(seed: int, rid: str, summary: Mapping) -> dict:
    return {"seed": seed, "run": rid, "orbits": summary["orbits"],
            "n_particles": summary["n_particles"],
            "in_equilibrium": summary["in_equilibrium"], "reason": summary["reason"],
            "stop_reason": summary["stop_reason"],
            "equilibrium_from_orbit": summary["equilibrium"]["equilibrium_from_orbit"]["mean"],
            "ringsim_version": summary["ringsim_version"]}


class Runs:
    """The summaries of a study's runs, by case, variant and seed."""

    def __init__(self, specs: Sequence, ids: Sequence[str], summaries: Mapping[str, dict]):
        self.by_key: dict[tuple, list[tuple[int, str]]] = {}
        for spec, rid in zip(specs, ids, strict=True):
            self.by_key.setdefault((spec.case, spec.variant), []).append((spec.seed, rid))
        self.summaries = summaries

    def of(self, case: str, variant: str | None = None,
           seeds: Sequence[int] | None = None) -> list[dict]:
        """The summaries of a case (or of a variant of it), optionally of some seeds."""
        return [self.summaries[rid] for seed, rid in self.by_key[(case, variant)]
                if seeds is None or seed in seeds]

    def entries(self, case: str, variant: str | None = None) -> list[dict]:
        return [_run_entry(seed, rid, self.summaries[rid])
                for seed, rid in self.by_key[(case, variant)]]


def case_entry(overrides: Mapping, runs: Runs, case: str, keep: Sequence[str] = ()) -> dict:
    """One case: its overrides, runs and seed-averaged equilibrium (every table quantity,
    with its weighting), and the seed means of what its summaries keep (``kept``, only
    where the study keeps something)."""
    members = runs.of(case)
    equilibrium = {}
    for quantity in QUANTITIES:
        value = seed_mean(members, quantity)
        value["weighting"] = weighting(quantity)
        equilibrium[quantity] = value
    spin, kept = case_spin(members), case_kept(members, keep)
    return {"overrides": dict(overrides), "runs": runs.entries(case),
            "in_equilibrium": all(s["in_equilibrium"] for s in members),
            "equilibrium": equilibrium, **({"spin": spin} if spin is not None else {}),
            **({"kept": kept} if keep else {})}


def _case_ratio(runs: Runs, num: str, den: str, quantity: str, variant: str | None = None,
                seeds: Sequence[int] | None = None) -> dict:
    return ratio(seed_mean(runs.of(num, variant, seeds), quantity),
                 seed_mean(runs.of(den, variant, seeds), quantity))


def seed_ratios(runs: Runs, num: str, den: str, quantity: str) -> dict[int, dict]:
    """Each seed's ratio num / den, its window errors propagated
    (``analysis.compare.ratio``), for every seed both cases ran (a seed whose denominator
    is 0 is left out).  The cases of a study draw the same radii and positions from one
    seed, so each seed's ratio divides out what that realisation gives both cases."""
    def by_seed(case: str) -> dict[int, dict]:
        return {seed: budget.replica_value(runs.summaries[rid]["equilibrium"][quantity])
                for seed, rid in runs.by_key[(case, None)]}
    top, bottom = by_seed(num), by_seed(den)
    return {s: ratio(top[s], bottom[s]) for s in sorted(set(top) & set(bottom))
            if bottom[s]["mean"]}


def seed_scatter(runs: Runs, num: str, den: str, quantity: str) -> float | None:
    """The standard deviation over the seeds of one seed's ratio num / den (the seeds both
    cases ran; None with fewer than two): how far two runs of the ratio differ by
    realisation alone."""
    ratios = [r["mean"] for r in seed_ratios(runs, num, den, quantity).values()]
    if len(ratios) < 2:
        return None
    mean = sum(ratios) / len(ratios)
    return math.sqrt(sum((r - mean) ** 2 for r in ratios) / (len(ratios) - 1))


def paired_ratio(runs: Runs, num: str, den: str, quantity: str) -> dict:
    """The seed-paired ratio: the mean over the common seeds of each seed's ratio
    (`seed_ratios`), with the larger of the propagated error and the seeds' standard error
    of the mean (``budget.replica_mean``), and each seed's ratio (``by_seed``, keyed by the
    seed); mean and error None without a common seed."""
    ratios = seed_ratios(runs, num, den, quantity)
    if not ratios:
        return {"mean": None, "stderr": None, "n_replicas": 0, "by_seed": {}}
    return {**budget.replica_mean(list(ratios.values())),
            "by_seed": {str(s): r["mean"] for s, r in ratios.items()}}


def _variant_part(runs: Runs, num: str, den: str, quantity: str, variant: str,
                  seeds: Sequence[int], scatter: float | None) -> dict:
    """The shift of a ratio with one variant, against the same seeds without it, and the
    shift realisation alone gives (``scatter`` sqrt(2 / seeds))."""
    without = _case_ratio(runs, num, den, quantity, None, seeds)
    moved = _case_ratio(runs, num, den, quantity, variant, seeds)
    shift = moved["mean"] - without["mean"]
    noise = math.hypot(moved["stderr"], without["stderr"])
    relative = (max(abs(shift), noise) / abs(without["mean"])
                if math.isfinite(without["mean"]) and without["mean"] else math.nan)
    seed_noise = None if scatter is None else scatter * math.sqrt(2.0 / len(seeds))
    return {"ratio": moved["mean"], "ratio_without": without["mean"], "shift": shift,
            "noise": noise, "seed_noise": seed_noise, "relative": relative}


def common_seeds(runs: Runs, num: str, den: str) -> list[int] | None:
    """The seeds a ratio's mean is taken over (``budget.common_replicas`` of the cases'
    seeds): a case's other seeds are other realisations of the radii and positions, which
    in a ring whose few largest particles hold most of the mass move c and H by more than
    the ratio's own error (studies/kappa-saturn)."""
    return budget.common_replicas([seed for seed, _ in runs.by_key[(num, None)]],
                                  [seed for seed, _ in runs.by_key[(den, None)]])


def ratio_entry(runs: Runs, pair: tuple[str, str], quantity: str,
                variants: Sequence[str], variant_seeds: Sequence[int],
                ranges: Sequence[str] = ()) -> dict:
    """One ratio of one quantity, with its statistical and systematic errors (``syst_parts``:
    the shifts of the variants but ``ranges``, whose shifts are ``range_parts``); the ratio
    of the cases' seed means over their `common_seeds` where they ran different seeds
    (``seeds``: null where they ran the same, [] where they share none and the ratio is of
    all their seeds); ``in_equilibrium`` of the runs it is of."""
    num, den = pair
    seeds = common_seeds(runs, num, den)
    over = seeds or None        # [] (no seed in common): all the cases' seeds
    value = _case_ratio(runs, num, den, quantity, None, over)
    scatter = seed_scatter(runs, num, den, quantity)
    parts = {v: _variant_part(runs, num, den, quantity, v, variant_seeds, scatter)
             for v in variants}
    syst_parts = {v: part for v, part in parts.items() if v not in ranges}
    relative = {v: part["relative"] for v, part in syst_parts.items()}
    syst, _ = budget.systematic({"relative": {quantity: relative}}, quantity, value["mean"])
    members = runs.of(num, None, over) + runs.of(den, None, over)
    return {"numerator": num, "denominator": den, "quantity": quantity,
            "mean": value["mean"], "stat": value["stderr"], "syst": syst,
            "total": math.hypot(value["stderr"], syst), "units": value["units"],
            "quantity_units": QUANTITIES[quantity][1], "syst_parts": syst_parts,
            **({"range_parts": {v: parts[v] for v in ranges}} if ranges else {}),
            "seed_scatter": scatter, "paired": paired_ratio(runs, num, den, quantity),
            "seeds": seeds, "in_equilibrium": all(s["in_equilibrium"] for s in members)}


#: The warning for a run none of whose snapshots lies in its equilibrium window.
NO_WINDOW_SNAPSHOT = ("WARNING: {name}: no snapshot lies in its equilibrium window; its "
                      "by-size layers and occultations are from the last snapshot, which "
                      "lies before the window")


def _warnings(study, mode, runs: Runs) -> list[str]:
    out = []
    names = [(case, None) for case, _ in study.cases]
    names += [(case, v) for v, _ in mode.variants for case in study.ratio_cases()]
    for case, variant in names:
        for seed, rid in runs.by_key[(case, variant)]:
            s = runs.summaries[rid]
            label = f"{case}{f' [{variant}]' if variant else ''} seed {seed} (run {rid})"
            if not s["in_equilibrium"]:
                out.append(NOT_IN_EQUILIBRIUM.format(name=label, reason=s["reason"]))
            if s.get("no_snapshot_in_window"):
                out.append(NO_WINDOW_SNAPSHOT.format(name=label))
    return out


def build_report(study, quick: bool, specs: Sequence, ids: Sequence[str],
                 summaries: Mapping[str, dict]) -> dict:
    """The content of ``report.json`` (see docs/studies.md)."""
    mode = study.mode(quick)
    runs = Runs(specs, ids, summaries)
    quantities = list(study.quantities or QUANTITIES)
    variants = [name for name, _ in mode.variants]
    cassini = against_cassini({case: runs.of(case) for case, _ in study.cases})
    report = {
        "study": study.name, "description": study.description,
        "form": "quick" if quick else "full", "ringsim_version": __version__,
        "base": study.base_file, "overrides": dict(study.overrides),
        "seeds": list(mode.seeds),
        "variant_seeds": list(mode.variant_seeds) if variants else [],
        "length": dict(mode.length), "quick_overrides": dict(mode.overrides),
        "averaging": AVERAGING, "quantities": quantities,
        "systematics": SYSTEMATICS + (RANGES if mode.variant_ranges else ""),
        "cases": {case: case_entry(overrides, runs, case, study.keep)
                  for case, overrides in study.cases},
        "variants": {name: {"overrides": dict(changes),
                            **({"cases": list(mode.variant_cases[name])}
                               if name in mode.variant_cases else {}),
                            **({"budget": "range"} if name in mode.variant_ranges else {}),
                            "runs": {case: runs.entries(case, name)
                                     for case in study.ratio_cases()}}
                     for name, changes in mode.variants},
        "ratios": [ratio_entry(runs, pair, q, variants, mode.variant_seeds,
                               mode.variant_ranges)
                   for pair in study.ratios for q in quantities],
        "warnings": _warnings(study, mode, runs),
        **_by_size(study, mode, runs),
        **({"against_cassini": cassini} if cassini is not None else {}),
    }
    for case, start in study.starts.items():
        report["cases"][case]["start"] = start.to_dict()
    for case, seeds in study.case_seeds.items():
        report["cases"][case]["seeds"] = [s for s in mode.seeds if s in seeds]
    if not mode.quick:
        for case, length in study.case_lengths.items():
            report["cases"][case]["length"] = dict(length)
    if study.references:
        report["references"] = reference_entries(study.references, report)
        report["references_rule"] = rule(study.references)
    return report


def _by_size(study, mode, runs: Runs) -> dict:
    """``{"by_size": ...}`` when a case has runs of more than one radius, else {}; with
    variants, its ``variants`` (`variant_by_size`)."""
    section = by_size_report({case: runs.of(case) for case, _ in study.cases}, study.ratios,
                             {case: [seed for seed, _ in runs.by_key[(case, None)]]
                              for case, _ in study.cases})
    if not section["cases"]:
        return {}
    seeds, cases = mode.variant_seeds, study.ratio_cases()
    variants = variant_by_size({v: {c: runs.of(c, v, seeds) for c in cases}
                                for v, _ in mode.variants},
                               {c: runs.of(c, None, seeds) for c in cases}, study.ratios, seeds,
                               mode.variant_cases)
    section.update({"variants": variants} if variants else {})
    return {"by_size": section}
