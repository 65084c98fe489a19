"""``report.md`` of a study: its prose, the generated tables, the cost and the command."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence

from ringsim.analysis import budget
from ringsim.analysis.equilibrium import TABLE_ROWS
from ringsim.study import cassini
from ringsim.study.by_size import by_size_lines
from ringsim.study.kept import kept_section
from ringsim.study.references import references_section
from ringsim.study.variant_sizes import variant_by_size_lines


def _num(x: float | None, digits: int = 4) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def _pm(value: Mapping, scale: float = 1.0) -> str:
    """``mean ± error``, an error at the round-off of its value shown as 0
    (``budget.shown_error``; report.json keeps it as computed)."""
    mean = value["mean"]
    if mean is None or not math.isfinite(mean):
        return "n/a"
    err = budget.shown_error(mean, value["stderr"])
    return f"{mean * scale:.4g} ± {_num(err * scale if err is not None else None, 2)}"


def _label(quantity: str) -> str:
    label, unit, _scale = TABLE_ROWS[quantity]
    return label + (f" [{unit}]" if unit else "")


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    return (["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            + ["| " + " | ".join(row) + " |" for row in rows])


def _changes(overrides: Mapping) -> str:
    """``key: value`` pairs, values as YAML writes them (``true``, ``5e-4``)."""
    return ", ".join(f"`{k}: {v if isinstance(v, str) else json.dumps(v)}`"
                     for k, v in overrides.items()) or "none"


def _start(start: Mapping | None) -> str:
    """How a case's runs start, when from another case's run."""
    if start is None:
        return ""
    seed = "the same seed" if start["seed"] is None else f"seed {start['seed']}"
    return (f"; starts from snapshot {start['snapshot']} of case `{start['case']}`'s run of "
            f"{seed} (same form and variant), tiled {start['tile'][0]} x {start['tile'][1]}")


def _scope(variant: Mapping) -> str:
    """What a variant that names its cases leaves as it is."""
    if "cases" not in variant:
        return ""
    kept = [case for case in variant["runs"] if case not in variant["cases"]]
    return (f"; it changes the runs of {', '.join(f'`{c}`' for c in variant['cases'])} only"
            + (f" ({', '.join(f'`{c}`' for c in kept)} keep their own runs: the study file "
               "states that the variant does not change them)" if kept else ""))


def setup_section(report: Mapping) -> list[str]:
    """What was run: the base, the changes of every run, the cases and the variants."""
    lines = ["## Set-up", "", f"Base scenario `{report['base']}`; every run: "
             f"{_changes({**report['length'], **report['overrides']})}"
             + (f"; the quick form then sets {_changes(report['quick_overrides'])}"
                if report["form"] == "quick" else "") + f". Seeds {report['seeds']}.", ""]
    lines += [f"- case `{case}`: {_changes(entry['overrides'])}" + _start(entry.get("start"))
              + (f" (seeds {entry['seeds']} only)" if "seeds" in entry else "")
              + (f"; its length, in place of every run's: {_changes(entry['length'])}"
                 if "length" in entry else "")
              for case, entry in report["cases"].items()]
    lines += [f"- variant `{name}` (seeds {report['variant_seeds']}): "
              f"{_changes(v['overrides'])}" + _scope(v)
              + ("; a model parameter's range (`budget: range`), not in the systematic error"
                 if v.get("budget") == "range" else "")
              for name, v in report["variants"].items()]
    return lines + [""]


def equilibria_section(report: Mapping) -> list[str]:
    cases = report["cases"]
    rows = []
    for quantity in TABLE_ROWS:
        scale = TABLE_ROWS[quantity][2]
        first = next(iter(cases.values()))["equilibrium"][quantity]
        rows.append([_label(quantity), first["weighting"].split(":")[0]]
                    + [_pm(c["equilibrium"][quantity], scale) for c in cases.values()])
    rows.append(["in equilibrium (every seed)", ""]
                + [str(c["in_equilibrium"]).lower() for c in cases.values()])
    return (["## Equilibria", "",
             f"Mean over the seeds {report['seeds']}: {report['averaging']}. The weighting "
             "says what each quantity counts equally (report.json gives it in full).", ""]
            + _table(["quantity", "weighting", *cases], rows) + [""])


def _ratio_text(entry: Mapping, variant_seeds: Sequence[int] = ()) -> str:
    if entry["mean"] is None or not math.isfinite(entry["mean"]):
        return "n/a"
    syst = budget.shown_error(entry["mean"], entry["syst"])
    syst_text = (f" ± {_num(syst, 2)} (syst)" if syst is not None and math.isfinite(syst)
                 else " (syst. not measured)")
    stat = budget.shown_error(entry["mean"], entry["stat"])
    ranges = "".join(f"; {_num(part['ratio_without'])} → {_num(part['ratio'])} with "
                     f"{variant} (range; seeds {list(variant_seeds)})"
                     for variant, part in entry.get("range_parts", {}).items())
    return f"**{entry['mean']:.4g}** ± {_num(stat, 2)} (stat){syst_text}{ranges}"


def _paired_lines(report: Mapping) -> list[str]:
    """Each seed's ratio and their mean (the seed-paired ratio), where a ratio has two or
    more common seeds."""
    entries = [e for e in report["ratios"]
               if e.get("paired") and e["paired"]["n_replicas"] > 1]
    if not entries:
        return []
    seeds = sorted({int(s) for e in entries for s in e["paired"]["by_seed"]})
    rows = [[f"{e['numerator']} / {e['denominator']}", _label(e["quantity"])]
            + [_num(e["paired"]["by_seed"][str(s)]) if str(s) in e["paired"]["by_seed"]
               else "–" for s in seeds]
            + [f"**{e['paired']['mean']:.4g}** ± "
               f"{_num(budget.shown_error(e['paired']['mean'], e['paired']['stderr']), 2)}"]
            for e in entries]
    return (["### Seed by seed", "",
             "Each seed's ratio, of the runs of the two cases with that seed (the same radii "
             "and starting positions), and their mean with the larger of the propagated window "
             "error and the seeds' standard error of the mean: the seed-paired ratio. It "
             "divides out what a realisation gives both cases alike, which the ratio of the "
             "seed means above keeps in its statistical error.", ""]
            + _table(["ratio", "quantity", *(f"seed {s}" for s in seeds), "paired mean"],
                     rows) + [""])


def ratios_section(report: Mapping, figure: str | None) -> list[str]:
    if not report["ratios"]:
        return []
    pairs = list(dict.fromkeys((e["numerator"], e["denominator"]) for e in report["ratios"]))
    by = {(e["numerator"], e["denominator"], e["quantity"]): e for e in report["ratios"]}
    rows = [[_label(q)] + [_ratio_text(by[(n, d, q)], report["variant_seeds"])
                           for n, d in pairs]
            for q in report["quantities"]]
    lines = ["## Ratios", "", f"Systematic part: {report['systematics']}.", ""]
    lines += _table(["quantity", *(f"{n} / {d}" for n, d in pairs)], rows) + [""]
    common = {(e["numerator"], e["denominator"]): e["seeds"] for e in report["ratios"]
              if e.get("seeds") is not None}
    if common:
        lines += ["Where the two cases ran different seeds, the ratio is of their seed means "
                  "over the seeds both ran (a case's other seeds are other realisations, "
                  "which would enter one side only). Its statistical error is then that of "
                  "those seeds' runs; of one seed, that run's window error alone, without "
                  "the scatter between realisations. "
                  + "; ".join(f"{n} / {d}: " + (f"seeds {seeds}" if seeds else
                                                "no seed in common, so of different "
                                                "realisations")
                              for (n, d), seeds in common.items()) + ".", ""]
    if figure:
        lines += [f"![The ratios with their statistical and total errors]({figure})", ""]
    lines += _paired_lines(report)
    shifts = [[f"{e['numerator']} / {e['denominator']}", _label(e["quantity"]), variant,
               _num(part["ratio"]), _num(part["ratio_without"]), _num(part["shift"], 2),
               _num(part["noise"], 2), _num(part.get("seed_noise"), 2)]
              for e in report["ratios"]
              for variant, part in [*e["syst_parts"].items(),
                                    *((f"{v} (range)", p)
                                      for v, p in e.get("range_parts", {}).items())]]
    if shifts:
        lines += ["### The variants' shifts", "",
                  f"Seeds {report['variant_seeds']}, with and without each variant. The "
                  "last column is the shift that realisation alone gives: the seed-to-seed "
                  "standard deviation of one seed's ratio times sqrt(2 / variant seeds) "
                  "(n/a with fewer than two seeds). A variant run with the same seed is "
                  "another realisation, so a shift below it is not told apart from chance "
                  "even where it exceeds its statistical error; the budget counts it "
                  "(an upper estimate)."
                  + (" A variant marked (range) is not in the budget: its rows give the "
                     "ratio at the other end of the range a model parameter is known within."
                     if any(e.get("range_parts") for e in report["ratios"]) else ""), ""]
        lines += _table(["ratio", "quantity", "variant", "with the variant",
                         "without", "shift", "its stat. error", "seed noise"], shifts)
        lines += [""]
    return lines


def _cassini_cell(entry: Mapping, quantity: str) -> str:
    if not entry["gravity"]:
        return "-"
    value = entry.get(quantity)
    if value is None and entry.get("seeds_measured") and quantity in cassini.BAR_MODEL:
        return "no wake"
    return "not measured" if value is None else _pm(value)


def _seeds_cell(entry: Mapping) -> str:
    n, waking = entry["seeds_measured"], entry.get("seeds_with_wake")
    return str(n) if waking is None or waking == n else f"{n} ({waking} with a wake)"


def _toomre_cell(entry: Mapping) -> str:
    """The case's mass-weighted Toomre Q, with the seeds it is of where not all."""
    if entry.get("toomre_Q_mass") is None:
        return "-" if not entry["gravity"] else "not measured"
    n, of = entry["seeds_with_gravity"], entry["n_seeds"]
    return _pm(entry["toomre_Q_mass"]) + (f" ({n} of {of} seeds)" if n < of else "")


def cassini_section(report: Mapping) -> list[str]:
    """The synthetic occultations of the gravitating cases beside the published Cassini
    values (``report.json``'s ``against_cassini``; none without one)."""
    table = report.get("against_cassini")
    if not table:
        return []
    b = f"{table['asymmetry_elevation_deg']:g}°"
    header = ["case", "κ", "size distribution", "friction", "seeds measured", "H/W",
              "gap τ", "wake angle from radial [deg]", f"asymmetry of τ_n at B = {b}",
              f"peak T at B = {b}", "geometric τ", "fit's reduced χ² (largest seed)",
              "consistent with"]
    rows = [[case, _num(e["kappa"]), e["size_distribution"], e["friction"],
             _seeds_cell(e) if e["gravity"] else "-"]
            + [_cassini_cell(e, q) for q in cassini.QUANTITIES]
            + [_num(e["fit_reduced_chi2_max"]) if e.get("fit_reduced_chi2_max") is not None
               else "-", f"**{e['verdict']}**"]
            for case, e in table["cases"].items()]
    toomre = ""
    if any("toomre_Q_mass" in e for e in table["cases"].values()):
        header.insert(5, "Toomre Q (mass-weighted σ_x)")
        for row, e in zip(rows, table["cases"].values(), strict=True):
            row.insert(5, _toomre_cell(e))
        toomre = ("Toomre Q: σ_x Ω / (3.36 G Σ) with the mass-weighted radial velocity "
                  "dispersion of the window's snapshots (`analyze`'s `toomre_Q_mass`), the "
                  "Q of the mass a wake is made of, over the seeds whose summary holds it "
                  "(report.json adds Q by number, λ_cr and r_h). ")
    published = [[p["ring"], p["quantity"], p["text"], p["source"]]
                 for p in table["published"].values()]
    return (["## Against Cassini", "",
             f"What a stellar occultation would measure of each case: {table['geometry']}. "
             "Mean ± standard error over the seeds whose summary holds the occultations "
             "(the larger of the propagated error and the seed-to-seed one); \"not "
             "measured\": summaries made before they kept the occultations; n/a: no "
             "number (an asymmetry of views some of which let no ray through). The bar model's "
             "H/W, gap τ and wake angle are means over the seeds with a significant wake "
             "and a fit (\"no wake\": no such seed); the table shows the largest reduced "
             "χ² of a case's fits. " + toomre +
             f"Rule: {table['rule']}.", ""]
            + _table(header, rows) + ["", "The published values:", ""]
            + _table(["ring", "quantity", "published", "source"], published) + [""])


def runs_section(report: Mapping) -> list[str]:
    rows = []
    groups = [(case, "", entry["runs"]) for case, entry in report["cases"].items()]
    groups += [(case, name, runs) for name, v in report["variants"].items()
               for case, runs in v["runs"].items()]
    for case, variant, runs in groups:
        rows += [[case, variant, str(r["seed"]), f"`{r['run']}`", str(r["n_particles"]),
                  _num(r["orbits"]), str(r["in_equilibrium"]).lower(), r["stop_reason"]]
                 for r in runs]
    return (["## Runs", "", "Each run is named by the hash of its scenario; its summary is "
             "`summaries/<run>.json` beside the study file.", ""]
            + _table(["case", "variant", "seed", "run", "particles", "orbits",
                      "in equilibrium", "stop reason"], rows) + [""])


def _cpu_s(summary: Mapping) -> float | None:
    value = summary["cost"].get("cpu_time_s")
    return None if value is None else float(value)


def _cpu_part_s(summary: Mapping) -> float | None:
    """The CPU time [s] of a run's last sessions where its whole is unknown (its run file
    began before runs kept their CPU time), else None."""
    value = summary["cost"].get("cpu_time_s_part")
    return None if _cpu_s(summary) is not None or value is None else float(value)


def _cpu_hours(group: Sequence[Mapping]) -> str:
    """The CPU-hours of a group of runs' summaries, naming the runs without a CPU time; a
    run with only the part of its last sessions (``cpu_time_s_part``) makes the sum a
    lower bound."""
    known = [c for c in (_cpu_s(s) for s in group) if c is not None]
    parts = [c for c in (_cpu_part_s(s) for s in group) if c is not None]
    missing = len(group) - len(known) - len(parts)
    if parts:
        return (f"≥ {(sum(known) + sum(parts)) / 3600:.3g} ({len(parts)} run(s): their "
                "last sessions only" + (f"; + {missing} not recorded" if missing else "")
                + ")")
    text = f"{sum(known) / 3600:.3g}" if known else "not recorded"
    return text + (f" (+ {missing} run(s) not recorded)" if known and missing else "")


def _variant_cpu_hours(runs: list[Mapping], base: set[str], case: str,
                      summaries: Mapping[str, dict]) -> str:
    """The CPU-hours of a variant's runs of ``case``, without the runs it shares with the
    case (``base``: a variant that does not change a case keeps that case's runs, whose
    cost its own row counts)."""
    own = [summaries[r["run"]] for r in runs if r["run"] not in base]
    shared = len(runs) - len(own)
    if not own:
        return f"the runs of {case}, counted in its row"
    return _cpu_hours(own) + (f" (+ {shared} run(s) of {case}, counted in its row)"
                              if shared else "")


def cost_section(report: Mapping, summaries: Mapping[str, dict]) -> list[str]:
    """CPU-hours of each case and variant, from the summaries' ``cost``."""
    groups = [(case, entry["runs"]) for case, entry in report["cases"].items()]
    rows = [[name, str(len(runs)), _cpu_hours([summaries[r["run"]] for r in runs])]
            for name, runs in groups]
    for name, v in report["variants"].items():
        for case, runs in v["runs"].items():
            label = f"{case} [{name}]"
            groups.append((label, runs))
            rows.append([label, str(len(runs)), _variant_cpu_hours(
                runs, {r["run"] for r in report["cases"][case]["runs"]}, case, summaries)])
    distinct = sorted({r["run"] for _, runs in groups for r in runs})
    part = [rid for rid in distinct if _cpu_part_s(summaries[rid]) is not None]
    unknown = [rid for rid in distinct if _cpu_s(summaries[rid]) is None and rid not in part]
    total = sum(_cpu_s(summaries[rid]) or _cpu_part_s(summaries[rid]) or 0.0
                for rid in distinct) / 3600
    lines = ["## Cost", "", "CPU time of the sessions that ran each run, from the "
             "summaries (a session killed before its run finished is not counted).", ""]
    lines += _table(["case", "runs", "CPU-hours"], rows)
    lines += ["", f"Total: {'≥ ' if part else ''}{total:.3g} CPU-hours for {len(distinct)} "
              "distinct runs."]
    if part:
        lines[-1] += (f" {len(part)} run(s) count only their last sessions: their run files "
                      "began before runs kept their CPU time.")
    if unknown:
        wall = sum(summaries[rid]["cost"].get("run_wall_time_s") or 0.0 for rid in unknown)
        lines[-1] += (f" {len(unknown)} run(s) were summarised from a finished run file "
                      f"without their CPU time (integration wall time {wall / 3600:.3g} h).")
    return lines + [""]


def report_markdown(report: Mapping, summaries: Mapping[str, dict], prose: str,
                    command: str, figure: str | None) -> str:
    """The text of ``report.md``."""
    form = ("the quick form (reduced, for a first look; not the study's result)"
            if report["form"] == "quick" else "the full form")
    lines = [f"# Study {report['study']}", ""]
    if report["description"]:
        lines += [report["description"], ""]
    lines += [f"Generated by ringsim {report['ringsim_version']} from the runs' summaries, "
              f"{form}: `{command}` regenerates it, running only the runs without a "
              "summary; with `--report-only` it is rewritten from the summaries alone. "
              "Every number is also in `report.json`.", ""]
    if report.get("partial"):
        lines += [f"**{report['partial']}**", ""]
    if prose.strip():
        lines += [prose.strip(), ""]
    lines += setup_section(report) + equilibria_section(report)
    lines += references_section(report.get("references", []),
                                report.get("references_rule", ""))
    lines += kept_section(report)
    lines += ratios_section(report, figure) + by_size_lines(report.get("by_size", {}))
    lines += variant_by_size_lines(report.get("by_size", {}).get("variants", []))
    lines += cassini_section(report)
    lines += runs_section(report) + cost_section(report, summaries)
    if report["warnings"]:
        lines += ["## Warnings", ""] + [f"- {w}" for w in report["warnings"]] + [""]
    return "\n".join(lines)
