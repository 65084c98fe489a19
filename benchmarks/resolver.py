"""Benchmark of ringsim's native collision resolver against REBOUND's hard-sphere resolver.

Usage (from the repository root, about a minute on 2 cores)::

    python benchmarks/resolver.py
    python benchmarks/resolver.py --n 2000 --tau 0.25 --orbits 1 --repeats 5

Prints

1. whole-run wall time of a shearing-sheet run with ringsim's C resolver (constant eps)
   divided by the same run with REBOUND's built-in ``hardsphere`` resolver given the same
   constant eps through a C ``coefficient_of_restitution`` callback; the runs are
   interleaved, repeated, and the median ratio is reported (target <= 1.03).  Both give
   the same trajectory up to round-off, so they do the same tree and integrator work.
2. cost per resolved collision of the pure-Python twin divided by that of the C
   resolver: the C cost from one batched C call over fresh two-particle collisions, each
   reported twice as the tree search does; the Python cost both over the same collisions
   and inside REBOUND callbacks during a shorter run.
"""

from __future__ import annotations

import argparse
import ctypes
import math
import os
import platform
import statistics
import time

import numpy as np
import rebound
from rebound.simulation import CORFF

from ringsim.engine.resolver import (
    collision_records,
    constant_epsilon_callback_address,
    install_resolver,
)
from ringsim.physics.sizes import PowerLaw
from ringsim.testing import PythonReferenceResolver

OMEGA = 2e-4                    # [1/s] orbital frequency
ORBIT = 2.0 * math.pi / OMEGA   # [s]
DENSITY = 900.0                 # [kg/m^3]
EPSILON = 0.5                   # constant coefficient of restitution of the comparison


def make_sheet(n: int, tau: float, seed: int, r_min: float = 0.5, r_max: float = 2.0,
               q: float = 3.0) -> rebound.Simulation:
    """Non-overlapping shearing-sheet patch (SEI, shear boundaries, tree collisions, no
    gravity), radii [m] from dN/dR ∝ R^-q, box side from the optical depth tau."""
    rng = np.random.default_rng(seed)
    radii = np.sort(PowerLaw(q=q, r_min=r_min, r_max=r_max).draw_radii(n, rng))[::-1]
    box = math.sqrt(np.sum(np.pi * radii**2) / tau)
    sim = rebound.Simulation()
    sim.OMEGA = OMEGA
    sim.integrator = "sei"
    sim.boundary = "shear"
    sim.gravity = "none"
    sim.collision = "tree"
    sim.N_ghost_x = sim.N_ghost_y = 1
    sim.N_ghost_z = 0
    sim.root_size = box
    sim.N_root_x = sim.N_root_y = sim.N_root_z = 1
    sim.dt = 1e-3 * ORBIT
    sim.rand_seed = seed
    positions = np.empty((n, 3))
    placed = 0
    while placed < n:
        trial = np.array([rng.uniform(-box / 2, box / 2), rng.uniform(-box / 2, box / 2),
                          rng.normal(0.0, 2.0 * radii[placed])])
        d = positions[:placed] - trial
        d[:, :2] -= box * np.round(d[:, :2] / box)
        if np.all(np.sum(d * d, axis=1) > (radii[:placed] + radii[placed]) ** 2):
            positions[placed] = trial
            placed += 1
    velocities = rng.normal(0.0, 2.0 * OMEGA, (n, 3))
    velocities[:, 1] += -1.5 * OMEGA * positions[:, 0]
    masses = DENSITY * 4.0 / 3.0 * np.pi * radii**3
    for (x, y, z), (vx, vy, vz), m, r in zip(positions, velocities, masses, radii,
                                             strict=True):
        sim.add(m=m, r=r, x=x, y=y, z=z, vx=vx, vy=vy, vz=vz)
    return sim


def use_ringsim(sim: rebound.Simulation):
    return install_resolver(sim, {"model": "constant", "epsilon": EPSILON})


def use_builtin(sim: rebound.Simulation):
    handle = install_resolver(sim, {"model": "constant", "epsilon": EPSILON})
    sim.collision_resolve = "hardsphere"
    sim._corfp = CORFF(constant_epsilon_callback_address())    # C callback, no Python
    sim._coefficient_of_restitution = sim._corfp
    return handle


def timed_run(sim: rebound.Simulation, orbits: float) -> tuple[float, float]:
    """Wall-clock and CPU seconds of integrating ``orbits`` orbits."""
    wall, cpu = time.perf_counter(), time.process_time()
    sim.integrate(orbits * ORBIT)
    return time.perf_counter() - wall, time.process_time() - cpu


def whole_run_ratio(n: int, tau: float, orbits: float, repeats: int, seed: int) -> dict:
    """Interleaved runs; the order alternates so drifts of machine load cancel."""
    times = {"ringsim": [], "rebound": []}
    cpu = {"ringsim": [], "rebound": []}
    collisions = {}
    for rep in range(repeats):
        order = ("ringsim", "rebound") if rep % 2 == 0 else ("rebound", "ringsim")
        for name in order:
            sim = make_sheet(n, tau, seed)
            (use_ringsim if name == "ringsim" else use_builtin)(sim)
            wall, cpu_seconds = timed_run(sim, orbits)
            times[name].append(wall)
            cpu[name].append(cpu_seconds)
            collisions[name] = sim.collisions_log_n
    ratios = [a / b for a, b in zip(times["ringsim"], times["rebound"], strict=True)]
    cpu_ratios = [a / b for a, b in zip(cpu["ringsim"], cpu["rebound"], strict=True)]
    return {"times": times, "cpu": cpu, "ratios": ratios,
            "median_ratio": statistics.median(ratios),
            "median_cpu_ratio": statistics.median(cpu_ratios),
            "ratio_of_medians": statistics.median(times["ringsim"])
            / statistics.median(times["rebound"]),
            "collisions": collisions}


def fresh_pairs(n_pairs: int, seed: int) -> rebound.Simulation:
    """n_pairs far-apart two-sphere collisions (overlapping, approaching at 1e-4 to
    1e-2 m/s, random orientation), particles 2k and 2k+1."""
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=(n_pairs, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    r1 = rng.uniform(0.5, 2.0, n_pairs)
    r2 = rng.uniform(0.5, 2.0, n_pairs)
    centre = np.zeros((n_pairs, 3))
    centre[:, 0] = 10.0 * np.arange(n_pairs)
    speed = 10.0 ** rng.uniform(-4.0, -2.0, n_pairs)
    xyz = np.empty((2 * n_pairs, 3))
    vxyz = np.zeros((2 * n_pairs, 3))
    xyz[0::2] = centre + 0.98 * (r1 + r2)[:, None] * normal
    xyz[1::2] = centre
    vxyz[0::2] = -speed[:, None] * normal
    sim = rebound.Simulation()
    radii = np.empty(2 * n_pairs)
    radii[0::2], radii[1::2] = r1, r2
    for r in radii:
        sim.add(m=DENSITY * 4.0 / 3.0 * math.pi * r**3, r=r)
    sim.set_serialized_particle_data(xyz=xyz, vxvyvz=vxyz)
    return sim


def per_collision_costs(n_pairs: int, twin_orbits: float, n: int, tau: float,
                        seed: int) -> dict:
    restitution = {"model": "constant", "epsilon": EPSILON}
    # Each pair reported twice, (i, j) then (j, i), as REBOUND's tree search does.
    pairs = np.empty((2 * n_pairs, 2), dtype=np.int64)
    pairs[0::2] = np.column_stack([np.arange(0, 2 * n_pairs, 2), np.arange(1, 2 * n_pairs, 2)])
    pairs[1::2] = pairs[0::2, ::-1]

    sim_c = fresh_pairs(n_pairs, seed)
    handle = install_resolver(sim_c, restitution)
    records = collision_records(pairs)
    start = time.perf_counter()
    resolved = handle.resolve_batch(records)
    c_seconds = (time.perf_counter() - start) / resolved

    sim_py = fresh_pairs(n_pairs, seed)
    twin = PythonReferenceResolver(restitution)
    sim_pointer = ctypes.pointer(sim_py)
    collisions = [rebound.simulation.CollisionS(p1=int(i), p2=int(j)) for i, j in pairs]
    start = time.perf_counter()
    for collision in collisions:
        twin(sim_pointer, collision)
    py_seconds = (time.perf_counter() - start) / twin.count
    assert twin.count == resolved == n_pairs and not twin.errors

    # Inside REBOUND's callbacks during a run (includes the second, receding reports).
    sim_run = make_sheet(n, tau, seed)
    twin_run = PythonReferenceResolver(restitution)
    spent = [0.0]

    def timed_twin(sim_p, collision):
        t0 = time.perf_counter()
        outcome = twin_run(sim_p, collision)
        spent[0] += time.perf_counter() - t0
        return outcome

    sim_run.collision_resolve = timed_twin
    run_seconds = timed_run(sim_run, twin_orbits)[0]
    in_run = spent[0] / twin_run.count
    return {"c_ns": 1e9 * c_seconds, "py_us": 1e6 * py_seconds, "py_run_us": 1e6 * in_run,
            "ratio": py_seconds / c_seconds, "ratio_in_run": in_run / c_seconds,
            "run_seconds": run_seconds, "run_collisions": twin_run.count}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=2000, help="particles in the sheet")
    parser.add_argument("--tau", type=float, default=0.25, help="optical depth")
    parser.add_argument("--orbits", type=float, default=1.0, help="run length [orbits]")
    parser.add_argument("--repeats", type=int, default=7, help="runs per resolver")
    parser.add_argument("--twin-orbits", type=float, default=0.2,
                        help="run length with the Python twin [orbits]")
    parser.add_argument("--pairs", type=int, default=20000, help="pairs in the batch timing")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    print(f"ringsim resolver benchmark  {time.strftime('%Y-%m-%d %H:%M:%S')}")
    print(f"machine: {platform.machine()} {platform.processor() or ''}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}, "
          f"REBOUND {rebound.__version__}")
    print(f"sheet: N={args.n}, tau={args.tau}, radii 0.5-2 m (q=3), Omega={OMEGA} 1/s, "
          f"dt=1e-3 orbit, SEI, shear boundary, tree collisions, no gravity, "
          f"eps={EPSILON} constant")

    whole = whole_run_ratio(args.n, args.tau, args.orbits, args.repeats, args.seed)
    print(f"\n1. whole run ({args.orbits} orbit, {args.repeats} interleaved repeats each)")
    for name in ("ringsim", "rebound"):
        t = whole["times"][name]
        print(f"   {name:8s} wall median {statistics.median(t):7.3f} s   runs "
              + " ".join(f"{x:.3f}" for x in t)
              + f"   CPU median {statistics.median(whole['cpu'][name]):.3f} s"
              + f"   collisions {whole['collisions'][name]}")
    print("   wall ratios per repeat  " + " ".join(f"{x:.3f}" for x in whole["ratios"]))
    print(f"   median wall ratio ringsim C / REBOUND hardsphere = {whole['median_ratio']:.3f}"
          "   (target <= 1.03)")
    print(f"   ratio of median wall times = {whole['ratio_of_medians']:.3f},"
          f"   median CPU-time ratio = {whole['median_cpu_ratio']:.3f}")

    cost = per_collision_costs(args.pairs, args.twin_orbits, args.n, args.tau, args.seed)
    print(f"\n2. cost per resolved collision ({args.pairs} fresh pairs, each reported twice)")
    print(f"   C resolver (one batched call)        {cost['c_ns']:9.1f} ns")
    print(f"   Python twin (same collisions)        {cost['py_us']:9.2f} us"
          f"   ratio Python / C = {cost['ratio']:.0f}")
    print(f"   Python twin inside REBOUND callbacks {cost['py_run_us']:9.2f} us"
          f"   ratio Python / C = {cost['ratio_in_run']:.0f}"
          f"   ({args.twin_orbits} orbit, {cost['run_collisions']} collisions, "
          f"run {cost['run_seconds']:.2f} s)")


if __name__ == "__main__":
    main()
