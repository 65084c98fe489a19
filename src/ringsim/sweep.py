"""`ringsim sweep`: run every point of a sweep file's grid and tabulate their equilibria.

A sweep file names a base scenario and a grid of dotted scenario keys
(``ringsim.scenario.load_sweep``).  Every grid point becomes one run file in the output
directory (default ``runs/<sweep file stem>/``), named from the point's parameters
(``restitution.kappa=0.1_seed=2.h5``), so that a sweep started again finds its own files:

* a file whose status is ``finished`` is reused, not rerun;
* a file left ``running`` (the sweep crashed) or ``stopped`` (SIGTERM, Ctrl-C) is continued
  from its last checkpoint (``ringsim.run(resume=True)``, bit-identical to an uninterrupted
  run);
* a file made by a different scenario is never touched: the sweep refuses to start (bad
  input, exit status 2) and says which key differs (``integration.threads`` is not
  compared: it changes the speed, never a result).

This policy is ``ringsim.batch``'s, shared with ``ringsim study`` (which also lengthens a
finished run when more orbits are asked; a sweep point takes its length from the grid).

Points run in local worker processes (``concurrent.futures.ProcessPoolExecutor``) or, with
``--scheduler ADDRESS``, on a Dask cluster (``dask.distributed.Client``; the output
directory must then be on a file system the Dask workers share, and the workers need the
same ringsim).  Each worker runs its point and computes its equilibrium
(``ringsim.compare.equilibrium``).  When all points are done the sweep writes
``summary.csv`` and ``summary.h5``: one row per point with its parameters, its run file, its
status and every equilibrium quantity's mean and standard error (units in the CSV column
names, ``units`` attributes in the HDF5 file).  A point that fails is reported and marked
``failed`` in the summary; the other points still run, and the sweep exits with status 1.

Every point's run file has one writer at a time (``store.lock``): a point file another
process is writing makes the sweep refuse at planning (bad input, exit status 2), as does a
damaged point file (unreadable, truncated, incomplete, checkpoint bytes not matching their
SHA-256, newer format).  A checkpoint that is intact but does not load (a REBOUND
incompatibility) fails that point only.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ringsim.batch import LabelledStream as _LabelledStream
from ringsim.batch import dask_client as _dask_client
from ringsim.batch import existing_action, run_dask, run_local, run_to_file
from ringsim.config.scenario import with_threads
from ringsim.config.sweep import load_sweep
from ringsim.errors import InputError
from ringsim.store.summary import write_summary

__all__ = [
    "PointResult",
    "PointTask",
    "SweepResult",
    "plan_sweep",
    "point_file_name",
    "run_point",
    "run_sweep",
    "sweep_command",
]

#: Longest file-name stem made from parameters before it is shortened and hashed.
_MAX_STEM = 150
_UNSAFE = re.compile(r"[^A-Za-z0-9.+-]")
_UNSAFE_KEY = re.compile(r"[^A-Za-z0-9._-]")


# --- naming -----------------------------------------------------------------------------------

def _value_text(value: Any) -> str:
    """The spelling of a grid value in a file name (floats round-trip exactly)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (int, str)):
        return str(value)
    return repr(value)


def point_file_name(params: Mapping[str, Any]) -> str:
    """The run file name of a grid point, e.g. ``restitution.kappa=0.1_seed=2.h5``.

    Keys and values are joined as ``key=value`` with ``_``.  Characters outside
    ``A-Za-z0-9.+-`` in a value (outside ``A-Za-z0-9._-`` in a key) are replaced by ``-``;
    when that loses information, or the name is longer than 150 characters, a hash of the
    exact parameters is appended, so different points always get different names.

    Parameters
    ----------
    params : mapping
        Dotted scenario key -> value, in grid order.
    """
    parts = []
    lossless = True
    for key, value in params.items():
        text = _value_text(value)
        safe_key = _UNSAFE_KEY.sub("-", str(key))
        safe_value = _UNSAFE.sub("-", text)
        lossless = lossless and safe_key == str(key) and safe_value == text and bool(text)
        parts.append(f"{safe_key}={safe_value}")
    stem = "_".join(parts)
    if not lossless or len(stem) > _MAX_STEM:
        exact = repr([(str(k), type(v).__name__, _value_text(v)) for k, v in params.items()])
        digest = hashlib.sha1(exact.encode("utf-8")).hexdigest()[:10]
        stem = f"{stem[:_MAX_STEM]}_{digest}"
    return stem + ".h5"


# --- planning ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class PointTask:
    """One grid point to process (picklable: sent to worker processes or Dask workers).

    Attributes
    ----------
    index : int
        Position in the grid (``Sweep.parameter_sets`` order).
    params : dict
        Dotted key -> value of this point.
    scenario : Scenario
        The base scenario with the point's values (and its name made unique).
    path : str
        Absolute path of the point's run file.
    action : str
        ``run`` (new file), ``restart`` (overwrite a file that has no checkpoint yet),
        ``resume`` (continue from the checkpoint) or ``reuse`` (already finished).
    """

    index: int
    params: dict
    scenario: Any
    path: str
    action: str


@dataclass
class PointResult:
    """What became of one grid point.

    Attributes
    ----------
    index : int
    params : dict
    file : str
        Run file name (relative to the sweep's output directory).
    status : str
        ``finished``, ``stopped`` (interrupted; continue by starting the sweep again) or
        ``failed``.
    action : str
        As in `PointTask`.
    wall_time : float [s]
        Time the worker spent on the point (run and analysis).
    equilibrium : dict or None
        ``compare.equilibrium`` of the run file; None unless finished.
    error : str
        Why the point failed ("" otherwise).
    """

    index: int
    params: dict
    file: str
    status: str
    action: str
    wall_time: float = 0.0
    equilibrium: dict | None = None
    error: str = ""


def _existing_action(path: Path, scenario) -> str:
    """How to treat an existing run file of a point: reuse, resume or restart (the shared
    policy, ``batch.existing_action``; a point is never extended: a different
    ``integration.orbits`` is a different scenario)."""
    return existing_action(path, scenario)


def _point_scenario(base, params: Mapping[str, Any], stem: str):
    """The point's scenario, named ``<base name>_<file stem>`` unless the grid sets the name."""
    from ringsim.config.scenario import with_overrides

    scenario = with_overrides(base, params)
    if "name" in params:
        return scenario
    return with_overrides(scenario, {"name": f"{base.name}_{stem}"})


def plan_sweep(sweep, out: str | os.PathLike, threads: int | None = None) -> list[PointTask]:
    """The tasks of a sweep: one per grid point with its run file and what to do with it.

    Nothing is written.  Raises InputError when two points would share a run file or an
    existing file cannot be reused or resumed (see `_existing_action`).

    Parameters
    ----------
    sweep : ringsim.scenario.Sweep
    out : output directory
    threads : ``integration.threads`` of every point (None: the scenario's)
    """
    out = Path(out).absolute()
    tasks: list[PointTask] = []
    seen: dict[str, dict] = {}
    for index, (params, _scenario) in enumerate(sweep.points()):
        name = point_file_name(params)
        if name in seen:
            raise InputError(sweep.source, "grid", f"points {seen[name]} and {params} are the "
                             f"same run ({name}); remove the repeated value")
        seen[name] = params
        scenario = with_threads(_point_scenario(sweep.base, params, name[:-len(".h5")]),
                                threads)
        path = out / name
        action = _existing_action(path, scenario) if path.exists() else "run"
        tasks.append(PointTask(index=index, params=dict(params), scenario=scenario,
                               path=str(path), action=action))
    return tasks


# --- one point (runs in a worker) -------------------------------------------------------------

def run_point(task: PointTask) -> PointResult:
    """Run (or resume, or reuse) one grid point and compute its equilibrium.

    This is the function sent to worker processes and Dask workers.  Errors propagate to
    the caller, which marks the point failed.  What the run writes to stderr (guard
    warnings, Python warnings) is prefixed with the point's run file name.
    """
    with contextlib.redirect_stderr(_LabelledStream(sys.stderr, Path(task.path).name)):
        return _run_point(task)


def _run_point(task: PointTask) -> PointResult:
    from ringsim.analysis.equilibrium import equilibrium
    from ringsim.store.runfile import open_run

    start = time.perf_counter()
    run_to_file(task.scenario, task.path, task.action)
    result = PointResult(index=task.index, params=task.params, file=Path(task.path).name,
                         status="failed", action=task.action)
    run_file = open_run(task.path)
    status = run_file.attrs.get("status")
    if status == "finished":
        result.equilibrium = equilibrium(run_file)
        result.status = "finished"
    elif status == "stopped":
        result.status = "stopped"
        result.error = "stopped before the end; start the sweep again to continue it"
    elif status == "failed":
        result.error = f"the run failed: {run_file.attrs.get('failure')}"
    else:
        result.error = f"the run file's status is {status!r} after the run"
    result.wall_time = time.perf_counter() - start
    return result


def _failed(task: PointTask, exc: BaseException) -> PointResult:
    message = " ".join(f"{type(exc).__name__}: {exc}".split())
    return PointResult(index=task.index, params=task.params, file=Path(task.path).name,
                       status="failed", action=task.action, error=message)


# --- executors --------------------------------------------------------------------------------

def _run_local(tasks: Sequence[PointTask], workers: int,
               report: Callable[[PointResult], None]) -> None:
    run_local(run_point, tasks, workers, report, _failed)


def _run_dask(client, tasks: Sequence[PointTask],
              report: Callable[[PointResult], None]) -> None:
    run_dask(client, run_point, tasks, report, _failed)


# --- the sweep --------------------------------------------------------------------------------

@dataclass
class SweepResult:
    """The outcome of `run_sweep`.

    Attributes
    ----------
    out : Path
        Output directory.
    results : list of PointResult
        In grid order.
    summary_csv, summary_h5 : Path
    wall_time : float [s]
    """

    out: Path
    results: list[PointResult]
    summary_csv: Path
    summary_h5: Path
    wall_time: float
    keys: tuple[str, ...] = field(default=())

    @property
    def n_failed(self) -> int:
        """Points not finished (failed or stopped)."""
        return sum(r.status != "finished" for r in self.results)


def default_output_dir(sweep_path: str | os.PathLike) -> Path:
    """``runs/<sweep file stem>`` (relative to the working directory)."""
    return Path("runs") / Path(sweep_path).stem


def _plan_line(sweep_path, tasks: Sequence[PointTask], out_dir: Path, scheduler: str | None,
               n_workers: int) -> str:
    """What the sweep is about to do, in one line (``n_workers`` 0: nothing left to run)."""
    counts = {a: sum(t.action == a for t in tasks) for a in ("run", "restart", "resume", "reuse")}
    if scheduler is not None:
        where = f"Dask scheduler {scheduler}"
    elif n_workers:
        where = f"{n_workers} worker process{'es' if n_workers > 1 else ''}"
    else:
        where = "analysed in this process"
    return (f"sweep {sweep_path}: {len(tasks)} points -> {out_dir}/ ({counts['run']} new, "
            f"{counts['resume']} to resume, {counts['restart']} to restart, {counts['reuse']} "
            f"finished already; {where})")


def _output_dir(sweep_path: str | os.PathLike, out: str | os.PathLike | None) -> Path:
    """The sweep's output directory: ``out``, else ``runs/<sweep file stem>``."""
    out_dir = Path(out) if out is not None else default_output_dir(sweep_path)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(str(out_dir), "--out", "exists and is not a directory")
    return out_dir


def _execute(tasks: Sequence[PointTask], client, n_workers: int,
             report: Callable[[PointResult], None]) -> None:
    """Run the points on the Dask ``client``, on ``n_workers`` local processes, or, with
    nothing left to run (``n_workers`` 0), analyse the finished points in this process;
    ``report`` receives every point's result."""
    try:
        if client is not None:
            _run_dask(client, tasks, report)
        elif n_workers:
            _run_local(tasks, n_workers, report)
        else:
            for task in tasks:
                try:
                    report(run_point(task))
                except Exception as exc:  # noqa: BLE001 - reported as a failed point
                    report(_failed(task, exc))
    finally:
        if client is not None:
            client.close()


def run_sweep(sweep_path: str | os.PathLike, out: str | os.PathLike | None = None,
              workers: int | None = None, scheduler: str | None = None,
              echo: Callable[[str], None] | None = print,
              threads: int | None = None) -> SweepResult:
    """Run every grid point of a sweep file and write ``summary.csv`` and ``summary.h5``.

    Parameters
    ----------
    sweep_path : sweep YAML file
    out : output directory (default ``runs/<sweep file stem>``)
    workers : int, optional
        Local worker processes (default ``os.cpu_count()``); ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); needs ``pip install ringsim[dask]``.
    echo : callable or None
        Receives the progress lines (default ``print``).
    threads : int, optional
        ``integration.threads`` of every point (changes the speed, never a result).

    Raises
    ------
    InputError
        Invalid sweep file or option, Dask missing, or an existing run file that cannot be
        reused; nothing is written then.
    """
    say = echo if echo is not None else (lambda line: None)
    if workers is not None and workers < 1:
        raise InputError("<command line>", "--workers", f"{workers} is not a positive number "
                         "of worker processes")
    sweep = load_sweep(sweep_path)
    out_dir = _output_dir(sweep_path, out)
    tasks = plan_sweep(sweep, out_dir, threads)
    client = _dask_client(scheduler) if scheduler else None

    todo = [t for t in tasks if t.action != "reuse"]
    n_workers = 1 if client is not None else max(1, min(workers or os.cpu_count() or 1,
                                                        len(tasks)))
    say(_plan_line(sweep_path, tasks, out_dir, scheduler if client is not None else None,
                   n_workers if todo else 0))
    out_dir.mkdir(parents=True, exist_ok=True)

    results: dict[int, PointResult] = {}
    start = time.perf_counter()

    def report(result: PointResult) -> None:
        results[result.index] = result
        line = (f"[{len(results)}/{len(tasks)}] {result.file}: {result.status} "
                f"({result.action}, {result.wall_time:.1f} s); sweep time "
                f"{time.perf_counter() - start:.1f} s")
        if result.error:
            line += f": {result.error}"
        say(line)

    try:
        _execute(tasks, client, n_workers if todo else 0, report)
    except KeyboardInterrupt:   # the summary of what finished, then exit status 130
        _summarise(sweep, out_dir, [results.get(t.index) or _not_finished(t) for t in tasks],
                   start, say)
        raise
    return _summarise(sweep, out_dir, [results[t.index] for t in tasks], start, say)


def _not_finished(task: PointTask) -> PointResult:
    """The result of a point an interrupted sweep did not finish (stopped or not started)."""
    return PointResult(index=task.index, params=task.params, file=Path(task.path).name,
                       status="stopped", action=task.action,
                       error="stopped before the end; start the sweep again to continue it")


def _summarise(sweep, out_dir: Path, ordered: list[PointResult], start: float,
               say: Callable[[str], None]) -> SweepResult:
    """Write the summary of the points' results (in grid order) and say how the sweep
    went; ``start`` is the sweep's ``time.perf_counter()`` at its start."""
    csv_path, h5_path = write_summary(out_dir, sweep, ordered)
    wall = time.perf_counter() - start
    n_bad = sum(r.status != "finished" for r in ordered)
    say(f"sweep done in {wall:.1f} s: {len(ordered) - n_bad} finished, {n_bad} failed or "
        f"stopped; summary {csv_path} and {h5_path}")
    return SweepResult(out=out_dir, results=ordered, summary_csv=csv_path, summary_h5=h5_path,
                       wall_time=wall, keys=sweep.keys)


def sweep_command(args) -> int:
    """``ringsim sweep SWEEP.yaml [--workers N] [--scheduler ADDRESS] [--out DIR] [--threads N]
    [--plots DIR]``; ``--plots`` draws ``sweep.png`` (``ringsim.plots.plot_sweep``) from
    the summary once every point is done.

    Returns 0 when every point finished, 1 when any failed or stopped (InputError for bad
    input propagates: exit status 2).
    """
    def echo(line: str) -> None:
        print(line, flush=True)

    plots = getattr(args, "plots", None)    # a folder, not the sweep file: checked by the cli
    result = run_sweep(args.sweep, out=args.out, workers=args.workers,
                       scheduler=args.scheduler, echo=echo, threads=args.threads)
    if plots is not None:
        from ringsim.plots import plot_sweep

        for path in plot_sweep(result.summary_h5, plots):
            print(f"wrote {path}", flush=True)
    if result.n_failed:
        failed = [r.file for r in result.results if r.status != "finished"]
        print(f"ringsim sweep: {result.n_failed} point(s) did not finish: "
              f"{', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


