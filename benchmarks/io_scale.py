"""Benchmark: set-up, snapshot I/O and memory of sheets of up to 10^6 particles.

Line mode, no gravity, power law 0.5-5 m (q = 3).  Five measurements:

* ``setup``: ``build_sheet`` (radii, overlap-free placement, REBOUND simulation, resolver)
  at N = 1e4, 1e5, 1e6 and tau = 0.25, 1.5: wall and CPU time, median of ``--repeat``.
* ``snapshot``: one commit of a snapshot of the sheet, in the run file (as small runs
  write it) and in a part file (as runs over ~125,000 particles write it): wall time, the
  file's growth; plus a commit of rows alone, the cost every commit of a large run pays.
* ``run``: a short run with a snapshot at every output (4 outputs, ``--every`` orbits
  apart): the run's wall time in each commit of a snapshot (its stall: commits are made by
  a writer thread, so this is the wait for the commit before), the writer's own time for
  it, and the integration between outputs.
* ``million``: ``scenarios/million.yaml`` for a fraction of its orbit (``--orbits``), set-up,
  steps and outputs timed apart; one orbit extrapolated from them.
* ``memory``: peak RSS of a short run (set-up, two outputs with snapshots and checkpoints)
  in a fresh process per N, per particle.

    python benchmarks/io_scale.py setup [--n 1e4 1e5 1e6] [--tau 0.25 1.5] [--repeat 3]
    python benchmarks/io_scale.py snapshot [--n 1e5 1e6] [--repeat 3]
    python benchmarks/io_scale.py run [--n 1e5 1e6] [--every 0.005]
    python benchmarks/io_scale.py memory [--n 1e3 1e5 1e6]
    python benchmarks/io_scale.py million [--orbits 0.02]

The machine is shared: CPU times are the steadier figure; wall times are medians.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine import sheet
from ringsim.store import bulk, runfile


def scenario(n: int, tau: float = 0.25, orbits: float = 0.004, every: float = 0.001):
    return scenario_from_dict({
        "name": "io-scale", "seed": 1, "planet": {"Omega": 2.0e-4},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 5.0}},
        "sheet": {"optical_depth": tau, "n_particles": int(n)},
        "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1},
        "integration": {"orbits": orbits, "dt": "auto", "collision_detection": "line"},
        "output": {"timeseries_every": every, "snapshot_every": every,
                   "checkpoint_every": 2 * every},
    }, source="<benchmark>")


def _timed(function, *args, **kwargs):
    wall, cpu = time.perf_counter(), time.process_time()
    out = function(*args, **kwargs)
    return time.perf_counter() - wall, time.process_time() - cpu, out


def measure_setup(ns, taus, repeat) -> list[dict]:
    rows = []
    for n in ns:
        for tau in taus:
            times = [_timed(sheet.build_sheet, scenario(n, tau))[:2] for _ in range(repeat)]
            rows.append({"n": int(n), "tau": tau,
                         "wall_s": statistics.median(t[0] for t in times),
                         "cpu_s": statistics.median(t[1] for t in times)})
            print(json.dumps(rows[-1]), flush=True)
    return rows


def _new_file(path: Path, external_bytes: int) -> runfile.RunFileWriter:
    writer = runfile.RunFileWriter(path, external_bytes=external_bytes)
    writer.create(scenario_yaml="name: io-scale", seed=1, attributes={},
                  size_bin_edges=None, histogram_edges={})
    return writer


def _size(path: Path) -> int:
    folder = bulk.parts_folder(path)
    return path.stat().st_size + sum(p.stat().st_size for p in folder.glob("*")) \
        if folder.is_dir() else path.stat().st_size


def measure_snapshot(ns, repeat) -> list[dict]:
    rows = []
    row = {"t": 0.0, "orbits": 0.0, "velocity_dispersion": 1.0}
    for n in ns:
        arrays = sheet.particle_arrays(sheet.build_sheet(scenario(n)).sim)
        raw = sum(a.nbytes for a in arrays.values())
        for label, external in (("in run file", 1 << 62), ("part file", 0)):
            walls, cpus, growth, rows_only = [], [], [], []
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "io.h5"
                writer = _new_file(path, external)
                for k in range(repeat):
                    before = _size(path)
                    wall, cpu, _ = _timed(writer.commit, rows=[row],
                                          snapshot=(k, 0.0, arrays))
                    walls.append(wall)
                    cpus.append(cpu)
                    growth.append(_size(path) - before)
                    rows_only.append(_timed(writer.commit, rows=[row])[0])
            rows.append({"n": int(n), "where": label, "raw_MB": raw / 1e6,
                         "stored_MB": statistics.median(growth) / 1e6,
                         "commit_wall_s": statistics.median(walls),
                         "commit_cpu_s": statistics.median(cpus),
                         "rows_only_commit_after_s": statistics.median(rows_only)})
            print(json.dumps(rows[-1]), flush=True)
    return rows


class _TimedWriter:
    """A RunFileWriter that records the wall time of each commit and what it carried."""

    def __init__(self, writer: runfile.RunFileWriter):
        self.writer, self.log = writer, []

    def create(self, **kwargs):
        return self.writer.create(**kwargs)

    def commit(self, **changes):
        wall = time.perf_counter()
        self.writer.commit(**changes)
        self.log.append({"snapshot": changes.get("snapshot") is not None,
                         "checkpoint": changes.get("checkpoint") is not None,
                         "wall_s": time.perf_counter() - wall})


def measure_run(ns, every: float) -> list[dict]:
    from ringsim.engine.runner import Runner

    rows = []
    for n in ns:
        with tempfile.TemporaryDirectory() as tmp:
            runner = Runner(scenario(n, orbits=4 * every, every=every), Path(tmp) / "run.h5",
                            progress=False)
            runner.writer = timed = _TimedWriter(runner.writer)
            integrate, stalls = [], []

            def timed_advance(t_next, advance=runner._advance, integrate=integrate):
                integrate.append(_timed(advance, t_next)[0])

            def timed_commit(commit=runner._commit, stalls=stalls, **changes):
                stalls.append((changes.get("snapshot") is not None, _timed(commit,
                                                                           **changes)[0]))

            runner._advance, runner._commit = timed_advance, timed_commit
            runner.start_new()
            runner.loop()
        snap = [wall for has, wall in stalls[1:-1] if has]   # not the first nor the final
        written = [c["wall_s"] for c in timed.log[2:-1] if c["snapshot"]]
        rows.append({"n": int(n), "outputs": len(stalls),
                     "stall_per_snapshot_s": statistics.median(snap),
                     "snapshot_commit_in_background_s": statistics.median(written),
                     "integration_per_output_s": statistics.median(integrate)})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def _memory_child(n: int) -> None:
    """In a fresh process: a short run; prints the peak RSS [bytes]."""
    from ringsim.engine.runner import run

    with tempfile.TemporaryDirectory() as tmp:
        run(scenario(n, orbits=0.002), output=Path(tmp) / "mem.h5", progress=False)
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)


def measure_memory(ns) -> list[dict]:
    rows = []
    for n in ns:
        out = subprocess.run([sys.executable, __file__, "_memory", str(int(n))],
                             capture_output=True, text=True, check=True)
        peak = int(out.stdout.split()[-1])
        rows.append({"n": int(n), "peak_rss_MB": peak / 1e6, "bytes_per_particle": peak / n})
        print(json.dumps(rows[-1]), flush=True)
    if len(rows) > 1:   # the increment over the smallest run: what the particles cost
        base = rows[0]
        for r in rows[1:]:
            r["increment_bytes_per_particle"] = (r["peak_rss_MB"] - base["peak_rss_MB"]) \
                * 1e6 / (r["n"] - base["n"])
            print(json.dumps(r), flush=True)
    return rows


def measure_million(orbits: float) -> dict:
    """scenarios/million.yaml for ``orbits`` (a fraction of its one orbit): set-up, steps and
    outputs timed apart, and the one-orbit time extrapolated from them."""
    from ringsim.config.scenario import load_scenario, with_overrides
    from ringsim.engine.runner import Runner

    full = load_scenario(Path(__file__).resolve().parents[1] / "scenarios" / "million.yaml")
    sc = with_overrides(full, {"integration.orbits": orbits})
    with tempfile.TemporaryDirectory() as tmp:
        runner = Runner(sc, Path(tmp) / "million.h5", progress=False)
        integrate, outputs = [], []

        def timed_advance(t_next, advance=runner._advance):
            integrate.append(_timed(advance, t_next))

        def timed_output(first=False, output=runner._output):
            outputs.append(_timed(output, first))

        runner._advance, runner._output = timed_advance, timed_output
        setup = _timed(runner.start_new)
        steps0 = runner.sim.t
        loop = _timed(runner.loop)
        steps = round((runner.sim.t - steps0) / runner.sim.dt)
    per_step = sum(t[0] for t in integrate) / steps, sum(t[1] for t in integrate) / steps
    steps_per_orbit = full.orbital_period / runner.sim.dt
    n_outputs = full.integration.orbits / full.output.timeseries_every
    per_output = statistics.median(t[0] for t in outputs[1:]) if len(outputs) > 1 else 0.0
    out = {"orbits_run": orbits, "steps": steps, "setup_and_first_output_wall_s": setup[0],
           "setup_and_first_output_cpu_s": setup[1], "loop_wall_s": loop[0],
           "step_wall_s": per_step[0], "step_cpu_s": per_step[1],
           "output_wall_s": per_output,
           "one_orbit_wall_s_extrapolated": setup[0] + steps_per_orbit * per_step[0]
           + n_outputs * per_output}
    print(json.dumps(out), flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=["setup", "snapshot", "run", "memory", "million",
                                         "_memory"])
    parser.add_argument("n_child", nargs="?", type=int)
    parser.add_argument("--n", type=float, nargs="+")
    parser.add_argument("--tau", type=float, nargs="+", default=[0.25, 1.5])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--orbits", type=float, default=0.02,
                        help="million: orbits of scenarios/million.yaml to run")
    parser.add_argument("--every", type=float, default=0.005,
                        help="run: orbits between outputs (each with a snapshot)")
    args = parser.parse_args()
    if args.what == "_memory":
        _memory_child(args.n_child)
    elif args.what == "setup":
        measure_setup(args.n or [1e4, 1e5, 1e6], args.tau, args.repeat)
    elif args.what == "snapshot":
        measure_snapshot(args.n or [1e5, 1e6], args.repeat)
    elif args.what == "million":
        measure_million(args.orbits)
    elif args.what == "run":
        measure_run(args.n or [1e5, 1e6], args.every)
    else:
        measure_memory(args.n or [1e3, 1e5, 1e6])


if __name__ == "__main__":
    main()
