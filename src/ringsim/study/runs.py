"""The runs of a study: their identity, run files and summaries, the plan, and the worker.

A run is identified by the hash of its resolved scenario (`run_id`): the first 16 hex
digits of the SHA-256 of the canonical YAML (keys sorted, every default filled in) of the
scenario without `IDENTITY_EXCLUDES`.  So the same run is found again whatever study, case
or variant asks for it.  Its run file is ``<out>/runs/<id>.h5`` and its summary
``summaries/<id>.json`` beside the study file.  A run's own name, description and output
path are set from the id (`labelled`), so that every study writes the same file for it.

The summary (`make_summary`) is the small JSON that outlives the run file: the run's
scenario, stop reason, length reached, equilibrium with errors and units, the ringsim
version that made the run and, apart in ``cost``, its CPU and wall time; a self-gravitating
run's also keeps its synthetic occultations (``occultation``, ``study.cassini``).  A summary
is written by the worker as soon as its run is finished; a run whose summary matches the
scenario asked is not run again, even when its run file is gone.  A gravitating run's
summary without ``occultation`` or ``gravity`` (made before summaries kept them) is completed
from its run file when that is there and finished, keeping its ``cost`` (and its
``occultation`` where it observed the same snapshots).

A run that starts from another run of the study (the case key ``start``) names that run's
file by its hash alone (``sheet.initial_state.file: <origin>.h5``, found beside its own run
file: ``engine.initial_file.resolve_path``), and its identity holds the origin's hash and
the origin's length in orbits, which the origin's own hash leaves out: a lengthened origin
gives a new started run, never a changed one.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ringsim.batch import LabelledStream, existing_action, run_to_file
from ringsim.config.scenario import SPEED_ONLY_KEYS, with_overrides, without_keys
from ringsim.errors import InputError
from ringsim.study.by_size import size_summary
from ringsim.study.cassini import (
    gravity_summary,
    kept_occultation,
    lacks_gravity,
    lacks_occultation,
)
from ringsim.study.kept import kept_summary, lacks_kept
from ringsim.study.spin import spin_summary

#: Scenario keys left out of a run's identity: its labels and the thread count change no
#: result, and a run asked for with more ``integration.orbits`` is the same run lengthened.
LABEL_KEYS = ("name", "description", "output.path")
IDENTITY_EXCLUDES = (*LABEL_KEYS, *SPEED_ONLY_KEYS, "integration.orbits")
#: The ``format`` of a summary file.
SUMMARY_FORMAT = "ringsim study summary 1"
#: Plain numbers of a summary and their units.
SUMMARY_UNITS = {"orbits": "orbits", "n_particles": "count", "mean_radius": "m",
                 "optical_depth": "dimensionless", "cpu_time_s": "s",
                 "run_wall_time_s": "s"}


def _without(d: dict, dotted: Iterable[str]) -> dict:
    """``d`` without the dotted keys, as plain JSON values (the text a hash is taken of)."""
    return json.loads(json.dumps(without_keys(d, dotted)))


def summary_scenario(scenario) -> dict:
    """The scenario a summary records: without its labels and thread count."""
    return _without(scenario.to_dict(), (*LABEL_KEYS, *SPEED_ONLY_KEYS))


def canonical_yaml(d: Mapping) -> str:
    """YAML text with sorted keys (the text a run's hash is taken of)."""
    return yaml.safe_dump(dict(d), sort_keys=True, default_flow_style=False,
                          allow_unicode=True)


def run_id(scenario, started_from: Mapping | None = None) -> str:
    """The first 16 hex digits of the SHA-256 of the canonical YAML of the scenario
    without `IDENTITY_EXCLUDES` (and, for a run that starts from another run of the study,
    ``started_from``: that run's hash ``run`` and length ``orbits``)."""
    payload = _without(scenario.to_dict(), IDENTITY_EXCLUDES)
    if started_from is not None:
        payload["started_from"] = dict(started_from)
    text = canonical_yaml(payload)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def labelled(scenario, rid: str, threads: int | None = None):
    """The scenario a run is made with: named ``run-<id>``, no description, output path
    ``runs/<id>.h5`` and, if given, ``integration.threads``."""
    changes: dict[str, Any] = {"name": f"run-{rid}", "description": "",
                               "output.path": f"runs/{rid}.h5"}
    if threads is not None:
        changes["integration.threads"] = threads
    return with_overrides(scenario, changes)


@dataclass
class StudyRun:
    """One distinct run of a study and the specs (case, variant, seed) that ask for it;
    ``origin``: the id of the run it starts from (None: it draws its particles); ``keep``:
    what its summary keeps beyond the equilibrium (``study.kept``)."""

    run_id: str
    scenario: Any
    labels: list[str] = field(default_factory=list)
    origin: str | None = None
    keep: tuple[str, ...] = ()


def collect(specs: Sequence[Any], threads: int | None = None, keep: tuple[str, ...] = ()
            ) -> tuple[dict[str, StudyRun], list[str]]:
    """The distinct runs of ``specs`` (``config.study.RunSpec``) by id, each after the run
    it starts from, and the id of each spec.  A run that a spec only starts from (the
    origin of a variant's run, or of a fixed seed) is among the runs as well."""
    runs: dict[str, StudyRun] = {}
    ids = [_collect_one(spec, runs, threads) for spec in specs]
    for run in runs.values():
        run.keep = keep
    return runs, ids


def _collect_one(spec, runs: dict[str, StudyRun], threads: int | None,
                 start_of: str | None = None) -> str:
    """Add the run of ``spec`` (after its origin's) to ``runs``; its id."""
    scenario, origin, started_from = spec.scenario, None, None
    if spec.origin is not None:
        origin = _collect_one(spec.origin, runs, threads, start_of=spec.label)
        scenario = with_overrides(scenario, {"sheet.initial_state.file": f"{origin}.h5"})
        started_from = {"run": origin, "orbits": runs[origin].scenario.integration.orbits}
    rid = run_id(scenario, started_from)
    if rid not in runs:
        runs[rid] = StudyRun(rid, labelled(scenario, rid, threads), origin=origin)
    labels = runs[rid].labels
    if start_of is None:   # a run the study asks for itself is named only as such
        labels[:] = [x for x in labels if not x.startswith(f"{spec.label} (the start of")]
        labels.append(spec.label)
    elif not any(x == spec.label or x.startswith(f"{spec.label} (") for x in labels):
        labels.append(f"{spec.label} (the start of {start_of})")
    return rid


# --- summaries --------------------------------------------------------------------------------

def plain_json(value: Any) -> Any:
    """``value`` with non-finite floats as None (JSON null) and tuples as lists."""
    if isinstance(value, Mapping):
        return {str(k): plain_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(payload: Any) -> str:
    """Sorted keys, one-space indent, floats as Python's repr, null for non-finite."""
    return json.dumps(plain_json(payload), sort_keys=True, indent=1, allow_nan=False) + "\n"


def write_json(path: str | Path, payload: Any) -> Path:
    """Write `json_text` under a temporary name and rename it over ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json_text(payload), encoding="utf-8")
    os.replace(tmp, path)
    return path


def read_summary(path: str | Path) -> dict | None:
    """A summary file, None if there is none; InputError if it is not a summary."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(str(path), "<file>", f"not a readable summary ({exc}); delete it "
                         "to run the run again") from None
    if not isinstance(data, dict) or data.get("format") != SUMMARY_FORMAT:
        raise InputError(str(path), "format", f"not a {SUMMARY_FORMAT!r} file; delete it "
                         "to run the run again")
    return data


def summary_state(summary: Mapping | None, scenario) -> str:
    """``missing``, ``same`` (the summary is of the run asked), ``shorter`` (of the same run
    with fewer orbits: to be lengthened), ``longer`` or ``other`` (another scenario)."""
    if summary is None:
        return "missing"
    have, want = summary.get("scenario", {}), summary_scenario(scenario)
    if _without(have, ["integration.orbits"]) != _without(want, ["integration.orbits"]):
        return "other"
    had, asked = have["integration"]["orbits"], want["integration"]["orbits"]
    return "same" if had == asked else "shorter" if had < asked else "longer"


def make_summary(rid: str, run, eq: Mapping, quantities: Iterable[str],
                 cost: Mapping, keep: Iterable[str] = (),
                 occultation: Mapping | None = None) -> dict:
    """The summary of the finished run ``rid`` (``ringsim.open_run``) from its
    equilibrium (``ringsim.equilibrium``); ``cost``: ``cpu_time_s`` and
    ``run_wall_time_s``.  A self-gravitating run's also holds ``occultation``
    (``study.cassini.kept_occultation``: ``occultation``, the one of the summary being
    remade, where it still holds) and ``gravity`` (``study.cassini.gravity_summary``);
    ``keep``: the kept entries (``study.kept``)."""
    kept = [*quantities, "equilibrium_from_orbit"]
    sizes, spin = size_summary(eq), spin_summary(eq)
    extra = ({"occultation": kept_occultation(run, eq.get("wake_significant"), occultation),
              "gravity": gravity_summary(eq)} if run.scenario.sheet.gravity else {})
    if spin is not None:
        extra["spin"] = spin
    extra.update(kept_summary(eq, keep, run))
    return {**extra, "format": SUMMARY_FORMAT, "run": rid,
            "ringsim_version": str(run.attrs.get("ringsim_version", "")),
            "scenario": summary_scenario(run.scenario),
            "status": str(run.attrs.get("status")),
            "stop_reason": str(run.attrs.get("stop_reason", "")),
            "in_equilibrium": bool(eq["in_equilibrium"]), "reason": str(eq["reason"]),
            "equilibrium": {key: dict(eq[key]) for key in kept},
            "orbits": float(eq["orbits"]), "n_particles": int(eq["n_particles"]),
            "mean_radius": float(eq["mean_radius"]),
            "optical_depth": float(eq["optical_depth"]),
            "units": dict(SUMMARY_UNITS), "cost": dict(cost),
            **({"by_size": sizes} if sizes is not None else {}),
            **({"no_snapshot_in_window": True}
               if eq["window_snapshots"] == 0 and (sizes is not None or "occultation" in extra)
               else {})}


# --- the plan -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class RunTask:
    """One run to process (picklable: sent to worker processes or Dask workers).

    Attributes
    ----------
    run_id : str
    scenario : Scenario (`labelled`)
    path, summary : str
        Absolute paths of the run file and of the summary.
    action : str
        ``batch.ACTIONS``: ``reuse`` here means "summarise the finished run file".
    labels : tuple of str
        The cases and seeds that ask for the run (for messages).
    cpu_before : float or None [s]
        CPU time of the sessions that made the run before (from the summary of its shorter
        form), added to this session's.
    cost : dict or None
        The ``cost`` of a summary being remade from the finished run file (to add
        ``occultation`` or a kept entry, or with ``resummarise``), kept as it is.
    keep : tuple of str
        What the summary keeps beyond the equilibrium (``study.kept``).
    occultation : dict or None
        The ``occultation`` of a summary being completed (not with ``resummarise``), kept
        where it still holds (``study.cassini.kept_occultation``).
    """

    run_id: str
    scenario: Any
    path: str
    summary: str
    action: str
    labels: tuple[str, ...]
    cpu_before: float | None = None
    cost: dict | None = None
    keep: tuple[str, ...] = ()
    occultation: dict | None = None


def _cpu_of(summary: Mapping | None) -> float | None:
    value = (summary or {}).get("cost", {}).get("cpu_time_s")
    return float(value) if isinstance(value, (int, float)) else None


def plan_run(run: StudyRun, runs_dir: Path, summaries_dir: Path,
             resummarise: bool = False) -> RunTask | None:
    """What to do for one run: None when its summary is of the run asked, else a task
    (with ``resummarise``, a summary of the run asked is remade from its finished run
    file when that is there).

    Raises InputError for a summary or run file of another scenario, of a run longer than
    asked, or a run file that cannot be read or is being written (``batch``)."""
    summary_path = summaries_dir / f"{run.run_id}.json"
    path = runs_dir / f"{run.run_id}.h5"
    summary = read_summary(summary_path)
    state = summary_state(summary, run.scenario)
    advice = "delete it (and its summary) or choose another --out"
    if state == "same":
        return _completion(run, path, summary_path, summary, resummarise)
    if state in ("other", "longer"):
        orbits = summary["scenario"]["integration"]["orbits"] if summary else None
        why = ("a different scenario" if state == "other" else
               f"a run of {orbits:g} orbits, more than the "
               f"{run.scenario.integration.orbits:g} asked; a run is only ever lengthened")
        raise InputError(str(summary_path), "scenario", f"the summary is of {why}; "
                         "delete it to run the run again")
    action = (existing_action(path, run.scenario, extend=True, asker="the study",
                              advice=advice) if path.exists() else "run")
    return RunTask(run.run_id, run_scenario(run, path), str(path.absolute()),
                   str(summary_path.absolute()), action, tuple(run.labels),
                   _cpu_of(summary) if state == "shorter" and action != "run" else None,
                   keep=run.keep)


def _completion(run: StudyRun, path: Path, summary_path: Path,
                summary: Mapping | None, always: bool = False) -> RunTask | None:
    """The task that remakes a run's summary from its finished run file, keeping its
    ``cost``: when the summary of a gravitating run lacks ``occultation`` or ``gravity``, or
    the summary lacks an entry its study keeps, or ``always`` (None when the run file is not
    there finished)."""
    from ringsim.store.runfile import open_run

    if summary is None or not path.exists() or not (
            always or lacks_occultation(summary) or lacks_gravity(summary)
            or lacks_kept(summary, run.keep)):
        return None
    with contextlib.suppress(InputError):
        if (existing_action(path, run.scenario, extend=True, asker="the study") == "reuse"
                and open_run(path).attrs.get("status") == "finished"):
            return RunTask(run.run_id, run_scenario(run, path), str(path.absolute()),
                           str(summary_path.absolute()), "reuse", tuple(run.labels),
                           cost=dict(summary.get("cost", {})), keep=run.keep,
                           occultation=None if always else summary.get("occultation"))
    return None


def run_scenario(run: StudyRun, path: Path):
    """The scenario a run is made with: a started run's has its run file as its source, so
    that its start file (named by the origin's hash) is found beside it."""
    if run.origin is None:
        return run.scenario
    return dataclasses.replace(run.scenario, source=str(path.absolute()))


@dataclass
class TaskResult:
    """What became of one run: ``finished``, ``stopped`` (interrupted) or ``failed``."""

    run_id: str
    status: str
    action: str
    labels: tuple[str, ...]
    wall_time: float = 0.0
    error: str = ""


def failed(task: RunTask, exc: BaseException) -> TaskResult:
    """The result of a task whose worker raised."""
    message = " ".join(f"{type(exc).__name__}: {exc}".split())
    return TaskResult(task.run_id, "failed", task.action, task.labels, error=message)


def run_task(task: RunTask) -> TaskResult:
    """Run (or resume, lengthen, or only summarise) one run and write its summary, with
    every table quantity of its equilibrium (``analysis.equilibrium.QUANTITIES``).

    The function sent to worker processes and Dask workers.  What the run writes to stderr
    is prefixed with the run's id."""
    with contextlib.redirect_stderr(LabelledStream(sys.stderr, f"run {task.run_id}")):
        return _run_task(task)


def _run_task(task: RunTask) -> TaskResult:
    from ringsim.analysis.equilibrium import QUANTITIES, equilibrium
    from ringsim.store.runfile import open_run

    cpu0, wall0 = time.process_time(), time.perf_counter()
    run_to_file(task.scenario, task.path, task.action)
    run = open_run(task.path)
    status = str(run.attrs.get("status"))
    result = TaskResult(task.run_id, status if status in ("finished", "stopped") else "failed",
                        task.action, task.labels)
    if status == "finished":
        eq = equilibrium(run)
        kept = run.attrs.get("cpu_time_s")     # the run file's, over all its sessions
        measured = time.process_time() - cpu0 + (task.cpu_before or 0.0)
        # a resumed file without the count began before CPU time was kept: its earlier
        # sessions are unknown, and this session's time is only a part
        partial = task.action == "resume" and not isinstance(kept, (int, float))
        cpu = (None if task.action == "reuse" or partial
               else float(kept) if isinstance(kept, (int, float)) else measured)
        wall = run.attrs.get("wall_time_s", 0.0)
        cost = task.cost if task.cost is not None else {
            "cpu_time_s": cpu,
            "run_wall_time_s": float(wall) if isinstance(wall, (int, float)) else None,
            **({"cpu_time_s_part": measured} if partial else {})}
        write_json(task.summary, make_summary(task.run_id, run, eq, QUANTITIES, cost,
                                              task.keep, task.occultation))
    elif status == "stopped":
        result.error = "stopped before the end; start the study again to continue it"
    elif status == "failed":
        result.error = (f"the run failed: {run.attrs.get('failure')}; delete {task.path} to "
                        "run it again")
    else:
        result.error = f"the run file's status is {status!r} after the run"
    result.wall_time = time.perf_counter() - wall0
    return result
