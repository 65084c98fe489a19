"""The mission's comparison: ring equilibria with mass exponent kappa = 0 against kappa = 0.1.

Runs (or reuses finished runs of) ``scenarios/kappa0.yaml`` and ``scenarios/kappa0.1.yaml``
with several seeds, plus a monodisperse variant of both, every run until the equilibrium
finder calls c and H stationary (``integration.until_equilibrium``), and writes
``analysis/kappa_comparison.md``: the equilibria, the ratios kappa = 0.1 / kappa = 0 with
their full error budget (``ringsim.analysis.budget``: statistical from seeds and
autocorrelation, systematic from measured method variants), the per-size ratios with their
bins and the equipartition value for the same bins, the dilute kinetic estimate, and the
fraction of impacts outside the speeds the Dilley law was fitted to.

    python analysis/kappa_comparison.py [--seeds 1 2 3] [--workers 2]
    python analysis/kappa_comparison.py --systematics      # also measure the budget

``--systematics`` runs the power-law pair again with N/4 particles, with a fixed step half
the automatic one, and in a box of aspect 2, and writes the relative change of every ratio
to ``analysis/data/kappa_budget_<variant>.json`` (the file ``ringsim compare --systematics``
reads).
The collision-detection part comes from the line-vs-tree measurement of
``python -m validation line-mode`` (``analysis/data/line_mode_validation.json``).
A run the finder does not call stationary is never averaged: it is listed and left out.

``--friction constant:0`` (or ``coulomb:0.5``) runs the same comparison with rough
particles (the scenario's ``friction`` section) into ``runs/kappa_friction``, writes
``analysis/kappa_friction.md`` and the budget ``analysis/data/kappa_friction_budget_*.json``,
and adds the spin numbers (E_rot/E_tr, spins in units of Omega, the dissipation shares)::

    python analysis/kappa_comparison.py --friction constant:0 --variants powerlaw \
        --seeds 1 2 3 --particles 2000 --max-orbits 300 --systematics
"""

from __future__ import annotations

import argparse
import json
import math
import re
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import ringsim
from ringsim.analysis.budget import SOURCES
from ringsim.analysis.compare import comparison
from ringsim.analysis.equilibrium import TABLE_ROWS, equilibrium, size_ratio_line
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.plots import plot_comparison
from ringsim.store.runfile import open_run

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = {"kappa = 0": ROOT / "scenarios" / "kappa0.yaml",
             "kappa = 0.1": ROOT / "scenarios" / "kappa0.1.yaml"}
REPORT = ROOT / "analysis" / "kappa_comparison.md"
FIGURES = ROOT / "analysis" / "figures"
BUDGET = ROOT / "analysis" / "data" / "kappa_budget_{variant}.json"
FRICTION_REPORT = ROOT / "analysis" / "kappa_friction.md"
FRICTION_BUDGET = ROOT / "analysis" / "data" / "kappa_friction_budget_{variant}.json"
LINE_VALIDATION = ROOT / "analysis" / "data" / "line_mode_validation.json"
#: The reports' fixed text, part by part (``prose``): why kappa changes the equilibrium,
#: without and with friction, and where the detection part of the budget comes from.
TEXT = ROOT / "analysis" / "data" / "kappa_comparison_text.md"
#: The marker line that starts a part of a file of fixed report text (``prose``).
PART = re.compile(r"<!-- part: (.+) -->")
#: Most orbits a run may take to become stationary.
MAX_ORBITS = 400.0
#: Method variants of the systematic budget: source -> overrides of the power-law pair.
SYSTEMATIC_VARIANTS = {
    "n_particles": {"sheet.n_particles": None},     # a quarter of the pair's particles
    "dt": {"integration.dt": 5e-4},
    "box_size": {"sheet.aspect": 2.0},
}



def prose(path: Path) -> dict[str, list[str]]:
    """The parts of a Markdown file of fixed report text, as lines: a part runs from its
    marker line (``PART``: ``<!-- part: NAME -->``) to the next marker or the end, less the
    blank lines at either end.  Lines before the first marker (the file's note on itself)
    belong to no part."""
    parts: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in path.read_text().splitlines():
        marker = PART.fullmatch(line)
        if marker:
            current = parts.setdefault(marker[1], [])
        elif current is not None:
            current.append(line)
    for lines in parts.values():
        while lines and not lines[-1]:
            lines.pop()
        while lines and not lines[0]:
            lines.pop(0)
    return parts


def scaling_prediction(sc) -> tuple[float, float]:
    """Predicted c(kappa=0.1)/c(kappa=0) = (M_bar/60 g)^(kappa/p) for equal-sized pairs.

    Returns the values for pairs of the smallest particles and for pairs of mean-sized
    particles (equal for a monodisperse ring).
    """
    from ringsim.physics.restitution import M_REF

    sd = sc.particles.size_distribution
    p = sc.restitution_dict().get("p", 0.65)

    def factor(radius: float) -> float:
        m_bar = 0.5 * sc.particles.density * 4.0 / 3.0 * math.pi * radius**3
        return (m_bar / M_REF) ** (0.1 / p)

    return factor(sd.smallest_radius), factor(sd.mean_radius)


def friction_section(text: str | None) -> dict | None:
    """``constant:B`` -> {model: constant, beta: B}; ``coulomb:M`` -> {model: coulomb, mu: M}."""
    if not text:
        return None
    model, _, value = text.partition(":")
    key = {"constant": "beta", "coulomb": "mu"}.get(model)
    if key is None or not value:
        raise SystemExit(f"--friction: expected constant:BETA or coulomb:MU, got {text!r}")
    return {"model": model, key: float(value)}


def variants(args) -> dict[str, dict]:
    """Size-distribution variants: scenario overrides by name (``--variants``)."""
    common = {"integration.until_equilibrium": True, "integration.orbits": args.max_orbits}
    if args.particles:
        common["sheet.n_particles"] = args.particles
    friction = friction_section(args.friction)
    if friction:
        common["friction"] = friction
    mono = dict(common)
    mono["particles.size_distribution"] = {"kind": "monodisperse", "radius": args.mono_radius}
    mono["sheet.n_particles"] = args.mono_particles
    return {name: v for name, v in (("powerlaw", common), ("monodisperse", mono))
            if name in args.variants}


def outputs(args) -> tuple[Path, Path, str]:
    """(report, figures directory, budget file pattern) of this comparison."""
    if not args.friction:
        return Path(args.report), FIGURES, str(BUDGET)
    return (Path(args.report if args.report != str(REPORT) else FRICTION_REPORT),
            FIGURES / "friction", str(FRICTION_BUDGET))


def run_one(job: tuple[str, dict, str]) -> tuple[str, float]:
    """Run one scenario; returns (path, wall time [s]).  A finished file of the same
    scenario is reused; a stopped one, or one (finished or stopped) that differs only by
    fewer ``integration.orbits``, is continued (bit-identical to running it whole).  A
    file that differs only by more orbits is an error, not rewritten: a length is only
    ever raised.  ``integration.threads`` changes no result, so a file that differs in it
    is the same scenario (continued on the job's thread count)."""
    scenario_path, overrides, output = job
    out = Path(output)
    sc = with_overrides(load_scenario(scenario_path), overrides)
    t0 = time.perf_counter()
    if out.exists():
        try:
            existing = open_run(out)
        except (OSError, KeyError, ringsim.InputError):
            existing = None
        if existing is not None and with_overrides(
                existing.scenario, {"integration.orbits": sc.integration.orbits,
                                    "integration.threads": sc.integration.threads}) == sc:
            had, status = existing.scenario.integration.orbits, existing.attrs.get("status")
            if had > sc.integration.orbits:
                raise ValueError(f"{out} has integration.orbits = {had:g}, more than the "
                                 f"{sc.integration.orbits:g} asked; not rewritten")
            if had == sc.integration.orbits and status == "finished":
                return output, 0.0
            if had == sc.integration.orbits or status in ("finished", "stopped"):
                ringsim.run(sc, output=out, resume=True, progress=False)
                return output, time.perf_counter() - t0
    ringsim.run(sc, output=out, force=True, progress=False)
    return output, time.perf_counter() - t0


def run_all(jobs: list[tuple[str, dict, str]], workers: int) -> list[str]:
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return [path for path, _ in pool.map(run_one, jobs)]


def pair_jobs(variant: str, overrides: dict, seeds, runs_dir: Path) -> list[tuple]:
    """(scenario, overrides, output) of both kappa values and every seed."""
    return [(str(path), dict(overrides, seed=seed),
             str(runs_dir / f"{variant}_{path.stem}_seed{seed}.h5"))
            for path in SCENARIOS.values() for seed in seeds]


def stationary_equilibria(paths: list[str]) -> tuple[list[dict], list[str]]:
    """Equilibria of the runs the finder calls stationary, and a line per one it does not."""
    kept, left_out = [], []
    for path in paths:
        eq = equilibrium(open_run(path))
        if eq["in_equilibrium"]:
            kept.append(eq)
        else:
            left_out.append(f"{eq['name']} (seed {eq['scenario']['seed']}): {eq['reason']}")
    return kept, left_out


def comparable(eqs: list[dict]) -> bool:
    """Whether stationary runs of both kappa values are there to form a ratio."""
    kappas = {e["scenario"]["restitution"]["kappa"] for e in eqs}
    return len(kappas) == 2


def ratio_of_pair(paths: list[str]) -> dict | None:
    """The comparison (kappa = 0.1 / kappa = 0) of one set of runs; None unless both
    kappa values have a stationary run."""
    eqs, _ = stationary_equilibria(paths)
    return comparison(eqs)["ratios"][0] if comparable(eqs) else None


def detection_systematics(variant: str) -> dict[str, float]:
    """Relative change of the kappa ratio of c and H between line and tree detection, from
    the short same-state comparisons of validation/line_mode.py (its cases
    kappa0-powerlaw, kappa0.1-powerlaw, kappa0-mono, kappa0.1-mono)."""
    if not LINE_VALIDATION.exists():
        return {}
    data = json.loads(LINE_VALIDATION.read_text())
    out = {}
    for key in ("velocity_dispersion", "thickness"):
        ratios = []
        short = "powerlaw" if variant == "powerlaw" else "mono"
        for case in (f"kappa0.1-{short}", f"kappa0-{short}"):
            tree = data[case]["tree"][key]
            line = data[case]["line"]["line0.001"][key]["mean"]
            ratios.append(line / tree)
        out[key] = abs(ratios[0] / ratios[1] - 1.0)
    out["velocity_dispersion_rOmega"] = out["velocity_dispersion"]
    out["thickness_r"] = out["thickness"]
    return out


def relative_changes(base_ratio: dict, other_ratio: dict) -> dict[str, float]:
    """For each table quantity, the relative change of a ratio between a method variant
    (``other_ratio``) and the base, or their combined statistical error if larger: a
    difference smaller than its own noise is not resolved, so the noise is taken."""
    out = {}
    for key in TABLE_ROWS:
        a, b = base_ratio[key], other_ratio[key]
        if math.isfinite(a["mean"]) and math.isfinite(b["mean"]) and a["mean"]:
            noise = math.hypot(a["statistical"], b["statistical"]) / abs(a["mean"])
            out[key] = max(abs(b["mean"] / a["mean"] - 1.0), noise)
    return out


def measure_budget(args, runs_dir: Path, variant: str, base_ratio: dict) -> dict:
    """Run the method variants of one size-distribution variant and write its systematic
    budget (see module docstring)."""
    relative: dict[str, dict[str, float]] = {key: {} for key in TABLE_ROWS}
    common = variants(args)[variant]
    n_base = common.get("sheet.n_particles") or load_scenario(
        SCENARIOS["kappa = 0"]).sheet.n_particles
    for source, overrides in SYSTEMATIC_VARIANTS.items():
        if source == "n_particles":
            overrides = {"sheet.n_particles": n_base // 4}
        paths = run_all(pair_jobs(f"syst-{variant}-{source}", {**common, **overrides},
                                  args.systematic_seeds, runs_dir), args.workers)
        other = ratio_of_pair(paths)
        if other is None:
            continue
        for key, value in relative_changes(base_ratio, other).items():
            relative[key][source] = value
    for key, value in detection_systematics(variant).items():
        relative[key]["collision_detection"] = value
    budget = {"description": "measured by analysis/kappa_comparison.py --systematics for the "
                             f"kappa0/kappa0.1 {variant} pair (" + ", ".join(
                                 f"{s}: {SOURCES[s]}" for s in (*SYSTEMATIC_VARIANTS,
                                                                "collision_detection")) + ")",
              "measured_by": "analysis/kappa_comparison.py --systematics"
                             + (f" --friction {args.friction}" if args.friction else ""),
              "variants": SYSTEMATIC_VARIANTS, "relative": relative}
    path = Path(outputs(args)[2].format(variant=variant))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(budget, indent=1) + "\n")
    return budget


def fmt(v: dict, scale: float = 1.0, digits: int = 3) -> str:
    if not math.isfinite(v["mean"]):
        return "n/a"
    return f"{v['mean'] * scale:.{digits}g} ± {v['stderr'] * scale:.2g}"


def fmt_ratio(r: dict) -> str:
    if not math.isfinite(r["mean"]):
        return "n/a"
    syst = f"{r['systematic']:.2g}" if math.isfinite(r["systematic"]) else "not measured"
    return (f"**{r['mean']:.3g}** ± {r['statistical']:.2g} (stat) ± {syst} (syst)"
            + (f" = ± {r['total']:.2g}" if math.isfinite(r["total"]) else ""))


def variant_section(variant: str, comp: dict, left_out: list[str], eqs: list[dict]) -> list[str]:
    """Markdown of one size-distribution variant."""
    base, other = comp["runs"]
    r = comp["ratios"][0]
    sc = eqs[0]["scenario"]
    lines = [f"## {variant} particles", "",
             f"Scenario: {sc['particles']['size_distribution']}, density "
             f"{sc['particles']['density']:g} kg/m^3, tau = {sc['sheet']['optical_depth']:g}, "
             f"{sc['sheet']['n_particles']} particles, Omega = {sc['planet']['Omega']:g} 1/s, "
             "collision "
             f"detection {sc['integration']['collision_detection']}, dt "
             f"{sc['integration']['dt']}, run until stationary (at most "
             f"{sc['integration']['orbits']:g} orbits). Stationary runs averaged: "
             f"{base['name']} and {other['name']}.", "",
             "| quantity | kappa = 0 | kappa = 0.1 | ratio 0.1 / 0 |", "|---|---|---|---|"]
    for key, (label, unit, scale) in TABLE_ROWS.items():
        lines.append(f"| {label}{f' [{unit}]' if unit else ''} | {fmt(base[key], scale)} | "
                     f"{fmt(other[key], scale)} | {fmt_ratio(r[key])} |")
    kin = [g["kinetic_estimate"] for g in (base, other)]
    lines.append("| dilute kinetic estimate c / (<r> Omega) | " + " | ".join(
        f"{k['velocity_dispersion_rOmega']:.3g}" if k["status"] == "equilibrium"
        else k["status"] for k in kin) + " | |")
    for key, what in (("outside_speeds", "speeds"), ("outside_sizes", "reduced radii")):
        cells = []
        for g in (base, other):
            shares = [e["law_range"][key] for e in eqs if e.get("law_range")
                      and e["name"] in g.get("replicas", [g["name"]])]
            cells.append(f"{100 * sum(shares) / len(shares):.1f} %" if shares
                         and all(math.isfinite(s) for s in shares) else "not stated")
        lines.append(f"| impacts outside the law's measured {what} | " + " | ".join(cells)
                     + " | |")
    lines += ["", f"The kinetic estimate uses {kin[0].get('representative', 'the mean particle')}.",
              ""]
    for g in (base, other):
        line = size_ratio_line(g.get("size_ratio"))
        if line:
            lines.append(f"- {g['name']}: {line}")
    if left_out:
        lines += ["", "Runs left out (the finder did not call them stationary):", ""]
        lines += [f"- {item}" for item in left_out]
    return lines + [""]


def _seed_mean(values: list[dict]) -> str:
    """Mean over seeds ± the larger of the scatter's standard error and the mean stderr."""
    means = [v["mean"] for v in values]
    mean = sum(means) / len(means)
    scatter = (math.sqrt(sum((m - mean) ** 2 for m in means) / (len(means) - 1) / len(means))
               if len(means) > 1 else 0.0)
    err = max(scatter, math.sqrt(sum(v["stderr"] ** 2 for v in values)) / len(values))
    return f"{mean:.3g} ± {err:.2g}"


def spin_section(eqs: list[dict]) -> list[str]:
    """Markdown table of the spin numbers and the dissipation shares of both kappa values
    (means over the stationary seeds)."""
    rows = [("E_rot / E_tr", lambda e: e["spin"]["rotational_energy_fraction"]),
            ("mean w_z / Omega (rotating frame)", lambda e: e["spin"]["mean_spin_z"]),
            ("rms \\|w\\| / Omega", lambda e: e["spin"]["rms_spin"]),
            ("tangential share of the dissipation",
             lambda e: e["energy_budget"]["tangential_share"]),
            ("shear heating / (normal + tangential dissipation)",
             lambda e: e["energy_budget"]["ratio"])]
    groups = {}
    for e in eqs:
        groups.setdefault(e["scenario"]["restitution"]["kappa"], []).append(e)
    kappas = sorted(groups)
    lines = ["### Spins and dissipation", "",
             "| quantity | " + " | ".join(f"kappa = {k:g}" for k in kappas) + " |",
             "|---|" + "---|" * len(kappas)]
    for label, get in rows:
        lines.append(f"| {label} | " + " | ".join(_seed_mean([get(e) for e in groups[k]])
                                                   for k in kappas) + " |")
    ref = eqs[0]["spin"]["collisional_spin_ratio"]
    if ref is not None:
        lines.append(f"| E_rot / E_tr, collisional balance (closed form) | {ref:.3g} | "
                     f"{ref:.3g} |")
    lines += ["", "Per size bin (seed-averaged snapshots of the stationary window; E per "
              "particle):", "", "| kappa | r [m] | E_tr [J] | E_rot [J] | E_rot/E_tr | "
              "rms w/Omega | <w_z>/Omega |", "|---|---|---|---|---|---|---|"]
    for k in kappas:
        bins = [e["spin"]["per_size_bin"] for e in groups[k]]
        for j, b in enumerate(bins[0]):
            col = {key: sum(s[j][key] for s in bins) / len(bins) for key in
                   ("translational_energy", "rotational_energy", "rms_spin", "mean_spin_z")}
            lines.append(f"| {k:g} | {b['r_low']:.3g}-{b['r_high']:.3g} | "
                         f"{col['translational_energy']:.3g} | {col['rotational_energy']:.3g} | "
                         f"{col['rotational_energy'] / col['translational_energy']:.3g} | "
                         f"{col['rms_spin']:.3g} | {col['mean_spin_z']:.3g} |")
    return lines + ["", f"Spin convention: {eqs[0]['spin']['convention']}.", ""]


def spin_figures(paths: list[str], directory: Path) -> list[Path]:
    """``spins.png`` (``ringsim.plots.spins``) of one run of each kappa value."""
    from ringsim.plots.common import save_figure
    from ringsim.plots.spins import spin_figure

    out = []
    for path in paths:
        run = open_run(path)
        eq = equilibrium(run)
        out.append(save_figure(spin_figure(run, eq), directory / f"spins_{eq['name']}.png"))
    return out


def parse_args():
    """The command line of this comparison (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--max-orbits", type=float, default=MAX_ORBITS)
    parser.add_argument("--mono-radius", type=float, default=1.0,
                        help="radius of the monodisperse variant [m]")
    parser.add_argument("--particles", type=int, default=None,
                        help="particles of the power-law pair (default: as the scenarios)")
    parser.add_argument("--mono-particles", type=int, default=2000)
    parser.add_argument("--systematic-seeds", type=int, nargs="+", default=[1],
                        help="seeds of the method variants of --systematics")
    parser.add_argument("--runs", default=str(ROOT / "runs" / "kappa"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--systematics", action="store_true",
                        help="also run the method variants and write the budget")
    parser.add_argument("--report", default=str(REPORT))
    parser.add_argument("--friction", default=None,
                        help="rough particles: constant:BETA or coulomb:MU")
    parser.add_argument("--variants", nargs="+", default=["powerlaw", "monodisperse"],
                        choices=["powerlaw", "monodisperse"])
    args = parser.parse_args()
    if args.friction and args.runs == str(ROOT / "runs" / "kappa"):
        args.runs = str(ROOT / "runs" / "kappa_friction")
    return args


def budgets_of(args, results: dict, runs_dir: Path, budget_pattern: str) -> dict:
    """Systematic budget of each variant: measured now (``--systematics``, where both kappa
    values have stationary runs) or read from its file where one was written before."""
    budgets = {}
    for variant, (_paths, eqs, _left_out) in results.items():
        path = Path(budget_pattern.format(variant=variant))
        if args.systematics and comparable(eqs):
            budgets[variant] = measure_budget(args, runs_dir, variant,
                                              comparison(eqs)["ratios"][0])
        elif path.exists():
            budgets[variant] = json.loads(path.read_text())
    return budgets


def variant_lines(args, results: dict, budgets: dict, report: Path,
                  figures_dir: Path) -> tuple[list[str], list[str]]:
    """(sections, summary lines) of the report: per variant its tables and figures, or the
    runs left out where no ratio can be formed."""
    sections, summary = [], []
    for variant, (paths, eqs, left_out) in results.items():
        if not comparable(eqs):
            summary.append(f"- **{variant}**: no ratio: not both kappa values have a run the "
                           "equilibrium finder calls stationary.")
            sections += [f"## {variant} particles", "", "Runs left out (the finder did not "
                         "call them stationary):", "", *[f"- {item}" for item in left_out], ""]
            continue
        comp = comparison(eqs, budgets.get(variant))
        sections += variant_section(variant, comp, left_out, eqs)
        if args.friction:
            sections += spin_section(eqs)
        r = comp["ratios"][0]
        low, high = scaling_prediction(open_run(paths[0]).scenario)
        predicted = (f"{low:.2f}" if abs(high - low) < 0.01 * low else
                     f"{low:.2f} (pairs of the smallest particles) to {high:.2f} (mean-sized)")
        summary.append(f"- **{variant}**: c(kappa = 0.1) / c(kappa = 0) = "
                       f"{fmt_ratio(r['velocity_dispersion'])}; H ratio "
                       f"{fmt_ratio(r['thickness'])}; the (M/60 g)^(kappa/p) scaling "
                       f"predicts {predicted}.")
        shown = [paths[0], paths[len(paths) // 2]]
        figures = plot_comparison([open_run(p) for p in shown],
                                  [equilibrium(open_run(p)) for p in shown],
                                  figures_dir / variant)
        if args.friction:
            figures += spin_figures(shown, figures_dir / variant)
        sections += [f"![{f.stem}]({f.relative_to(report.parent)})" for f in figures] + [""]
    return sections, summary


def header(args, seconds: float) -> list[str]:
    """Title and the command line that regenerates the report, with its time [s]."""
    mono_flag = (f" --mono-particles {args.mono_particles}"
                 if "monodisperse" in args.variants else "")
    title = "# Ring equilibria with kappa = 0 and kappa = 0.1" + (
        f" with friction ({friction_section(args.friction)})" if args.friction else "")
    return [title, "",
            f"Generated by `python analysis/kappa_comparison.py "
            f"{f'--friction {args.friction} ' if args.friction else ''}"
            f"--variants {' '.join(args.variants)} --seeds "
            f"{' '.join(map(str, args.seeds))}"
            f"{f' --particles {args.particles}' if args.particles else ''}"
            f"{mono_flag}"
            f" --max-orbits {args.max_orbits:g}"
            f"{' --systematics' if args.systematics else ''}`"
            f" in {seconds:.0f} s.", ""]


def main() -> None:
    args = parse_args()
    report, figures_dir, budget_pattern = outputs(args)
    runs_dir = Path(args.runs)
    runs_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    results = {}
    for variant, overrides in variants(args).items():
        paths = run_all(pair_jobs(variant, overrides, args.seeds, runs_dir), args.workers)
        eqs, left_out = stationary_equilibria(paths)
        results[variant] = (paths, eqs, left_out)
    budgets = budgets_of(args, results, runs_dir, budget_pattern)
    sections, summary = variant_lines(args, results, budgets, report, figures_dir)
    text = prose(TEXT)
    lines = [*header(args, time.perf_counter() - t0),
             "## What changes between kappa = 0 and kappa = 0.1", "", *summary, "",
             *text["friction explanation" if args.friction else "explanation"], "",
             *[f"Systematic budget, {v}: " + (budgets[v]["description"] if v in budgets else
                                              "not measured (run with --systematics)") + "."
               for v in results], "",
             *[line.format(seeds=" ".join(map(str, args.systematic_seeds)))
               for line in text["detection budget"]], "",
             *sections]
    report.write_text("\n".join(lines) + "\n")
    print(f"wrote {report}")

if __name__ == "__main__":
    main()
