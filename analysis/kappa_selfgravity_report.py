"""The report of ``analysis/kappa_selfgravity.py``: ``analysis/kappa_selfgravity.md``.

Reads the runs of every case that exist, combines the seeds (``ringsim.analysis.compare``:
replicas, statistical error the larger of the propagated one and the seed scatter), forms
the ratio kappa = 0.1 / kappa = 0 with and without self-gravity with the systematic budget
of ``analysis/data/kappa_selfgravity_budget_<size>.json`` (what is in it is said in the
report), and writes the tables, the measured costs and what is not done.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
from kappa_comparison import fmt, fmt_ratio, relative_changes
from kappa_selfgravity import (
    BOX_LAMBDA,
    CASES,
    GRAVITY_ROWS,
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

from ringsim.analysis.budget import replica_mean
from ringsim.analysis.compare import comparison
from ringsim.analysis.compare import ratio as compare_ratio
from ringsim.analysis.equilibrium import TABLE_ROWS, equilibrium
from ringsim.analysis.timeseries import autocorrelated_mean
from ringsim.errors import InputError
from ringsim.physics.gravity import toomre_q
from ringsim.store.runfile import open_run

EXPLANATION_FILE = ROOT / "analysis" / "data" / "kappa_selfgravity_explanation.md"
#: The quantities of the headline table.
HEADLINE = ("velocity_dispersion", "thickness")


#: What went wrong in the first attempt, and why the protocol is what it is.
FIRST_ATTEMPT = [
    "## The first attempt, and why every run is now long and starts cold", "",
    "The first attempt started each gravity run at the velocity dispersion its no-gravity "
    "twin had settled at (isotropic, with the matching scale height) and stopped it when "
    "the equilibrium finder first called c and H stationary (`until_equilibrium`). For the "
    "power law at a = 1e8 m, tau = 0.25, kappa = 0.1 that gave c = 75 mm/s with gravity "
    "against 43 without, a ratio kappa 0.1 / 0 of 7.9 instead of 4.3. Gravity had nothing "
    "to do with it: the same start WITHOUT gravity overshoots to 80 mm/s within 4 orbits, "
    "stays within 2 % over orbits 2-5 - where the finder stopped the gravity run - and "
    "returns to 40 mm/s only after about 25 orbits (one run, seed 1, 80 orbits). A "
    "transient slower than the run so far looks stationary to any finder that sees only "
    "the run so far. Now both twins start from the scenario's initial state (the same "
    "particles, the scenario's initial dispersion), run a fixed number of orbits, and the "
    "finder chooses the window afterwards; docs/scenario.md warns about "
    "`until_equilibrium`. The first attempt's mono-1e8-0.25 ratios (4.69 ± 0.16 in c with "
    "gravity, 4.63 ± 0.22 without) agree with the final ones within their errors.",
]


def load_group(runs: Path, case: str, kappa: float, gravity: bool, seeds,
               slab: bool = False) -> dict:
    """Equilibria of one (case, kappa, gravity): ``kept`` (stationary), ``left_out`` (a line
    per run the finder did not call stationary), ``missing`` (seeds without a run).
    ``slab``: the gravity runs with the slab solver (``run_slab``) instead."""
    kept, left_out, missing = [], [], []
    for seed in seeds:
        path = (slab_output(runs, case, kappa, seed) if slab
                else output(runs, case, kappa, seed, gravity))
        if not path.exists():
            missing.append(seed)
            continue
        try:
            run = open_run(path)
        except (OSError, KeyError, InputError):   # being written, or damaged
            missing.append(seed)
            continue
        wanted = orbits(case, gravity, kappa, slab)
        if run.attrs.get("status") != "finished" or run.scenario.integration.orbits != wanted:
            missing.append(seed)     # still running, or not yet extended to its length
            continue
        eq = equilibrium(run)
        if not gravity:
            eq["toomre_Q"] = nograv_toomre_q(run, eq)
        (kept if eq["in_equilibrium"] else left_out).append(eq)
    return {"kept": kept, "left_out": [f"{e['name']} seed {e['scenario']['seed']}: "
                                       f"{e['reason']}" for e in left_out],
            "missing": missing}


def nograv_toomre_q(run, eq: dict) -> dict:
    """Toomre Q a run without self-gravity would have: Q = sigma_x Omega / (3.36 G Sigma)
    over its equilibrium window, Sigma [kg/m^2] from its first snapshot's masses."""
    snap = run.snapshot(0)
    sigma = float(np.sum(snap["mass"])) / (float(run.attrs["Lx"]) * float(run.attrs["Ly"]))
    ts = run.timeseries
    start = int(np.searchsorted(np.asarray(ts["orbits"]), eq["equilibrium_from_orbit"]["mean"]))
    q = toomre_q(np.sqrt(np.asarray(ts["sigma_xx"][start:])), sigma, float(run.attrs["Omega"]))
    mean, stderr, _ = autocorrelated_mean(q)
    return {"mean": float(mean), "stderr": float(stderr), "units": "dimensionless"}


def ratio(groups: list[dict], budget: dict | None) -> dict | None:
    """comparison() of [kappa 0, kappa 0.1] groups; None unless both have stationary runs."""
    if not all(g["kept"] for g in groups):
        return None
    return comparison(groups[0]["kept"] + groups[1]["kept"], budget)


def combined(group: dict, key: str) -> dict | None:
    """Seed mean of one quantity of a group (gravity rows are not in comparison())."""
    values = [e[key] for e in group["kept"] if key in e and math.isfinite(e[key]["mean"])]
    return replica_mean(values) if values else None


def quotient(a: dict | None, b: dict | None) -> dict | None:
    """a / b with first-order error (``ringsim.analysis.compare.ratio``); None without
    both."""
    return None if a is None or b is None else compare_ratio(a, b)


def fmt_quotient(q: dict | None) -> str:
    if q is None or not math.isfinite(q["mean"]):
        return ""
    return f"{q['mean']:.3g} ± {q['stderr']:.2g}"


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


def case_comps(groups: dict, slab: dict, budgets: dict) -> dict:
    """The comparisons kappa 0.1 / 0 of a case: no gravity (False), tree (True) and slab,
    each with its budget of ``budgets`` (None or missing: not measured)."""
    comps = {g: ratio([groups[(0.0, g)], groups[(0.1, g)]], budgets.get(g))
             for g in (False, True)}
    comps["slab"] = ratio([slab[0.0], slab[0.1]], budgets.get("slab"))
    return comps


def has_runs(group: dict) -> bool:
    """Whether a group has a finished run, stationary or not."""
    return bool(group["kept"] or group["left_out"])


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
    lines = ["Systematic parts are relative errors of the ratio kappa 0.1 / 0, added in "
             "quadrature (`ringsim compare`). They are measured with the slab solver and "
             "applied to the tree's ratio as well (a tree variant costs 20-40 times more); "
             "the slab's ratio also carries `gravity_solver`, the largest slab / tree "
             "difference (or its error, if larger) over the cases with both: of the ratio, "
             "or of the kappa = 0 ring where only it was run with the tree. "
             "The detection part is measured per step, not per run: kicked paths dissipate "
             "1.1e-3 ± 0.4e-3 less than the converged step (seven seeds, docs/gravity.md), "
             "far below every part of the budget.", ""]
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
    """Orbits the recorded CPU time covers (older records: from their stop reason)."""
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
    lines += ["- Boxes of at least 4 lambda_cr for wake statistics (here 2.1-4.2, and "
              "0.75-1.34 for the cases in SLAB_PARTICLES). No ring of identical particles "
              "here reaches the wake regime, but the power-law kappa = 0 ring at 1.3e8 m, "
              "tau = 0.5 sits at mass-weighted Q = 2.1 with the full field: its ratio needs "
              "full-field runs in a box of at least 2 lambda_cr.",
              "- With the slab solver the cases not run would cost about what their "
              "no-gravity runs cost (0.3-0.6 ms of CPU per particle-orbit)."]
    return lines


def budget_file(size: str) -> Path:
    """The systematic budget of the cases of size distribution ``size`` (``SIZES``)."""
    return ROOT / "analysis" / "data" / f"kappa_selfgravity_budget_{size}.json"


def write_budget(case: str, args, runs: Path) -> None:
    """The budget of ``case``'s size distribution from the variants of ``case``: for each
    kind of run (no gravity, slab), source and table quantity the relative change of the
    ratio kappa 0.1 / 0, or its statistical error if larger."""
    from kappa_selfgravity import SYSTEMATIC_VARIANTS, VARIANT_KINDS, variant_output

    def group(paths):
        eqs = [equilibrium(open_run(p)) for p in paths if p.exists()]
        return {"kept": [e for e in eqs if e["in_equilibrium"]]}

    out, unmeasured = {}, []
    for kind in VARIANT_KINDS:
        base = ratio([load_group(runs, case, k, kind != "nograv", args.base_seeds,
                                 slab=kind == "slab") for k in SCENARIOS], None)
        relative: dict[str, dict[str, float]] = {key: {} for key in TABLE_ROWS}
        for source in SYSTEMATIC_VARIANTS:
            other = ratio([group([variant_output(runs, source, case, k, s, kind)
                                  for s in args.seeds]) for k in SCENARIOS], None)
            if base is None or other is None:
                unmeasured.append(f"{kind} {source}: no stationary "
                                  + ("base runs" if base is None else "variant runs")
                                  + " of both kappa values")
                continue
            for key, value in relative_changes(base["ratios"][0], other["ratios"][0]).items():
                relative[key][source] = value
        out[kind] = {"relative": {k: v for k, v in relative.items() if v}}
    path = budget_file(CASES[case][0])
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({
        "description": f"the no-gravity and slab runs of case {case} (seeds "
                       f"{list(args.base_seeds)}) again, seeds {list(args.seeds)}, with the "
                       "step halved (dt) and with twice the particles, a box sqrt(2) times as "
                       "wide (n_particles); each entry the relative change of the ratio "
                       "kappa 0.1 / 0, or its statistical error if larger",
        "measured_by": f"analysis/kappa_selfgravity.py --systematics {case}",
        "not_measured": unmeasured, **out},
        indent=1) + "\n")


def load_budgets() -> dict:
    """size distribution -> its budget file's contents, for the files that exist."""
    return {size: json.loads(budget_file(size).read_text()) for size in SIZES
            if budget_file(size).exists()}


def solver_parts(loaded: dict) -> dict:
    """size distribution -> quantity -> the largest relative difference between slab and
    tree over the cases of that size distribution (or its statistical error if larger):
    of the ratio kappa 0.1 / 0 where both have it, else of the kappa = 0 ring where both
    have that (the ratio's denominator, and the ring gravity changes most).  The slab's
    systematic as a stand-in for the tree.  ``loaded``: case -> (groups, slab)."""
    parts: dict[str, dict[str, float]] = {}
    for case, (groups, slab) in loaded.items():
        comps = case_comps(groups, slab, {})
        if comps[True] is not None and comps["slab"] is not None:
            changes = relative_changes(comps[True]["ratios"][0], comps["slab"]["ratios"][0])
        elif groups[(0.0, True)]["kept"] and slab[0.0]["kept"]:
            changes = relative_changes(kappa0_values(groups[(0.0, True)]),
                                       kappa0_values(slab[0.0]))
        else:
            continue
        size = parts.setdefault(CASES[case][0], {})
        for key, value in changes.items():
            size[key] = max(size.get(key, 0.0), value)
    return parts


def kappa0_values(group: dict) -> dict:
    """The table quantities of a group in the form ``relative_changes`` reads: key ->
    {"mean", "statistical"} (NaN where the group has none)."""
    out = {}
    for key in TABLE_ROWS:
        c = combined(group, key)
        out[key] = ({"mean": c["mean"], "statistical": c["stderr"]} if c
                    else {"mean": math.nan, "statistical": math.nan})
    return out


def case_budgets(case: str, budgets: dict, solver: dict) -> dict:
    """The budgets of a case's three ratios: no gravity, tree and slab (the slab's with the
    solver part added); None where not measured."""
    size = CASES[case][0]
    b = budgets.get(size)
    nograv = b["nograv"] if b else None
    gravity = b["slab"] if b else None
    relative = {key: dict(parts) for key, parts in
                (gravity["relative"] if gravity else {}).items()}
    for key, value in solver.get(size, {}).items():
        relative.setdefault(key, {})["gravity_solver"] = value
    return {False: nograv, True: gravity, "slab": {"relative": relative} if relative else None}


def write_report(args, runs: Path, costs: dict) -> None:
    loaded, not_run = {}, []
    for case in CASES:
        groups = {(k, g): load_group(runs, case, k, g, args.seeds)
                  for k in SCENARIOS for g in (False, True)}
        slab = {k: load_group(runs, case, k, True, args.seeds, slab=True) for k in SCENARIOS}
        if not any(has_runs(g) for g in [*groups.values(), *slab.values()]):
            not_run.append(case)
            continue
        loaded[case] = (groups, slab)
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
    from kappa_selfgravity_p3m import P3M_SECTION, p3m_check_lines, slab_check_flags

    check = json.loads(P3M_CHECK.read_text()) if P3M_CHECK.exists() else {}
    check_lines, flags = p3m_check_lines(check), slab_check_flags(check, solver)
    lines = [
        "# Ring equilibria with kappa = 0 and kappa = 0.1 with self-gravity (issue 12, item 6)",
        "", "Produced by `python analysis/kappa_selfgravity.py --cases ... --seeds "
        + " ".join(str(s) for s in args.seeds) + "` (finished runs are reused; "
        "`--report-only` rewrites this file; `--slab CASE ...` runs the slab runs and "
        "their no-gravity twins). Each case: both kappa values, with and without "
        "self-gravity, every seed from the scenario's initial state (the same particles "
        "with and without gravity), for a fixed number of orbits (\"Run lengths\" below)"
        "; the equilibrium finder then chooses each run's "
        "window (MSER: the transient is cut) and a run it does not call stationary is left "
        "out. No run stops early: `until_equilibrium` was caught inside slow transients "
        "(see the note on the first attempt below). Self-gravity: REBOUND's tree "
        "(opening angle 0.3, the field beyond the ghost boxes added; 0.5 % rms force error, "
        "docs/gravity.md), softening 0.1 x the smallest radius, or, where a table says so, "
        "the slab solver (the vertical field of the horizontally averaged layer, "
        "docs/gravity.md 4c), which the tree was checked against. Collisions: line detection "
        "with kicked paths at 1e-3 orbit (docs/gravity.md, \"Line detection with "
        "self-gravity\"). Dilley law xi0 = 0.16, p = 0.65; solid ice, 900 kg/m^3. Boxes: at "
        f"least {BOX_LAMBDA:g} lambda_cr on a side and {MIN_PARTICLES} particles.", "",
        "## Set-up of the cases", "", *setup_table(done, runs), "",
        "### Run lengths [orbits]", "", *length_table(done, runs, args.seeds), "",
        "## The answer: kappa = 0.1 / kappa = 0, without and with self-gravity", "",
        *headline(rows), "",
        "Errors: statistical (seeds and autocorrelation, `ringsim compare`) and systematic "
        "(\"Error budget\" below); a ratio is formed only from runs the finder calls "
        "stationary. Cases run with the slab only (\"gravity, tree\" empty) give the ratio "
        "with the mean vertical field of self-gravity; the slab matched the tree where both "
        "were run (\"Slab against tree\"), and the difference is in their budget.", "",
        *([*flags, ""] if flags else []),
        *([P3M_SECTION, "", *check_lines, ""] if check_lines else []),
        "## What changes and why", "", *explanation, "",
        "## Error budget", "", *budget_lines(budgets, solver), "", *FIRST_ATTEMPT, "",
        "## Every case", "", *sections,
        "## Not done", "",
        *([f"- case {case}: not run ({patch(case)['n_particles']} particles"
            + (f"; {patch(case)['full_box_particles']} in a box of {BOX_LAMBDA:g} lambda_cr)"
               if patch(case)["full_box_particles"] != patch(case)["n_particles"] else ")")
           for case in not_run] or ["- every case was run"]),
        *not_done_lines(runs, costs, not_run + tree_less), "",
        "## Cost (measured, CPU of each run's worker process)", "",
        *cost_lines(runs, costs), ""]
    Path(args.report).write_text("\n".join(lines))
    REPORT.parent.mkdir(parents=True, exist_ok=True)
