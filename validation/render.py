"""The Markdown of ``docs/validation.md``: the reference-case section and the line-mode section.

Pure rendering: stored results in, text out.  ``section_markdown`` renders the cases'
``CaseResult`` objects under "## Reference cases"; ``line_mode_markdown`` renders the
summary of ``validation.line_mode.collect`` under its own heading.  The callers
(``ladder.main``, ``line_mode.main``) put the sections into the file with
``ringsim.report.replace_section``, which keeps the other sections.  ``fmt`` and the other
small formatters are shared with the cases' own tables.
"""

from __future__ import annotations

import math

from validation.common import CaseResult, Comparison

SECTION_HEADING = "## Reference cases"
LINE_MODE_HEADING = "## Line-mode collision detection vs small-dt tree reference"


# --- numbers ---------------------------------------------------------------------------------

def fmt(x: float, err: float | None = None) -> str:
    """'1.716 ± 0.011': the value to the first two significant digits of its error."""
    if not math.isfinite(x):
        return "n/a"
    if err is None or not math.isfinite(err) or err <= 0:
        return f"{x:.4g}"
    if abs(x) < 1e-3 or abs(x) >= 1e5:
        return f"{x:.3e} ± {err:.1e}"
    digits = min(max(0, 1 - int(math.floor(math.log10(err)))), 8)
    return f"{x:.{digits}f} ± {err:.{digits}f}"


def percent(c: Comparison) -> str:
    """'+2.1% (+3.6σ)': a value row's relative difference from its reference."""
    return f"{100 * (c.ringsim / c.ref_value - 1):+.1f}% ({c.sigma:+.1f}σ)"


def equilibrium_note(table: list[dict]) -> str:
    """A sentence on the runs ``ringsim.compare.equilibrium`` does not call equilibrated."""
    flagged = [t for t in table if not t["in_equilibrium"]]
    if not flagged:
        return "Every run is in equilibrium by `ringsim.compare.equilibrium`'s test.\n\n"
    taus = ", ".join(f"{t['tau']:g}" for t in flagged)
    only_short = all("drifting" not in t["reason"] and "may not be over" not in t["reason"]
                     for t in flagged)
    if only_short:
        return (f"The runs at τ = {taus} are flagged 'not in equilibrium' by "
                "`ringsim.compare.equilibrium` only because their windows hold fewer than "
                "20 independent samples (at low τ the thermal relaxation is slow and the "
                "autocorrelation time several orbits), not for a drift; their standard "
                "errors are corrected for that autocorrelation.\n\n")
    reasons = "; ".join(f"τ = {t['tau']:g}: {t['reason']}" for t in flagged)
    return f"Runs flagged 'not in equilibrium' by `ringsim.compare.equilibrium`: {reasons}.\n\n"


# --- the reference cases ------------------------------------------------------------------

def row_markdown(c: Comparison) -> str:
    if c.kind == "range":
        ours = f"{c.ringsim:.5g}" if c.ringsim_err == 0 else fmt(c.ringsim, c.ringsim_err)
    else:
        ours = fmt(c.ringsim, c.ringsim_err)
    sigma = c.sigma
    sig = "inside" if (c.kind == "range" and sigma == 0) else f"{sigma:+.1f}σ"
    outcome = "agrees" if c.agrees else "differs"
    if c.expected == "disagree":
        outcome += " (expected to differ)" if not c.agrees else " (expected to DIFFER)"
    mark = "" if c.as_expected else " **✗**"
    return (f"| {c.quantity} | {ours} | {c.reference} | {c.source} | {sig} | "
            f"{outcome}{mark} |")


def section_markdown(results: dict[int, CaseResult], figures_rel: str) -> str:
    """The "## Reference cases" section."""
    out = [SECTION_HEADING, "",
           "Six classic cases run through the machinery users run (`ringsim.run`, the "
           "native resolver, `ringsim.compare.equilibrium`). Written by "
           "`python -m validation ladder` (`--quick` for small sizes; the slow tests in "
           "`tests/test_validation.py` run each case at small sizes and assert the same "
           "agreements). Every table gives ringsim's value with its standard error "
           "(autocorrelation-corrected), the reference with its source, and the "
           "difference in units of the combined uncertainty; 'agrees' means within "
           "3σ (for a range: inside it, or within 3 standard errors of its edge). Where "
           "a published number could not be read, the text says so and the comparison "
           "is with the dilute kinetic estimate or a physics argument instead.", "",
           "| case | verdict | run time [s] | sizes |", "|---|---|---|---|"]
    for k in sorted(results):
        r = results[k]
        bad = sum(not c.as_expected for c in r.comparisons)
        verdict = ("every row as expected" if not bad
                   else f"**{bad} of {len(r.comparisons)} rows differ** (see text)")
        out.append(f"| {k}. {r.title} | {verdict} | {r.cpu_seconds:.0f} | {r.sizes} |")
    total = sum(r.cpu_seconds for r in results.values())
    out += ["", f"Total run time: {total / 60:.0f} min (wall clock, one process at a time on a "
            "2-core machine shared with other jobs).", ""]
    for k in sorted(results):
        r = results[k]
        out += [f"### {k}. {r.title}", "", r.setup, "",
                "| quantity | ringsim | reference | source | difference | outcome |",
                "|---|---|---|---|---|---|"]
        out += [row_markdown(c) for c in r.comparisons]
        out += ["", f"![case {k}]({figures_rel}/{r.figure})", "", r.discussion, ""]
    return "\n".join(out).rstrip() + "\n"


# --- the line-mode section ------------------------------------------------------------------

def scales(entry: dict) -> tuple[float, float]:
    """Units of the line-mode tables and figures: c in <r> Omega, H in <r>."""
    return 1.0 / (entry["mean_radius"] * entry["Omega"]), 1.0 / entry["mean_radius"]


def _fmt_line(v: dict, scale: float) -> str:
    return f"{v['mean'] * scale:.3g} ± {v['stderr'] * scale:.2g} (s = {v['spread'] * scale:.2g})"

def line_mode_markdown(summary: dict, replicas: int) -> str:
    """The line-mode validation section (self-contained, under its own heading)."""
    lines = [LINE_MODE_HEADING, "",
             "Generated by `python -m validation line-mode all` (numbers also in "
             "`docs/data/line_mode_validation.json`, figures in "
             "`docs/figures/line_mode/`).", ""]
    lines += _method_text(replicas)
    zs: list[tuple[float, str, str, str]] = []    # (|z|, case, run, quantity)
    lines += _equilibria_table(summary, zs)
    lines += _size_bin_table(summary, zs)
    lines += _reference_runs_table(summary)
    lines += _verdict(zs)
    lines += _interpretation(summary)
    lines += ["![dt convergence](figures/line_mode/dt_convergence.png)", "",
              "![velocity dispersion](figures/line_mode/velocity_dispersion.png)", "",
              "![multi-encounters](figures/line_mode/multi_encounters.png)", ""]
    return "\n".join(lines)


def _equilibria_table(summary: dict, zs: list) -> list[str]:
    """c, H, z-scores, multi-encounters and cost of every run; appends the z-scores to zs."""
    lines = ["### Equilibria", "",
             "c in <r> Omega, H in <r>; means over the last two thirds of each run.  Tree: one "
             "run.  Line: mean over the replicas ± its standard error (s = scatter of one "
             "run); z = (line - tree) / (s sqrt(1 + 1/M)).  Multi-encounters: fraction of "
             "collisions in which a partner had been deflected earlier in the same step, "
             "measured by the resolver / predicted by `dt: auto`'s estimate.", "",
             "| case | run | dt [orbit] | c | H | z(c) | z(H) | multi-enc. measured / "
             "predicted | CPU / particle-step |",
             "|---|---|---|---|---|---|---|---|---|"]
    for case, entry in summary.items():
        c_scale, h_scale = scales(entry)
        tree = entry["tree"]
        dt = tree["dt_orbits"]
        lines.append(f"| {case} | tree | {dt[0]:.2g}-{dt[1]:.2g} | "
                     f"{tree['velocity_dispersion'] * c_scale:.3g} | "
                     f"{tree['thickness'] * h_scale:.3g} |  |  | "
                     f"{100 * tree['multi_fraction']:.2g}% / – | "
                     f"{tree['cpu_per_particle_step_ns']:.0f} ns |")
        for dt, fixed in entry["tree_fixed_dt"].items():
            lines.append(f"| {case} | tree, fixed dt | {dt} | "
                         f"{fixed['velocity_dispersion'] * c_scale:.3g} | "
                         f"{fixed['thickness'] * h_scale:.3g} |  |  | "
                         f"{100 * fixed['multi_fraction']:.2g}% / – | "
                         f"{fixed['cpu_per_particle_step_ns']:.0f} ns |")
        for tag, line in entry["line"].items():
            dt = line["dt_orbits"]
            dt_text = f"{dt[0]:.3g}" if dt[0] == dt[1] else f"{dt[0]:.3g}-{dt[1]:.3g}"
            zc, zh = line["z"]["velocity_dispersion"], line["z"]["thickness"]
            zs += [(abs(zc), case, tag, "c"), (abs(zh), case, tag, "H")]
            lines.append(
                f"| {case} | {tag} (M = {line['replicas']}) | {dt_text} | "
                f"{_fmt_line(line['velocity_dispersion'], c_scale)} | "
                f"{_fmt_line(line['thickness'], h_scale)} | {zc:+.2f} | {zh:+.2f} | "
                f"{100 * line['multi_fraction']['mean']:.2g}% / "
                f"{100 * line['predicted_multi_fraction']['mean']:.2g}% | "
                f"{line['cpu_per_particle_step_ns']['mean']:.0f} ns |")
    lines.append("")
    return lines


def _size_bin_table(summary: dict, zs: list) -> list[str]:
    """Per size bin, line at dt = 1e-3 orbit against tree; appends the z-scores to zs."""
    lines = ["### Per size bin (power-law cases; line at dt = 1e-3 orbit against tree)", "",
             "| case | bin [m] | n | c tree | c line | z(c) | H tree | H line | z(H) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for case, entry in summary.items():
        edges = entry["size_bin_edges"]
        if edges is None or "line0.001" not in entry["line"]:
            continue
        c_scale, h_scale = scales(entry)
        tree, line = entry["tree"]["size_bins"], entry["line"]["line0.001"]
        bins, z = line["size_bins"], line["z"]["size_bins"]
        for k in range(len(edges) - 1):
            zc, zh = z["velocity_dispersion"][k], z["thickness"][k]
            for value, quantity in ((zc, "c"), (zh, "H")):
                if math.isfinite(value):
                    zs.append((abs(value), case, f"line0.001 bin {k}", quantity))
            lines.append(
                f"| {case} | {edges[k]:.2f}-{edges[k + 1]:.2f} | {tree['n'][k]:.0f} | "
                f"{tree['velocity_dispersion'][k] * c_scale:.3g} | "
                f"{_fmt_line(bins['velocity_dispersion'][k], c_scale)} | {zc:+.2f} | "
                f"{tree['thickness'][k] * h_scale:.3g} | "
                f"{_fmt_line(bins['thickness'][k], h_scale)} | {zh:+.2f} |")
    lines.append("")
    return lines


def _reference_runs_table(summary: dict) -> list[str]:
    """Warm-ups, drifts and costs of the reference runs."""
    lines = ["### Reference runs: warm-ups, drift, cost", "",
             "| case | warm-up [orbits] | c at its end [<r> Omega] | relaxation time "
             "[orbits] | measured run [orbits] | drift of c, tree / line 1e-3 [<r> Omega per "
             "orbit] | tree CPU [s] | line 1e-3 CPU per run [s] |",
             "|---|---|---|---|---|---|---|---|"]
    for case, entry in summary.items():
        c_scale, _ = scales(entry)
        warm = entry.get("warmup")
        tree, line = entry["tree"], entry["line"].get("line0.001")
        drift_line = (f"{line['drift']['mean'] * c_scale:+.2g} ± "
                      f"{line['drift']['stderr'] * c_scale:.2g}") if line else "–"
        lines.append(
            f"| {case} | {warm['orbits'] if warm else 0:.0f} | "
            + (f"{warm['velocity_dispersion'] * c_scale:.3g}" if warm else "–") + " | "
            + (f"{warm['relaxation_orbits']:.2g}" if warm else "–")
            + f" | {tree['orbits']:.0f} | {tree['drift'] * c_scale:+.2g} / {drift_line} | "
            f"{tree['cpu_integrate']:.0f} | "
            + (f"{line['cpu_integrate']['mean']:.1f}" if line else "–") + " |")
    lines.append("")
    return lines


def _verdict(zs: list) -> list[str]:
    """How many line-vs-tree z-scores fall within 1, 2 and 3 standard deviations."""
    finite = sorted((w for w in zs if math.isfinite(w[0])), reverse=True)
    n_total = len(finite)
    within = [sum(1 for w in finite if w[0] <= k) for k in (1.0, 2.0, 3.0)]
    return ["### Verdict", "",
            f"{n_total} line-vs-tree comparisons (c and H of every line variant, and per "
            f"size bin at dt = 1e-3 orbit): {within[0]} within 1, {within[1]} within 2, "
            f"{within[2]} within 3 combined standard deviations (Gaussian: 68%, 95%, "
            "99.7%).  Largest: "
            + ", ".join(f"{c} {t} {q} {z:.1f}" for z, c, t, q in finite[:6]) + ".", ""]


def _relative(line: dict, tree: float) -> float:
    return 100.0 * (line["mean"] / tree - 1.0)


def _interpretation(summary: dict) -> list[str]:
    """What the numbers say, with the numbers."""
    out = ["### What this shows", ""]
    out += [_case_interpretation(case, entry) for case, entry in summary.items()
            if entry["line"]]
    out += [
        "",
        "* Where a measured window is much shorter than the relaxation time (kappa = 0.1: 3 "
        "orbits against 9-16), the replica scatter understates the uncertainty of a window "
        "mean - two replica sets of the same method then differ by more than their stated "
        "errors - and the line-tree comparison is good to a few per cent, not to its "
        "nominal error bars.  Settling it better needs tree runs of tens of orbits "
        "(about 3 CPU minutes per orbit for the 300-particle kappa = 0.1 power law), beyond "
        "this budget.",
        "* The largest per-bin deviations are in the top size bins, which hold 3-15 "
        "particles whose vertical oscillations damp over many orbits.",
    ]
    out.append(_multi_encounter_text(summary))
    speedups = []
    for c, entry in summary.items():
        if not entry["line"]:
            continue
        tree = entry["tree"]
        line = entry["line"]["line0.001"]
        per_orbit_tree = tree["cpu_integrate"] / tree["orbits"]
        per_orbit_line = line["cpu_integrate"]["mean"] / line["orbits"]
        speedups.append(f"{c} {per_orbit_tree / per_orbit_line:.0f}x")
    out += [
        "* CPU per orbit, tree at `dt: auto` over line at 1e-3 orbit (integration only): "
        + ", ".join(speedups) + ".",
        "",
    ]
    return out


def _case_interpretation(case: str, entry: dict) -> str:
    """One case's bullet: line against tree, the tree's own step, dt: auto, relaxation."""
    line, tree = entry["line"], entry["tree"]
    dev = {key: [_relative(v[key], tree[key]) for v in line.values()]
           for key in ("velocity_dispersion", "thickness")}
    text = (f"* **{case}**: line mode (all steps) differs from the tree reference by "
            f"{min(dev['velocity_dispersion']):+.1f}% to "
            f"{max(dev['velocity_dispersion']):+.1f}% in c and "
            f"{min(dev['thickness']):+.1f}% to {max(dev['thickness']):+.1f}% in H")
    fixed = entry.get("tree_fixed_dt", {})
    if fixed:
        shifts = []
        for dt, v in fixed.items():
            dc = 100 * (v["velocity_dispersion"] / tree["velocity_dispersion"] - 1)
            dh = 100 * (v["thickness"] / tree["thickness"] - 1)
            shifts.append(f"{dt} orbit c {dc:+.1f}%, H {dh:+.1f}%")
        text += ("; the tree's own step matters at that level: at fixed dt = "
                 + "; ".join(shifts)
                 + " relative to its `dt: auto` run, i.e. towards the line-mode values")
    auto, fixed1 = line.get("lineauto"), line.get("line0.001")
    if auto and fixed1 and auto["dt_orbits"] == fixed1["dt_orbits"]:
        diff = auto["velocity_dispersion"]["mean"] / fixed1["velocity_dispersion"]["mean"] - 1
        err = math.hypot(auto["velocity_dispersion"]["stderr"],
                         fixed1["velocity_dispersion"]["stderr"]) / fixed1[
            "velocity_dispersion"]["mean"]
        text += (f"; `dt: auto` kept 1e-3 orbit here, so its replicas are a second "
                 f"independent set of the same method: the two sets' c differ by "
                 f"{100 * diff:+.1f}% ({abs(diff) / err:.1f} times their combined "
                 "stated error)")
    warm = entry.get("warmup")
    if warm and math.isfinite(warm["relaxation_orbits"]):
        text += (f"; relaxation time {warm['relaxation_orbits']:.2g} orbits against a "
                 f"{tree['orbits']:.0f}-orbit run")
    return text + "."


def _multi_encounter_text(summary: dict) -> str:
    """The multiple-encounter fractions of the cold and the hot rings, measured/predicted."""
    cold = [c for c in summary if c.startswith("constant") and summary[c]["line"]]
    hot = [c for c in summary if not c.startswith("constant") and summary[c]["line"]]

    def multi(cases, tag):
        values = [100 * summary[c]["line"][tag]["multi_fraction"]["mean"] for c in cases]
        return f"{min(values):.2g}-{max(values):.2g}%" if values else "n/a"

    ratios = [summary[c]["line"]["line0.001"]["multi_fraction"]["mean"]
              / max(summary[c]["line"]["line0.001"]["predicted_multi_fraction"]["mean"], 1e-12)
              for c in cold]
    return (
        f"* Multiple encounters: at 1e-3 orbit {multi(cold, 'line0.001')} of the collisions "
        f"in the cold dense rings had a partner deflected earlier in the same step, "
        f"{multi(hot, 'line0.001')} in the hot rings; at 5e-3 orbit "
        f"{multi(cold, 'line0.005')} and {multi(hot, 'line0.005')}.  `dt: auto` kept "
        f"{multi(cold, 'lineauto')} in the cold cases and {multi(hot, 'lineauto')} in the hot "
        f"ones.  Measured / predicted = "
        + ", ".join(f"{r:.2g}" for r in ratios)
        + " in the dense cases at 1e-3 orbit; in the hot rings the prediction is lower (cut "
        "to its 2-sigma lower bound with few contacts per snapshot), harmlessly at these "
        "fractions.")


def _method_text(replicas: int) -> list[str]:
    return [
        "**What is compared.**  The same ring integrated with REBOUND's tree collision search "
        "at `dt: auto` (overlaps found at step ends; the step keeps the largest relative "
        "displacement per step below 0.1 of the smallest radius: 2x10^3 - 5x10^5 steps "
        "per orbit here) and in ringsim's line mode (swept-sphere search in the shear frame, "
        "`ringsim/csrc/rs_sheet_detect.c`; each pair resolved at its first contact on the "
        "straight relative path of the step) at fixed dt = 1e-3, 2e-3 and 5e-3 orbit and "
        "at `dt: auto`.",
        "",
        "**Cases.**  Omega = 2e-4 1/s, solid ice (900 kg/m^3), no self-gravity.  Constant "
        "eps = 0.5 at tau = 1 (cold and dense, 400 particles); Dilley (1993) xi0 = 0.16, "
        "p = 0.65 with kappa = 0 and with kappa = 0.1 at tau = 0.25 (hot, 300 particles).  "
        "Each monodisperse (r = 1 m) and power law (0.5-5 m, dN/dR ~ R^-3, six logarithmic "
        "size bins).  Seed 1.",
        "",
        "**Protocol.**  The hot rings first warm up in line mode (`dt: auto`) from the "
        "scenario's cold start until c has levelled off; from that state (same particles, "
        "same time) the tree reference and the line runs integrate the same number of "
        "orbits.  The cold dense cases start every run from the cold initial state.  "
        f"Every line variant is run {replicas} times from that same state with different "
        "seeds of the collision shuffle (REBOUND's `rand_seed`), which the ring's chaos "
        "turns into independent trajectories: the scatter s of their window means (the "
        "last two thirds of each run) estimates the uncertainty of one run's window mean "
        "given the common start, instead of autocorrelations of a short series, which the "
        "slow thermal relaxation of the hot rings (5-16 orbits) makes unreliable.  The tree "
        "run, one more such draw if the modes agree, is compared with the replica mean in "
        "units of s sqrt(1 + 1/M).  For the cold dense monodisperse ring, where the tree is "
        "cheap, tree runs at fixed dt = 2.5e-4 and 1.25e-4 orbit show the reference's own "
        "step error.",
        "",
        "**Why these sizes.**  A tree run of the hot kappa = 0.1 rings needs 10^5 - 5x10^5 "
        "steps per orbit; 300 particles keep each reference to minutes of one core and the whole "
        "validation to about half an hour.  The boxes are 40-70 m wide while the hot rings "
        "are 50-200 m thick: both modes integrate the same small box, so the comparison is "
        "fair, but these equilibria are not those of 2000-particle runs.  The measured "
        "windows are short (2-7 orbits) against the hot rings' relaxation times, so a tree "
        "run started at the line-mode state would reveal a different equilibrium mainly as a "
        "drift: the drifts of the tree run and of the line replicas are listed together.",
        "",
    ]
