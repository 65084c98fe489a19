"""The run loop: integrate a sheet, write its HDF5 file, keep the guards, resume it from
its checkpoint (``engine.checkpoint``).

Order of work at every time-series output (every ``output.timeseries_every`` orbits):

0. runtime invariants (``engine.invariants``: finite state, particle count, momentum of
   the sheet relative to the shear flow); a violation stops the run as ``failed`` with
   the last good checkpoint kept;
1. diagnostics of the current state and the resolver's collision statistics of the
   interval -> one row of ``/timeseries``; the statistics are reset;
2. guards: the vertical guard enlarges the box before any particle can reach 0.4 of the
   half z period; ``dt: auto`` re-chooses the step as the ring heats (a fixed step that
   breaks dt << r/v is reported); deep overlaps are counted;
3. at every ``snapshot_every`` a snapshot, at every ``checkpoint_every`` a checkpoint
   (``engine.checkpoint``, with the resolver's open-interval statistics), and one at the
   first output after CHECKPOINT_WALL_INTERVAL of wall time without; rows, guard
   events, snapshot and checkpoint of an output are one atomic commit
   (``store.runfile.RunFileWriter``).

SIGINT/SIGTERM stop the run after the current step with a final checkpoint (status
``stopped``; the command line exits 130).  ``run`` holds the file's lock
(``store.lock.RunFileLock``) for the whole run: one writer per file.

Integration runs between outputs with ``exact_finish_time=0`` so the step sequence never
depends on where outputs or restarts fall: a run resumed from its last checkpoint is
bit-identical to one that never stopped.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from ringsim.analysis import snapshot
from ringsim.engine import box, gravity, invariants, sheet, timestep
from ringsim.engine.blas import one_blas_thread
from ringsim.engine.checkpoint import LoopState, checkpoint_of, resume
from ringsim.engine.ending import equilibrium_reached, stop_reason
from ringsim.engine.failure import record_failure
from ringsim.engine.hardsphere import resolver_attributes
from ringsim.engine.memory import check_particle_memory
from ringsim.engine.native import set_detector_threads, use_threaded_sei
from ringsim.engine.progress import progress_bar
from ringsim.engine.resolver import ResolverHandle
from ringsim.engine.statistics import histogram_edges, resolver_rows
from ringsim.engine.stop import StopRequest as _StopRequest
from ringsim.errors import InputError
from ringsim.gravity.registry import raise_pending, set_gravity_threads
from ringsim.physics.gravity import toomre_q
from ringsim.store import guarded, runfile
from ringsim.store.background import CommitThread
from ringsim.store.lock import RunFileLock
from ringsim.store.paths import check_replaceable

#: Time-series rows are written at most this often [s of wall time] (and at every checkpoint
#: and at the end), so the HDF5 cost stays small against the integration.
WRITE_INTERVAL = 2.0
#: A commit copies the run file (crash consistency, ``store.runfile``): rows alone are
#: written no more often than this share of wall time allows.
COMMIT_COST_SHARE = 0.02
#: A checkpoint is also written at the first output after this much wall time [s] since
#: the last one, so that a run killed without a signal (SIGKILL, a machine's end) loses at
#: most about this much work; where checkpoints fall changes no result (resumes are exact).
CHECKPOINT_WALL_INTERVAL = 600.0


def _interval_index(t: float, every: float) -> int:
    """Index of the last output at or before time t for outputs every ``every``."""
    return int(math.floor(t / every + 1e-9))


class Runner:
    """Drives one run; ``ringsim.run`` is the usual entry point.

    All writes go through one :class:`~ringsim.store.runfile.RunFileWriter`; the rows,
    guard events and snapshot of an output and the checkpoint that follows them are
    committed together, so the file never holds a checkpoint without the rows before it.
    """

    def __init__(self, scenario, path: Path, progress: bool):
        self.scenario = scenario
        self.path = Path(path)
        self.writer = runfile.RunFileWriter(self.path)
        self.progress = progress
        self.orbit = scenario.orbital_period
        self.Omega = scenario.orbital_frequency
        out = scenario.output
        self.ts_every = out.timeseries_every * self.orbit
        self.snap_every = out.snapshot_every * self.orbit
        self.ckpt_every = out.checkpoint_every * self.orbit
        self.t_end = scenario.integration.orbits * self.orbit
        self.threads = scenario.integration.thread_count()   # ``auto`` resolved once
        self.check_momentum = not scenario.sheet.gravity
        self.gravity: dict | None = None  # engine.gravity.scenario_gravity of a gravitating run
        self.state = LoopState()
        self.stop = _StopRequest()   # the loop's (an inactive one until then)
        self.pending_rows: list[dict] = []
        self.pending_events: list[tuple[float, float, str]] = []
        self.last_write = time.perf_counter()
        self.commit_cost = 0.0  # wall time [s] of the last commit
        self.wall_start = time.perf_counter()
        self.last_checkpoint_wall = self.wall_start   # perf_counter() of the last checkpoint
        self.wall_before = 0.0  # wall time [s] of earlier sessions of this run
        self.cpu_start = time.process_time()
        self.cpu_before: float | None = 0.0   # [s]; None: unknown
        # c and H so far (number-, mass-weighted), for until_equilibrium: [orbits], [m/s], [m]
        self.history: dict[str, list[float]] = {
            key: [] for key in ("orbits", "velocity_dispersion", "thickness",
                                "velocity_dispersion_mass_weighted", "thickness_mass_weighted")}

    # -- set-up --------------------------------------------------------------------------------

    @one_blas_thread
    def start_new(self, built: sheet.BuiltSheet | None = None) -> None:
        """Set the run up: ``built`` (a sheet of this scenario from ``sheet.build_sheet``,
        e.g. to time the loop apart from the set-up), or a new one; first output."""
        if built is None:
            built = sheet.build_sheet(self.scenario)
        self.sim, self.geometry = built.sim, built.geometry
        self.handle = built.resolver
        self._set_threads()
        self.edges = built.size_bin_edges
        self.n_particles = self.sim.N
        self.momentum = invariants.sheet_momentum(sheet.particle_arrays(self.sim), self.Omega,
                                                  self.sim.t)
        attributes = dict(self.geometry.attributes())
        attributes["name"] = self.scenario.name
        attributes.update(resolver_attributes(self.handle))
        if self.scenario.sheet.gravity:
            self.gravity = gravity.scenario_gravity(self.scenario, built.radii, built.masses,
                                                    self.geometry)
            attributes.update(self.gravity["attributes"])
            print(f"ringsim: {self.gravity['message']}", file=sys.stderr)
        self.writer.create(scenario_yaml=self.scenario.yaml_text, seed=self.scenario.seed,
                           attributes=attributes, size_bin_edges=self.edges,
                           histogram_edges=histogram_edges())
        try:
            self._output(first=True)
        except Exception as error:   # the file exists now: it says failed, and why
            record_failure(self, error)
            raise

    def _set_threads(self) -> None:
        """The SEI step, line detection's search and the gravity solver (P3M) on
        ``integration.threads`` threads (no effect on results)."""
        threads = self.threads
        use_threaded_sei(self.sim, threads)
        if isinstance(self.handle, ResolverHandle) and self.handle.collision_detection == "line":
            set_detector_threads(self.handle.address, threads)
        set_gravity_threads(self.sim, threads)

    @one_blas_thread
    def start_resume(self) -> None:
        """Set the run up from its file's last checkpoint (``engine.checkpoint.resume``);
        with a larger ``integration.orbits`` than the file's, the run is extended."""
        resumed = resume(self.path, self.scenario)
        self.sim, self.handle, self.geometry = resumed.sim, resumed.handle, resumed.geometry
        self.state, self.n_particles = resumed.state, resumed.n_particles
        self.momentum, self.wall_before = resumed.momentum, resumed.wall_before
        self.cpu_before = resumed.cpu_before
        self._set_threads()
        for key, values in self.history.items():
            values.extend(float(x) for x in resumed.run.timeseries[key][:self.state.rows])
        edges = resumed.run.timeseries.get("size_bin_edges")
        self.edges = None if edges is None else np.asarray(edges)
        if self.scenario.sheet.gravity:
            arrays = sheet.particle_arrays(self.sim)
            self.gravity = gravity.scenario_gravity(self.scenario, arrays["radius"],
                                                    arrays["mass"], self.geometry)
        attributes = {"status": "running"}
        old_orbits, new_orbits = resumed.orbits
        if new_orbits > old_orbits:
            # a longer run of the same scenario: continue it, and let the file say so
            attributes["scenario_yaml"] = self.scenario.yaml_text
            self._guard_event(f"run extended from {old_orbits:g} to {new_orbits:g} orbits",
                              show=False)
        self._commit(truncate=(self.state.rows, self.state.snapshots,
                               self.state.guard_events - len(self.pending_events)),
                     attributes=attributes)

    # -- outputs -------------------------------------------------------------------------------

    def _row(self, arrays: dict, stats: dict) -> dict:
        g = self.geometry
        summary = snapshot.snapshot_summary(
            arrays["x"], arrays["y"], arrays["z"], arrays["vx"], arrays["vy"], arrays["vz"],
            arrays["radius"], arrays["mass"], self.Omega, g.Lx, g.Ly, size_bins=self.edges,
            spins=None if self.handle.friction is None else self.handle.spins(),
            inertia_factor=self.scenario.particles.inertia_factor)
        count = int(stats["count"])
        row = {
            "t": self.sim.t,
            "orbits": self.sim.t / self.orbit,
            "dt": self.sim.dt,
            "collisions": count,
            "collisions_log_n": int(self.sim.collisions_log_n),
            "collisions_plog": float(self.sim.collisions_plog),
            "mean_epsilon": float(stats["mean_epsilon"]) if count else float("nan"),
            "mean_impact_speed": float(stats["mean_vn"]) if count else float("nan"),
            "max_vertical_amplitude": sheet.max_vertical_amplitude(arrays, self.Omega),
            "z_half_period": 0.5 * g.z_period,
            "overlapping_pairs": box.count_overlaps(arrays, g, self.sim.t,
                                                    threads=self.threads),
            **resolver_rows(stats, self.edges, self.scenario.particles.density,
                            self.handle.log_capacity),
        }
        if self.handle.friction is not None:     # the spins' rows come with the summary
            row.update(tangential_dissipation=float(stats["tangential_dissipation"]),
                       sliding_collisions=int(stats["n_sliding"]))
        for key in runfile.TIMESERIES_UNITS:
            if key not in row and key in summary:
                if key.startswith("size_bin_") and self.edges is None:
                    continue
                row[key] = summary[key]
        return row

    def _invariants(self, arrays: dict, stats: dict, first: bool) -> float:
        """Check the runtime invariants (``engine.invariants``); the momentum residual [m/s].

        Raises InvariantViolation; the momentum reference moves to this output otherwise.
        """
        invariants.check_state(arrays, self.n_particles, self.sim.t)
        now = invariants.sheet_momentum(arrays, self.Omega, self.sim.t)
        residual = 0.0
        if self.check_momentum and not first:
            n_steps = math.ceil((now.t - self.momentum.t) / self.sim.dt) + 1
            tolerance = invariants.momentum_tolerance(arrays, self.Omega, n_steps,
                                                      int(stats["count"]))
            residual = invariants.check_momentum(now, self.momentum, self.Omega, tolerance)
        self.momentum = now
        return residual

    def _guard_event(self, message: str, show: bool = True) -> None:
        """Record a guard's action (written with the next commit); show it unless ``show``
        is False."""
        self.pending_events.append((self.sim.t, self.sim.t / self.orbit, message))
        self.state.guard_events += 1
        if show:
            from tqdm import tqdm

            tqdm.write(f"ringsim: {message}", file=sys.stderr)

    def _guards(self, arrays: dict, row: dict) -> None:
        """The guards of an output on its particle ``arrays`` and time-series ``row``."""
        g = self.geometry
        overlapping_pairs = row["overlapping_pairs"]
        if overlapping_pairs and not self.state.overlap_warned:
            self.state.overlap_warned = 1
            self._guard_event(f"WARNING: {overlapping_pairs} pairs overlap by more than "
                              f"{box.OVERLAP_REPORT_FRACTION:.0%} of the smaller radius "
                              "(collisions missed or particles sinking into each other); "
                              "counts per output are in /timeseries/overlapping_pairs")
        # vertical: never let a particle's oscillation reach the periodic z boundary
        amplitude = row["max_vertical_amplitude"]
        limit = sheet.VERTICAL_GUARD_FRACTION * 0.5 * g.z_period
        if amplitude >= limit:
            needed = amplitude / (sheet.VERTICAL_GUARD_FRACTION * 0.5)
            n_root_z = max(2 * g.n_root_z, math.ceil(1.5 * needed / g.root_size))
            new_sim, new_geometry = sheet.enlarged_copy(self.sim, g, n_root_z)
            self.handle.reinstall(new_sim)
            self.sim, self.geometry = new_sim, new_geometry
            self._set_threads()     # a new P3M solver was made for the new box
            self._guard_event(f"vertical guard: largest vertical amplitude {amplitude:.4g} m "
                              f"reached 0.4 of the half z period; box enlarged from "
                              f"{g.n_root_z} to {n_root_z} root boxes in z "
                              f"(period {new_geometry.z_period:.4g} m)")
        # time step
        integ = self.scenario.integration
        # tree mode's bound follows the fastest particle and is checked at every output; line
        # mode's dt: auto is the orbit limit, fixed when the sheet is built
        if integ.dt == "auto" and integ.collision_detection == "tree":
            dt = timestep.auto_dt(arrays, self.Omega, integ.dt_safety, current=self.sim.dt,
                               collision_detection=integ.collision_detection)
            if dt != self.sim.dt:
                self._guard_event(f"dt auto: {self.sim.dt:.6g} s -> {dt:.6g} s "
                                  f"({dt / self.orbit:.3g} orbit)", show=False)
                self.sim.dt = dt
        elif integ.dt != "auto" and not self.state.dt_warned \
                and integ.collision_detection == "tree":
            ratio = timestep.dt_violation(arrays, self.Omega, self.sim.dt, integ.dt_safety)
            if ratio > 1.0:
                self.state.dt_warned = 1
                self._guard_event(f"WARNING: fixed dt {self.sim.dt:.4g} s lets particles move "
                                  f"{ratio:.3g} x {integ.dt_safety} of the smallest radius per "
                                  "step; end-of-step collision detection may miss collisions "
                                  "(use dt: auto or collision_detection: line)")

    @one_blas_thread
    def _output(self, first: bool = False) -> None:
        arrays = sheet.particle_arrays(self.sim)
        stats = self.handle.stats()
        residual = self._invariants(arrays, stats, first)
        row = self._row(arrays, stats)
        row["momentum_residual"] = residual
        if self.gravity is not None:
            row["toomre_Q"] = float(toomre_q(math.sqrt(row["sigma_xx"]), self.gravity["Sigma"],
                                             self.Omega))
        for key, values in self.history.items():
            values.append(float(row[key]))
        self.pending_rows.append(row)
        self.state.rows += 1
        self.handle.reset_stats()
        if not first:   # (a taller box from the vertical guard holds the same particles)
            self._guards(arrays, row)
        t = self.sim.t
        snap = None
        if first or _interval_index(t, self.snap_every) >= self.state.snapshots:
            if self.handle.friction is not None:
                arrays = {**arrays, **dict(zip(runfile.SPIN_FIELDS, self.handle.spins().T,
                                               strict=True))}
            snap = (self.state.snapshots, t, arrays)
            self.state.snapshots += 1
        if first or _interval_index(t, self.ckpt_every) > _interval_index(
                t - self.ts_every, self.ckpt_every) or self._checkpoint_due():
            self.checkpoint(snapshot=snap)
        elif snap is not None or self._rows_due():
            self._commit(snapshot=snap)

    def _checkpoint_due(self) -> bool:
        """CHECKPOINT_WALL_INTERVAL of wall time passed since the last checkpoint."""
        return time.perf_counter() - self.last_checkpoint_wall > CHECKPOINT_WALL_INTERVAL

    def _rows_due(self) -> bool:
        """Time to write the gathered rows: WRITE_INTERVAL passed, and at least
        COMMIT_COST_SHARE^-1 times the cost of the last commit (a large file is copied)."""
        since = time.perf_counter() - self.last_write
        return since > max(WRITE_INTERVAL, self.commit_cost / COMMIT_COST_SHARE)

    def _commit(self, **changes) -> None:
        """One atomic commit of the gathered rows and guard events plus ``changes``, made by
        a writer thread while the integration goes on (``store.background``); one that sets
        ``status`` (the end, a failure, a resumed start) is complete when this returns."""
        rows, events = self.pending_rows, self.pending_events
        self.pending_rows, self.pending_events = [], []
        self.last_write = time.perf_counter()
        self._writes = getattr(self, "_writes", None) or CommitThread()
        self._writes.submit(lambda: self.writer.commit(rows=rows, events=events, **changes),
                            wait="status" in (changes.get("attributes") or {}))
        self.commit_cost = self._writes.last_cost

    def write_rows(self) -> None:
        """Write the time-series rows and guard events gathered since the last write."""
        self._commit()

    def checkpoint(self, snapshot=None, attributes: dict | None = None) -> None:
        """Commit the pending rows, events, ``snapshot`` and a checkpoint of the current
        state (REBOUND binary, loop counters, resolver statistics, momentum reference)."""
        attributes = dict(attributes or {})
        self.last_checkpoint_wall = time.perf_counter()
        attributes["wall_time_s"] = self.wall_before + self.last_checkpoint_wall - self.wall_start
        if self.cpu_before is not None:
            attributes["cpu_time_s"] = self.cpu_before + time.process_time() - self.cpu_start
        self._commit(snapshot=snapshot, attributes=attributes,
                     checkpoint=checkpoint_of(self.sim, self.state, self.geometry,
                                              self.n_particles, self.momentum, self.handle))

    def fail(self, violation: Exception) -> None:
        """Stop a run that broke an invariant: keep the last (good) checkpoint, write the
        good rows gathered since, a guard event, ``status = "failed"`` and ``failure``."""
        message = (f"FAILED at orbit {self.sim.t / self.orbit:.4f}: {violation}; the "
                   "checkpoint is the last good state before it")
        self._guard_event(message)
        self._commit(attributes={"status": "failed", "failure": str(violation)})

    # -- the loop ------------------------------------------------------------------------------

    def _advance(self, t_next: float) -> None:
        """Integrate to the first step end at or after ``t_next`` [s], or to the end of
        the step in progress when SIGINT or SIGTERM arrives (``self.stop.requested``)."""
        self.stop.integrate(self.sim, t_next)
        raise_pending(self.sim)   # an error in a solver's callback, which ctypes swallows

    def loop(self, stop: _StopRequest | None = None) -> str:
        """Integrate to the end (or a stop); returns the status written to the file.

        ``stop``: an active :class:`_StopRequest` (``run`` installs one before the set-up,
        so that a signal during it also ends in a checkpoint); one is made if None.
        """
        bar = progress_bar(self.scenario, self.sim.t / self.orbit) if self.progress else None
        wall0, coll0 = time.perf_counter(), int(self.sim.collisions_log_n)
        status = "finished"
        reason = None
        try:
            with contextlib.nullcontext(stop) if stop is not None else _StopRequest() as stop:
                self.stop = stop
                while self.sim.t < self.t_end * (1 - 1e-12):
                    if stop.requested:
                        status = "stopped"
                        break
                    reason = equilibrium_reached(self.scenario, self.history, self.state.rows)
                    if reason:
                        break
                    t_next = min(self.state.rows * self.ts_every, self.t_end)
                    t_next = max(t_next, self.sim.t)
                    try:
                        self._advance(t_next)
                    except KeyboardInterrupt:
                        stop.requested = True
                    if stop.requested:   # after a complete step: checkpoint here, no row
                        status = "stopped"
                        break
                    try:
                        self._output()
                    except invariants.InvariantViolation as violation:
                        self.fail(violation)
                        return "failed"
                    if bar is not None:
                        bar.update(min(self.sim.t / self.orbit, bar.total) - bar.n)
                        elapsed = time.perf_counter() - wall0
                        rate = (int(self.sim.collisions_log_n) - coll0) / max(elapsed, 1e-9)
                        bar.set_postfix_str(f"{rate:,.0f} coll/s, dt={self.sim.dt:.3g} s")
                    if stop.requested:
                        status = "stopped"
                        break
                # a final checkpoint (a signal now waits for it): a stopped run resumes
                # from here, the resolver's statistics of the open interval included; a
                # finished one can be extended
                why = stop_reason(self.scenario, status, reason)
                self.checkpoint(attributes={"status": status, "stop_reason": why})
        except Exception as error:   # any other error: the file says failed, and why
            record_failure(self, error)
            raise
        finally:
            if bar is not None:
                bar.close()
            if getattr(self, "_writes", None) is not None:
                self._writes.join()   # no commit outlives the loop (and the file's lock)
        return status


def run(scenario, output: str | os.PathLike | None = None, force: bool = False,
        resume: bool = False, progress: bool = True) -> Path:
    """Run a scenario and write its HDF5 run file; returns the file's path.

    Parameters
    ----------
    scenario : Scenario (``ringsim.load_scenario``)
    output : path, optional
        Run file; default the scenario's ``output.path``.
    force : bool
        Overwrite an existing file, which must be a ringsim run file (a regular file; no
        name the run owns may be a symbolic link, ``store.paths``).
    resume : bool
        Continue the file's run from its last checkpoint (bit-identical to an uninterrupted
        run).
    progress : bool
        Show a progress bar.

    A finished run is one HDF5 file: the snapshots and checkpoint a large run kept in part
    files while it ran (``store.bulk``) are copied into it at the end.

    Returns the path whatever the run's end; the file's root attribute ``status`` says it:
    ``finished``, ``stopped`` (SIGINT/SIGTERM; a checkpoint was written, ``resume``
    continues) or ``failed`` (a runtime invariant broke, ``engine.invariants``; the message
    is in the attribute ``failure`` and in ``/guards``, and was printed).

    Raises
    ------
    InputError
        The file exists (without ``force``), there is nothing to resume, the file to resume
        is damaged (``store.runfile.RunFileError``), or another process writes it (one
        writer per file: ``store.lock.RunFileLock``).
    OSError
        A full disk (``store.guarded.full_disk``): the file keeps its last commit.
    """
    path = Path(output if output is not None else scenario.output.path)
    check_particle_memory(scenario)
    if force and not resume:   # only a run file is replaced, and nothing through a link
        check_replaceable(path)
    with RunFileLock(path), _StopRequest() as stop, guarded.full_disk(path):
        runner = Runner(scenario, path, progress)
        if resume:
            if not path.exists():
                raise InputError(str(path), "--resume", "no run file to resume")
            runner.start_resume()
        else:
            if path.exists() and not force:
                raise InputError(str(path), "output", "file exists; overwrite it with "
                                 "--force (force=True in Python) or continue it with "
                                 "--resume (resume=True)")
            runner.start_new()
        status = runner.loop(stop)
        if status == "finished":   # one file to keep: the part files of a large run go in
            runfile.pack(path)
    if status == "stopped":
        print(f"ringsim: stopped at orbit {runner.sim.t / runner.orbit:.3f}; checkpoint "
              f"written to {path}; continue with --resume")
    return path
