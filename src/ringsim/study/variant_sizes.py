"""A study's variants by particle size: what each variant does to a ratio's thicknesses and
to the velocity dispersion of each size bin.

A variant's shift of a ratio (``study.report``) is of the equilibrium quantities, by number
for c and H.  In a ring whose sizes span decades the smallest particles hold the number, so
a variant can move that ratio while leaving what the ratio says of the particles that hold
the mass nearly as it was (a reference mass of Dilley's law acts so: studies/kappa-saturn,
"By size, with each variant").  Per
variant and ratio of cases with the same size bins, `variant_by_size` gives the ratio of the
thickness under each weighting, of the small and the large layer's thickness and of each
bin's c, over the variant seeds with the variant and without it (``study.by_size``'s seed
means; statistical errors).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ringsim.study.by_size import (
    WEIGHTINGS,
    bin_edges,
    case_by_size,
    plus_minus,
    ratio_with_stat,
)

#: The layers of the by-size summaries (the lowest and the highest third of the radii in
#: log r).
LAYERS = ("small", "large")


def _size_ratios(a: Mapping, b: Mapping) -> dict:
    """The ratios a / b of two `case_by_size` entries with the same bins."""
    rows: dict = {"thickness": {w: ratio_with_stat(a["thickness"][w], b["thickness"][w])
                                for w in WEIGHTINGS},
                  "layers": {name: ratio_with_stat(a["layers"][name], b["layers"][name])
                             for name in LAYERS}}
    rows["bins"] = [{"r_low": x["r_low"], "r_high": x["r_high"],
                     "velocity_dispersion": ratio_with_stat(x["velocity_dispersion"],
                                                            y["velocity_dispersion"])}
                    for x, y in zip(a["bins"], b["bins"], strict=True)]
    return rows


def variant_by_size(variants: Mapping[str, Mapping[str, Sequence[Mapping]]],
                    without: Mapping[str, Sequence[Mapping]],
                    ratios: Sequence[Sequence[str]], seeds: Sequence[int],
                    changed: Mapping[str, Sequence[str]] | None = None) -> list[dict]:
    """Per variant and ratio, the by-size ratios with the variant (``with``) and without it
    (``without``), both over the variant ``seeds``; only where the four seed means have the
    same size bins, and the variant changes a case of the ratio.

    Parameters
    ----------
    variants : variant name -> case -> the summaries of its runs with the variant seeds
    without : case -> the summaries of its runs with the variant seeds, without a variant
    ratios : (numerator, denominator) case names
    seeds : the variant seeds
    changed : variant name -> the cases whose runs it changes (the variant key ``cases``;
        a variant not in it changes every case)
    """
    out = []
    for variant, cases in variants.items():
        for num, den in ratios:
            if changed and variant in changed and not {num, den} & set(changed[variant]):
                continue
            found = [(case_by_size(runs[num]), case_by_size(runs[den]))
                     for runs in (cases, without)]
            entries = [e for pair in found for e in pair if e is not None]
            if len(entries) < 4 or any(bin_edges(e) != bin_edges(entries[0]) for e in entries):
                continue
            out.append({"variant": variant, "numerator": num, "denominator": den,
                        "seeds": list(seeds), "with": _size_ratios(*entries[:2]),
                        "without": _size_ratios(*entries[2:])})
    return out


def variant_by_size_lines(entries: Sequence[Mapping]) -> list[str]:
    """The report's Markdown subsection "By size, with each variant" (nothing without
    entries)."""
    if not entries:
        return []
    lines = ["### By size, with each variant", "",
             "Each ratio of two cases with the same size bins, over the variant seeds with "
             "the variant and without it: the thickness H (rms z) under each weighting, of "
             "the small and the large layer, and the velocity dispersion c of each size bin "
             "(statistical errors). A variant that moves a ratio by number can leave what "
             "it says of the particles that hold the mass as it was.", ""]
    for e in entries:
        w, wo = e["with"], e["without"]
        rows = [(f"H by {name.replace('_', ' ')}", w["thickness"][name], wo["thickness"][name])
                for name in WEIGHTINGS]
        rows += [(f"H of the {name} layer", w["layers"][name], wo["layers"][name])
                 for name in LAYERS]
        rows += [(f"c of {b['r_low']:.3g}–{b['r_high']:.3g} m", b["velocity_dispersion"],
                  c["velocity_dispersion"]) for b, c in zip(w["bins"], wo["bins"], strict=True)]
        lines += [f"{e['numerator']} / {e['denominator']} with and without {e['variant']} "
                  f"(seeds {e['seeds']}):", "",
                  f"| quantity | without | with {e['variant']} |", "|---|---|---|"]
        lines += [f"| {label} | {plus_minus(b, digits=4)} | {plus_minus(a, digits=4)} |"
                  for label, a, b in rows] + [""]
    return lines
