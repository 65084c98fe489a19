"""Profile of the whole line-mode step: where the time per particle-step goes.

Splits the CPU time of the run loop (one thread) into

* REBOUND's SEI drift/kick and boundary wrap (the simulation integrated with the resolver
  removed),
* ringsim's detector search (``rs_sheet_detect.c``: wrap, grid, candidate search; timed
  through its test entry ``rs_sheet_detect_pairs``, which searches without resolving),
* the time-ordered resolution (the whole step minus the two above),
* the work of a time-series output: the whole of ``runner.Runner._output`` (without the
  commits, which a writer thread makes while the integration goes on) and its pieces
  (particle copies out of REBOUND, invariants, diagnostics, overlap count in C, guards),
  with BLAS on one thread as in a run (``engine.blas``), per output and per particle-step
  at the default cadence (an output every 0.1 orbit = 100 steps of 1e-3 orbit); and, as the
  baseline in the same process, the overlap count of its numpy twin (the engine's count
  before issue 16 part C, ``testing.count_overlaps_numpy``).

Scenario: benchmarks/scale.yaml (line mode, no gravity, power law 0.5-5 m, q = 3,
tau = 0.25, Bridges et al. 1984 law).  ``--setup scenario`` builds the sheet with
``ringsim.engine.sheet.build_sheet`` (the run's set-up); ``--setup lattice`` places the
particles on a jittered lattice with numpy (overlap-free by construction, 7 layers) and
adds them with REBOUND, for sizes whose set-up through the scenario is slow.  Only the
steps are timed.

    python benchmarks/profile_step.py --sizes 10000 100000 [--steps 100] [--setup lattice]

The C side's own split (SEI, rs_scan, rs_grid_sort ...) was read with ``perf record``
(docs/performance.md "Whole step").
"""

from __future__ import annotations

import argparse
import ctypes
import math
import tempfile
import time
from pathlib import Path

import numpy as np
import rebound

from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.engine import box, invariants, native, sheet, timestep
from ringsim.engine.blas import one_blas_thread
from ringsim.engine.resolver import install_resolver
from ringsim.engine.runner import Runner
from ringsim.physics.sizes import size_bin_edges
from ringsim.testing import count_overlaps_numpy

#: Default cadence: steps of 1e-3 orbit between outputs every 0.1 orbit.
STEPS_PER_OUTPUT = 100


#: The benchmark's sheet (also benchmarks/scale.py's).
SCENARIO = Path(__file__).with_name("scale.yaml")


def scale_scenario(n_particles: int, **overrides):
    """benchmarks/scale.yaml with ``n_particles`` and further dotted-key ``overrides``."""
    return with_overrides(load_scenario(SCENARIO),
                          {"sheet.n_particles": int(n_particles), **overrides})


def lattice_sheet(sc):
    """A ``sheet.BuiltSheet`` of the scenario's particles on a jittered lattice.

    Lattice spacing a = 2.2 r_max in x and y, layers a apart in z: each particle moves by
    at most a / 2 - r from its site, so no two overlap.  Velocities: the shear flow plus
    a random 2 <r> Omega.
    """
    rng = np.random.default_rng(sc.seed)
    n = sc.sheet.n_particles
    Omega = sc.orbital_frequency
    radii = sc.particles.size_distribution.draw_radii(n, rng)
    masses = sc.particles.density * 4.0 / 3.0 * np.pi * radii**3
    a = 2.2 * float(radii.max())
    geometry = box.box_geometry(radii, sc.sheet.optical_depth, 1.0, Omega, 1.0)
    nx, ny = int(geometry.Lx // a), int(geometry.Ly // a)
    layers = math.ceil(n / (nx * ny))
    geometry = box.box_geometry(radii, sc.sheet.optical_depth, 1.0, Omega, 2.0 * layers * a)
    sites = rng.permutation(nx * ny * layers)[:n]
    ix, iy, iz = sites % nx, (sites // nx) % ny, sites // (nx * ny)
    play = (0.5 * a - radii)[:, None] * rng.uniform(-1.0, 1.0, (n, 3))
    x = -0.5 * geometry.Lx + (ix + 0.5) * geometry.Lx / nx + play[:, 0]
    y = -0.5 * geometry.Ly + (iy + 0.5) * geometry.Ly / ny + play[:, 1]
    z = (iz - 0.5 * (layers - 1)) * a + play[:, 2]
    c = 2.0 * float(radii.mean()) * Omega
    state = {"x": x, "y": y, "z": z, "vx": rng.normal(0.0, c, n),
             "vy": -1.5 * Omega * x + rng.normal(0.0, c, n), "vz": rng.normal(0.0, c, n)}
    sim = rebound.Simulation()
    sheet.configure_simulation(sim, geometry, gravity=None, collision_detection="line",
                               rand_seed=sc.seed)
    sheet.add_particles(sim, state, radii, masses)
    sim.minimum_collision_velocity = sheet.minimum_collision_velocity(radii, Omega)
    sim.dt = timestep.choose_dt(sc.integration, sheet.particle_arrays(sim), Omega)
    handle = install_resolver(sim, sc.restitution_dict(), collision_detection="line")
    return sheet.BuiltSheet(sim, geometry, radii, masses,
                            size_bin_edges(sc.particles.size_distribution), handle)


def _cpu_per(function, repeat: int) -> float:
    """Median CPU time [s] of ``function()`` over ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        function()
        times.append(time.process_time() - start)
    return float(np.median(times))


@one_blas_thread
def output_work(sim, geometry, handle, Omega: float, repeat: int) -> dict[str, float]:
    """CPU time [s] of the pieces of one time-series output (runner.Runner._output), and of
    the numpy twin of the overlap count."""
    from ringsim.analysis.snapshot import snapshot_summary

    arrays = sheet.particle_arrays(sim)
    momentum = invariants.sheet_momentum(arrays, Omega, sim.t)

    def invariant_checks():
        invariants.check_state(arrays, sim.N, sim.t)
        now = invariants.sheet_momentum(arrays, Omega, sim.t)
        tolerance = invariants.momentum_tolerance(arrays, Omega, STEPS_PER_OUTPUT, 0)
        return invariants.momentum_residual(now, momentum, Omega) <= tolerance

    def diagnostics():
        snapshot_summary(arrays["x"], arrays["y"], arrays["z"], arrays["vx"], arrays["vy"],
                         arrays["vz"], arrays["radius"], arrays["mass"], Omega, geometry.Lx,
                         geometry.Ly)

    return {
        "particle copies": _cpu_per(lambda: sheet.particle_arrays(sim), repeat),
        "invariants": _cpu_per(invariant_checks, repeat),
        "diagnostics": _cpu_per(diagnostics, repeat),
        "overlap count": _cpu_per(lambda: box.count_overlaps(arrays, geometry, sim.t),
                                  repeat),
        "overlap count, numpy twin (before)": _cpu_per(
            lambda: count_overlaps_numpy(arrays, geometry.Lx, geometry.Ly,
                                         1.5 * Omega * geometry.Lx * sim.t,
                                         box.OVERLAP_REPORT_FRACTION), repeat),
        "guards": _cpu_per(lambda: sheet.max_vertical_amplitude(arrays, Omega), repeat),
        "resolver statistics": _cpu_per(handle.stats, repeat),
    }


def whole_output(sc, built: sheet.BuiltSheet, repeat: int) -> float:
    """CPU time [s] of ``runner.Runner._output`` at the sheet's present state, without the
    commits (no snapshot, checkpoint or row write falls due while it is timed)."""
    with tempfile.TemporaryDirectory() as folder:
        runner = Runner(sc, Path(folder) / "profile.h5", progress=False)
        runner.start_new(built)   # the first output, committed with a checkpoint
        runner._writes.join()
        runner.snap_every = runner.ckpt_every = math.inf
        runner.last_write = math.inf
        return _cpu_per(runner._output, repeat)


def search_only(sim, steps: int) -> float:
    """CPU time [s] of ``steps`` detector searches of the current state (no resolution):
    the C entry ``rs_sheet_detect_pairs`` with no room for the pairs, so nothing is
    copied out."""
    pairs = (ctypes.c_int64 * 2)()
    offsets = (ctypes.c_double * 6)()
    address = ctypes.addressof(sim)
    start = time.process_time()
    for _ in range(steps):
        found = native._LIB.rs_sheet_detect_pairs(address, 0, pairs, offsets)
        if found < 0:
            raise RuntimeError(f"sheet detector error {-found - 1}")
    return time.process_time() - start


def profile(n: int, steps: int, setup: str) -> dict[str, float]:
    """ns of CPU per particle-step of each part, for ``n`` particles."""
    sc = scale_scenario(n)
    built = lattice_sheet(sc) if setup == "lattice" else sheet.build_sheet(sc)
    sim, geometry, handle = built.sim, built.geometry, built.resolver
    sim.integrate(sim.t + 10 * sim.dt, exact_finish_time=0)   # first contacts of the set-up
    per = 1e9 / (n * steps)
    start = time.process_time()
    sim.integrate(sim.t + steps * sim.dt, exact_finish_time=0)
    whole = (time.process_time() - start) * per
    search = search_only(sim, steps) * per
    work = {"whole output (Runner._output, no commits)": whole_output(sc, built, repeat=3)}
    work.update(output_work(sim, geometry, handle, sc.orbital_frequency, repeat=3))
    handle.close()  # REBOUND alone from here
    start = time.process_time()
    sim.integrate(sim.t + steps * sim.dt, exact_finish_time=0)
    rebound_only = (time.process_time() - start) * per
    result = {"whole step": whole, "REBOUND SEI + wrap": rebound_only,
              "detector search": search,
              "resolution (rest)": whole - rebound_only - search}
    for key, seconds in work.items():
        result[f"output: {key}"] = seconds * 1e9 / (n * STEPS_PER_OUTPUT)
        result[f"output: {key} [ms per output]"] = seconds * 1e3
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1e4, 1e5])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--setup", choices=["scenario", "lattice"], default="scenario")
    args = parser.parse_args()
    rows = {int(n): profile(int(n), args.steps, args.setup) for n in args.sizes}
    print(f"CPU ns per particle-step ({args.steps} steps, setup {args.setup}; outputs at "
          f"one per {STEPS_PER_OUTPUT} steps), and CPU ms per output")
    print("| part | " + " | ".join(f"N = {n:.0e}" for n in rows) + " |")
    print("|---|" + "---|" * len(rows))
    for key in next(iter(rows.values())):
        digits = ".1f" if key.endswith("[ms per output]") else ".0f"
        print(f"| {key} | " + " | ".join(f"{r[key]:{digits}}" for r in rows.values()) + " |")


if __name__ == "__main__":
    main()
