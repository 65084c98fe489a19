"""Which runs a study's cases and variants ask for: the case keys ``seeds`` and
``length`` and the variant key ``cases`` of a study file (docs/studies.md, "Fewer runs where
they add nothing", "A case's own length"), and the ``length`` sections they share with the
study.

A case's ``seeds`` (among the study's seeds) are the seeds it runs: a case outside the
headline ratio can run once where the headline pair runs three times.  In the quick form
the case runs the quick seeds among its own.

A variant's ``cases`` (among the cases of the ratios) are the cases whose runs it changes.
Every other case of the ratios keeps its own run in the variant, the run of the same seed
without the variant: the study file asserts that the variant does not change that case's
physics (a reference mass of Dilley's mass factor where kappa = 0, say), so running it
again would give the same equilibrium at the cost of a run.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ringsim.config.scenario import MAX_SEED
from ringsim.config.schema import ScenarioError, Section, show

#: Keys of a variant besides its dotted scenario overrides.
VARIANT_KEYS = ("cases", "budget")
#: A variant's part of the error budget (the variant key ``budget``): ``systematic`` (its
#: shift of a ratio adds to the ratio's systematic error) or ``range`` (it sets a model
#: parameter to the other end of the range its value is known within: the ratio there is
#: given beside the ratio, not added to its error).
VARIANT_BUDGETS = ("systematic", "range")
#: Keys of a ``length`` section.
LENGTH_KEYS = ("orbits", "until_equilibrium", "max_orbits")


def read_length(sec: Section, key: str) -> dict:
    """``{orbits: N}`` or ``{until_equilibrium: true, max_orbits: N}`` as dotted overrides."""
    allowed = "{orbits: N} (a fixed length) or {until_equilibrium: true, max_orbits: N}"
    length = sec.section(key, allowed=allowed)
    length.check_keys(LENGTH_KEYS)
    until = length.boolean("until_equilibrium", False)
    need, refuse = ("max_orbits", "orbits") if until else ("orbits", "max_orbits")
    if length.has(refuse):
        raise length.error(refuse, f"not with until_equilibrium: {str(until).lower()}",
                           f"give {need}")
    orbits = length.number(need, unit="orbits", gt=0.0)
    return {"integration.orbits": orbits, "integration.until_equilibrium": until}


def case_scope(cases: Section, name: str, value: object, seeds: Sequence[int]
               ) -> tuple[object, tuple[int, ...] | None, dict | None]:
    """A case's value without its keys ``seeds`` and ``length``, and those (None where the
    case gives none): its own seeds among ``seeds``, its own length as dotted overrides."""
    if not isinstance(value, Mapping):
        return value, None, None
    here = Section(cases.file, cases.key(name), value)
    own_seeds = read_seeds(here, "seeds", within=seeds) if "seeds" in value else None
    own_length = read_length(here, "length") if "length" in value else None
    return {k: v for k, v in value.items() if k not in ("seeds", "length")}, own_seeds, \
        own_length


def read_seeds(sec: Section, key: str, within: Sequence[int] | None = None) -> tuple[int, ...]:
    """The list of seeds ``key`` of ``sec`` (optionally among ``within``)."""
    allowed = (f"a non-empty list of distinct integers in [0, {MAX_SEED}]"
               + (f" among the seeds {list(within)}" if within is not None else ""))
    value = sec.get(key, None, allowed)
    if not isinstance(value, list) or not value:
        raise sec.error(key, f"got {show(value)}", allowed)
    for item in value:
        if isinstance(item, bool) or not isinstance(item, int) or not 0 <= item <= MAX_SEED \
                or (within is not None and item not in within):
            raise sec.error(key, f"{show(item)} is not allowed", allowed)
    if len(set(value)) != len(value):
        raise sec.error(key, f"{value} repeats a seed", allowed)
    return tuple(value)


def read_variant_keys(variants: Section, name: str, value: object,
                      ratio_cases: Sequence[str]
                      ) -> tuple[object, tuple[str, ...] | None, str]:
    """A variant's overrides without its `VARIANT_KEYS`, its ``cases`` (None: every case
    of the ratios) and its ``budget`` (`VARIANT_BUDGETS`, ``systematic`` by default)."""
    if not isinstance(value, Mapping):
        return value, None, "systematic"
    cases = (read_variant_cases(variants, name, value["cases"], ratio_cases)
             if "cases" in value else None)
    part = value.get("budget", "systematic")
    if part not in VARIANT_BUDGETS:
        raise variants.error(f"{name}.budget", f"got {show(part)}",
                             " or ".join(VARIANT_BUDGETS) + ": whether the variant's shift "
                             "adds to the systematic error or gives a model parameter's range")
    return {k: v for k, v in value.items() if k not in VARIANT_KEYS}, cases, str(part)


def read_variant_cases(variants: Section, name: str, value: object,
                       ratio_cases: Sequence[str]) -> tuple[str, ...]:
    """The variant key ``cases``: distinct cases of the ratios."""
    allowed = ("a non-empty list of distinct cases of the ratios, the cases whose runs the "
               f"variant changes: {', '.join(ratio_cases)}")
    key = f"{name}.cases"
    if not isinstance(value, list) or not value or len(set(map(str, value))) != len(value):
        raise variants.error(key, f"got {show(value)}", allowed)
    for item in value:
        if item not in ratio_cases:
            raise variants.error(key, f"{show(item)} is not a case of the ratios", allowed)
    return tuple(str(item) for item in value)


def form_seeds(seeds: Sequence[int], case_seeds: Sequence[int] | None) -> tuple[int, ...]:
    """The seeds a case runs in a form: the form's ``seeds``, or those among the case's
    own ``case_seeds`` (None: the case declares none)."""
    if case_seeds is None:
        return tuple(seeds)
    return tuple(seed for seed in seeds if seed in case_seeds)


def check_form_seeds(source: str, form: str, seeds: Sequence[int],
                     variant_seeds: Sequence[int], ratio_cases: Sequence[str],
                     case_seeds: Mapping[str, tuple[int, ...]], has_variants: bool) -> None:
    """Every case runs at least one seed in the form, and each case of the ratios runs
    every variant seed (a variant's shift compares the same seeds with and without it)."""
    for case, own in case_seeds.items():
        runs = form_seeds(seeds, own)
        if not runs:
            raise ScenarioError(source, f"cases.{case}.seeds", f"none of {list(own)} is "
                                f"among the {form} form's seeds {list(seeds)}",
                                "seeds the form runs")
        missing = [s for s in variant_seeds if s not in runs]
        if has_variants and case in ratio_cases and missing:
            raise ScenarioError(source, f"cases.{case}.seeds", f"lacks the {form} form's "
                                f"variant seeds {missing}", "seeds that include the "
                                "variant seeds: a variant's shift compares the same seeds "
                                "with and without it")
