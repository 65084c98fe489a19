"""``ringsim study STUDY.yaml``: run every run of a study and write its report.

The runs go to local worker processes or, with ``--scheduler``, to a Dask cluster (the
output directory and the study's folder must then be on a file system the workers share);
the numbers are the same either way.  The report is written only when every run has a
summary; a run that fails makes the command exit with status 1, an interrupted one with
130 (start it again to continue), bad input with 2 before anything is written.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ringsim.batch import ACTIONS, dask_client, run_dask, run_local
from ringsim.config.scenario import check_threads
from ringsim.config.study import load_study
from ringsim.errors import InputError
from ringsim.study.partial import partial_output_dir, reduced
from ringsim.study.runs import (
    TaskResult,
    collect,
    failed,
    read_summary,
    run_task,
    summary_state,
    write_json,
)
from ringsim.study.waves import plan_waves

#: Folder of a study's run summaries, beside the study file.
SUMMARIES = "summaries"


@dataclass
class StudyResult:
    """The outcome of `run_study`: the output directory, what became of each run that had
    work to do, and the report's files (None when it was not written)."""

    out: Path
    results: list[TaskResult] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    @property
    def n_failed(self) -> int:
        return sum(r.status == "failed" for r in self.results)

    @property
    def n_stopped(self) -> int:
        return sum(r.status == "stopped" for r in self.results)


def default_output_dir(study_path: str | os.PathLike, quick: bool = False) -> Path:
    """``<stem>.report/`` (``<stem>.quick.report/`` with ``--quick``) beside the study."""
    path = Path(study_path)
    return path.parent / f"{path.stem}{'.quick' if quick else ''}.report"


def _check_options(workers: int | None, threads: int | None, out: Path) -> None:
    if workers is not None and workers < 1:
        raise InputError("<command line>", "--workers", f"{workers} is not a positive number")
    check_threads(threads)
    if out.exists() and not out.is_dir():
        raise InputError(str(out), "--out", "exists and is not a directory")


def read_summaries(runs: dict, folder: Path, missing_ok: bool = False) -> dict[str, dict]:
    """The summary of every run; InputError naming the first that is missing or is not of
    the run asked (the report needs them all), or with ``missing_ok`` only the runs that
    have one of their own (a partial report)."""
    out = {}
    for rid, run in runs.items():
        path = folder / f"{rid}.json"
        summary = read_summary(path)
        state = summary_state(summary, run.scenario)
        if summary is None or state != "same":
            if missing_ok:
                continue
            why = {"missing": "no summary", "shorter": "the summary is of a shorter run",
                   "longer": "the summary is of a longer run",
                   "other": "the summary is of another scenario"}[state]
            raise InputError(str(path), "summary", f"{why} for {', '.join(run.labels)}; "
                             "run the study (without --report-only) first")
        out[rid] = summary
    return out


def _plan_line(path, n_runs: int, tasks: list, out: Path, where: str) -> str:
    counts = {a: sum(t.action == a for t in tasks) for a in ACTIONS}
    return (f"study {path}: {n_runs} runs -> {out}/ ({counts['run']} new, {counts['resume']} "
            f"to resume, {counts['extend']} to lengthen, {counts['restart']} to restart, "
            f"{counts['reuse']} to summarise, {n_runs - len(tasks)} done already; {where})")


def _execute(waves: list[list], workers: int | None, scheduler: str | None,
             say: Callable[[str], None], plan: Callable[[str], str]) -> list[TaskResult]:
    """Run the tasks locally or on Dask, wave after wave (a wave starts when the one before
    has ended, and not after a run of it failed or stopped), reporting each result as it
    arrives."""
    tasks = [task for wave in waves for task in wave]
    client = dask_client(scheduler) if scheduler and tasks else None
    n_workers = max(1, min(workers or os.cpu_count() or 1, len(tasks) or 1))
    say(plan(f"Dask scheduler {scheduler}" if client is not None else
             f"{n_workers} worker process{'es' if n_workers > 1 else ''}" if tasks
             else "nothing to run"))
    results: list[TaskResult] = []
    start = time.perf_counter()

    def report(result: TaskResult) -> None:
        results.append(result)
        line = (f"[{len(results)}/{len(tasks)}] run {result.run_id} "
                f"({'; '.join(result.labels)}): {result.status} ({result.action}, "
                f"{result.wall_time:.1f} s); study time {time.perf_counter() - start:.1f} s")
        say(line + (f": {result.error}" if result.error else ""))

    try:
        for wave in waves:
            if any(r.status != "finished" for r in results):
                break
            if client is not None:
                run_dask(client, run_task, wave, report, failed)
            else:
                run_local(run_task, wave, min(n_workers, len(wave)), report, failed)
    finally:
        if client is not None:
            client.close()
    return results


def only_runs(runs: dict, specs, ids, only: Sequence[str]) -> dict:
    """The runs of ``runs`` that ``only`` asks for, each with the run it starts from:
    an entry is a case (all of its runs, its variants' included) or a run's label as the
    plan prints it (``"kappa0 seed 2"``, ``"kappa0.1 [smaller_box] seed 1"``).

    Raises InputError for an entry that is neither."""
    chosen: set[str] = set()
    for entry in only:
        hits = {rid for spec, rid in zip(specs, ids, strict=True)
                if entry in (spec.case, spec.label)}
        if not hits:
            cases = ", ".join(dict.fromkeys(spec.case for spec in specs))
            raise InputError("<command line>", "--only",
                             f"{entry!r} is neither a case nor a run's label of the study "
                             f"(cases: {cases}; a label: {specs[0].label!r})")
        chosen |= hits
    for rid in list(chosen):
        while runs[rid].origin is not None:
            rid = runs[rid].origin
            chosen.add(rid)
    return {rid: run for rid, run in runs.items() if rid in chosen}


def _run_asked(study_path, runs: dict, specs, ids, only: Sequence[str], out_dir: Path,
               summaries_dir: Path, resummarise: bool, workers: int | None,
               scheduler: str | None, say: Callable[[str], None]) -> list[TaskResult]:
    """Plan and run the study's runs (those of ``only`` when given)."""
    asked = only_runs(runs, specs, ids, only) if only else runs
    waves = plan_waves(asked, out_dir / "runs", summaries_dir, resummarise)
    tasks = [task for wave in waves for task in wave]
    return _execute(waves, workers, scheduler, say, lambda where: _plan_line(
        study_path, len(asked), tasks, out_dir, where))


def _check_modes(only: Sequence[str], report_only: bool, partial: bool) -> None:
    """InputError for --partial without --report-only, or --only with it."""
    if partial and not report_only:
        raise InputError("<command line>", "--partial", "given without --report-only "
                         "(--report-only --partial: the report of the runs done so far)")
    if only and report_only:
        raise InputError("<command line>", "--only", "given with --report-only (--only "
                         "chooses the runs to run; the report is of every summary)")


def run_study(study_path: str | os.PathLike, out: str | os.PathLike | None = None,
              workers: int | None = None, scheduler: str | None = None, quick: bool = False,
              report_only: bool = False, threads: int | None = None,
              resummarise: bool = False,
              echo: Callable[[str], None] | None = print,
              command: str | None = None, partial: bool = False,
              only: Sequence[str] = ()) -> StudyResult:
    """Run a study (docs/studies.md) and write ``report.json``, ``report.md`` and
    ``ratios.png`` into ``out``.

    Parameters
    ----------
    study_path : the study file
    out : output directory (default `default_output_dir`); run files go to ``out/runs/``
    workers : local worker processes (default: the CPUs); ignored with ``scheduler``
    scheduler : address of a Dask scheduler (``pip install ringsim[dask]``)
    quick : run the study's ``quick`` form
    report_only : write the report from the summaries alone; run nothing
    resummarise : remake the summary of every run whose finished run file is in
        ``out/runs/`` from that file (today's analysis of the same run; its ``cost`` kept)
    threads : ``integration.threads`` of every run (changes the speed, never a result)
    echo : receives the progress lines (None: quiet)
    command : the command line the report names as the one that regenerates it
    partial : with ``report_only``, the report so far (``ringsim.study.partial``)
    only : run only these cases or runs (`only_runs`) and write no report

    Raises
    ------
    InputError
        Invalid study file or option, a run file or summary that cannot be reused, a
        missing summary with ``report_only``, Dask missing; nothing is written then.
    """
    from ringsim.analysis.equilibrium import QUANTITIES

    say = echo if echo is not None else (lambda line: None)
    _check_modes(only, report_only, partial)
    out_dir = (Path(out) if out is not None else partial_output_dir(study_path, quick)
               if partial else default_output_dir(study_path, quick))
    _check_options(workers, threads, out_dir)
    study = load_study(study_path, quantities=tuple(QUANTITIES))
    specs = study.specs(quick)
    runs, ids = collect(specs, threads, study.keep)
    summaries_dir = study.folder / SUMMARIES
    result = StudyResult(out_dir)
    if not report_only:
        result.results = _run_asked(study_path, runs, specs, ids, only, out_dir,
                                    summaries_dir, resummarise, workers, scheduler, say)
        if result.n_failed or result.n_stopped or only:
            return result
    study, specs, ids, summaries, note = _reported(study, quick, specs, ids, runs,
                                                   summaries_dir, partial)
    command = command or (f"ringsim study {study_path}{' --quick' if quick else ''}"
                          + (" --report-only --partial" if partial else ""))
    result.files = write_report(study, quick, specs, ids, summaries, out_dir, command,
                                note)
    for path in result.files:
        say(f"wrote {path}")
    return result


def _reported(study, quick: bool, specs, ids, runs: dict, summaries_dir: Path,
              partial: bool) -> tuple:
    """``(study, specs, ids, summaries, note)`` of the report: every run's summary (InputError
    for a missing one), or with ``partial`` the study cut to its summarised cases and the
    note of what it leaves out (``study.partial``)."""
    if not partial:
        return study, specs, ids, read_summaries(runs, summaries_dir), None
    summaries = read_summaries(runs, summaries_dir, missing_ok=True)
    study, specs, ids, note = reduced(study, quick, specs, ids, summaries)
    if not study.cases:
        raise InputError(str(summaries_dir), "summary", "no case has a summary of every run "
                         "yet; run the study (without --report-only) first")
    return study, specs, ids, {rid: summaries[rid] for rid in ids}, note


def write_report(study, quick: bool, specs, ids, summaries: dict, out_dir: Path,
                 command: str, partial: str | None = None) -> list[Path]:
    """``report.json``, ``report.md`` and (with ratios) ``ratios.png`` into ``out_dir``;
    ``partial``: the note of a partial report (what it leaves out), or None."""
    from ringsim.plots.study import plot_ratios
    from ringsim.study.markdown import report_markdown
    from ringsim.study.report import build_report

    report = build_report(study, quick, specs, ids, summaries)
    if partial is not None:
        report["partial"] = partial
    out_dir.mkdir(parents=True, exist_ok=True)
    files = [write_json(out_dir / "report.json", report)]
    figure = plot_ratios(report, out_dir)
    prose = "\n\n".join(Path(file).read_text(encoding="utf-8").strip()
                        for file in (study.report, study.quick_report if quick else None)
                        if file)
    text = report_markdown(report, summaries, prose, command,
                           figure.name if figure is not None else None)
    md = out_dir / "report.md"
    tmp = md.with_name(f".report.md.{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, md)
    files.append(md)
    return files + ([figure] if figure is not None else [])


def _shown(path: str) -> str:
    """A path as the user would retype it: relative to the working directory when inside
    it."""
    rel = os.path.relpath(Path(path).absolute())
    return rel if not rel.startswith("..") else str(path)


def study_command(args) -> int:
    """``ringsim study STUDY.yaml [--out DIR] [--workers N] [--scheduler ADDRESS] [--quick]
    [--report-only] [--resummarise] [--threads N] [--only CASE_OR_RUN ...]``.

    Returns 0 when the report is written, 1 when a run failed, 130 when a run was
    interrupted (InputError for bad input propagates: exit status 2).
    """
    def echo(line: str) -> None:
        print(line, flush=True)

    command = (f"ringsim study {_shown(args.study)}" + (" --quick" if args.quick else "")
               + (" --report-only --partial" if args.partial else "")
               + (f" --out {_shown(args.out)}" if args.out else ""))
    result = run_study(args.study, out=args.out, workers=args.workers,
                       scheduler=args.scheduler, quick=args.quick,
                       report_only=args.report_only, threads=args.threads,
                       resummarise=args.resummarise, echo=echo,
                       command=command, partial=args.partial, only=args.only or ())
    if result.n_failed or result.n_stopped:
        bad = [f"{r.run_id} ({'; '.join(r.labels)}): {r.status}" for r in result.results
               if r.status != "finished"]
        print(f"ringsim study: {len(bad)} run(s) did not finish, no report written: "
              f"{', '.join(bad)}", file=sys.stderr)
        return 1 if result.n_failed else 130
    if args.only:
        print(f"ringsim study: ran the runs of {', '.join(args.only)} (--only); no report "
              "written: --report-only --partial gives the report so far", flush=True)
    return 0
