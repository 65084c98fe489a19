"""PILOT: ring equilibria with kappa = 0 and kappa = 0.1 WITH self-gravity (issue 12, item 6).

Runs (or reuses finished runs of) ``scenarios/kappa0-gravity.yaml`` and
``scenarios/kappa0.1-gravity.yaml`` (1 m ice, tau = 0.5, a = 1e8 m, P3M, tree detection)
and, as the baseline, the same two scenarios with ``sheet.gravity: false`` and line
detection (same particles, same Omega, same tau), every run until the equilibrium finder
calls c and H stationary or its maximum of orbits.  Writes ``analysis/kappa_selfgravity.md``
(equilibria, the ratio kappa = 0.1 / kappa = 0 with and without gravity, the gravity
numbers of ``ringsim analyze``: r_h, Q, lambda_cr, wake wavelength and amplitude,
gravitational viscosity) and the figures of ``ringsim compare --plots`` into
``analysis/figures/selfgravity/``.  The CPU time of every run is measured and reported
(``time.process_time`` of this process: the runs run here, one at a time).

    python analysis/kappa_selfgravity.py --gravity-kappas 0 --gravity-orbits 3 --probe-kappas 0.1
    python analysis/kappa_selfgravity.py --cases       # only rewrite the report

The first line is this pilot (about 25 CPU-minutes); the defaults (both kappa values run
until stationary, at most the scenarios' 30 orbits) are the measurement it cannot afford:
the kappa = 0.1 scenario with gravity costs about 3.4 CPU-hours per orbit.

It is a pilot: one seed by default, no systematic budget; the document says what the full
item 6 still needs.  Functions of ``analysis/kappa_comparison.py`` are imported, not copied.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from kappa_comparison import fmt, fmt_ratio, run_one

from ringsim.analysis.compare import comparison
from ringsim.analysis.equilibrium import TABLE_ROWS, equilibrium
from ringsim.analysis.timeseries import autocorrelated_mean
from ringsim.physics.gravity import toomre_q
from ringsim.store.runfile import open_run

ROOT = Path(__file__).resolve().parent.parent
#: kappa (as written in the file names) -> scenario.
SCENARIOS = {"0": ROOT / "scenarios" / "kappa0-gravity.yaml",
             "0.1": ROOT / "scenarios" / "kappa0.1-gravity.yaml"}
REPORT = ROOT / "analysis" / "kappa_selfgravity.md"
FIGURES = ROOT / "analysis" / "figures" / "selfgravity"
DATA = ROOT / "analysis" / "data" / "kappa_selfgravity.json"
#: The no-gravity baseline: the same scenarios without self-gravity, line detection
#: (cheap for hot rings, docs/validation.md), at most this many orbits.
NOGRAV_OVERRIDES = {"sheet.gravity": False, "integration.collision_detection": "line"}
NOGRAV_MAX_ORBITS = 200.0
#: Rows of the gravity numbers of ``ringsim analyze``: key -> (label, unit shown, scale).
GRAVITY_ROWS = {
    "toomre_Q": ("Toomre Q (from sigma_x)", "", 1.0),
    "wake_wavelength": ("wake wavelength", "m", 1.0),
    "wake_amplitude": ("wake amplitude (peak contrast A)", "", 1.0),
    "gravitational_viscosity": ("gravitational viscosity", "m^2/s", 1.0),
}


def jobs(case: str, args, runs_dir: Path) -> list[tuple]:
    """(scenario, overrides, output) of one case and every seed: ``nograv`` (both kappa
    values, no gravity, line detection), ``gravity`` (the scenarios as bundled, kappa values
    ``args.gravity_kappas``) or ``probe`` (a cost probe of ``args.probe_orbits`` of the
    scenarios of ``args.probe_kappas``, not an equilibrium)."""
    kappas = {"nograv": list(SCENARIOS), "gravity": args.gravity_kappas,
              "probe": args.probe_kappas}[case]
    out = []
    for kappa in kappas:
        path = SCENARIOS[kappa]
        for seed in args.seeds:
            overrides: dict = {"seed": seed}
            if case == "nograv":
                overrides.update(NOGRAV_OVERRIDES)
                overrides["name"] = path.stem.replace("-gravity", "-nogravity")
                overrides["integration.orbits"] = NOGRAV_MAX_ORBITS
            elif case == "probe":
                overrides.update({"integration.orbits": args.probe_orbits,
                                  "integration.until_equilibrium": False,
                                  "output.timeseries_every": args.probe_orbits / 2,
                                  "output.snapshot_every": args.probe_orbits})
            elif args.gravity_orbits is not None:
                overrides["integration.orbits"] = args.gravity_orbits
            out.append((str(path), overrides, str(runs_dir / f"{case}_{path.stem}_seed{seed}.h5")))
    return out


def run_timed(job_list: list[tuple], costs: dict) -> list[str]:
    """Run the jobs one after the other in this process (the machine is shared); record
    each run's CPU time [s] and orbits in ``costs`` (a finished run is reused, cost kept)."""
    paths = []
    for job in job_list:
        t0 = time.process_time()
        path, _wall = run_one(job)
        cpu = time.process_time() - t0
        if cpu > 1.0 or Path(path).name not in costs:
            attrs = open_run(path).attrs
            costs[Path(path).name] = {"cpu_s": cpu,
                                      "stop_reason": str(attrs.get("stop_reason", "")),
                                      "wall_s": float(attrs.get("wall_time_s", math.nan))}
        paths.append(path)
    return paths


def load_costs() -> dict:
    """Measured costs of earlier runs, by run-file name."""
    costs = json.loads(DATA.read_text())["costs"] if DATA.exists() else {}
    return {Path(key).name: value for key, value in costs.items()}


def save_costs(costs: dict) -> None:
    DATA.parent.mkdir(parents=True, exist_ok=True)
    DATA.write_text(json.dumps({"costs": costs, "units": {"cpu_s": "s (CPU)",
                                                          "wall_s": "s (wall)"}}, indent=1))


HEADER = [
    "# PILOT: ring equilibria with kappa = 0 and kappa = 0.1 with self-gravity",
    "",
    "**This is a pilot, not the measurement of issue 12 item 6.** One seed, one size "
    "distribution (identical 1 m spheres), one distance (a = 1e8 m), one optical depth "
    "(tau = 0.5), no systematic budget. Its numbers say what changes and what the full "
    "measurement will cost; they are not yet results a referee should quote.",
]


def setup_lines(eqs: dict, attrs: dict) -> list[str]:
    """The scenario and the numbers of the gravitating patch (``attrs``: of its run file)."""
    sc = eqs["nograv"][0]["scenario"]
    return [
        "## Set-up", "",
        f"`scenarios/kappa0-gravity.yaml` and `scenarios/kappa0.1-gravity.yaml`: "
        f"{sc['particles']['size_distribution']}, density {sc['particles']['density']:g} "
        f"kg/m^3, tau = {sc['sheet']['optical_depth']:g}, {sc['sheet']['n_particles']} "
        f"particles, Saturn (GM = {sc['planet']['GM']:g} m^3/s^2) at a = "
        f"{sc['planet']['a']:g} m, Dilley law xi0 = {sc['restitution']['xi0']:g}, "
        f"p = {sc['restitution']['p']:g}, kappa 0 and 0.1, self-gravity by P3M, tree "
        "detection, dt auto, until stationary. Patch: r_h = "
        f"{attrs['r_h']:.3g}, lambda_cr = {attrs['lambda_cr']:.3g} m"
        f", Sigma = {attrs['Sigma']:.3g} kg/m^2, box = {attrs['Lx']:.3g} m = "
        f"{attrs['box_lambda_cr']:.3g} lambda_cr.",
        "",
        "No-gravity baseline: the same two scenarios with `sheet.gravity: false` and line "
        "detection (same particles, Omega, tau and box), until stationary (at most "
        f"{NOGRAV_MAX_ORBITS:g} orbits). The existing analysis/kappa_comparison.md cannot serve "
        "as the baseline: it is at tau = 0.25 and Omega = 2e-4 1/s.",
    ]


#: The command of this pilot (one seed; kappa = 0.1 with gravity only probed for its cost).
PILOT_COMMAND = ("python analysis/kappa_selfgravity.py --gravity-kappas 0 --gravity-orbits 3 "
                 "--probe-kappas 0.1")
#: "What changes and why", written from the measured numbers of the table above.
EXPLANATION = [
    "## What changes and why", "",
    "(Written by hand from the numbers above: seed 1, the gravity run NOT stationary.)", "",
    "- **The expected picture does not hold for this law.** Dilley's xi0 = 0.16, p = 0.65 "
    "keeps collisions nearly elastic at low speed, so even the kappa = 0 ring heats until the "
    "collision-averaged epsilon is about 0.79, at c = 5 mm/s = 26 r Omega: Toomre Q = 9.3 "
    "without gravity and 9.3 with it. Wakes need Q below about 2 (Salo 1995); none formed "
    "(no significant wake in any snapshot; the strongest mode, about 4 m = 0.1 lambda_cr, is "
    "the particle-scale noise, and the gravitational viscosity is about 1 % of the "
    "translational one). The kappa = 0.1 ring (Q = 44) is further still from wakes.",
    "- **What gravity does to the kappa = 0 ring: it flattens it, it does not heat it.** "
    "H falls by 8 % (0.922 ± 0.007), the mid-plane filling factor and the collision rate rise "
    "by 11-13 %, c and Q do not change over the window (0.999 ± 0.006) - but c was still "
    "falling (means over orbits 0.5-1.5, 1.6-2.3, 2.3-3: 5.22, 5.04, 4.97 mm/s; H 22.8, 21.6, "
    "21.6 m), so whether c settles slightly below the no-gravity 5.01 mm/s is open. Why: the "
    "vertical field of the sheet, "
    "2 pi G Sigma = 2.5e-7 m/s^2, is 0.28 of the planet's vertical pull Omega^2 H at z = H, so "
    "the layer contracts; the random velocities are set by the thermal balance of collisions "
    "(the mean applied epsilon is the same, 0.785), and gravitational scattering is weak at "
    "c = 7 v_esc (v_esc = 0.71 mm/s). The viscosities rise by 6-9 %, within 1-2 sigma.",
    "- **What that means for the kappa ratio (an estimate, NOT measured):** for the kappa = 0.1 "
    "ring the sheet's field is only 0.06 of Omega^2 H (H = 109 m), so a contraction of order "
    "0.06 / 0.28 x 8 % = 2 % is expected, and no change of c. The ratio of c would then stay "
    "at the no-gravity 4.7, while the ratio of H would grow from 4.66 to about 4.66 x 0.98 / "
    "0.922 = 5.0: with gravity H no longer follows c. Measuring it needs the kappa = 0.1 "
    "gravity run, which costs about 3.4 CPU-hours per orbit here (below).",
    "- Caveats: one seed; the gravity run is 3 orbits long and the finder does not call it "
    "stationary (8.5 effective samples of c after the transient, 20 needed; the averages are "
    "over orbits 1.6-3, after the layer contracted within the first half orbit); box 2.08 "
    "lambda_cr; no systematic budget.",
]


def quotient(a: dict, b: dict) -> dict:
    """a / b with its first-order statistical error (independent runs)."""
    if not (math.isfinite(a["mean"]) and math.isfinite(b["mean"])) or b["mean"] == 0:
        return {"mean": math.nan, "stderr": math.nan}
    q = a["mean"] / b["mean"]
    rel = math.hypot(a["stderr"] / a["mean"] if a["mean"] else 0.0, b["stderr"] / b["mean"])
    return {"mean": q, "stderr": abs(q) * rel}


def fmt_q(r: dict) -> str:
    return "n/a" if not math.isfinite(r["mean"]) else f"**{r['mean']:.3g}** ± {r['stderr']:.2g}"


def nograv_toomre_q(path: str, eq: dict, Sigma: float) -> dict:
    """Toomre Q a run without self-gravity would have (from its sigma_x over its
    equilibrium window; Sigma [kg/m^2] that of the gravitating twin)."""
    run = open_run(path)
    ts = run.timeseries
    start = int(np.searchsorted(np.asarray(ts["orbits"]), eq["equilibrium_from_orbit"]["mean"]))
    q = toomre_q(np.sqrt(np.asarray(ts["sigma_xx"][start:])), Sigma, run.attrs["Omega"])
    mean, stderr, _ = autocorrelated_mean(q)
    return {"mean": float(mean), "stderr": float(stderr), "units": "dimensionless"}


def ratio_cell(pair: list, key: str) -> str:
    """The kappa = 0.1 / kappa = 0 cell of one case (pair: [eq0, eq0.1], None if not run)."""
    if any(e is None or key not in e for e in pair):
        return "not measured"
    if key in TABLE_ROWS:
        return fmt_ratio(comparison(pair)["ratios"][0][key])
    return fmt_q(quotient(pair[1][key], pair[0][key]))


def pair_table(eqs: dict) -> list[str]:
    """Markdown table: both kappa values without and with gravity, both ratios and the
    effect of gravity (gravity / no gravity).  ``eqs``: case -> [eq kappa 0, eq kappa 0.1],
    None where a run was not made."""
    lines = ["| quantity | no gravity, kappa = 0 | no gravity, kappa = 0.1 | ratio 0.1 / 0, "
             "no gravity | gravity, kappa = 0 | gravity, kappa = 0.1 | ratio 0.1 / 0, gravity "
             "| kappa = 0: gravity / no gravity |", "|---|---|---|---|---|---|---|---|"]
    for key, (label, unit, scale) in {**TABLE_ROWS, **GRAVITY_ROWS}.items():
        cells = []
        for case in ("nograv", "gravity"):
            cells += [fmt(e[key], scale) if e is not None and key in e else
                      ("not run (cost)" if e is None else "-") for e in eqs[case]]
            cells.append(ratio_cell(eqs[case], key))
        g0, n0 = eqs["gravity"][0], eqs["nograv"][0]
        cells.append(fmt_q(quotient(g0[key], n0[key])) if g0 is not None and key in n0 else "")
        lines.append(f"| {label}{f' [{unit}]' if unit else ''} | " + " | ".join(cells) + " |")
    g = [e for e in eqs["gravity"] if e is not None]
    lines.append("| wake wavelength / lambda_cr | | | | " + " | ".join(
        f"{e['wake_wavelength']['mean'] / e['lambda_cr']['mean']:.3g} "
        f"({100 * e['wake_significant_fraction']:.0f} % of {e['wake_snapshots']} snapshots "
        "significant)" for e in g) + " |" * (4 - len(g)))
    rows = (("stationary (equilibrium finder)", lambda e: str(bool(e["in_equilibrium"]))),
            ("averaged over orbits",
             lambda e: f"{e['equilibrium_from_orbit']['mean']:.3g}-{e['orbits']:.3g}"))
    for label, show in rows:
        cells = []
        for case in ("nograv", "gravity"):
            cells += [show(e) if e is not None else "" for e in eqs[case]] + [""]
        lines.append(f"| {label} | " + " | ".join(cells) + " | |")
    return lines


def cost_lines(paths: dict, costs: dict) -> tuple[list[str], dict]:
    """Markdown table of the measured cost of every run; returns it and the CPU seconds
    per orbit of the gravity scenarios by kappa."""
    lines = ["| run | orbits | CPU [s] | CPU per orbit [min] | stop reason |",
             "|---|---|---|---|---|"]
    per_orbit = {}
    for case in ("nograv", "gravity", "probe"):
        for path in paths[case]:
            run = open_run(path)
            orbits = float(np.asarray(run.timeseries["orbits"])[-1])
            c = costs.get(Path(path).name, {"cpu_s": math.nan, "stop_reason": "?"})
            rate = c["cpu_s"] / orbits
            if case != "nograv":
                per_orbit[run.scenario.restitution.kappa] = rate
            lines.append(f"| {Path(path).name} | {orbits:.3g} | {c['cpu_s']:.0f} | "
                         f"{rate / 60:.3g} | {c['stop_reason']} |")
    return lines, per_orbit


#: Issue 12 item 6 in full: distances x optical depths x size distributions x seeds
#: (per kappa value), and the fewest orbits a hot-started run took to be called stationary
#: here (the no-gravity pair, 10 orbits each).
FULL_RUNS_PER_KAPPA = 2 * 2 * 2 * 3
FEWEST_ORBITS = 10.0


def full_item_lines(per_orbit: dict) -> list[str]:
    """What the full item 6 still needs, with its CPU cost from the measured cost per orbit
    (CPU seconds per orbit by kappa)."""
    lines = ["## What the full item 6 still needs", "",
             f"- The runs: {FULL_RUNS_PER_KAPPA} per kappa value (a = 1e8 m and 1.3e8 m, tau = "
             "0.25 and 0.5, 1 m monodisperse and the 0.5-5 m power law, >= 3 seeds), every one "
             "called stationary by the finder; with gravity none of this pilot's runs is.",
             "- The error budget of analysis/kappa_comparison.md: statistical from the seeds "
             "and the autocorrelation, systematic from measured method variants (particle "
             "number, time step, box size; with gravity also the P3M parameters, force error "
             "< 1 % rms, docs/gravity.md), and a box of >= 4 lambda_cr for the wake statistics "
             "(this pilot: 2.08).",
             "- A way to afford the hot rings: with tree detection the automatic step follows "
             "the fastest particles (1 s at kappa = 0, 0.25 s at kappa = 0.1, against 1e-3 "
             "orbit = 32 s for line detection), and line detection is refused with gravity "
             "(docs/gravity.md); P3M's layer count grows with the vertical extent (particles "
             "500 m from the mid-plane at kappa = 0.1, layers 2.25 m apart).", ""]
    if per_orbit:
        total = sum(FULL_RUNS_PER_KAPPA * FEWEST_ORBITS * rate for rate in per_orbit.values())
        lines.append(
            "- Cost, a LOWER bound: every run as cheap per orbit as this pilot's smallest box "
            "(1200 particles, 1 m) and stationary after " f"{FEWEST_ORBITS:g} orbits: "
            + ", ".join(f"kappa = {k:g}: {FULL_RUNS_PER_KAPPA} x {FEWEST_ORBITS:g} orbits x "
                        f"{rate / 60:.3g} CPU-min" for k, rate in sorted(per_orbit.items()))
            + f" = **{total / 3600:.3g} CPU-hours** in all. Larger boxes (4 lambda_cr: 4 times "
            "the particles at a = 1e8 m, about 19 times at 1.3e8 m, where lambda_cr = 91.6 m), "
            "the power law's 0.5 m particles (half the time step) and more seeds raise it.")
    return lines


def cli_compare(paths: list[str]) -> str:
    """``ringsim compare --plots`` as a user runs it; returns its table."""
    FIGURES.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["ringsim", "compare", *(os.path.relpath(p, ROOT) for p in paths),
                           "--plots", os.path.relpath(FIGURES, ROOT)],
                          capture_output=True, text=True, check=True, cwd=ROOT)
    return done.stdout


def cli_analyze(path: str) -> tuple[str, list[Path]]:
    """``ringsim analyze --plots`` of one gravitating run (its wake and gravity numbers);
    returns its text and figures."""
    where = FIGURES / Path(path).stem
    where.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["ringsim", "analyze", os.path.relpath(path, ROOT), "--plots",
                           os.path.relpath(where, ROOT)],
                          capture_output=True, text=True, check=True, cwd=ROOT)
    return done.stdout, sorted(where.glob("*.png"))


def by_kappa(paths: list[str]) -> list:
    """[equilibrium of kappa = 0, of kappa = 0.1] of the first seed; None where not run."""
    found = {}
    for path in paths:
        eq = equilibrium(open_run(path))
        found.setdefault(eq["scenario"]["restitution"]["kappa"], (path, eq))
    return [found.get(k, (None, None)) for k in (0.0, 0.1)]


def analyze_lines(analyzed: list[tuple[str, list[Path]]]) -> list[str]:
    lines = []
    for text, figures in analyzed:
        lines += ["## `ringsim analyze` of the gravitating run", "", "```", text.rstrip(), "```",
                  ""]
        lines += [f"![{f.stem}]({f.relative_to(REPORT.parent).as_posix()})" for f in figures]
    return lines + [""]


def write_report(args, paths: dict, costs: dict) -> None:
    """analysis/kappa_selfgravity.md from the finished runs."""
    found = {case: by_kappa(paths[case]) for case in ("nograv", "gravity")}
    eqs = {case: [eq for _, eq in found[case]] for case in found}
    attrs = open_run((paths["gravity"] + paths["probe"])[0]).attrs
    for path, eq in found["nograv"]:
        eq["toomre_Q"] = nograv_toomre_q(path, eq, attrs["Sigma"])
    cost_table, per_orbit = cost_lines(paths, costs)
    compared = [p for case in ("nograv", "gravity") for p, _ in found[case] if p]
    text = cli_compare(compared)
    figures = sorted(FIGURES.glob("*.png"))
    analyzed = [cli_analyze(p) for p, _ in found["gravity"] if p]
    lines = HEADER + ["", f"Produced by `{PILOT_COMMAND}` (about 25 CPU-minutes; finished "
                      "runs are reused, and `--cases` without names only rewrites this file; "
                      "this time: `" + " ".join(["...", *args.argv]) + "`). CPU times: "
                      "`time.process_time` around each run, one run at a time.", "",
                      *setup_lines(eqs, attrs), "",
                      "## Equilibria and ratios (one seed)", "", *pair_table(eqs), "",
                      *EXPLANATION, "", "## Cost (measured)", "", *cost_table, "",
                      *full_item_lines(per_orbit), "", "## `ringsim compare` of the runs", "",
                      "```", text.rstrip(), "```", "",
                      *[f"![{f.stem}](figures/selfgravity/{f.name})" for f in figures], "",
                      *analyze_lines(analyzed)]
    Path(args.report).write_text("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--gravity-orbits", type=float, default=None,
                        help="maximum orbits of the gravity runs (default: the scenarios')")
    parser.add_argument("--gravity-kappas", nargs="*", default=list(SCENARIOS),
                        choices=list(SCENARIOS), help="gravity scenarios run until stationary")
    parser.add_argument("--probe-kappas", nargs="*", default=[], choices=list(SCENARIOS),
                        help="gravity scenarios only probed for their cost")
    parser.add_argument("--probe-orbits", type=float, default=0.01)
    parser.add_argument("--cases", nargs="*", default=["nograv", "gravity", "probe"],
                        choices=["nograv", "gravity", "probe"], help="which runs to run now "
                        "(the others are read if their files exist)")
    parser.add_argument("--runs", default=str(ROOT / "runs" / "kappa_selfgravity"))
    parser.add_argument("--report", default=str(REPORT))
    args = parser.parse_args()
    args.argv = sys.argv[1:]
    runs_dir = Path(args.runs)
    runs_dir.mkdir(parents=True, exist_ok=True)
    costs = load_costs()
    paths = {}
    for case in ("nograv", "gravity", "probe"):
        case_jobs = jobs(case, args, runs_dir)
        if case in args.cases:
            paths[case] = run_timed(case_jobs, costs)
            save_costs(costs)
        else:
            paths[case] = [out for _, _, out in case_jobs if Path(out).exists()]
    write_report(args, paths, costs)


if __name__ == "__main__":
    main()
