"""Validation ladder: ringsim against published ring physics.

Runs the reference case 5 through the same machinery users run (``ringsim.run`` on
scenarios, the native resolver, ``ringsim.compare.equilibrium``) and writes the section
"## Reference cases" of ``docs/validation.md`` with one table and one figure per case
(figures in ``docs/figures/validation/``)::

    python -m validation ladder                # documented size (~3 min of CPU)
    python -m validation ladder --quick        # small size, same checks,
                                               # report in runs/validation/quick/
    python -m validation ladder --report-only  # rewrite the report from stored results

The case (all SI inside; results in units of the particle radius r and Omega):

5. REBOUND's shearing-sheet example through ``scenarios/bridges.yaml``: ringsim's resolver
   against REBOUND's built-in hard-sphere resolver from the same seed.

Cases 1 (constant eps = 0.5), 2 (the Goldreich & Tremaine 1978 threshold), 3 (the
Bridges law, identical particles) and 4 (the Bridges law with a q = 3 size distribution)
are study files, ``studies/validation-constant-eps``, ``studies/validation-threshold``,
``studies/validation-bridges`` and ``studies/validation-size-distribution``, run by
``ringsim study``; case 6 (Dilley 1993 Figs. 1 and 5) compares eps with the paper's
equations, not a run's statistics, and is the test ``tests/test_dilley_figures.py``.

The case is the module ``case5_rebound_example``, built from ``common`` and rendered to
Markdown by ``render``.  It returns a ``CaseResult``: rows comparing ringsim's value (with
its standard error) with a reference value (with its uncertainty and source), the
difference in units of the combined uncertainty, and whether that is the expected
outcome.  Results are stored as JSON beside the runs (``--workdir``, default
``runs/validation``) and finished run files are reused when their scenario is unchanged.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from ringsim.report import replace_section
from validation.case5_rebound_example import case5
from validation.common import (
    DOC,
    FULL,
    QUICK,
    ROOT,
    RUNS_USED,
    WORKDIR,
    CaseResult,
    Sizes,
    load_results,
    save_result,
)
from validation.render import SECTION_HEADING, row_markdown, section_markdown

FIGURES = ROOT / "docs" / "figures" / "validation"

CASES: dict[int, Callable[[Sizes, Path, Path], CaseResult]] = {5: case5}


def run_case(number: int, sizes: Sizes, workdir: Path, figures: Path) -> CaseResult:
    """Run one case, time it and store its result.

    The time is the wall-clock time the case costs from scratch: the recorded run time of
    every run file it uses (reused or new) plus this invocation's other work.
    """
    workdir.mkdir(parents=True, exist_ok=True)
    RUNS_USED.clear()
    t0 = time.perf_counter()
    result = CASES[number](sizes, workdir, figures)
    elapsed = time.perf_counter() - t0
    new_runs = sum(w for w, fresh in RUNS_USED.values() if fresh)
    result.cpu_seconds = (max(elapsed - new_runs, 0.0)
                          + sum(w for w, _ in RUNS_USED.values()))
    result.sizes = "quick" if sizes == QUICK else ("full" if sizes == FULL else "custom")
    save_result(result, workdir)
    return result


def main(argv: Sequence[str] | None = None, prog: str | None = None) -> int:
    """``python -m validation ladder``: run the cases, write the report; 0 if all agree."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (~5 min of CPU)")
    parser.add_argument("--cases", type=int, nargs="+", choices=sorted(CASES),
                        default=sorted(CASES))
    parser.add_argument("--workdir", type=Path, default=WORKDIR,
                        help="run files and stored results")
    parser.add_argument("--doc", type=Path, default=None,
                        help=f"report to write (default {DOC.relative_to(ROOT)}; with "
                        "--quick WORKDIR/quick/validation.md, so that quick numbers never "
                        "replace the documented ones)")
    parser.add_argument("--figures", type=Path, default=None,
                        help=f"figure directory (default {FIGURES.relative_to(ROOT)}; with "
                        "--quick WORKDIR/quick/figures)")
    parser.add_argument("--report-only", action="store_true",
                        help="rewrite the report from stored results")
    args = parser.parse_args(argv)
    sizes = QUICK if args.quick else FULL
    workdir = args.workdir / ("quick" if args.quick else "full")
    if args.doc is None:
        args.doc = workdir / "validation.md" if args.quick else DOC
    if args.figures is None:
        args.figures = workdir / "figures" if args.quick else FIGURES
    if not args.report_only:
        for number in args.cases:
            t0 = time.perf_counter()
            result = run_case(number, sizes, workdir, args.figures)
            print(f"case {number}: {'as expected' if result.passed else 'NOT AS EXPECTED'} "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
            for c in result.comparisons:
                print("   ", row_markdown(c))
    results = {k: r for k, r in load_results(workdir).items() if k in CASES}
    try:
        figures_rel = args.figures.resolve().relative_to(args.doc.resolve().parent)
    except ValueError:
        figures_rel = args.figures.resolve()
    # replace_section re-reads the file right before writing and keeps other sections
    replace_section(args.doc, SECTION_HEADING, section_markdown(results, figures_rel.as_posix()),
                    title="Validation")
    print(f"wrote {args.doc}")
    return 0 if all(r.passed for r in results.values()) else 1
