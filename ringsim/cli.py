"""The ``ringsim`` command line (see CONTRACT.md for the commands and exit statuses).

Exit status: 0 success; 2 bad input (one line on stderr naming the file and the key, no
traceback, no output written; also a damaged, newer-format or locked run file); 130
interrupted (SIGINT/SIGTERM; ``run`` wrote a checkpoint first); 1 anything else (a run that
failed a runtime invariant included).  ``--debug`` shows tracebacks.
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
from pathlib import Path

from ringsim.errors import InputError

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as bad input (status 2) in one line."""

    def error(self, message):
        raise InputError("<command line>", self.prog, message)


def _cmd_epsilon(args) -> int:
    from ringsim.plots import paper_curves, plot_epsilon_curves

    curves = paper_curves()
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise InputError(args.plot, "--plot", "the figure must be a .png file")
    speeds_cm_s = (0.01, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
    header = f"{'curve':<62}" + "".join(f"{v:>8g}" for v in speeds_cm_s)
    print("coefficient of restitution at impact speeds [cm/s]")
    print(header)
    panel = None
    for curve in curves:
        if curve.panel != panel:
            panel = curve.panel
            print(f"[{panel}]")
        idx = [int(abs(curve.v - v * 0.01).argmin()) for v in speeds_cm_s]
        print(f"  {curve.label:<60}" + "".join(f"{curve.epsilon[i]:8.4f}" for i in idx))
    if args.json:
        payload = {
            "units": {"v": "m/s", "epsilon": "dimensionless"},
            "curves": [{"panel": c.panel, "label": c.label, "v": c.v.tolist(),
                        "epsilon": [float(e) for e in c.epsilon]} for c in curves],
        }
        Path(args.json).write_text(json.dumps(payload, indent=1))
    if args.plot:
        path = plot_epsilon_curves(curves, args.plot)
        print(f"wrote {path}")
    return EXIT_OK


def _cmd_run(args) -> int:
    from ringsim.config.scenario import load_scenario
    from ringsim.engine.runner import run

    scenario = load_scenario(args.scenario)
    path = run(scenario, output=args.output, force=args.force, resume=args.resume,
               progress=not args.no_progress)
    from ringsim.store.runfile import open_run

    run = open_run(path)
    status = run.attrs.get("status")
    print(f"{scenario.name}: {status}; run file {path}")
    if status == "failed":
        print(f"ringsim: error: {path}: the run failed: {run.attrs.get('failure')}",
              file=sys.stderr)
    return {"finished": EXIT_OK, "stopped": EXIT_INTERRUPTED}.get(status, EXIT_FAILURE)


def _open_runs(paths: list[str]):
    from ringsim.store.runfile import open_run

    # open_run checks each file (RunFileError, exit status 2, for a damaged one)
    return [open_run(path) for path in paths]


def _write_json(path: str, payload) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(payload, indent=2, allow_nan=True) + "\n")


def _cmd_analyze(args) -> int:
    from ringsim.analysis.equilibrium import equilibrium, equilibrium_table

    (run,) = _open_runs([args.run])
    eq = equilibrium(run)
    print(equilibrium_table(eq))
    if args.json:
        _write_json(args.json, eq)
    if args.plots:
        from ringsim.plots import plot_run

        for path in plot_run(run, eq, args.plots):
            print(f"wrote {path}")
    return EXIT_OK


def _cmd_compare(args) -> int:
    from ringsim.analysis.compare import comparison, comparison_table
    from ringsim.analysis.equilibrium import equilibrium

    runs = _open_runs(args.runs)
    equilibria = [equilibrium(run) for run in runs]
    comp = comparison(equilibria)
    print(comparison_table(comp))
    if args.json:
        _write_json(args.json, comp)
    if args.plots:
        from ringsim.plots import plot_comparison

        for path in plot_comparison(runs, equilibria, args.plots):
            print(f"wrote {path}")
    return EXIT_OK


def _cmd_sweep(args) -> int:
    from ringsim.sweep import sweep_command

    return sweep_command(args)


def _cmd_fit(args) -> int:
    from ringsim.analysis.fit import fit_command

    return fit_command(args)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="ringsim", description="Collisional N-body simulations of a "
                     "planetary-ring patch with size- and mass-dependent restitution.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    from ringsim import __version__

    parser.add_argument("--version", action="version", version=f"ringsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("epsilon", help="epsilon(v) curves of the restitution laws "
                       "(Dilley 1993 Figs. 1 and 5)")
    p.add_argument("--plot", metavar="PNG", help="write the figure to this PNG file")
    p.add_argument("--json", metavar="OUT.json", help="write the curves as JSON")
    p.set_defaults(func=_cmd_epsilon)

    p = sub.add_parser("run", help="run a scenario and write its HDF5 run file")
    p.add_argument("scenario", metavar="SCENARIO.yaml")
    p.add_argument("-o", "--output", metavar="RUN.h5", help="run file (default: the "
                   "scenario's output.path)")
    p.add_argument("--force", action="store_true", help="overwrite an existing run file")
    p.add_argument("--resume", action="store_true", help="continue a stopped run from its "
                   "last checkpoint")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (batch jobs)")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("analyze", help="equilibrium table of one run")
    p.add_argument("run", metavar="RUN.h5")
    p.add_argument("--json", metavar="OUT.json", help="write the equilibrium as JSON")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    p.set_defaults(func=_cmd_analyze)

    p = sub.add_parser("compare", help="side-by-side equilibria with ratios")
    p.add_argument("runs", metavar="RUN.h5", nargs="+")
    p.add_argument("--json", metavar="OUT.json", help="write the comparison as JSON")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    p.set_defaults(func=_cmd_compare)

    p = sub.add_parser("sweep", help="run a grid of scenarios (local processes or Dask)")
    p.add_argument("sweep", metavar="SWEEP.yaml")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: number of CPUs)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address "
                   "(e.g. tcp://127.0.0.1:8786); needs the 'dask' extra")
    p.add_argument("--out", metavar="DIR", help="output directory (default: "
                   "runs/<sweep file name>)")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("fit", help="fit restitution laws to measured epsilon(v, R, M)")
    p.add_argument("data", metavar="DATA.csv")
    p.add_argument("--model", default="dilley", help="dilley, bridges, constant, andrews, "
                   "tabor or all (default: dilley)")
    p.add_argument("--json", metavar="OUT.json", help="write the fit as JSON")
    p.add_argument("--plot", metavar="PNG", help="plot data and fitted curves")
    p.add_argument("--write-restitution", metavar="OUT.yaml",
                   help="write the best fit as a scenario 'restitution' section")
    p.set_defaults(func=_cmd_fit)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv  # accepted anywhere on the line
    argv = [a for a in argv if a != "--debug"]
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except InputError as exc:
        if debug:
            traceback.print_exc()
        print(f"ringsim: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("ringsim: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - the command line's last resort, status 1
        if debug:
            traceback.print_exc()
        print(f"ringsim: error: {type(exc).__name__}: {exc} (rerun with --debug for a "
              "traceback)", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
