"""A run's checkpoint: what the run loop saves at an output, and a run resumed from it.

A checkpoint (``store.runfile.Checkpoint``) holds the state of a run at one output: REBOUND's
binary of the sheet, the loop counters (`LoopState`), the box, REBOUND's collision-shuffle
seed ``rand_seed``, the particle count, the momentum reference of the runtime invariants
(``engine.invariants``), the resolver's statistics of the open output interval and, with
friction, the spins.  `resume` rebuilds the simulation from it: REBOUND does not save
function pointers, so the gravity solver and the resolver are installed again, with their
statistics and spins restored bit for bit.  Because the integration never depends on where
outputs or restarts fall (``engine.runner``), a resumed run gives the bits of a run that
never stopped.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import rebound

from ringsim.config.scenario import result_dict
from ringsim.engine import box, invariants, sheet
from ringsim.engine.binary import simulation_binary, simulation_from_binary
from ringsim.engine.hardsphere import HardsphereHandle, install_scenario_resolver
from ringsim.engine.resolver import ResolverHandle
from ringsim.errors import InputError
from ringsim.gravity.registry import install_scenario_gravity
from ringsim.store import runfile

if TYPE_CHECKING:
    from ringsim.config.scenario import Scenario


@dataclass
class LoopState:
    """Counters of the run loop (saved with every checkpoint)."""

    rows: int = 0          # time-series rows written
    snapshots: int = 0     # snapshots written
    guard_events: int = 0  # guard events written
    dt_warned: int = 0     # 1 once a fixed-dt violation has been reported
    overlap_warned: int = 0  # 1 once deep overlaps have been reported

    def as_attributes(self) -> dict:
        return {"rows": self.rows, "snapshots": self.snapshots,
                "guard_events": self.guard_events, "dt_warned": self.dt_warned,
                "overlap_warned": self.overlap_warned}


def checkpoint_of(sim: rebound.Simulation, state: LoopState, geometry: box.SheetGeometry,
                  n_particles: int, momentum: invariants.SheetMomentum,
                  handle: ResolverHandle | HardsphereHandle) -> runfile.Checkpoint:
    """The checkpoint of a run at ``sim.t``: REBOUND binary, loop counters, box, seed, time
    [s], particle count, momentum reference, resolver statistics and (with friction) spins."""
    saved = state.as_attributes()
    saved.update(geometry.attributes())
    saved["rand_seed"] = int(sim.rand_seed)
    saved["t"] = float(sim.t)
    saved["n_particles"] = int(n_particles)
    saved.update(momentum.as_attributes())
    return runfile.Checkpoint(simulation_binary(sim), saved, handle.stats_state(),
                              None if handle.friction is None else handle.spin_state())


def resumable_orbits(path: Path, old: Scenario, new: Scenario) -> tuple[float, float]:
    """Old and new ``integration.orbits`` of a run file's scenario ``old`` and the scenario
    ``new`` that continues it; InputError unless only they (or the thread count, which
    changes no result) differ, or if the new duration is shorter."""
    old_orbits, new_orbits = old.integration.orbits, new.integration.orbits
    if result_dict(old, without_orbits=True) != result_dict(new, without_orbits=True):
        raise InputError(str(path), "--resume",
                         "the scenario differs from the one the run file was made with "
                         "(only integration.orbits may grow)")
    if new_orbits < old_orbits:
        raise InputError(str(path), "integration.orbits",
                         f"{new_orbits:g} is shorter than the run file's {old_orbits:g}")
    return old_orbits, new_orbits


@dataclass
class Resumed:
    """A run restored from its last checkpoint, ready to integrate on.

    Attributes
    ----------
    sim : rebound.Simulation
        The sheet at the checkpoint's time, its gravity solver installed.
    handle : ResolverHandle or HardsphereHandle
        The resolver in ``sim``, statistics (and spins) as at the checkpoint.
    geometry : box.SheetGeometry
    state : LoopState
    n_particles : int
    momentum : invariants.SheetMomentum
        The momentum reference of the invariants at the checkpoint.
    run : runfile.Run
        The run file as it was read (time series, attributes).
    wall_before : float [s]
        Wall time of the run's earlier sessions.
    cpu_before : float or None [s]
        CPU time of the run's earlier sessions (None: a file written before run files
        kept it).
    orbits : (float, float) [orbits]
        The file's and the scenario's ``integration.orbits`` (the second larger: an
        extended run).
    """

    sim: rebound.Simulation
    handle: ResolverHandle | HardsphereHandle
    geometry: box.SheetGeometry
    state: LoopState
    n_particles: int
    momentum: invariants.SheetMomentum
    run: runfile.Run
    wall_before: float
    orbits: tuple[float, float]
    cpu_before: float | None = None


def _counters(path: Path, st: dict, Omega: float) -> tuple[LoopState, box.SheetGeometry, int]:
    """Loop counters, box and ``rand_seed`` of a checkpoint's state; RunFileError if one is
    unusable."""
    try:
        state = LoopState(int(st["rows"]), int(st["snapshots"]), int(st["guard_events"]),
                          int(st["dt_warned"]), int(st["overlap_warned"]))
        geometry = box.SheetGeometry(float(st["root_size"]), int(st["N_root_x"]),
                                     int(st["N_root_y"]), int(st["N_root_z"]), Omega)
        return state, geometry, int(st["rand_seed"])
    except (TypeError, ValueError) as exc:
        raise runfile.RunFileError(path, f"holds an unusable counter ({exc})",
                                   "/checkpoint") from None


def _restore_resolver(path: Path, handle: ResolverHandle | HardsphereHandle,
                      checkpoint: runfile.Checkpoint) -> None:
    """The checkpoint's statistics of the open interval and spins into ``handle``;
    RunFileError naming the dataset if they do not fit it."""
    if checkpoint.statistics is not None:
        try:
            handle.set_stats(checkpoint.statistics)
        except ValueError as exc:
            raise runfile.RunFileError(path, f"cannot be restored ({exc})",
                                       f"/{runfile.CHECKPOINT_STATISTICS}") from None
    if handle.friction is not None:
        try:
            handle.set_spin_state(checkpoint.spins)
        except ValueError as exc:
            raise runfile.RunFileError(path, f"cannot restore the spins ({exc})",
                                       f"/{runfile.CHECKPOINT_SPINS}") from None


def resume(path: Path, scenario: Scenario) -> Resumed:
    """The run of file ``path`` restored from its last checkpoint, to go on with ``scenario``.

    Raises
    ------
    InputError
        The file has no checkpoint, or ``scenario`` differs from the file's in more than
        ``integration.orbits`` (`resumable_orbits`).
    RunFileError
        The checkpoint is damaged or does not match the time series and snapshots it
        refers to.
    """
    run = runfile.open_run(path)
    checkpoint = runfile.read_checkpoint(path)
    if checkpoint is None:
        raise InputError(str(path), "--resume", "the file has no checkpoint to resume")
    orbits = resumable_orbits(path, run.scenario, scenario)
    st = checkpoint.state
    state, geometry, rand_seed = _counters(path, st, scenario.orbital_frequency)
    if state.rows > run.timeseries["t"].size or state.snapshots > run.n_snapshots:
        raise runfile.RunFileError(path, "is newer than the time series or the "
                                   "snapshots it refers to", "/checkpoint")
    sim = simulation_from_binary(checkpoint.binary, path)
    n_particles = int(st.get("n_particles", sim.N))
    if sim.N != n_particles:
        raise runfile.RunFileError(path, f"holds {sim.N} particles but records "
                                   f"{n_particles}", "/checkpoint")
    sim.rand_seed = rand_seed
    if scenario.sheet.gravity:
        install_scenario_gravity(sim, scenario)
    handle = install_scenario_resolver(sim, scenario)
    _restore_resolver(path, handle, checkpoint)
    momentum = (invariants.SheetMomentum.from_attributes(st)
                or invariants.sheet_momentum(sheet.particle_arrays(sim),
                                             scenario.orbital_frequency, sim.t))
    wall = run.attrs.get("wall_time_s", 0.0)
    if not isinstance(wall, (int, float)):
        raise runfile.RunFileError(path, f"{wall!r} is not a number", "wall_time_s")
    cpu = run.attrs.get("cpu_time_s")
    return Resumed(sim, handle, geometry, state, n_particles, momentum, run, float(wall),
                   orbits,
                   float(cpu) if isinstance(cpu, (int, float)) else None)
