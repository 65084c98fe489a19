"""P3M in thick rings with a sparse high tail: the whole step with gravity over the step
without, the mesh spanning every particle (``--tail-fractions 0``) against the mesh spanning
the dense core (``sheet.p3m_tail_fraction``, docs/gravity.md 4b "The sparse high tail").

Rings: a constructed production-like ring (``--n`` particles, 0.5-5 m, q = 3, solid ice at
tau = 0.5, a = 1.3e8 m, Dilley's law with kappa = 0, line detection) whose heights are a
Gaussian of rms ``--sigmas`` [m] with ``--tail`` of the particles moved to 3-6 sigma (half
above, half below), as the production rings of studies/kappa-selfgravity/earlier_runs.md (rms 44 m,
99 % within 133 m, the highest at 268 m; the hot kappa = 0.1 ring rms 183 m); and the
B-ring preset (scenarios/saturn-b-ring.yaml) at its initial state.  For each: CPU time per
particle-step of ``--steps`` whole steps after two warm-up steps (one thread), without
gravity (the same state, the same process) and with P3M at each tail fraction, each with
the stages of P3M's force evaluation (``P3MSolver.profile``) and the force error against
the converged shear-periodic image sum on ``--targets`` random particles (rms of the
per-particle relative error) at the state before the steps.  Medians of ``--repeats``.

With ``--configs F:K ...`` the script instead times P3M with the mesh every K steps
(``sheet.p3m_mesh_interval``) and the split at F times `auto`'s, in the constructed rings
(tail apart) and the Saturn presets ``--presets``, each against the step without gravity
(section "P3M: the mesh every k steps" of docs/performance.md).  With ``--height-index 0
1`` each configuration is timed with the pair sum by whole columns (0) and through its
height index (1, the default: ``P3MSolver.set_height_index``) in the same process, written
to the section "P3M: the pair sum through a height index".

Usage: python benchmarks/p3m_thick.py [--n 20000] [--sigmas 44 183] [--steps 10]
       [--tail-fractions 0 0.02] [--write-doc]
       python benchmarks/p3m_thick.py --configs 1:1 1:5 0.6:15 [--presets a b c] ...
       python benchmarks/p3m_thick.py --configs 1:5 --height-index 0 1 [--presets a b c] ...
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from datetime import datetime, timezone

import numpy as np
import rebound

from ringsim import testing
from ringsim.config.scenario import load_scenario, scenario_from_dict, with_overrides
from ringsim.engine.sheet import build_sheet, without_gravity
from ringsim.gravity import p3m
from ringsim.report import replace_section

B_RING = "scenarios/saturn-b-ring.yaml"


def ring_scenario(n: int, gravity: bool):
    """The constructed production-like ring (module docstring) with or without P3M."""
    return scenario_from_dict({
        "name": "p3m-thick", "seed": 1,
        "planet": {"GM": 3.7931e16, "a": 1.3e8},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}},
        "sheet": {"optical_depth": 0.5, "n_particles": n, "gravity": gravity,
                  "initial_dispersion": 2.0},
        "restitution": {"model": "dilley", "kappa": 0.0},
        "integration": {"orbits": 1.0, "dt": 1.0e-3, "collision_detection": "line",
                        "threads": 1},
    }, source="<benchmark>")


def tailed_heights(n: int, sigma: float, tail: float, seed: int = 4) -> np.ndarray:
    """Heights [m]: a Gaussian of rms ``sigma`` [m] with a fraction ``tail`` moved to
    3-6 sigma, half above and half below."""
    rng = np.random.default_rng(seed)
    z = rng.normal(0.0, sigma, n)
    k = int(round(tail * n))
    idx = rng.choice(n, k, replace=False)
    z[idx] = np.where(np.arange(k) % 2 == 0, 1.0, -1.0) * rng.uniform(3.0, 6.0, k) * sigma
    return z


def build(sc, heights):
    """``sc`` built, its heights replaced by ``heights`` [m] (None: as built)."""
    built = build_sheet(sc)
    if heights is not None:
        for p, z in zip(built.sim.particles, heights, strict=True):
            p.z = float(z)
    return built


def force_error(sim, n_targets: int) -> float:
    """rms per-particle relative error of the forces of ``sim`` against the converged
    shear-periodic image sum on ``n_targets`` random particles."""
    n = sim.N
    targets = np.sort(np.random.default_rng(0).choice(n, min(n, n_targets), replace=False))
    ref = testing.simulation_reference(sim, targets)
    acc = testing.accelerations(sim)
    return testing.force_errors(acc[targets], ref)["rms_relative"]


def step_cost(sc, heights, steps: int, tail_fraction=None, n_targets=0) -> dict:
    """CPU seconds per particle-step of ``steps`` steps after two warm-up steps, with the
    P3M stages [s per particle-step], mesh and force error (``tail_fraction``: the solver's
    ``tail_fraction``; None: no gravity)."""
    built = build(sc, heights)
    sim = built.sim
    solver = p3m.installed_solver(sim)
    out: dict = {}
    if solver is not None:
        solver.tail_fraction = float(tail_fraction)
        if n_targets:
            out["error"] = force_error(sim, n_targets)
    sim.steps(2)
    p3m.raise_pending(sim)
    if solver is not None:
        solver.profile = {}
    t0 = time.process_time()
    sim.steps(steps)
    out["step"] = (time.process_time() - t0) / steps / sim.N
    p3m.raise_pending(sim)
    if solver is not None:
        out["stages"] = {k: v / steps / sim.N for k, v in solver.profile.items()}
        par = solver.params
        out["mesh"] = f"{par.split:.2f}: {par.nx} x {par.ny} x {par.nz}"
    out["rms_z"] = float(np.std([p.z for p in sim.particles]))
    out["n"] = sim.N
    built.resolver.close()
    return out


def median_cost(sc, heights, args, tail_fraction=None) -> dict:
    """`step_cost` repeated ``args.repeats`` times: the median step and stages."""
    runs = [step_cost(sc, heights, args.steps, tail_fraction,
                      n_targets=args.targets if i == 0 else 0)
            for i in range(args.repeats)]
    best = dict(runs[0])
    best["step"] = float(np.median([r["step"] for r in runs]))
    if "stages" in best:
        best["stages"] = {k: float(np.median([r["stages"][k] for r in runs]))
                          for k in best["stages"]}
    return best


def ring_rows(label, sc, heights, args) -> list[str]:
    """Table rows of one ring: each tail fraction against the step without gravity."""
    plain = median_cost(without_gravity(sc), heights, args)
    rows = []
    for tf in args.tail_fractions:
        g = median_cost(sc, heights, args, tf)
        st = g["stages"]
        rest = sum(v for k, v in st.items()
                   if k not in ("mesh fields (FFT)", "pair sum"))
        rows.append(
            f"| {label} | {g['n']} | {g['rms_z']:.1f} | {tf:g} | {g['mesh']} "
            f"| {g['error'] * 100:.2f} % | {g['step'] * 1e6:.2f} "
            f"| {st['mesh fields (FFT)'] * 1e6:.2f} | {st['pair sum'] * 1e6:.2f} "
            f"| {rest * 1e6:.2f} | {plain['step'] * 1e6:.2f} "
            f"| {g['step'] / plain['step']:.1f} |")
        print(rows[-1], flush=True)
    return rows


def document(rows: list[str], args) -> str:
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (
        "## P3M with the sparse high tail apart\n\n"
        f"`python benchmarks/p3m_thick.py --n {args.n} --sigmas "
        f"{' '.join(f'{s:g}' for s in args.sigmas)} --tail {args.tail:g} --steps {args.steps} "
        f"--repeats {args.repeats} --tail-fractions "
        f"{' '.join(f'{t:g}' for t in args.tail_fractions)} --write-doc`, {when}, "
        f"{platform.machine()} {platform.system()}, REBOUND {rebound.__version__}, one "
        "thread, CPU microseconds per particle-step (medians; the machine shared with other "
        "jobs, so absolute figures are inflated alike).  Rings as in the script's docstring: "
        f"constructed, 0.5-5 m at tau = 0.5, a = 1.3e8 m, {args.tail * 100:g} % of the "
        "particles moved to 3-6 sigma; the B-ring preset at its initial state.  Tail "
        "fraction 0 is the mesh spanning every particle (the method before "
        "`sheet.p3m_tail_fraction`).  Error: rms per-particle relative force error against "
        f"the converged shear-periodic image sum on {args.targets} random particles.\n\n"
        "| ring | N | rms z [m] | tail fraction | split [m]: mesh nx x ny x layers "
        "| rms force error | whole step | mesh fields (FFT) | pair sum | assignment, "
        "interpolation, mean vertical field, heights | no gravity (same state) "
        "| with / without gravity |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n"
        + "\n".join(rows) + "\n")


def interval_cost(sc, heights, args, k: int, split_factor: float,
                  height_index: bool = True) -> dict:
    """`step_cost`'s figures of ``sc`` with the mesh every ``k`` steps
    (``sheet.p3m_mesh_interval``) and the split at ``split_factor`` times the one `auto`
    takes at the state (1: `auto`), the pair sum through its height index or not;
    ``args.steps`` rounded up to whole intervals, medians of ``args.repeats``; the force
    error is that of the whole force (the mesh's impulse spread over its k steps)."""
    over: dict = {"sheet.p3m_mesh_interval": k}
    if split_factor != 1.0:
        probe = build(sc, heights)
        probe.sim.steps(1)
        over["sheet.p3m_split"] = split_factor * p3m.installed_solver(probe.sim).params.split
        probe.resolver.close()
    sc = with_overrides(sc, over)
    steps = -(-args.steps // k) * k
    runs = []
    for i in range(args.repeats):
        built = build(sc, heights)
        sim, solver = built.sim, p3m.installed_solver(built.sim)
        solver.set_height_index(height_index)
        out = {"n": sim.N, "k": k}
        if i == 0 and args.targets:
            solver.mesh_interval = 1
            out["error"] = force_error(sim, args.targets)
            solver.mesh_interval = k
        sim.steps(2 * k)
        solver.profile = {}
        t0 = time.process_time()
        sim.steps(steps)
        out["step"] = (time.process_time() - t0) / steps / sim.N
        p3m.raise_pending(sim)
        out["stages"] = {name: v / steps / sim.N for name, v in solver.profile.items()}
        par = solver.params
        out["mesh"] = f"{par.split:.2f}: {par.nx} x {par.ny} x {par.nz}"
        out["rms_z"] = float(np.std([p.z for p in sim.particles]))
        built.resolver.close()
        runs.append(out)
    best = dict(runs[0])
    best["step"] = float(np.median([r["step"] for r in runs]))
    best["stages"] = {name: float(np.median([r["stages"].get(name, 0.0) for r in runs]))
                      for name in runs[0]["stages"]}
    return best


MESH_STAGES = ("mass assignment", "mesh fields (FFT)", "interpolation")


def interval_rows(label, sc, heights, args) -> list[str]:
    """Table rows of one ring: each (split factor, mesh interval) of ``args.configs``
    against the step without gravity (the same state, the same process)."""
    plain = median_cost(without_gravity(sc), heights, args)
    rows = []
    for config in args.configs:
        factor, k = (float(v) for v in config.split(":"))
        for index in args.height_index:
            g = interval_cost(sc, heights, args, int(k), factor, bool(index))
            st = g["stages"]
            mesh = sum(st.get(name, 0.0) for name in MESH_STAGES)
            rest = sum(v for name, v in st.items() if name not in (*MESH_STAGES, "pair sum"))
            error = f"{g['error'] * 100:.2f} %" if "error" in g else "-"
            way = f" | {'height index' if index else 'columns'}" if _compare(args) else ""
            rows.append(
                f"| {label} | {g['n']} | {g['rms_z']:.1f} | {factor:g} | {g['mesh']} "
                f"| {int(k)}{way} | {error} | {g['step'] * 1e6:.2f} | {mesh * 1e6:.2f} "
                f"| {st['pair sum'] * 1e6:.2f} | {rest * 1e6:.2f} "
                f"| {plain['step'] * 1e6:.2f} | {g['step'] / plain['step']:.1f} |")
            print(rows[-1], flush=True)
    return rows


def _compare(args) -> bool:
    """Whether the run compares the pair sum by columns and through the height index."""
    return len(set(args.height_index)) > 1


def index_document(rows: list[str], args) -> str:
    """The section of the ``--height-index 0 1`` mode."""
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = " ".join(f"{v:.1f}" for v in os.getloadavg())
    return (
        "## P3M: the pair sum through a height index\n\n"
        f"`python benchmarks/p3m_thick.py --n {args.n} --sigmas "
        f"{' '.join(f'{s:g}' for s in args.sigmas)} --tail {args.tail:g} --steps {args.steps} "
        f"--repeats {args.repeats} --targets {args.targets} --presets "
        f"{' '.join(args.presets)} --configs {' '.join(args.configs)} --height-index 0 1 "
        f"--write-doc`, {when}, {platform.machine()} {platform.system()}, REBOUND "
        f"{rebound.__version__}, one thread, load average {load} at the end, CPU "
        "microseconds per particle-step (medians of the repeats over whole intervals of k "
        "steps).  As the section \"P3M: the mesh every k steps\" (the same rings, states "
        "and columns), each configuration timed with the pair sum by whole columns and "
        "through its height index in the same process; the force error is the same for "
        "both (the same bits).\n\n"
        "| ring | N | rms z [m] | split factor | split [m]: mesh nx x ny x layers | k "
        "| pair sum | rms force error | whole step | mesh | pair sum | mean vertical field, "
        "split and layers | no gravity (same state) | with / without gravity |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
        + "\n".join(rows) + "\n")


def interval_document(rows: list[str], args) -> str:
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (
        "## P3M: the mesh every k steps\n\n"
        f"`python benchmarks/p3m_thick.py --n {args.n} --sigmas "
        f"{' '.join(f'{s:g}' for s in args.sigmas)} --tail {args.tail:g} --steps {args.steps} "
        f"--repeats {args.repeats} --presets {' '.join(args.presets)} --configs "
        f"{' '.join(args.configs)} --write-doc`, {when}, {platform.machine()} "
        f"{platform.system()}, REBOUND {rebound.__version__}, one thread, CPU microseconds "
        "per particle-step (medians of the repeats over whole intervals of k steps; the "
        "machine shared with other jobs, so absolute figures are inflated alike).  "
        "Constructed rings as in the script's docstring with the tail apart "
        "(`sheet.p3m_tail_fraction` 0.08); the presets as they run, at their initial "
        "state.  Split factor: the split is that times the one `auto` takes at the state "
        "(1: `auto`).  k: `sheet.p3m_mesh_interval`.  Error: rms per-particle relative "
        "error of the whole force (mesh every step) against the converged shear-periodic "
        f"image sum on {args.targets} random particles.  Mesh: assignment, FFTs and "
        "interpolation per step (averaged over the k steps).\n\n"
        "| ring | N | rms z [m] | split factor | split [m]: mesh nx x ny x layers | k "
        "| rms force error | whole step | mesh | pair sum | mean vertical field, split "
        "and layers | no gravity (same state) | with / without gravity |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
        + "\n".join(rows) + "\n")


def interval_main(args) -> None:
    """The ``--configs`` mode: `interval_rows` of the constructed rings (tail apart) and
    the presets ``args.presets``."""
    rows = []
    for sigma in args.sigmas:
        heights = tailed_heights(args.n, sigma, args.tail)
        sc = with_overrides(ring_scenario(args.n, True), {"sheet.p3m_tail_fraction": 0.08})
        rows += interval_rows(f"constructed, sigma {sigma:g} m", sc, heights, args)
    for name in args.presets:
        sc = with_overrides(load_scenario(f"scenarios/saturn-{name}-ring.yaml"),
                            {"integration.threads": 1})
        rows += interval_rows(f"{name.upper()}-ring preset", sc, None, args)
    if _compare(args):
        text = index_document(rows, args)
        section = "## P3M: the pair sum through a height index"
    else:
        text = interval_document(rows, args)
        section = "## P3M: the mesh every k steps"
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", section, text, "Performance")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000)
    ap.add_argument("--sigmas", type=float, nargs="+", default=[44.0, 183.0])
    ap.add_argument("--tail", type=float, default=0.02)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--targets", type=int, default=100)
    ap.add_argument("--tail-fractions", type=float, nargs="+", default=[0.0, 0.02])
    ap.add_argument("--no-b-ring", action="store_true")
    ap.add_argument("--write-doc", action="store_true")
    ap.add_argument("--configs", nargs="+", default=None,
                    help="SPLIT_FACTOR:K pairs: the mesh-interval mode (interval_main)")
    ap.add_argument("--presets", nargs="*", default=["b"],
                    help="Saturn presets of the mesh-interval mode (a, b, c)")
    ap.add_argument("--height-index", type=int, nargs="+", default=[1], choices=[0, 1],
                    help="the mesh-interval mode's pair sum: 0 by columns, 1 through its "
                         "height index (0 1: both, compared)")
    args = ap.parse_args(argv)
    if args.configs:
        interval_main(args)
        return
    rows = []
    for sigma in args.sigmas:
        heights = tailed_heights(args.n, sigma, args.tail)
        rows += ring_rows(f"constructed, sigma {sigma:g} m", ring_scenario(args.n, True),
                          heights, args)
    if not args.no_b_ring:
        sc = with_overrides(load_scenario(B_RING), {"integration.threads": 1})
        rows += ring_rows("B-ring preset", sc, None, args)
    text = document(rows, args)
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", "## P3M with the sparse high tail apart", text,
                        "Performance")


if __name__ == "__main__":
    main()
