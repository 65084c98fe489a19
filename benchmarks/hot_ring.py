"""Benchmark: hot rings in line mode against tree mode.

Two measurements, written to the section "Hot rings: line vs tree" of docs/performance.md
with ``--write-doc``:

1. ``time-to-equilibrium``: ``scenarios/kappa0.1.yaml`` (2000 particles, Dilley kappa = 0.1)
   run by ``ringsim run`` in line mode with ``dt: auto`` until its equilibrium (the start
   of the equilibrium window of ``ringsim analyze``), against tree mode with ``dt: auto``.
   Tree mode cannot be run that far here (its step falls to ~5e-6 orbit as the ring heats:
   hours of CPU), so it is measured piecewise along the line run's own heating path: from
   the line run's snapshot at every orbit, tree mode's ``dt: auto`` is evaluated, and at
   every ``--probe-every`` orbits the tree search and integrator are timed for
   ``--probe-steps`` steps from that state.  The tree wall time to the same orbit is the
   sum over orbits of (orbit / dt_tree) x (time per step), 1/dt_tree averaged over the two
   ends of each orbit.  The model is checked against a
   real tree run from the cold start over the first ``--tree-orbits`` orbits.
2. ``scaling``: CPU time per particle-step of the integration (integrator, collision
   search, resolver) for tree mode, REBOUND's linetree with ringsim's resolver, and ringsim's
   sheet detector, against N (10^3 - 10^5 at tau = 0.25) and box size (N = 10^4 at
   tau = 0.05, 0.25, 1), for a cold ring (2 <r> Omega) and a hot one (100 <r> Omega).

    python benchmarks/hot_ring.py [time-to-equilibrium] [scaling] [--write-doc]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import rebound

import ringsim
from ringsim.analysis.equilibrium import equilibrium
from ringsim.config.scenario import load_scenario, scenario_from_dict, with_overrides
from ringsim.engine import box, sheet, timestep
from ringsim.engine.resolver import install_resolver
from ringsim.report import replace_section
from ringsim.store.runfile import open_run

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "performance.md"
HEADING = "## Hot rings: line vs tree"


# --- 1. time to equilibrium ------------------------------------------------------------------

def _set_state(sim, snapshot: dict) -> None:
    xyz = np.ascontiguousarray(np.column_stack([snapshot["x"], snapshot["y"], snapshot["z"]]))
    vxyz = np.ascontiguousarray(np.column_stack([snapshot["vx"], snapshot["vy"],
                                                 snapshot["vz"]]))
    sim.set_serialized_particle_data(xyz=xyz, vxvyvz=vxyz)


def tree_probe(sc, snapshot: dict, t: float, steps: int) -> tuple[float, float]:
    """Tree mode's dt: auto [s] at a state and its CPU time per step [s] there."""
    tree_sc = with_overrides(sc, {"integration.collision_detection": "tree"})
    built = sheet.build_sheet(tree_sc)
    sim, geometry = built.sim, built.geometry
    _set_state(sim, snapshot)
    sim.t = t
    arrays = sheet.particle_arrays(sim)
    if not sheet.vertical_guard_ok(arrays, geometry):
        # the box as ringsim run's vertical guard would have enlarged it (the state may lie
        # outside the fresh box, so build the taller one directly)
        needed = sheet.max_vertical_amplitude(arrays, geometry.Omega) / (
            sheet.VERTICAL_GUARD_FRACTION * 0.5)
        n_root_z = math.ceil(1.5 * needed / geometry.root_size)
        geometry = box.SheetGeometry(geometry.root_size, geometry.n_root_x,
                                     geometry.n_root_y, n_root_z, geometry.Omega)
        sim = rebound.Simulation()
        sheet.configure_simulation(sim, geometry, gravity=None, collision_detection="tree",
                                   rand_seed=sc.seed)
        sheet.add_particles(sim, arrays, arrays["radius"], arrays["mass"])
        sim.t = t
        sim.minimum_collision_velocity = built.sim.minimum_collision_velocity
        built.resolver.reinstall(sim)
    dt = timestep.auto_dt(arrays, sc.orbital_frequency, sc.integration.dt_safety,
                          collision_detection="tree")
    sim.dt = dt
    if steps <= 0:
        return dt, math.nan
    sim.steps(2)
    c0 = time.process_time()
    sim.steps(steps)
    return dt, (time.process_time() - c0) / steps


def time_to_equilibrium(args) -> dict:
    """Measurement 1 (module docstring): the line run to its equilibrium, tree mode's CPU
    to the same orbit along its path (``tree_model``), the model's check against a real
    tree run, and the ratio of their CPU times to equilibrium."""
    sc = load_scenario(ROOT / "scenarios" / "kappa0.1.yaml")
    out: dict = {"scenario": "scenarios/kappa0.1.yaml", "n_particles": sc.sheet.n_particles}
    with tempfile.TemporaryDirectory() as tmp:
        keep = Path(args.keep) if args.keep else Path(tmp)
        keep.mkdir(parents=True, exist_ok=True)
        run, out["line"] = line_run(sc, args, keep)
        t_eq = out["line"]["equilibrium_from_orbit"]
        out["tree_model"], t_nodes, tree_cpu_cumulative = tree_model(sc, run, args, t_eq)
        out["tree_run"] = tree_run(sc, args, Path(tmp) / "tree.h5", t_nodes,
                                   tree_cpu_cumulative)
        line_cpu_per_orbit = out["line"]["cpu"] / out["line"]["orbits"]
        out["ratio_cpu_line_over_tree"] = (line_cpu_per_orbit * t_eq
                                           / out["tree_model"]["cpu_to_equilibrium"])
    return out


def line_run(sc, args, keep: Path) -> tuple:
    """The line-mode run of ``sc`` (``dt: auto``, ``args.line_orbits``, a snapshot every
    orbit) in ``keep`` (reused with its timing when both are there): the opened run, and
    its wall and CPU time [s], equilibrium and steps."""
    line_sc = with_overrides(sc, {"integration.collision_detection": "line",
                                  "integration.dt": "auto",
                                  "integration.orbits": args.line_orbits,
                                  "output.snapshot_every": 1.0})
    path = keep / "line.h5"
    timing = keep / "line_timing.json"
    if not (path.exists() and timing.exists()):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        ringsim.run(line_sc, output=path, force=True, progress=False)
        timing.write_text(json.dumps({"wall": time.perf_counter() - wall0,
                                      "cpu": time.process_time() - cpu0}))
    line_wall, line_cpu = (json.loads(timing.read_text())[k] for k in ("wall", "cpu"))
    run = open_run(path)
    eq = equilibrium(run)
    t_eq = eq["equilibrium_from_orbit"]["mean"]
    orbits = run.timeseries["orbits"]
    line = {"orbits": float(orbits[-1]), "wall": line_wall, "cpu": line_cpu,
            "equilibrium_from_orbit": t_eq, "in_equilibrium": eq["in_equilibrium"],
            "reason": eq["reason"],
            "c_rOmega": eq["velocity_dispersion_rOmega"],
            "H_r": eq["thickness_r"],
            "dt_orbits": sorted({float(x) for x in np.unique(
                run.timeseries["dt"] / sc.orbital_period)})}
    # line mode's cost per orbit is uniform (dt fixed at its orbit bound nearly always)
    line["wall_to_equilibrium"] = line_wall * t_eq / float(orbits[-1])
    return run, line


def tree_model(sc, run, args, t_eq: float) -> tuple:
    """Tree mode's CPU along the line run's heating path: its ``dt: auto`` at every
    snapshot and its CPU per step at every ``args.probe_every``-th (``tree_probe``).
    Returns the model (steps and CPU to orbit ``t_eq``), the snapshots' orbits and the
    cumulative tree CPU [s] at them."""
    n_snap = run.n_snapshots
    dts, costs = [], {}
    for i in range(n_snap):
        snap = run.snapshot(i)
        t = float(snap["t"])
        probe = (i % args.probe_every == 0) or i == n_snap - 1
        dt, cost = tree_probe(sc, snap, t, args.probe_steps if probe else 0)
        dts.append((t / sc.orbital_period, dt))
        if probe:
            costs[t / sc.orbital_period] = cost
    dts = np.array(dts)
    probe_t = np.array(sorted(costs))
    probe_cost = np.array([costs[k] for k in probe_t])
    orbit = sc.orbital_period
    # steps in [t_k, t_k+1]: the interval over dt, 1/dt averaged over its two ends
    t_nodes = dts[:, 0]
    steps = np.diff(t_nodes) * orbit * 0.5 * (1.0 / dts[:-1, 1] + 1.0 / dts[1:, 1])
    cost_at = np.interp(0.5 * (t_nodes[:-1] + t_nodes[1:]), probe_t, probe_cost)
    tree_cpu_cumulative = np.concatenate([[0.0], np.cumsum(steps * cost_at)])
    model = {
        "orbit": t_nodes.tolist(), "dt_orbits": (dts[:, 1] / orbit).tolist(),
        "cpu_per_step": {f"{k:g}": float(v) for k, v in costs.items()},
        "cpu_to_equilibrium": float(np.interp(t_eq, t_nodes, tree_cpu_cumulative)),
        "steps_to_equilibrium": float(np.interp(
            t_eq, t_nodes, np.concatenate([[0.0], np.cumsum(steps)]))),
    }
    return model, t_nodes, tree_cpu_cumulative


def tree_run(sc, args, path: Path, t_nodes, tree_cpu_cumulative) -> dict:
    """The model's check: a real tree run of ``sc`` (``dt: auto``) over the first
    ``args.tree_orbits`` orbits from the cold start, its wall and CPU time [s] beside the
    model's CPU to the same orbit."""
    tree_sc = with_overrides(sc, {"integration.collision_detection": "tree",
                                  "integration.dt": "auto",
                                  "integration.orbits": args.tree_orbits,
                                  "output.snapshot_every": args.tree_orbits})
    wall0, cpu0 = time.perf_counter(), time.process_time()
    ringsim.run(tree_sc, output=path, force=True, progress=False)
    tree_wall = time.perf_counter() - wall0
    tree_cpu = time.process_time() - cpu0
    return {"orbits": args.tree_orbits, "wall": tree_wall, "cpu": tree_cpu,
            "model_cpu": float(np.interp(args.tree_orbits, t_nodes, tree_cpu_cumulative))}


# --- 2. scaling ------------------------------------------------------------------------------

def scaling_scenario(n: int, tau: float, dispersion: float, collision_detection: str):
    return scenario_from_dict({
        "name": "scaling", "seed": 1, "planet": {"Omega": 2.0e-4},
        "particles": {"density": 900.0,
                      "size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "sheet": {"optical_depth": tau, "n_particles": n, "initial_dispersion": dispersion},
        "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1},
        "integration": {"orbits": 1.0, "dt": 1.0e-3, "collision_detection": collision_detection},
    }, source="<benchmark>")


def cost_per_particle_step(n: int, tau: float, dispersion: float, engine: str) -> dict:
    """CPU time [s] per particle-step of sim.steps for one engine (after 2 warm-up steps)."""
    sc = scaling_scenario(n, tau, dispersion, "tree" if engine == "tree" else "line")
    built = sheet.build_sheet(sc)
    sim = built.sim
    if engine == "linetree" or (engine == "sheet"
                                and built.resolver.collision_detection != "line"):
        built.resolver.close()
        if engine == "linetree":
            sim.collision = "linetree"
            install_resolver(sim, sc.restitution_dict())
        else:
            install_resolver(sim, sc.restitution_dict(), collision_detection="line")
    sim.steps(2)
    steps = max(3, int(3e5 / n))
    c0 = time.process_time()
    sim.steps(steps)
    cpu = time.process_time() - c0
    return {"ns": 1e9 * cpu / (steps * n), "box": built.geometry.Lx, "steps": steps}


def scaling(args) -> list[dict]:
    rows = []
    grid = [(n, 0.25) for n in args.n] + [(10_000, tau) for tau in (0.05, 1.0)]
    for dispersion in (2.0, 100.0):
        for n, tau in grid:
            if dispersion > 2.0 and n > 10_000:
                continue        # the hot 10^5 ring: vertical boxes too many for the tree
            row = {"n": n, "tau": tau, "dispersion_rOmega": dispersion}
            for engine in ("tree", "linetree", "sheet"):
                result = cost_per_particle_step(n, tau, dispersion, engine)
                row[engine] = result["ns"]
                row["box"] = result["box"]
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


# --- report ----------------------------------------------------------------------------------

def markdown(tte: dict | None, rows: list[dict] | None, args) -> str:
    now = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [HEADING, "",
             f"`benchmarks/hot_ring.py`, run on {now} on {platform.machine()} "
             f"{platform.system()} with {os.cpu_count()} cores (shared with other jobs), "
             f"REBOUND 5.2.2, numpy {np.__version__}.  Line mode is ringsim's swept-sphere "
             "search (`rs_sheet_detect.c`) with contact-time resolution; tree mode is "
             "REBOUND's tree search with end-of-step overlaps.  Command: `python "
             "benchmarks/hot_ring.py --write-doc` (defaults `--line-orbits 100 --tree-orbits "
             "0.5 --probe-every 10 --probe-steps 100 --n 1000 10000 100000`); CPU times, "
             "which other jobs on the machine disturb less than wall times.", ""]
    if tte is not None:
        line, model, tree = tte["line"], tte["tree_model"], tte["tree_run"]
        line_cpu_to_equilibrium = line["cpu"] * line["equilibrium_from_orbit"] / line["orbits"]
        c, h = line["c_rOmega"], line["H_r"]
        lines += [
            "**1. Time to equilibrium, `scenarios/kappa0.1.yaml`** (2000 particles, power law "
            "0.5-5 m, tau = 0.25, Dilley kappa = 0.1).", "",
            f"Line mode, `dt: auto` (steps used: "
            f"{', '.join(f'{d:g}' for d in line['dt_orbits'])} orbit), `ringsim run` for "
            f"{line['orbits']:.0f} orbits: {line['wall']:.0f} s wall, {line['cpu']:.0f} s "
            f"CPU.  Equilibrium from orbit {line['equilibrium_from_orbit']:.1f}: "
            f"c = {c['mean']:.1f} ± {c['stderr']:.1f} <r> Omega, H = {h['mean']:.1f} ± "
            f"{h['stderr']:.1f} <r>" + ("" if line["in_equilibrium"] else
                                        f" (verdict: {line['reason']})") + ".", "",
            f"Tree mode, `dt: auto`, on the same heating path: its step falls from "
            f"{model['dt_orbits'][0]:.2g} to {min(model['dt_orbits']):.2g} orbit; "
            f"{model['steps_to_equilibrium']:.3g} steps to orbit "
            f"{line['equilibrium_from_orbit']:.1f} at a measured "
            + ", ".join(f"{1e3 * v:.2f} ms (orbit {float(k):.0f})" for k, v in
                        model["cpu_per_step"].items())
            + f" per step: **{model['cpu_to_equilibrium']:.3g} s CPU "
            f"({model['cpu_to_equilibrium'] / 3600:.2g} h)**.  Check of this model against a "
            f"real tree run of the first {tree['orbits']:g} orbits from the cold start: "
            f"model {tree['model_cpu']:.1f} s, measured {tree['cpu']:.1f} s CPU.", "",
            f"**Ratio line / tree, CPU time to equilibrium: "
            f"{tte['ratio_cpu_line_over_tree']:.2g}** (target <= 0.1): line mode reaches "
            f"the equilibrium in {line_cpu_to_equilibrium:.0f} s of CPU.", ""]
    if rows:
        lines += [
            "**2. Cost per particle-step** (CPU ns per particle per step of `sim.steps`: "
            "integrator, collision search and resolver; 1 m particles, Dilley kappa = 0.1, "
            "dt = 1e-3 orbit, states of the initial ring: cold 2 <r> Omega, hot "
            "100 <r> Omega in a layer about 100 m thick).  REBOUND's linetree widens every "
            "search by dt times the largest absolute speed, the shear flow 0.75 Omega Lx at "
            "the box edge; ringsim's search uses speeds relative to the shear flow.", "",
            "| ring | N | tau | box [m] | tree | linetree | ringsim sheet |",
            "|---|---|---|---|---|---|---|"]
        for r in rows:
            ring = "cold" if r["dispersion_rOmega"] <= 2.0 else "hot"
            lines.append(f"| {ring} | {r['n']} | {r['tau']:g} | {r['box']:.0f} | "
                         f"{r['tree']:.0f} | {r['linetree']:.0f} | {r['sheet']:.0f} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("parts", nargs="*", metavar="{time-to-equilibrium,scaling}",
                        help="default: both")
    parser.add_argument("--line-orbits", type=float, default=100.0)
    parser.add_argument("--tree-orbits", type=float, default=0.5)
    parser.add_argument("--probe-every", type=int, default=10, help="[snapshots]")
    parser.add_argument("--probe-steps", type=int, default=100)
    parser.add_argument("--n", type=int, nargs="+", default=[1000, 10_000, 100_000])
    parser.add_argument("--json", help="also write the results to this file")
    parser.add_argument("--keep", help="keep (and reuse) the line-mode run in this directory")
    parser.add_argument("--from-json", help="only write the report from an earlier --json")
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    parts = ("time-to-equilibrium", "scaling")
    args.parts = args.parts or list(parts)
    for part in args.parts:
        if part not in parts:
            parser.error(f"unknown part {part!r}; choose from {', '.join(parts)}")
    if args.from_json:
        saved = json.loads(Path(args.from_json).read_text())
        text = markdown(saved["time_to_equilibrium"], saved["scaling"], args)
        print(text)
        if args.write_doc:
            replace_section(DOC, HEADING, text, "Performance")
        return
    tte = time_to_equilibrium(args) if "time-to-equilibrium" in args.parts else None
    if tte is not None:
        print(json.dumps(tte, indent=1, default=float), flush=True)
    rows = scaling(args) if "scaling" in args.parts else None
    if args.json:
        Path(args.json).write_text(json.dumps({"time_to_equilibrium": tte, "scaling": rows},
                                              indent=1, default=float))
    text = markdown(tte, rows, args)
    print(text)
    if args.write_doc:
        replace_section(DOC, HEADING, text, "Performance")


if __name__ == "__main__":
    main()
