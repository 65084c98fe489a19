"""Study files: a base scenario, named cases run with several seeds, the ratios between cases
and the method variants that measure the ratios' systematic error (docs/studies.md).

Every run of a study is the base scenario with, in this order (a later one wins): the
study's ``length``, its ``overrides`` (of every run), the case's overrides, with ``--quick``
the ``quick`` overrides, the variant's overrides, and the seed.  Overrides are dotted
scenario keys, as in a sweep file (``ringsim.config.scenario.with_overrides``).  Every value
is checked when the file is read, in both its full and its quick form, so that a bad key is
bad input (one line naming the key) before anything runs.  A case may start from another
case's run instead of drawing its particles (the case key ``start``,
``ringsim.config.study_start``).
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from ringsim.config.scenario import Scenario, load_scenario, with_overrides
from ringsim.config.schema import (
    REQUIRED,
    ScenarioError,
    Section,
    parse_yaml,
    read_text,
    show,
)
from ringsim.config.study_references import Reference, read_keep, read_references
from ringsim.config.study_scope import (
    case_scope,
    check_form_seeds,
    form_seeds,
    read_length,
    read_seeds,
    read_variant_keys,
)
from ringsim.config.study_start import (
    START_FILE,
    Start,
    check_case_keys,
    check_cycles,
    read_start,
    started,
    without_file_keys,
)

#: Keys of a study file.
STUDY_KEYS = ("name", "description", "base", "seeds", "overrides", "cases", "ratios",
              "quantities", "variants", "variant_seeds", "length", "quick", "report",
              "references", "keep")
#: Keys of the ``quick`` section besides dotted scenario overrides.
QUICK_KEYS = ("length", "seeds", "variant_seeds", "variants", "report")
#: Scenario keys a study sets itself, which cases, variants and ``quick`` may not set: the
#: seed comes from ``seeds``; a run's name, description and output path are labels, set
#: from the run's hash (``ringsim.study.runs``).
RESERVED_KEYS = ("seed", "name", "description", "output.path")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_NAME_TEXT = "letters, digits, '.', '_' and '-', starting with a letter or digit"


@dataclass(frozen=True)
class Mode:
    """What the study runs in one of its forms (full, or reduced with ``--quick``).

    Attributes
    ----------
    quick : bool
    seeds : tuple of int
        The seeds of every case.
    variant_seeds : tuple of int
        The seeds the variants run with (a subset of ``seeds``).
    length : dict
        Dotted overrides of the run length (``integration.orbits`` [orbits],
        ``integration.until_equilibrium``).
    overrides : dict
        ``quick``'s dotted overrides of every run (empty in the full form).
    variants : tuple of (name, dict of dotted overrides)
    variant_cases : dict of variant name -> tuple of case names
        The cases whose runs a variant changes, for the variants that name them
        (``config.study_scope``); a variant not in it changes every case of the ratios.
    variant_ranges : tuple of str
        The variants whose ``budget`` is ``range`` (``config.study_scope``).
    """

    quick: bool
    seeds: tuple[int, ...]
    variant_seeds: tuple[int, ...]
    length: dict
    overrides: dict
    variants: tuple[tuple[str, dict], ...]
    variant_cases: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    variant_ranges: tuple[str, ...] = ()

    def changes(self, variant: str | None, case: str) -> dict:
        """The overrides of ``variant`` on the runs of ``case`` ({} where it keeps the
        case's own run)."""
        if variant is None or case not in self.variant_cases.get(variant, (case,)):
            return {}
        return dict(self.variants)[variant]


@dataclass(frozen=True)
class RunSpec:
    """One run a study asks for: a case (or a variant of it) with one seed.

    ``origin`` is the run it starts from (the case key ``start``), whose scenario's
    ``sheet.initial_state.file`` is the placeholder `START_FILE` until the study names the
    file after the origin's hash (``ringsim.study.runs.collect``)."""

    case: str
    variant: str | None
    seed: int
    scenario: Scenario
    origin: RunSpec | None = None

    @property
    def label(self) -> str:
        """``k01 seed 2`` or ``k01 [half_dt] seed 1``."""
        return f"{self.case}{f' [{self.variant}]' if self.variant else ''} seed {self.seed}"


@dataclass(frozen=True)
class Study:
    """A validated study file.

    Attributes
    ----------
    name, description : str
    source : str
        The study file.
    base : Scenario
    base_file : str
        The base scenario as the study file names it (relative to the study file).
    overrides : dict
        Dotted overrides of every run, before the case's.
    cases : tuple of (name, dict of dotted overrides)
        In file order.
    ratios : tuple of (numerator, denominator)
        Case names.
    quantities : tuple of str or None
        Equilibrium quantities of the ratios (None: every table quantity).
    full : Mode
    quick_mode : Mode or None
        The ``--quick`` form (None: the study has no ``quick`` section).
    report : str or None
        The study's prose: a Markdown file spliced into its report (its path, beside the
        study file).
    quick_report : str or None
        Prose of the quick form only (``quick.report``), after ``report`` in its report.
    references : tuple of Reference
        The values the cases are checked against (``config.study_references``).
    starts : dict of case name -> Start
        The cases that start from another case's run (``config.study_start``).
    case_lengths : dict of case name -> dict
        The full form's run length of the cases that name their own (the case key
        ``length``, as the study's), in place of the study's ``length``; the quick form's
        length applies to every case.
    case_seeds : dict of case name -> tuple of int
        The seeds of the cases that name their own (``config.study_scope``).
    keep : tuple of str
        What the summaries keep beyond the equilibrium (``KEPT_QUANTITIES``).
    """

    name: str
    description: str
    source: str
    base: Scenario
    base_file: str
    overrides: dict
    cases: tuple[tuple[str, dict], ...]
    ratios: tuple[tuple[str, str], ...]
    quantities: tuple[str, ...] | None
    full: Mode
    quick_mode: Mode | None
    report: str | None
    quick_report: str | None = None
    references: tuple[Reference, ...] = ()
    starts: Mapping[str, Start] = field(default_factory=dict)
    case_seeds: Mapping[str, tuple[int, ...]] = field(default_factory=dict)
    case_lengths: Mapping[str, dict] = field(default_factory=dict)
    keep: tuple[str, ...] = ()

    @property
    def folder(self) -> Path:
        """The study file's folder."""
        return Path(self.source).parent

    def mode(self, quick: bool) -> Mode:
        """The full or the quick form; ScenarioError if there is no quick form."""
        if not quick:
            return self.full
        if self.quick_mode is None:
            raise ScenarioError(self.source, "quick", "--quick given, but the study has no "
                                "quick section", "a quick section: reduced overrides and "
                                "length that run in minutes")
        return self.quick_mode

    def ratio_cases(self) -> list[str]:
        """The cases that appear in a ratio, in case order (the variants run these)."""
        used = {name for pair in self.ratios for name in pair}
        return [name for name, _ in self.cases if name in used]

    def specs(self, quick: bool = False) -> list[RunSpec]:
        """Every run of a form: seed by seed, each case with that seed (so a study run in
        order completes one replica of every case first), then each variant of each case
        of the ratios with each variant seed."""
        mode = self.mode(quick)
        out = [self.spec(mode, case, None, seed) for seed in mode.seeds
               for case, _ in self.cases
               if seed in form_seeds(mode.seeds, self.case_seeds.get(case))]
        for variant, _ in mode.variants:
            out += [self.spec(mode, case, variant, seed)
                    for case in self.ratio_cases() for seed in mode.variant_seeds]
        return out

    def spec(self, mode: Mode, case: str, variant: str | None, seed: int) -> RunSpec:
        """The run of a case (with a variant, or None) and a seed in a form; a case that
        starts from another's run has that run, of the same variant, as its ``origin``."""
        changes = mode.changes(variant, case)
        start = self.starts.get(case)
        length = mode.length if mode.quick else self.case_lengths.get(case, mode.length)
        scenario = _scenario(self, mode, dict(self.cases)[case], changes, seed, start, length)
        origin = (self.spec(mode, start.case, variant, seed if start.seed is None
                            else start.seed) if start is not None else None)
        return RunSpec(case, variant, seed, scenario, origin)


def _scenario(study: Study, mode: Mode, case: Mapping, variant: Mapping,
              seed: int, start: Start | None = None, length: Mapping | None = None
              ) -> Scenario:
    """The base with the length (``length``, else the form's), the study's and the case's
    overrides, the quick overrides, the variant and the seed; with a start, without the
    keys the start file replaces, from the placeholder file `START_FILE`."""
    changes = {**(mode.length if length is None else length), **study.overrides, **case,
               **mode.overrides, **variant, "seed": seed}
    if start is None:
        return with_overrides(study.base, changes)
    return started(with_overrides(study.base, without_file_keys(changes)), START_FILE, start)


# --- reading ----------------------------------------------------------------------------------

def _name(sec: Section, key: str, value: Any, what: str) -> str:
    """``value`` if it can name a study, case or variant (``what``)."""
    if not isinstance(value, str) or not _NAME.fullmatch(value):
        raise sec.error(key, f"{show(value)} cannot name a {what}", _NAME_TEXT)
    return value


def _check_overrides(sec: Section, key: str, base: Scenario, before: Mapping) -> dict:
    """A mapping of dotted scenario overrides, valid together on ``base`` with ``before``
    applied.  When they are not, the first override invalid on its own is named, else the
    combination; overrides valid only together (a smaller box with smaller particles)
    are accepted."""
    allowed = "a mapping of dotted scenario keys -> values, e.g. {restitution.kappa: 0.1}"
    value = sec.get(key, None, allowed)
    if not isinstance(value, Mapping):
        raise sec.error(key, f"got {show(value)}", allowed)
    here = Section(sec.file, sec.key(key), value)
    for dotted in value:
        if str(dotted) in RESERVED_KEYS:
            _check_override(here, str(dotted), value[dotted], base, before)
    try:
        with_overrides(base, {**before, **value})
    except ScenarioError as exc:
        for dotted, item in value.items():
            _check_override(here, str(dotted), item, base, before)
        raise sec.error(key, f"together these give an invalid scenario: {exc.key}: "
                        f"{exc.problem}", exc.allowed) from None
    return {str(k): v for k, v in value.items()}


def _check_override(sec: Section, dotted: str, value: Any, base: Scenario,
                    before: Mapping) -> None:
    if dotted in RESERVED_KEYS:
        raise sec.error(dotted, "is set by the study", "seeds come from 'seeds'; a run's "
                        "name, description and output path come from its hash")
    try:
        with_overrides(base, {**before, dotted: value})
    except ScenarioError as exc:
        raise sec.error(dotted, exc.problem if exc.key == dotted else
                        f"{show(value)} gives an invalid scenario: {exc.key}: {exc.problem}",
                        exc.allowed) from None


def _cases(top: Section, base: Scenario, length: dict, seeds: Sequence[int]
           ) -> tuple[tuple[tuple[str, dict], ...], dict[str, Start],
                      dict[str, tuple[int, ...]], dict[str, dict]]:
    """The cases' overrides, the starts of the cases that start from another's run, the
    seeds of the cases that name their own, and the lengths of those that name their own
    (``length`` is the study's length with its overrides)."""
    cases = top.section("cases", required=True, allowed="case name -> dotted overrides")
    if not cases.mapping:
        raise top.error("cases", "is empty", "case name -> dotted overrides (may be {})")
    names = [str(key) for key in cases.mapping]
    out, starts, case_seeds, case_lengths = [], {}, {}, {}
    for key in cases.mapping:
        name = _name(cases, str(key), key, "case")
        value = cases.mapping[key]
        if value is None:
            raise cases.error(name, "no value given", "a mapping of overrides ({} for none)")
        value, own_seeds, own_length = case_scope(cases, name, value, seeds)
        if own_seeds is not None:
            case_seeds[name] = own_seeds
        if own_length is not None:
            case_lengths[name] = own_length
        own = {**length, **(own_length or {})}
        if isinstance(value, Mapping) and "start" in value:
            starts[name] = read_start(cases, name, value["start"], names)
            value = {k: v for k, v in value.items() if k != "start"}
            check_case_keys(cases, name, value)
        here = Section(cases.file, cases.prefix, {name: value})
        out.append((name, _check_overrides(here, name, base, own)))
    check_cycles(cases, starts)
    return tuple(out), starts, case_seeds, case_lengths


def _ratios(top: Section, cases: Sequence[str]) -> tuple[tuple[str, str], ...]:
    allowed = "a list of [numerator, denominator] pairs of case names"
    value = top.get("ratios", [], allowed)
    if not isinstance(value, list):
        raise top.error("ratios", f"got {show(value)}", allowed)
    out: list[tuple[str, str]] = []
    for i, pair in enumerate(value):
        if not (isinstance(pair, list) and len(pair) == 2):
            raise top.error(f"ratios.{i}", f"got {show(pair)}", allowed)
        for name in pair:
            if name not in cases:
                close = difflib.get_close_matches(str(name), cases, n=1, cutoff=0.6)
                hint = f"did you mean {close[0]!r}? " if close else ""
                raise top.error(f"ratios.{i}", f"unknown case {show(name)}",
                                f"{hint}the cases: {', '.join(cases)}")
        if pair[0] == pair[1] or tuple(pair) in out:
            raise top.error(f"ratios.{i}", f"{pair} is a case over itself or repeated",
                            allowed)
        out.append((pair[0], pair[1]))
    return tuple(out)


def _quantities(top: Section, known: Sequence[str] | None) -> tuple[str, ...] | None:
    if not top.has("quantities"):
        return None
    allowed = ("a non-empty list of equilibrium quantities"
               + (f": {', '.join(known)}" if known else ""))
    value = top.get("quantities", None, allowed)
    if not isinstance(value, list) or not value or len(set(map(str, value))) != len(value):
        raise top.error("quantities", f"got {show(value)}", allowed)
    for name in value:
        if known is not None and name not in known:
            close = difflib.get_close_matches(str(name), known, n=1, cutoff=0.6)
            raise top.error("quantities", f"unknown quantity {show(name)}",
                            (f"did you mean {close[0]!r}? " if close else "") + allowed)
    return tuple(str(name) for name in value)


def _variants(sec: Section, base: Scenario, before: dict, ratio_cases: Sequence[str]
              ) -> tuple[tuple[tuple[str, dict], ...], dict[str, tuple[str, ...]],
                         tuple[str, ...]]:
    """The variants' overrides, the cases of the variants that name the cases whose runs
    they change, and the variants whose ``budget`` is ``range``."""
    variants = sec.section("variants", allowed="variant name -> dotted overrides, cases "
                           "(optional: the cases whose runs it changes) and budget")
    out, scopes, ranges = [], {}, []
    for key in variants.mapping:
        name = _name(variants, str(key), key, "variant")
        value, scope, part = read_variant_keys(variants, name, variants.mapping[key],
                                               ratio_cases)
        scopes.update({name: scope} if scope else {})
        ranges += [name] if part == "range" else []
        here = Section(variants.file, variants.prefix, {name: value})
        changes = _check_overrides(here, name, base, before)
        if not changes:
            raise variants.error(name, "is empty", "the overrides that change the method")
        out.append((name, changes))
    return tuple(out), scopes, tuple(ranges)


def _full_mode(top: Section, base: Scenario, seeds: tuple[int, ...], length: dict,
               ratio_cases: Sequence[str]) -> Mode:
    variants, scopes, ranges = _variants(top, base, length, ratio_cases)
    if top.has("variant_seeds") and not variants:
        raise top.error("variant_seeds", "given without variants", "remove it, or add variants")
    variant_seeds = (read_seeds(top, "variant_seeds", within=seeds) if top.has("variant_seeds")
                     else seeds[:1])
    return Mode(False, seeds, variant_seeds, length, {}, variants, scopes, ranges)


def _quick_mode(top: Section, base: Scenario, full: Mode, ratio_cases: Sequence[str]
                ) -> Mode | None:
    if not top.has("quick"):
        return None
    quick = top.section("quick", allowed="the --quick form: length, seeds, variant_seeds, "
                        "variants and dotted scenario overrides")
    for key in quick.mapping:
        name = str(key)
        close = difflib.get_close_matches(name, QUICK_KEYS, n=1, cutoff=0.6)
        if "." not in name and name not in QUICK_KEYS and close:
            raise quick.error(name, f"unknown key {name!r}", f"did you mean {close[0]!r}? "
                              f"allowed here: {', '.join(QUICK_KEYS)} and dotted scenario "
                              "keys")
    length = read_length(quick, "length") if quick.has("length") else full.length
    scenario_keys = {k: v for k, v in quick.mapping.items() if k not in QUICK_KEYS}
    overrides = _check_overrides(Section(top.file, "", {"quick": scenario_keys}), "quick",
                                 base, length)
    seeds = read_seeds(quick, "seeds") if quick.has("seeds") else full.seeds
    variants, scopes, ranges = (
        _variants(quick, base, {**length, **overrides}, ratio_cases) if quick.has("variants")
        else (full.variants, full.variant_cases, full.variant_ranges))
    if quick.has("variant_seeds"):
        if not variants:
            raise quick.error("variant_seeds", "given without variants", "remove it")
        variant_seeds = read_seeds(quick, "variant_seeds", within=seeds)
    else:
        variant_seeds = (full.variant_seeds if set(full.variant_seeds) <= set(seeds)
                         else seeds[:1])
    return Mode(True, seeds, variant_seeds, length, overrides, variants, scopes, ranges)


def _report(top: Section, folder: Path) -> str | None:
    if not top.has("report"):
        return None
    path = folder / top.string("report", what="a Markdown file, relative to the study file")
    if not path.is_file():
        raise top.error("report", f"no file {show(str(path))}",
                        "a Markdown file beside the study file: the study's prose")
    return str(path)


def _check_runs(study: Study) -> None:
    """Every case runs a seed in both forms, and every run of both forms is a valid
    scenario (cases and variants can clash)."""
    for quick in (False, True) if study.quick_mode is not None else (False,):
        mode = study.mode(quick)
        check_form_seeds(study.source, "quick" if quick else "full", mode.seeds,
                         mode.variant_seeds, study.ratio_cases(), study.case_seeds,
                         bool(mode.variants))
        try:
            study.specs(quick)
        except ScenarioError as exc:
            raise ScenarioError(study.source, "quick" if quick else "cases",
                                f"a run of the {'quick' if quick else 'full'} form is not a "
                                f"valid scenario: {exc.key}: {exc.problem}",
                                exc.allowed) from None


def load_study(path: str | PathLike, quantities: Sequence[str] | None = None) -> Study:
    """Read and check a study file (docs/studies.md); ScenarioError naming the key if it is
    invalid.

    Parameters
    ----------
    path : the study file (YAML)
    quantities : the equilibrium quantities ``quantities`` may name (None: not checked)
    """
    source = str(path)
    data = parse_yaml(read_text(path), source)
    if not isinstance(data, Mapping):
        raise ScenarioError(source, "<yaml>", "the top level is not a mapping",
                            "a YAML mapping with keys name, base, seeds and cases")
    top = Section(source, "", data)
    top.check_keys(STUDY_KEYS)
    name = _name(top, "name", top.get("name", REQUIRED, _NAME_TEXT), "study")
    description = top.string("description", "", allow_empty=True)
    base_file = top.string("base", what="a scenario file, relative to the study file")
    base_path = Path(source).parent / base_file
    if not base_path.is_file():
        raise top.error("base", f"no scenario file {show(str(base_path))}",
                        "a scenario file, relative to the study file")
    base = load_scenario(base_path)
    seeds = read_seeds(top, "seeds")
    length = read_length(top, "length") if top.has("length") else {}
    overrides = (_check_overrides(top, "overrides", base, length)
                 if top.has("overrides") else {})
    cases, starts, case_seeds, case_lengths = _cases(top, base, {**length, **overrides},
                                                     seeds)
    ratios = _ratios(top, [case for case, _ in cases])
    ratio_cases = [case for case, _ in cases if any(case in pair for pair in ratios)]
    full = _full_mode(top, base, seeds, length, ratio_cases)
    study_quantities = _quantities(top, quantities)
    if full.variants and not ratios:
        raise top.error("variants", "given without ratios", "variants measure the "
                        "systematic part of the ratios: add ratios, or remove variants")
    study = Study(name=name, description=description, source=source, base=base,
                  base_file=base_file, overrides=overrides, cases=cases, ratios=ratios,
                  quantities=study_quantities, full=full,
                  quick_mode=_quick_mode(top, base, full, ratio_cases),
                  report=_report(top, Path(source).parent),
                  quick_report=(_report(top.section("quick"), Path(source).parent)
                                if top.has("quick") else None),
                  references=read_references(top, [case for case, _ in cases], quantities,
                                             ratios, study_quantities or quantities),
                  starts=starts, case_seeds=case_seeds, case_lengths=case_lengths,
                  keep=read_keep(top))
    _check_runs(study)
    return study
