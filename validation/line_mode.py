"""Line-mode collision detection against the small-dt tree reference.

Produces the section "Line-mode collision detection vs small-dt tree reference" of
``docs/validation.md`` and its figures in ``docs/figures/line_mode/``::

    python -m validation line-mode run [--cases ...] [--replicas 6] [--runs DIR]
    python -m validation line-mode report [--runs DIR]
    python -m validation line-mode all

Six cases: constant eps = 0.5 (cold, dense: tau = 1), Dilley (1993) kappa = 0 and
kappa = 0.1 (hot: tau = 0.25), each monodisperse (1 m) and power law (0.5-5 m, q = 3).
For every case:

1. warm-up: line mode, ``dt: auto``, from the scenario's cold start until c levels off
   (the dense cold cases skip this: every run starts cold, the reference is cheap there);
2. from the final state of the warm-up (the "hand-off": same particles, same time) the
   reference, tree mode with ``dt: auto`` (dt << r/v), and line mode at fixed dt = 1e-3,
   2e-3 and 5e-3 orbit (the dt convergence) and at ``dt: auto``, all for the same number
   of orbits; every line variant ``--replicas`` times with different seeds of the
   collision shuffle;
3. means of c, H and per size bin over the last two thirds of each run; the scatter of the
   line replicas' means is the uncertainty of one run's mean, and the tree run is compared
   with the replica mean in units of that scatter.

Every run also records the resolver's ``multi_encounters`` (collisions in which a partner
was deflected earlier in the same step), the fraction predicted on straight paths for the
step in use (``validation.encounters.multi_encounter_rate``), and the CPU time per
particle-step of the integration alone.  Sizes are small (300-400 particles) to fit the
validation into about half an hour of one core: the tree reference of the hot Dilley rings
needs 10^4 - 10^5 steps per orbit.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from ringsim.analysis import snapshot
from ringsim.config.scenario import scenario_from_dict, with_overrides
from ringsim.engine import sheet, timestep
from ringsim.report import replace_section
from validation.common import DOC, ROOT, figure_file, pyplot
from validation.encounters import (
    MULTI_ENCOUNTER_TARGET,
    MULTI_ENCOUNTER_WINDOW_STEPS,
    multi_encounter_rate,
)
from validation.render import LINE_MODE_HEADING, line_mode_markdown, scales

FIGURES = ROOT / "docs" / "figures" / "line_mode"
SUMMARY = ROOT / "docs" / "data" / "line_mode_validation.json"

#: Fixed steps of the dt-convergence runs [orbits].
LINE_STEPS = (1e-3, 2e-3, 5e-3)

MONODISPERSE = {"kind": "monodisperse", "radius": 1.0}
POWERLAW = {"kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}
CONSTANT = {"model": "constant", "epsilon": 0.5}
DILLEY_0 = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0}
DILLEY_01 = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}

#: name -> (restitution, size distribution, optical depth, particles, warm-up orbits,
#: measured orbits).  Warm-up and measurement lengths follow the thermal time scales
#: measured in the warm-ups themselves (see the report).
CASES = {
    "constant-mono": (CONSTANT, MONODISPERSE, 1.0, 400, 0.0, 10.0),
    "constant-powerlaw": (CONSTANT, POWERLAW, 1.0, 400, 0.0, 10.0),
    "kappa0-mono": (DILLEY_0, MONODISPERSE, 0.25, 300, 40.0, 6.0),
    "kappa0-powerlaw": (DILLEY_0, POWERLAW, 0.25, 300, 40.0, 6.0),
    "kappa0.1-mono": (DILLEY_01, MONODISPERSE, 0.25, 300, 80.0, 3.0),
    "kappa0.1-powerlaw": (DILLEY_01, POWERLAW, 0.25, 300, 80.0, 3.0),
}

#: Tree runs at fixed, shorter steps [orbits]: the reference's own dt convergence, where the
#: tree is cheap enough (the cold dense monodisperse ring).
EXTRA_TREE_STEPS = {"constant-mono": (2.5e-4, 1.25e-4)}


def scenario(case: str, seed: int = 1):
    """The case's scenario (1 m or 0.5-5 m ice, Omega = 2e-4 1/s, no self-gravity)."""
    restitution, size_distribution, tau, n, _, _ = CASES[case]
    return scenario_from_dict({
        "name": f"line-validation-{case}",
        "seed": seed,
        "planet": {"Omega": 2.0e-4},
        "particles": {"density": 900.0, "size_distribution": size_distribution},
        "sheet": {"optical_depth": tau, "n_particles": n, "aspect": 1.0, "gravity": False},
        "restitution": restitution,
        "integration": {"orbits": 1.0, "dt": "auto", "collision_detection": "line"},
        "output": {"path": f"runs/{case}.h5", "timeseries_every": 0.1,
                   "snapshot_every": 1.0},
    }, source=f"<line-mode validation {case}>")


# --- one run ---------------------------------------------------------------------------------

def _set_state(sim, state: dict) -> None:
    """Put a saved state (positions [m], velocities [m/s], time [s]) into ``sim``."""
    xyz = np.ascontiguousarray(np.column_stack([state["x"], state["y"], state["z"]]))
    vxyz = np.ascontiguousarray(np.column_stack([state["vx"], state["vy"], state["vz"]]))
    sim.set_serialized_particle_data(xyz=xyz, vxvyvz=vxyz)
    sim.t = float(state["t"])


def simulate(sc, orbits: float, collision_detection: str, dt_orbits: float | str,
             state: dict | None = None, every: float = 0.1,
             shuffle_seed: int | None = None) -> dict:
    """Integrate a scenario as ``ringsim run`` does, recording one row every ``every`` orbits.

    Parameters
    ----------
    sc : Scenario
    orbits : float [orbits]
        Duration (from the state's time if a state is given).
    collision_detection : "tree" or "line"
    dt_orbits : float [orbits] or "auto"
    state : dict, optional
        Start from these positions [m], velocities [m/s] and time ``t`` [s] (same scenario
        and seed, so the same radii and masses) instead of the scenario's initial state.
    every : float [orbits]
    shuffle_seed : int, optional
        Seed of REBOUND's collision shuffle (``sim.rand_seed``) instead of the scenario's:
        replicas from one state differ only in the order of simultaneous collisions, which
        the ring's chaos amplifies into independent trajectories.

    Returns
    -------
    dict of arrays (one entry per row; row 0 is the start) and ``final`` (the end state),
    ``cpu_integrate`` [s], ``particle_steps``, ``size_bin_edges`` [m] or None.
    """
    sc = with_overrides(sc, {"integration.collision_detection": collision_detection,
                             "integration.dt": dt_orbits, "integration.orbits": orbits})
    built = sheet.build_sheet(sc)
    sim, geometry, handle = built.sim, built.geometry, built.resolver
    Omega, orbit = sc.orbital_frequency, sc.orbital_period
    if state is not None:
        _set_state(sim, state)
    if shuffle_seed is not None:
        sim.rand_seed = int(shuffle_seed)
    sim, geometry = _vertical_guard(sim, geometry, handle)
    if dt_orbits == "auto":
        sim.dt = timestep.auto_dt(sheet.particle_arrays(sim), Omega, sc.integration.dt_safety,
                                  collision_detection=collision_detection)
    t0 = sim.t
    rows: list[dict] = []
    cpu, particle_steps = 0.0, 0
    n = sim.N
    k = 0
    while True:
        arrays = sheet.particle_arrays(sim)
        rows.append(_row(sim, arrays, handle, geometry, built.size_bin_edges, Omega, orbit))
        if sim.t >= t0 + orbits * orbit * (1 - 1e-9):
            break
        sim, geometry = _vertical_guard(sim, geometry, handle)
        if dt_orbits == "auto":
            sim.dt = timestep.auto_dt(arrays, Omega, sc.integration.dt_safety, current=sim.dt,
                                      collision_detection=collision_detection)
        k += 1
        steps_before = sim.steps_done
        c0 = time.process_time()
        sim.integrate(t0 + k * every * orbit, exact_finish_time=0)
        cpu += time.process_time() - c0
        particle_steps += (sim.steps_done - steps_before) * n
    out = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    final = sheet.particle_arrays(sim)
    out["final"] = {key: final[key] for key in ("x", "y", "z", "vx", "vy", "vz")}
    out["final"]["t"] = sim.t
    out["cpu_integrate"] = cpu
    out["particle_steps"] = particle_steps
    out["size_bin_edges"] = built.size_bin_edges
    out["detector"] = handle.detector_stats()
    out["mean_radius"] = float(built.radii.mean())
    out["Omega"] = Omega
    return out


def _row(sim, arrays: dict, handle, geometry, size_bin_edges, Omega: float,
         orbit: float) -> dict:
    """One output row: c [m/s], H [m], filling factor, collisions, multi-encounters
    (measured since the last row, and the predicted rate), mean eps, per size bin.

    Omega [1/s] and orbit [s] are the scenario's."""
    stats = handle.stats()
    handle.reset_stats()
    summary = snapshot.snapshot_summary(
        arrays["x"], arrays["y"], arrays["z"], arrays["vx"], arrays["vy"], arrays["vz"],
        arrays["radius"], arrays["mass"], Omega, geometry.Lx, geometry.Ly,
        size_bins=size_bin_edges)
    row = {"t": sim.t, "orbits": sim.t / orbit, "dt": sim.dt,
           "velocity_dispersion": summary["velocity_dispersion"],
           "thickness": summary["thickness"], "filling_factor": summary["filling_factor"],
           "collisions": stats["count"], "multi_encounters": stats["multi_encounters"],
           "predicted_multi_fraction_per_dt": multi_encounter_rate(
               arrays, Omega, MULTI_ENCOUNTER_WINDOW_STEPS * 1e-3 * orbit),
           "mean_epsilon": stats["mean_epsilon"]}
    if size_bin_edges is not None:
        row["size_bin_velocity_dispersion"] = summary["size_bin_velocity_dispersion"]
        row["size_bin_thickness"] = summary["size_bin_thickness"]
        row["size_bin_n"] = summary["size_bin_n"]
    return row


def _vertical_guard(sim, geometry, handle):
    """Enlarge the box in z as ``ringsim run`` does, before any particle nears its edge."""
    arrays = sheet.particle_arrays(sim)
    while not sheet.vertical_guard_ok(arrays, geometry):
        needed = sheet.max_vertical_amplitude(arrays, geometry.Omega) / (
            sheet.VERTICAL_GUARD_FRACTION * 0.5)
        n_root_z = max(2 * geometry.n_root_z, math.ceil(1.5 * needed / geometry.root_size))
        sim, geometry = sheet.enlarged_copy(sim, geometry, n_root_z)
        handle.reinstall(sim)
    return sim, geometry


# --- window means and replica statistics -----------------------------------------------------

#: The first third of every run is discarded; the rest is the measurement window.
DISCARD_FRACTION = 1.0 / 3.0


def window_means(series: dict) -> dict:
    """Means over the measurement window (the last two thirds of the run).

    Returns c [m/s], H [m], per size bin c [m/s], H [m] and n, the measured and predicted
    multi-encounter fractions, the steps used [orbits], the slope of c [m/s per orbit], the
    CPU time per particle-step [ns] and the length [orbits].
    """
    t = series["orbits"]
    keep = t >= t[0] + DISCARD_FRACTION * (t[-1] - t[0]) - 1e-9
    orbit = 2.0 * math.pi / series["Omega"]
    out = {"velocity_dispersion": float(np.mean(series["velocity_dispersion"][keep])),
           "thickness": float(np.mean(series["thickness"][keep])),
           "drift": float(np.polyfit(t[keep], series["velocity_dispersion"][keep], 1)[0]),
           "orbits": float(t[-1] - t[0]),
           "dt_orbits": [float(np.min(series["dt"][1:]) / orbit),
                         float(np.max(series["dt"][1:]) / orbit)],
           "cpu_per_particle_step_ns": 1e9 * series["cpu_integrate"] / max(
               series["particle_steps"], 1),
           "cpu_integrate": float(series["cpu_integrate"])}
    collisions = float(np.sum(series["collisions"][keep]))
    out["collisions"] = collisions
    out["multi_fraction"] = float(np.sum(series["multi_encounters"][keep])) / max(collisions, 1)
    out["predicted_multi_fraction"] = float(np.mean(
        series["predicted_multi_fraction_per_dt"][keep] * series["dt"][keep]))
    if "size_bin_velocity_dispersion" in series:
        with np.errstate(invalid="ignore"):
            out["size_bins"] = {
                "velocity_dispersion": np.nanmean(
                    series["size_bin_velocity_dispersion"][keep], axis=0).tolist(),
                "thickness": np.nanmean(series["size_bin_thickness"][keep], axis=0).tolist(),
                "n": np.mean(series["size_bin_n"][keep], axis=0).tolist()}
    return out


def replica_statistics(means: list[dict]) -> dict:
    """Mean over replicas, the replica standard deviation (the scatter of one run's window
    mean) and the standard error of the replica mean, for every quantity."""
    def stats(values):
        v = np.asarray(values, dtype=float)
        spread = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
        return {"mean": float(np.mean(v)), "spread": spread,
                "stderr": spread / math.sqrt(v.size)}

    out = {key: stats([m[key] for m in means])
           for key in ("velocity_dispersion", "thickness", "multi_fraction",
                       "predicted_multi_fraction", "cpu_per_particle_step_ns", "drift",
                       "cpu_integrate")}
    out["dt_orbits"] = [min(m["dt_orbits"][0] for m in means),
                        max(m["dt_orbits"][1] for m in means)]
    out["replicas"] = len(means)
    out["orbits"] = means[0]["orbits"]
    if "size_bins" in means[0]:
        out["size_bins"] = {
            key: [stats([m["size_bins"][key][k] for m in means])
                  for k in range(len(means[0]["size_bins"][key]))]
            for key in ("velocity_dispersion", "thickness", "n")}
    return out


def z_score(line: dict, tree_value: float) -> float:
    """(line mean - tree) / (spread sqrt(1 + 1/M)): the tree run is one more draw whose
    window mean scatters like a line replica's if the two modes agree."""
    err = line["spread"] * math.sqrt(1.0 + 1.0 / max(len_replicas(line), 1))
    return (line["mean"] - tree_value) / err if err > 0 else math.nan


def len_replicas(value: dict) -> int:
    spread, stderr = value["spread"], value["stderr"]
    return int(round((spread / stderr) ** 2)) if stderr > 0 else 1


# --- the runs --------------------------------------------------------------------------------

def _save(path: Path, series: dict) -> None:
    arrays = {k: v for k, v in series.items() if isinstance(v, np.ndarray)}
    arrays.update({f"final_{k}": np.asarray(v) for k, v in series["final"].items()})
    if series["size_bin_edges"] is not None:
        arrays["size_bin_edges"] = series["size_bin_edges"]
    meta = {"cpu_integrate": series["cpu_integrate"],
            "particle_steps": series["particle_steps"], "detector": series["detector"],
            "mean_radius": series["mean_radius"], "Omega": series["Omega"]}
    np.savez(path, meta=json.dumps(meta), **arrays)


def load(path: Path) -> dict:
    with np.load(path) as f:
        series = {k: f[k] for k in f.files if k != "meta" and not k.startswith("final_")}
        series["final"] = {k[6:]: f[k] for k in f.files if k.startswith("final_")}
        series.update(json.loads(str(f["meta"])))
    series["final"]["t"] = float(series["final"]["t"])
    series.setdefault("size_bin_edges", None)
    return series


def line_tags() -> list[str]:
    return [*[f"line{dt:g}" for dt in LINE_STEPS], "lineauto"]


def run_case(case: str, runs: Path, replicas: int, log) -> None:
    """Warm-up, hand-off, reference and line runs of one case (skips runs already saved)."""
    _, _, _, _, warm_orbits, measure_orbits = CASES[case]
    sc = scenario(case)
    runs.mkdir(parents=True, exist_ok=True)

    def one(name, collision_detection, dt, orbits, state, shuffle_seed=None):
        path = runs / f"{case}_{name}.npz"
        if path.exists():
            return load(path)
        wall = time.perf_counter()
        series = simulate(sc, orbits, collision_detection, dt, state=state,
                          shuffle_seed=shuffle_seed)
        _save(path, series)
        log(f"{case} {name}: {orbits:g} orbits in {time.perf_counter() - wall:.1f} s wall, "
            f"{series['cpu_integrate']:.1f} s CPU integrating, "
            f"{1e9 * series['cpu_integrate'] / max(series['particle_steps'], 1):.0f} "
            "ns per particle-step")
        return series

    state = None
    if warm_orbits > 0:
        state = one("warmup", "line", "auto", warm_orbits, None)["final"]
    one("tree", "tree", "auto", measure_orbits, state)
    for dt in EXTRA_TREE_STEPS.get(case, ()):
        one(f"treedt{dt:g}", "tree", dt, measure_orbits, state)
    for k in range(replicas):
        for tag, dt in zip(line_tags(), [*LINE_STEPS, "auto"], strict=True):
            one(f"{tag}_r{k}", "line", dt, measure_orbits, state, shuffle_seed=1000 + k)


# --- the report ------------------------------------------------------------------------------

def collect(runs: Path) -> dict:
    """Window means, replica statistics, z-scores, costs and warm-ups of the cases in ``runs``."""
    summary = {}
    for case in CASES:
        if not (runs / f"{case}_tree.npz").exists():
            continue
        tree = load(runs / f"{case}_tree.npz")
        entry: dict = {"mean_radius": tree["mean_radius"], "Omega": tree["Omega"],
                       "size_bin_edges": (None if tree["size_bin_edges"] is None
                                          else tree["size_bin_edges"].tolist()),
                       "tree": window_means(tree), "line": {}, "tree_fixed_dt": {}}
        for dt in EXTRA_TREE_STEPS.get(case, ()):
            path = runs / f"{case}_treedt{dt:g}.npz"
            if path.exists():
                entry["tree_fixed_dt"][f"{dt:g}"] = window_means(load(path))
        for tag in line_tags():
            paths = sorted(runs.glob(f"{case}_{tag}_r*.npz"))
            if not paths:
                continue
            line = replica_statistics([window_means(load(p)) for p in paths])
            z = {key: z_score(line[key], entry["tree"][key])
                 for key in ("velocity_dispersion", "thickness")}
            if "size_bins" in line:
                z["size_bins"] = {
                    key: [z_score(v, t) for v, t in zip(line["size_bins"][key],
                                                        entry["tree"]["size_bins"][key],
                                                        strict=True)]
                    for key in ("velocity_dispersion", "thickness")}
            line["z"] = z
            entry["line"][tag] = line
        warm = runs / f"{case}_warmup.npz"
        if warm.exists():
            entry["warmup"] = _warmup_summary(load(warm))
        summary[case] = entry
    return summary


def _warmup_summary(series: dict) -> dict:
    """The warm-up's final third and the e-folding time of its approach [orbits], fitted to
    c_eq - c(t) while c is between half and 95% of its final value c_eq."""
    final = window_means(series)
    t = series["orbits"]
    c = series["velocity_dispersion"]
    c_eq = float(np.mean(c[t >= t[-1] - (t[-1] - t[0]) / 3.0]))
    ok = (c < 0.95 * c_eq) & (c > 0.5 * c_eq)
    first_reach = t[np.argmax(c >= 0.95 * c_eq)] if np.any(c >= 0.95 * c_eq) else t[-1]
    ok &= t < first_reach
    t_relax = math.nan
    if np.count_nonzero(ok) >= 3:
        slope = np.polyfit(t[ok], np.log(c_eq - c[ok]), 1)[0]
        t_relax = -1.0 / slope if slope < 0 else math.nan
    return {"velocity_dispersion": c_eq, "relaxation_orbits": t_relax,
            "orbits": float(t[-1] - t[0]), "cpu_integrate": final["cpu_integrate"],
            "cpu_per_particle_step_ns": final["cpu_per_particle_step_ns"]}


def figures(runs: Path, summary: dict) -> list[str]:
    """dt-convergence, time-series and multi-encounter figures; returns their file names."""
    plt = pyplot()
    cases = list(summary)
    return [_dt_convergence_figure(plt, summary, cases),
            _velocity_dispersion_figure(plt, runs, summary, cases),
            _multi_encounter_figure(plt, summary, cases)]


def _dt_convergence_figure(plt, summary: dict, cases: list[str]) -> str:
    """Line-mode means over replicas against dt; the tree run as a band of +- one replica
    spread (the scatter expected of a single run)."""
    fig, axes = plt.subplots(2, len(cases), figsize=(2.9 * len(cases), 5.4), squeeze=False)
    for col, case in enumerate(cases):
        entry = summary[case]
        c_scale, h_scale = scales(entry)
        for row, (key, label, s) in enumerate((
                ("velocity_dispersion", "c / (<r> Omega)", c_scale),
                ("thickness", "H / <r>", h_scale))):
            ax = axes[row, col]
            tree = entry["tree"][key] * s
            spread = entry["line"]["line0.001"][key]["spread"] * s
            ax.axhspan(tree - spread, tree + spread, color="0.85",
                       label="tree, dt auto (± replica spread)")
            ax.axhline(tree, color="0.3", lw=1.0)
            dts = np.array(LINE_STEPS) * 1e3
            vals = [entry["line"][f"line{dt:g}"][key] for dt in LINE_STEPS]
            ax.errorbar(dts, [v["mean"] * s for v in vals], [v["stderr"] * s for v in vals],
                        fmt="o-", color="C0", capsize=3, label="line, fixed dt (mean ± stderr)")
            auto = entry["line"]["lineauto"]
            ax.errorbar([1e3 * auto["dt_orbits"][1] * 0.9], [auto[key]["mean"] * s],
                        [auto[key]["stderr"] * s], fmt="s", color="C1", capsize=3,
                        label="line, dt auto")
            ax.set_xscale("log")
            ax.set_xticks(dts)
            ax.set_xticklabels([f"{d:g}" for d in dts])
            ax.minorticks_off()
            ax.set_xlabel("dt [10^-3 orbit]")
            if col == 0:
                ax.set_ylabel(label)
            if row == 0:
                ax.set_title(case, fontsize=9)
    axes[0, 0].legend(fontsize=6, loc="best")
    return figure_file(fig, FIGURES, "dt_convergence.png").name


def _velocity_dispersion_figure(plt, runs: Path, summary: dict, cases: list[str]) -> str:
    """c(t): warm-up, tree reference, two line replicas at 1e-3 and one at 5e-3 orbit."""
    fig, axes = plt.subplots(1, len(cases), figsize=(2.9 * len(cases), 3.0), squeeze=False)
    for col, case in enumerate(cases):
        ax = axes[0, col]
        c_scale, _ = scales(summary[case])
        for name, label, style in (
                ("warmup", "line warm-up", dict(color="0.6", lw=0.8)),
                ("line0.001_r0", "line 1e-3", dict(color="C0", lw=0.8)),
                ("line0.001_r1", None, dict(color="C0", lw=0.8, ls=":")),
                ("line0.005_r0", "line 5e-3", dict(color="C3", lw=0.8)),
                ("tree", "tree dt auto", dict(color="k", lw=1.3))):
            path = runs / f"{case}_{name}.npz"
            if path.exists():
                s = load(path)
                ax.plot(s["orbits"], s["velocity_dispersion"] * c_scale, label=label, **style)
        ax.set_xlabel("t [orbits]")
        if col == 0:
            ax.set_ylabel("c / (<r> Omega)")
        ax.set_title(case, fontsize=9)
    axes[0, 0].legend(fontsize=6)
    return figure_file(fig, FIGURES, "velocity_dispersion.png").name


def _multi_encounter_figure(plt, summary: dict, cases: list[str]) -> str:
    """The multi-encounter fraction, measured and predicted, against dt."""
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    for k, case in enumerate(cases):
        line = summary[case]["line"]
        dts = np.array(LINE_STEPS) * 1e3
        measured = [line[f"line{dt:g}"]["multi_fraction"]["mean"] for dt in LINE_STEPS]
        predicted = [line[f"line{dt:g}"]["predicted_multi_fraction"]["mean"]
                     for dt in LINE_STEPS]
        ax.plot(dts, np.maximum(measured, 1e-5), "o-", color=f"C{k}", label=case)
        ax.plot(dts, np.maximum(predicted, 1e-5), "x--", color=f"C{k}")
    ax.axhline(MULTI_ENCOUNTER_TARGET, color="0.5", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(np.array(LINE_STEPS) * 1e3)
    ax.set_xticklabels([f"{d * 1e3:g}" for d in LINE_STEPS])
    ax.minorticks_off()
    ax.set_xlabel("dt [10^-3 orbit]")
    ax.set_ylabel("collisions with a partner deflected earlier in the step")
    ax.set_title("measured (o, solid) and predicted (x, dashed); line: dt: auto target",
                 fontsize=8)
    ax.legend(fontsize=7)
    return figure_file(fig, FIGURES, "multi_encounters.png").name


def main(argv: list[str] | None = None, prog: str | None = None) -> None:
    """``python -m validation line-mode``: run the cases and/or write the section."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("stage", choices=["run", "report", "all"])
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument("--replicas", type=int, default=6,
                        help="line-mode runs per variant (shuffle seeds)")
    parser.add_argument("--runs", default=str(ROOT / "runs" / "line_mode"),
                        help="directory of the saved runs (.npz)")
    args = parser.parse_args(argv)
    runs = Path(args.runs)
    if args.stage in ("run", "all"):
        for case in args.cases:
            run_case(case, runs, args.replicas, log=lambda message: print(message, flush=True))
    if args.stage in ("report", "all"):
        summary = collect(runs)
        figures(runs, summary)
        SUMMARY.parent.mkdir(parents=True, exist_ok=True)
        SUMMARY.write_text(json.dumps(summary, indent=1, allow_nan=True))
        replace_section(DOC, LINE_MODE_HEADING, line_mode_markdown(summary, args.replicas),
                        "Validation")
        print(f"wrote {DOC}, {SUMMARY} and {FIGURES}")
