"""`ringsim export`: a snapshot of a run file as a particle CSV or as a REBOUND simulation.

The CSV has the columns of ``sheet.initial_state`` CSVs (`initial_file.CSV_COLUMNS`, SI,
vy including the shear flow -1.5 Omega x) after ``#`` comment lines naming the run, the
snapshot time and the box.  The REBOUND file is the simulation that a run continuing the
snapshot starts from (a scenario with ``sheet.initial_state: {file: RUN.h5, snapshot: i}``,
built by `sheet.new_simulation`): the run's sheet settings, box, step, time (the snapshot's
time modulo the shear period, see `initial_file`) and collision-shuffle seed.  REBOUND does
not save function pointers, so a REBOUND user re-installs the resolver after loading it
(docs/export.md): then ten steps of it equal ten steps of ringsim's own continuation bit
for bit (tests/test_export.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ringsim.engine.initial_file import CSV_COLUMNS
from ringsim.errors import InputError

_FIELDS = ("x", "y", "z", "vx", "vy", "vz", "radius", "mass")


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
             "the shear flow -1.5 Omega x",
             ",".join(CSV_COLUMNS)]
    table = np.column_stack([snap[f] for f in _FIELDS])
    lines += [",".join(repr(float(x)) for x in row) for row in table]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    return out


def continuation_scenario(run, index: int):
    """The run's scenario started from its snapshot ``index`` (``sheet.initial_state``)."""
    from ringsim.config.initial_state import sheet_dict_with_file  # noqa: F401 (documented)
    from ringsim.config.scenario import scenario_from_dict

    index = _snapshot_index(run, index)
    d = run.scenario.to_dict()
    for key in ("optical_depth", "n_particles", "aspect", "initial_dispersion"):
        d["sheet"].pop(key, None)
    d["sheet"]["initial_state"] = {"file": str(Path(run.path).resolve()), "snapshot": index}
    return scenario_from_dict(d, source=str(run.path))


def export_rebound(run, index: int, out: str | Path) -> tuple[Path, dict]:
    """Write the REBOUND simulation continuing snapshot ``index``; returns the path and
    what REBOUND's file does not keep: {"restitution": ..., "collision_detection": ...}."""
    from ringsim.engine.sheet import new_simulation

    scenario = continuation_scenario(run, index)
    sim = new_simulation(scenario)[0]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.exists():
        out.unlink()  # save_to_file appends to an existing file
    sim.save_to_file(str(out))
    return out, {"restitution": scenario.restitution_dict(),
                 "collision_detection": scenario.integration.collision_detection,
                 "rand_seed": int(sim.rand_seed), "t": float(sim.t),
                 "orbits": float(sim.t) * scenario.orbital_frequency / (2.0 * math.pi)}
