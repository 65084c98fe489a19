"""A study's report so far (``ringsim study --report-only --partial``): the cases with a
summarised run, each over the seeds done, the ratios between them and the variants whose
runs are all summarised; the rest named as not yet run.

A study of large runs takes many sessions of background work (``studies/kappa-saturn``).
Its committed summaries already hold finished equilibria; the partial report shows them
with the same tables and sections as the final one, in its own folder
(``<study>.partial.report/``), and says in its first warning what it leaves out, so that it
is never read as the study's result.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

from ringsim.study.runs import collect


def partial_output_dir(study_path, quick: bool = False) -> Path:
    """``<stem>.partial.report/`` (``<stem>.quick.partial.report/`` with ``--quick``)."""
    path = Path(study_path)
    return path.parent / f"{path.stem}{'.quick' if quick else ''}.partial.report"


def reduced(study, quick: bool, specs: Sequence, ids: Sequence[str],
            summaries: Mapping[str, dict]) -> tuple:
    """``(study, specs, ids, note)``: the study cut to the cases with at least one
    summarised run (each with the seeds whose runs are summarised), the ratios of two such
    cases and the variants whose runs of those ratios are all summarised, with its specs
    and their ids; ``note``, the warning that names what is left out (None when nothing
    is)."""
    done = {(s.case, s.variant, s.seed) for s, rid in zip(specs, ids, strict=True)
            if rid in summaries}
    every = {(s.case, s.variant, s.seed) for s in specs}
    asked = {name: sorted(seed for c, v, seed in every if c == name and v is None)
             for name, _ in study.cases}
    seeds = {name: [seed for seed in asked[name] if (name, None, seed) in done]
             for name in asked}
    cases = tuple((name, o) for name, o in study.cases if seeds[name])
    names = [name for name, _ in cases]    # in the study's order: the report's text
    ratios = tuple(pair for pair in study.ratios if set(pair) <= set(names))
    in_ratios = {name for pair in ratios for name in pair}
    mode = study.mode(quick)
    variants = tuple((v, o) for v, o in mode.variants if ratios and all(
        key in done and key[2] in seeds[key[0]] for key in every
        if key[1] == v and key[0] in in_ratios))
    cut_mode = dataclasses.replace(mode, variants=variants, variant_cases={
        v: tuple(c for c in mode.variant_cases[v] if c in in_ratios)
        for v, _ in variants if v in mode.variant_cases},
        variant_ranges=tuple(v for v in mode.variant_ranges if v in dict(variants)))
    cut = dataclasses.replace(
        study, cases=cases, ratios=ratios,
        references=tuple(r for r in study.references
                         if (r.ratio is not None and tuple(r.ratio) in ratios)
                         or (r.ratio is None and r.case in names)),
        starts={c: s for c, s in study.starts.items() if c in names},
        case_seeds={c: tuple(seeds[c]) for c in names if seeds[c] != asked[c]
                    or c in study.case_seeds},
        case_lengths={c: v for c, v in study.case_lengths.items() if c in names},
        **({"quick_mode": cut_mode} if quick else {"full": cut_mode}))
    cut_specs = cut.specs(quick)
    kept = list(zip(cut_specs, collect(cut_specs)[1], strict=True))
    missing = [name for name, _ in study.cases if name not in names]
    fewer = [f"{name} (seeds {seeds[name]} of {asked[name]})" for name in names
             if seeds[name] != asked[name]]
    left_out = [f"variants {', '.join(v for v, _ in mode.variants if v not in dict(variants))}"
                if len(variants) < len(mode.variants) else "",
                f"cases {', '.join(missing)}" if missing else "",
                f"{len(study.ratios) - len(ratios)} of {len(study.ratios)} ratios"
                if len(ratios) < len(study.ratios) else ""]
    if not (fewer or any(left_out)):
        return cut, [s for s, _ in kept], [rid for _, rid in kept], None
    waiting = _waiting_variant_runs(specs, ids, summaries, set(dict(variants)))
    note = (f"PARTIAL REPORT: {len(summaries)} of {len(set(ids))} runs have summaries"
            + (f"; fewer seeds than asked: {', '.join(fewer)}" if fewer else "")
            + (f"; not in it yet: {'; '.join(part for part in left_out if part)}"
               if any(left_out) else "")
            + (f"; summarised variant runs waiting for the ratios they measure: {waiting}"
               if waiting else "")
            + ". The study's result is its full report, when every run is done.")
    return cut, [s for s, _ in kept], [rid for _, rid in kept], note


def _waiting_variant_runs(specs: Sequence, ids: Sequence[str], summaries: Mapping[str, dict],
                          shown: set[str]) -> str:
    """The summarised runs of variants the partial report leaves out, each with its c and
    H by number beside the same case and seed without the variant (when summarised), so
    that prose quoting them can be checked against the report."""
    by_key = {(s.case, s.variant, s.seed): rid for s, rid in zip(specs, ids, strict=True)}
    parts = []
    for (case, variant, seed), rid in by_key.items():
        base_id = by_key.get((case, None, seed), "")
        if variant is None or variant in shown or rid not in summaries or rid == base_id:
            continue    # not a variant, shown, not summarised, or the base run itself
        base = summaries.get(base_id)
        parts.append(f"{variant} ({case} seed {seed}: {_c_and_h(summaries[rid])}"
                     + (f"; without it {_c_and_h(base)}" if base else "") + ")")
    return ", ".join(parts)


def _c_and_h(summary: Mapping) -> str:
    """c [mm/s] and H [m] by number of a run's summary."""
    eq = summary.get("equilibrium") or {}
    c, h = eq.get("velocity_dispersion"), eq.get("thickness")
    if not (c and h):
        return "no equilibrium"
    return f"c {1e3 * c['mean']:.4g} mm/s, H {h['mean']:.4g} m by number"
