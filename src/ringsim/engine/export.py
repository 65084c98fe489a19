"""`ringsim export`: a snapshot of a run file as a particle CSV or as a REBOUND simulation.

The CSV has the columns of ``sheet.initial_state`` CSVs (`initial_file.CSV_COLUMNS`, and
``CSV_SPIN_COLUMNS`` for a run with friction; SI, vy including the shear flow -1.5 Omega x)
after ``#`` comment lines naming the run, the snapshot time and the box. The REBOUND file is
the simulation that a run continuing the snapshot starts from (a scenario with
``sheet.initial_state: {file: RUN.h5, snapshot: i}``, built by `sheet.new_simulation`): the
run's sheet settings, box, step, time (the snapshot's time modulo the shear period, see
`initial_file`) and collision-shuffle seed. REBOUND does not save function pointers or
spins, so a REBOUND user puts back the resolver, the self-gravity solver and the spins after
loading it (`continuation_code`, docs/export.md): then ten steps of it equal ten steps of
ringsim's own continuation bit for bit (tests/test_initial_state_export.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine.initial_file import CSV_COLUMNS, CSV_FIELDS, CSV_SPIN_COLUMNS
from ringsim.engine.native import rebound_sei
from ringsim.engine.sheet import new_simulation
from ringsim.errors import InputError
from ringsim.gravity.registry import scenario_gravity_arguments
from ringsim.store.bulk import SPIN_FIELDS


def _snapshot_index(run, index: int) -> int:
    if not -run.n_snapshots <= index < run.n_snapshots:
        raise InputError(str(run.path), "--snapshot", f"the run has {run.n_snapshots} "
                         f"snapshots, no index {index} (-{run.n_snapshots} ... "
                         f"{run.n_snapshots - 1})")
    return index % run.n_snapshots


def export_csv(run, index: int, out: str | Path) -> Path:
    """Write snapshot ``index`` of ``run`` (a `ringsim.open_run` Run) as a particle CSV."""
    index = _snapshot_index(run, index)
    snap = run.snapshot(index)
    a = run.attrs
    lines = [f"# ringsim snapshot {index} of {run.path} (run {run.scenario.name}, seed "
             f"{run.scenario.seed})",
             f"# t = {snap['t']!r} s (give it as sheet.initial_state.t); box Lx = "
             f"{a['Lx']!r} m, Ly = {a['Ly']!r} m; Omega = {a['Omega']!r} 1/s; vy includes "
             "the shear flow -1.5 Omega x"]
    fields: tuple[str, ...] = CSV_FIELDS
    columns: tuple[str, ...] = CSV_COLUMNS
    if all(f in snap for f in SPIN_FIELDS):      # a run with friction: its spins too
        fields, columns = fields + SPIN_FIELDS, columns + CSV_SPIN_COLUMNS
    lines.append(",".join(columns))
    table = np.column_stack([snap[f] for f in fields])
    lines += [",".join(repr(float(x)) for x in row) for row in table]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    return out


def continuation_scenario(run, index: int):
    """The run's scenario started from its snapshot ``index`` (``sheet.initial_state``)."""
    index = _snapshot_index(run, index)
    d = run.scenario.to_dict()
    for key in ("optical_depth", "n_particles", "aspect", "initial_dispersion",
                "initial_toomre_q"):
        d["sheet"].pop(key, None)
    d["sheet"]["initial_state"] = {"file": str(Path(run.path).resolve()), "snapshot": index}
    return scenario_from_dict(d, source=str(run.path))


def export_rebound(run, index: int, out: str | Path) -> tuple[Path, dict]:
    """Write the REBOUND simulation continuing snapshot ``index``; returns the path and
    what REBOUND's file does not keep (its function pointers and the spins): restitution,
    collision_detection, resolver (``integration.resolver``), friction and inertia_factor,
    gravity (None, or the keywords of `gravity.registry.install_gravity`), spins (whether
    the snapshot has spins that a rough continuation needs), with the file's rand_seed,
    t [s] and orbits of the shear phase; `continuation_code` writes them as Python."""
    index = _snapshot_index(run, index)
    scenario = continuation_scenario(run, index)
    sim, *_, spins = new_simulation(scenario)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.exists():
        out.unlink()  # save_to_file appends to an existing file
    with rebound_sei(sim):      # the file names REBOUND's SEI: plain REBOUND loads it
        sim.save_to_file(str(out))
    gravity = None
    if scenario.sheet.gravity:      # the run loop's arguments, those not given left out
        gravity = {key: value for key, value in scenario_gravity_arguments(scenario).items()
                   if value is not None}
    friction = scenario.friction_dict()
    return out, {"restitution": scenario.restitution_dict(),
                 "collision_detection": scenario.integration.collision_detection,
                 "resolver": scenario.integration.resolver,
                 "friction": friction, "inertia_factor": scenario.particles.inertia_factor,
                 "gravity": gravity, "spins": spins is not None and friction is not None,
                 "run": str(Path(run.path).resolve()), "snapshot": index,
                 "rand_seed": int(sim.rand_seed), "t": float(sim.t),
                 "orbits": float(sim.t) * scenario.orbital_frequency / (2.0 * math.pi)}


def continuation_code(path: str | Path, info: dict) -> str:
    """Python that continues an exported simulation in plain REBOUND as ringsim continues
    the snapshot (``info`` from `export_rebound`): load it, put back ringsim's resolver
    (with the run's friction), its self-gravity solver and the spins, which REBOUND's file
    does not keep (tests/test_initial_state_export.py runs this code); a run of REBOUND's
    hard-sphere resolver (``integration.resolver``) gets that resolver back with its law."""
    resolver = f"{info['restitution']!r}"
    if info["friction"] is not None:
        resolver += (f", friction={info['friction']!r}, "
                     f"inertia_factor={info['inertia_factor']!r}")
    lines = [*(["import numpy"] if info["spins"] else []), "import rebound", "import ringsim", "",
             f"sim = rebound.Simulation({str(path)!r})",
             f"handle = ringsim.install_resolver(sim, {resolver}, "
             f"collision_detection={info['collision_detection']!r})"]
    if info.get("resolver") == "rebound_hardsphere":   # REBOUND's resolver with the law
        lines[-2:] = ["from ringsim.engine.hardsphere import HardsphereHandle", "",
                      f"sim = rebound.Simulation({str(path)!r})",
                      f"handle = HardsphereHandle({info['restitution']!r}).reinstall(sim)"]
    gravity = info["gravity"]
    if gravity is not None:
        keywords = ", ".join(f"{k}={v!r}" for k, v in gravity.items() if k != "solver")
        lines += ["from ringsim.engine.gravity import install_gravity",
                  f"install_gravity(sim, {gravity['solver']!r}, {keywords})"]
    if info["spins"]:
        lines += [f"snap = ringsim.open_run({info['run']!r}).snapshot({info['snapshot']})",
                  "handle.set_spins(numpy.column_stack([snap['wx'], snap['wy'], snap['wz']]))"]
    return "\n".join(lines) + "\n"
