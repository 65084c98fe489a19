"""The report of ``analysis/kappa_selfgravity.py``: ``analysis/kappa_selfgravity.md``.

Reads the runs of every case that exist, forms the ratio kappa = 0.1 / kappa = 0 with and
without self-gravity with its error budget (``kappa_selfgravity_ratios``), and writes the
tables, the P3M check of the slab (``kappa_selfgravity_p3m``), the measured costs and what
is not done.  The report's fixed text is in ``analysis/data/kappa_selfgravity_text.md``,
what its runs show (written by hand) in ``analysis/data/kappa_selfgravity_explanation.md``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
from kappa_comparison import fmt, fmt_ratio, prose
from kappa_selfgravity_cases import (
    BOX_LAMBDA,
    CASES,
    MIN_PARTICLES,
    P3M_CHECK,
    REPORT,
    ROOT,
    SCENARIOS,
    SIZES,
    last_orbit,
    orbits,
    output,
    patch,
    slab_output,
)
from kappa_selfgravity_p3m import P3M_SECTION, p3m_check_lines, slab_check_flags
from kappa_selfgravity_ratios import (
    HEADLINE,
    budget_file,
    case_budgets,
    case_comps,
    combined,
    fmt_quotient,
    has_runs,
    load_budgets,
    load_group,
    quotient,
    solver_parts,
)

from ringsim.analysis.equilibrium import TABLE_ROWS
from ringsim.errors import InputError
from ringsim.store.runfile import open_run

EXPLANATION_FILE = ROOT / "analysis" / "data" / "kappa_selfgravity_explanation.md"
#: The report's fixed text, part by part (``kappa_comparison.prose``): title and method,
#: the note on the errors, how the budget is measured, the first attempt, what is not done.
TEXT = ROOT / "analysis" / "data" / "kappa_selfgravity_text.md"
#: Gravity quantities shown beside the table rows: key -> (label, unit shown).
GRAVITY_ROWS = {"toomre_Q": ("Toomre Q (from sigma_x)", ""),
                "wake_wavelength": ("wake wavelength", "m"),
                "wake_amplitude": ("wake amplitude (peak contrast)", ""),
                "gravitational_viscosity": ("gravitational viscosity", "m^2/s")}


def case_table(groups: dict, comps: dict) -> list[str]:
    """Markdown: the four groups, both ratios, gravity / no gravity for each kappa."""
    head = ("| quantity | no gravity, kappa 0 | no gravity, kappa 0.1 | ratio, no gravity | "
            "gravity, kappa 0 | gravity, kappa 0.1 | ratio, gravity | gravity / no gravity, "
            "kappa 0 | gravity / no gravity, kappa 0.1 |")
    lines = [head, "|" + "---|" * 9]
    for key, (label, unit, scale) in {**TABLE_ROWS, **{k: (v[0], v[1], 1.0) for k, v in
                                                       GRAVITY_ROWS.items()}}.items():
        cells, means = [], {}
        for gravity in (False, True):
            for kappa in (0.0, 0.1):
                value = combined(groups[(kappa, gravity)], key)
                means[(kappa, gravity)] = value
                cells.append(fmt(value, scale) if value is not None else "-")
            comp = comps[gravity]
            if comp is not None and key in TABLE_ROWS:
                cells.append(fmt_ratio(comp["ratios"][0][key]))
            else:
                q = quotient(means[(0.1, gravity)], means[(0.0, gravity)])
                cells.append(fmt_quotient(q) or "-")
        cells += [fmt_quotient(quotient(means[(k, True)], means[(k, False)])) for k in (0.0, 0.1)]
        lines.append(f"| {label}{f' [{unit}]' if unit else ''} | " + " | ".join(cells) + " |")
    counts = [f"{len(groups[(k, g)]['kept'])}" for g in (False, True) for k in (0.0, 0.1)]
    lines.append(f"| stationary seeds | {counts[0]} | {counts[1]} | | {counts[2]} | {counts[3]} "
                 "| | | |")
    return lines


def case_section(case: str, groups: dict, slab: dict, comps: dict) -> list[str]:
    """Markdown of one case: its table (gravity columns from the tree, or from the slab
    where the tree has no stationary runs of both kappa values), the slab against the
    tree, the runs left out and the runs missing."""
    left = [line for g in [*groups.values(), *slab.values()] for line in g["left_out"]]
    missing = [f"{case} kappa {k:g} {'tree' if g else 'no gravity'} seeds {v['missing']}"
               for (k, g), v in groups.items() if v["missing"]]
    missing += [f"{case} kappa {k:g} slab seeds {v['missing']}" for k, v in slab.items()
                if v["missing"]]
    lines, tree = [], groups
    if comps[True] is None and comps["slab"] is not None:
        lines += ["Gravity columns: the slab solver (the mean vertical field only, docs/"
                  "gravity.md 4c); the tree has no stationary runs of both kappa values here.",
                  ""]
        groups = {**groups, **{(k, True): slab[k] for k in SCENARIOS}}
        comps = {**comps, True: comps["slab"]}
    lines += [*case_table(groups, comps), "", *slab_lines(case, tree, slab)]
    lines += [f"- not stationary, left out: {line}" for line in left]
    return lines + [f"- not run: {line}" for line in missing] + [""]


def slab_lines(case: str, groups: dict, slab: dict) -> list[str]:
    """Markdown: c and H of the slab runs of ``case`` (``slab``: kappa -> group) beside the
    tree's and no gravity's, and the kappa ratio of each; [] without finished slab runs or
    without tree runs (the case's table then shows the slab runs)."""
    if not any(has_runs(g) for g in slab.values()) or not any(
            has_runs(groups[(k, True)]) for k in SCENARIOS):
        return []
    lines = [f"Slab against tree ({case}): the gravity runs again with "
             "`sheet.gravity_solver: slab`, the vertical field of the horizontally averaged "
             "layer only (docs/gravity.md, 4c); same particles, box and lengths. Stationary "
             "slab seeds: " + ", ".join(f"kappa {k:g}: {len(g['kept'])}"
                                        for k, g in slab.items()) + ".", "",
             "| quantity | no gravity | tree | slab | tree / no gravity | slab / no gravity "
             "| slab / tree |", "|" + "---|" * 7]
    for key, (label, unit, scale) in ((k, TABLE_ROWS[k]) for k in HEADLINE):
        values = {}
        for kappa in SCENARIOS:
            row = {"none": combined(groups[(kappa, False)], key),
                   "tree": combined(groups[(kappa, True)], key),
                   "slab": combined(slab[kappa], key)}
            values[kappa] = row
            lines.append(_slab_row(f"{label}, kappa {kappa:g}", unit, scale, row))
        ratio_row = {name: quotient(values[0.1][name], values[0.0][name])
                     for name in ("none", "tree", "slab")}
        lines.append(_slab_row(f"{label}, ratio kappa 0.1 / 0", "", 1.0, ratio_row))
    return lines + [""]


def _slab_row(label: str, unit: str, scale: float, row: dict) -> str:
    cells = [fmt(row[n], scale) if row[n] is not None and unit else
             (fmt_quotient(row[n]) or "-") for n in ("none", "tree", "slab")]
    cells += [fmt_quotient(quotient(row[a], row[b])) or "-"
              for a, b in (("tree", "none"), ("slab", "none"), ("slab", "tree"))]
    return f"| {label}{f' [{unit}]' if unit else ''} | " + " | ".join(cells) + " |"


def case_attributes(runs: Path, case: str) -> dict:
    """The run attributes of the first readable run of ``case`` (tree runs first, then
    slab runs) that carries the self-gravity numbers (Lx, box_lambda_cr, r_h, Sigma,
    lambda_cr); {} if none does (no gravity run yet)."""
    keys = ("Lx", "box_lambda_cr", "r_h", "Sigma", "lambda_cr")
    for path_of in (lambda k, s: output(runs, case, k, s, True),
                    lambda k, s: slab_output(runs, case, k, s)):
        for kappa in SCENARIOS:
            for seed in (1, 2, 3):
                path = path_of(kappa, seed)
                try:
                    attrs = open_run(path).attrs
                except (OSError, KeyError, InputError):
                    continue
                if all(k in attrs for k in keys):
                    return attrs
    return {}


def setup_table(cases: list[str], runs: Path) -> list[str]:
    """The cases, with r_h, Sigma and lambda_cr of the drawn particles (a gravity run's
    attributes: the sample's Sigma differs from the distribution's by a few per cent)."""
    lines = ["| case | sizes | a [m] | tau | particles | box [m] | box / lambda_cr | r_h (mean "
             "pair) | Sigma [kg/m^2] | lambda_cr [m] |", "|" + "---|" * 10]
    for case in cases:
        size, a, tau = CASES[case]
        p = patch(case)
        d = SIZES[size]
        sizes = ("1 m" if d["kind"] == "monodisperse"
                 else f"{d['r_min']:g}-{d['r_max']:g} m, q = {d['q']:g}")
        attrs = case_attributes(runs, case)
        if not attrs:   # the distribution's numbers until a gravity run has drawn its own
            attrs = {"Lx": p["box"], "box_lambda_cr": p["box"] / p["lambda_cr"],
                     "r_h": math.nan, "Sigma": p["Sigma"], "lambda_cr": p["lambda_cr"]}
        r_h = "-" if math.isnan(float(attrs["r_h"])) else f"{float(attrs['r_h']):.2f}"
        lines.append(f"| {case} | {sizes} | {a:.3g} | {tau:g} | {p['n_particles']} | "
                     f"{float(attrs['Lx']):.0f} | {float(attrs['box_lambda_cr']):.2f} | "
                     f"{r_h} | {float(attrs['Sigma']):.0f} | "
                     f"{float(attrs['lambda_cr']):.1f} |")
    return lines


def length_table(cases: list[str], runs: Path, seeds) -> list[str]:
    """Orbits of every run of ``cases`` (``orbits``: every seed of a group alike); "-" for
    a group of tree runs without a file in ``runs`` for any of ``seeds``."""
    kinds = (("no gravity", False, False), ("tree", True, False), ("slab", True, True))
    lines = ["| case | " + " | ".join(f"{name}, kappa {k:g}" for name, _, _ in kinds
                                      for k in SCENARIOS) + " |", "|" + "---|" * 7]
    for case in cases:
        lines.append(f"| {case} | " + " | ".join(
            "-" if name == "tree" and not any(output(runs, case, k, s, True).exists()
                                              for s in seeds)
            else f"{orbits(case, gravity, k, slab):g}" for name, gravity, slab in kinds
            for k in SCENARIOS) + " |")
    return lines


def headline(rows: list[tuple[str, dict]]) -> list[str]:
    """The ratio kappa 0.1 / 0 of c and H, without gravity, with the tree and with the
    slab, case by case."""
    lines = ["| case | c: no gravity | c: gravity, tree | c: gravity, slab | H: no gravity | "
             "H: gravity, tree | H: gravity, slab |", "|---|---|---|---|---|---|---|"]
    for case, comps in rows:
        cells = []
        for key in HEADLINE:
            for solver in (False, True, "slab"):
                comp = comps[solver]
                cells.append(fmt_ratio(comp["ratios"][0][key]) if comp else "-")
        lines.append(f"| {case} | " + " | ".join(cells) + " |")
    return lines


def budget_lines(budgets: dict, solver: dict) -> list[str]:
    """Markdown: how each size distribution's budget was measured, and its parts for c
    and H (per cent of the ratio), the slab's solver part included."""
    lines = [*prose(TEXT)["budget"], ""]
    if not budgets and not solver:
        return lines + ["No budget file yet: the systematic parts are \"not measured\"."]
    lines += ["| size distribution | ratio | source | c [%] | H [%] |", "|---|---|---|---|---|"]
    for size in SIZES:
        b = budgets.get(size, {})
        for kind, label in (("nograv", "no gravity"), ("slab", "gravity (tree and slab)")):
            rel = b.get(kind, {}).get("relative", {})
            for source in sorted({src for parts in rel.values() for src in parts}):
                cells = [f"{100 * rel.get(key, {}).get(source, math.nan):.2g}"
                         for key in HEADLINE]
                lines.append(f"| {size} | {label} | {source} | " + " | ".join(cells) + " |")
        if size in solver:
            cells = [f"{100 * solver[size].get(key, math.nan):.2g}" for key in HEADLINE]
            lines.append(f"| {size} | gravity, slab | gravity_solver | " + " | ".join(cells)
                         + " |")
    lines += [""] + [f"- {size}: {b['description']} (`{b['measured_by']}`)."
                     + "".join(f" Not measured: {x}." for x in b.get("not_measured", []))
                     for size, b in budgets.items()]
    return lines


def recorded_orbits(cost: dict) -> float | None:
    """Orbits the recorded CPU time covers (a record without "orbits": from its stop
    reason)."""
    if "orbits" in cost:
        return float(cost["orbits"])
    found = re.search(r"orbits = ([0-9.eE+-]+)", cost.get("stop_reason", ""))
    return float(found.group(1)) if found else None


def cost_lines(runs: Path, costs: dict) -> list[str]:
    lines = ["| run | orbits | CPU [s] | orbits the CPU covers | CPU per orbit [s] | "
             "stop reason |", "|---|---|---|---|---|---|"]
    for path in sorted(runs.glob("*.h5")):
        c = costs.get(path.name)
        if c is None:
            continue
        try:
            run = open_run(path)
            done = last_orbit(run)
        except (OSError, KeyError, InputError):
            continue
        covered = recorded_orbits(c) or done
        note = "" if abs(covered - done) < 1e-6 else " (an extension's CPU not recorded)"
        lines.append(f"| {path.name} | {done:.3g} | {c['cpu_s']:.0f} | {covered:.3g}{note} | "
                     f"{c['cpu_s'] / max(covered, 1e-9):.3g} | "
                     f"{run.attrs.get('stop_reason', '')} |")
    return lines


def cpu_per_particle_step(runs: Path, costs: dict, pattern: str) -> list[float]:
    """CPU [s] per particle-step (1000 steps per orbit) of the recorded runs ``pattern``."""
    rates = []
    for path in runs.glob(pattern):
        c = costs.get(path.name)
        if c is None:
            continue
        try:
            run = open_run(path)
            covered = recorded_orbits(c) or last_orbit(run)
        except (OSError, KeyError, InputError):   # being written
            continue
        rates.append(c["cpu_s"] / (covered * 1000.0 * run.scenario.sheet.n_particles))
    return rates


def full_field_cpu(cases: list[str], rate: float) -> float:
    """CPU [s] of the gravity runs of ``cases`` (2 kappa values x 3 seeds at the lengths
    above, boxes of ``BOX_LAMBDA`` lambda_cr) at ``rate`` s per particle-step."""
    return sum(3 * 1000.0 * patch(case)["full_box_particles"] * rate * orbits(case, True, k)
               for case in cases for k in SCENARIOS)


def not_done_lines(runs: Path, costs: dict, no_tree: list[str]) -> list[str]:
    """The cost of the full-field runs of the cases without tree runs (``no_tree``), from
    the measured CPU per particle-step of the tree and of the P3M runs, and the rest."""
    lines = []
    tree, p3m = (cpu_per_particle_step(runs, costs, pattern)
                 for pattern in ("gravity_*.h5", "p3m_*.h5"))
    if tree and no_tree:
        rate = float(np.median(tree))
        lines.append(f"- Tree runs of {', '.join(no_tree)} (2 kappa values x 3 seeds at "
                     f"the lengths above, boxes of {BOX_LAMBDA:g} lambda_cr) at the measured "
                     f"{rate * 1e6:.1f} us of CPU per particle-step (median of the tree runs "
                     f"above): about {full_field_cpu(no_tree, rate) / 3600:.0f} CPU-hours, "
                     "more where the tree's cost per particle grows with N. The slab runs "
                     "stand in for them (\"Slab against tree\").")
    if p3m and no_tree:
        rate = float(np.median(p3m))
        lines.append(f"- The same runs with P3M, the cheaper solver of the full field, at its "
                     f"measured {rate * 1e6:.1f} us per particle-step (median of the P3M "
                     f"runs): about {full_field_cpu(no_tree, rate) / 3600:.0f} CPU-hours. The "
                     "P3M checks (\"The slab against the full field (P3M)\") say where the "
                     "slab may stand in: not for a size distribution at mass-weighted Q below "
                     "about 5.")
    missing = [size for size in SIZES if not budget_file(size).exists()]
    lines += [f"- The systematic budget of the {size} cases (no budget file)."
              for size in missing]
    lines += prose(TEXT)["not done"]
    return lines


def load_cases(runs: Path, seeds) -> tuple[dict, list[str]]:
    """The groups of every case with a finished run in ``runs`` (seeds ``seeds``): case ->
    (groups, slab) with groups (kappa, gravity) -> ``load_group`` and slab kappa ->
    ``load_group`` of its slab runs; and the cases without one."""
    loaded, not_run = {}, []
    for case in CASES:
        groups = {(k, g): load_group(runs, case, k, g, seeds)
                  for k in SCENARIOS for g in (False, True)}
        slab = {k: load_group(runs, case, k, True, seeds, slab=True) for k in SCENARIOS}
        if not any(has_runs(g) for g in [*groups.values(), *slab.values()]):
            not_run.append(case)
            continue
        loaded[case] = (groups, slab)
    return loaded, not_run


def not_run_lines(not_run: list[str]) -> list[str]:
    """Markdown list of the cases without runs, with their particles."""
    lines = []
    for case in not_run:
        p = patch(case)
        full = (f"; {p['full_box_particles']} in a box of {BOX_LAMBDA:g} lambda_cr)"
                if p["full_box_particles"] != p["n_particles"] else ")")
        lines.append(f"- case {case}: not run ({p['n_particles']} particles" + full)
    return lines or ["- every case was run"]


def write_report(args, runs: Path, costs: dict) -> None:
    """Write the report to ``args.report`` from the runs in ``runs`` (seeds ``args.seeds``)
    and the recorded CPU ``costs`` (file name -> record)."""
    loaded, not_run = load_cases(runs, args.seeds)
    budgets = load_budgets()
    solver = solver_parts(loaded)
    rows, sections = [], []
    for case, (groups, slab) in loaded.items():
        comps = case_comps(groups, slab, case_budgets(case, budgets, solver))
        rows.append((case, comps))
        sections += [f"### {case}", "", *case_section(case, groups, slab, comps)]
    tree_less = [case for case, comps in rows if comps[True] is None]
    explanation = (EXPLANATION_FILE.read_text().splitlines() if EXPLANATION_FILE.exists()
                   else ["(not written yet)"])
    done = [case for case, _ in rows]
    check = json.loads(P3M_CHECK.read_text()) if P3M_CHECK.exists() else {}
    check_lines, flags = p3m_check_lines(check), slab_check_flags(check, solver)
    text = prose(TEXT)
    head = [line.format(seeds=" ".join(str(s) for s in args.seeds), box_lambda=BOX_LAMBDA,
                        min_particles=MIN_PARTICLES) for line in text["head"]]
    lines = [
        *head, "",
        "## Set-up of the cases", "", *setup_table(done, runs), "",
        "### Run lengths [orbits]", "", *length_table(done, runs, args.seeds), "",
        "## The answer: kappa = 0.1 / kappa = 0, without and with self-gravity", "",
        *headline(rows), "", *text["errors"], "",
        *([*flags, ""] if flags else []),
        *([P3M_SECTION, "", *check_lines, ""] if check_lines else []),
        "## What changes and why", "", *explanation, "",
        "## Error budget", "", *budget_lines(budgets, solver), "", *text["first attempt"], "",
        "## Every case", "", *sections,
        "## Not done", "", *not_run_lines(not_run),
        *not_done_lines(runs, costs, not_run + tree_less), "",
        "## Cost (measured, CPU of each run's worker process)", "",
        *cost_lines(runs, costs), ""]
    Path(args.report).write_text("\n".join(lines))
    REPORT.parent.mkdir(parents=True, exist_ok=True)
