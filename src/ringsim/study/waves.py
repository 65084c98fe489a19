"""The plan of a study in waves: the runs that others start from first.

A run that starts from another run of the study (the case key ``start``) reads that run's
file when it is made from its start (``run``, ``restart``); resumed, lengthened or only
summarised, it continues from its own checkpoint and needs nothing else.  So the tasks go
in waves by depth (a run that draws its particles: 0; a run that starts from a run of
depth d: d + 1), each wave after the one before has ended, on the local pool and on Dask
alike.  A run whose summary is done but whose file is gone is made again (``run``) when a
run that starts from it needs its file: a rerun reproduces it exactly.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ringsim.study.runs import RunTask, StudyRun, plan_run, run_scenario

#: Actions of a started run that read its start file.
_READS_START = ("run", "restart")


def plan_waves(runs: Mapping[str, StudyRun], runs_dir: Path, summaries_dir: Path,
               resummarise: bool = False) -> list[list[RunTask]]:
    """The tasks of every run (`runs.plan_run`), grouped in waves of depth, shallowest
    first, each wave in the runs' order; empty waves left out.

    Raises InputError as `runs.plan_run`."""
    tasks: dict[str, RunTask] = {}
    for rid, run in runs.items():
        task = plan_run(run, runs_dir, summaries_dir, resummarise)
        if task is not None:
            tasks[rid] = task
    for rid in reversed(list(runs)):   # a run comes after its origin: dependents first
        origin = runs[rid].origin
        if (origin is not None and rid in tasks and tasks[rid].action in _READS_START
                and origin not in tasks and not (runs_dir / f"{origin}.h5").exists()):
            tasks[origin] = _remake(runs[origin], runs_dir, summaries_dir)
    depth: dict[str, int] = {}
    for rid, run in runs.items():
        depth[rid] = 0 if run.origin is None else depth[run.origin] + 1
    waves: list[list[RunTask]] = [[] for _ in range(max(depth.values(), default=0) + 1)]
    for rid in runs:
        if rid in tasks:
            waves[depth[rid]].append(tasks[rid])
    return [wave for wave in waves if wave]


def _remake(run: StudyRun, runs_dir: Path, summaries_dir: Path) -> RunTask:
    """The task that makes a run again from nothing (its summary is rewritten)."""
    path = runs_dir / f"{run.run_id}.h5"
    return RunTask(run.run_id, run_scenario(run, path), str(path.absolute()),
                   str((summaries_dir / f"{run.run_id}.json").absolute()), "run",
                   tuple(run.labels), keep=run.keep)
