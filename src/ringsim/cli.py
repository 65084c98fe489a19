"""The ``ringsim`` command line (see docs/interface.md for the commands and exit statuses).

Exit status: 0 success; 2 bad input (one line on stderr naming the file and the key, no
traceback, no output written; also a damaged, newer-format or locked run file); 130
interrupted (SIGINT/SIGTERM; ``run`` wrote a checkpoint first); 1 anything else (a run that
failed a runtime invariant included).  ``--debug`` shows tracebacks.

A reader that closes stdout early does not stop a command (``cli_io.ClosedPipeSafeStdout``).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import traceback
from pathlib import Path

from ringsim import __version__
from ringsim.cli_examples import add_examples
from ringsim.cli_io import ClosedPipeSafeStdout, Parser
from ringsim.errors import InputError, clip
from ringsim.store.paths import check_output, check_outputs

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def _add_force_option(p) -> None:
    """``--force``: replace existing output files (never an input of the command)."""
    p.add_argument("--force", action="store_true", help="replace existing output files "
                   "(never an input of the command)")


def _cmd_epsilon(args) -> int:
    check_outputs({"--json": args.json, "--plot": args.plot}, [args.restitution or ""],
                  args.force)
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise InputError(args.plot, "--plot", "the figure must be a .png file")
    if args.restitution is None:
        if args.radius or args.density is not None:
            raise InputError("<command line>", "--radius" if args.radius else "--density",
                             "only with --restitution (the paper's figures fix the sizes)")
        return _paper_epsilon(args)
    from ringsim import userlaw

    law, density, radii = userlaw.read_law(args.restitution, args.density, args.radius)
    curves = userlaw.user_curves(law, density, radii)
    title = userlaw.law_title(law, density)
    _print_curves(title, curves)
    if args.json:
        _write_json(args.json, {
            "units": {"v": "m/s", "epsilon": "dimensionless", "radius": "m",
                      "density": "kg/m^3"},
            "restitution": law, "density": density,
            "curves": [{"radius": r, "label": c.label, "v": c.v.tolist(),
                        "epsilon": [float(e) for e in c.epsilon]}
                       for r, c in zip(radii, curves, strict=True)]})
    if args.plot:
        print(f"wrote {userlaw.plot_user_curves(curves, title, args.plot, law['model'])}")
    return EXIT_OK


def _print_curves(title: str, curves) -> None:
    speeds_cm_s = (0.01, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
    print(f"coefficient of restitution at impact speeds [cm/s]: {title}")
    print(f"{'curve':<62}" + "".join(f"{v:>8g}" for v in speeds_cm_s))
    for curve in curves:
        idx = [int(abs(curve.v - v * 0.01).argmin()) for v in speeds_cm_s]
        print(f"  {curve.label:<60}" + "".join(f"{curve.epsilon[i]:8.4f}" for i in idx))


def _paper_epsilon(args) -> int:
    from ringsim.plots import paper_curves, plot_epsilon_curves

    curves = paper_curves()
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
        _write_json(args.json, payload, indent=1)
    if args.plot:
        path = plot_epsilon_curves(curves, args.plot)
        print(f"wrote {path}")
    return EXIT_OK


#: The first bytes of every HDF5 file (a run file given where a scenario belongs).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def _refuse_run_file(path: str) -> None:
    """InputError pointing to ``analyze`` and ``--resume`` if ``path`` is an HDF5 file."""
    try:
        with open(path, "rb") as f:
            head = f.read(len(HDF5_SIGNATURE))
    except OSError:
        return   # the scenario reader says what is wrong with it
    if head == HDF5_SIGNATURE:
        raise InputError(path, "SCENARIO.yaml", "an HDF5 run file, not a scenario: "
                         f"'ringsim analyze {path}' shows its equilibrium, 'ringsim run "
                         f"SCENARIO.yaml --resume -o {path}' continues it")


def _cmd_run(args) -> int:
    from ringsim.config.scenario import load_scenario, with_threads
    from ringsim.engine.runner import run

    _refuse_run_file(args.scenario)
    scenario = with_threads(load_scenario(args.scenario), args.threads)
    path = run(scenario, output=args.output, force=args.force, resume=args.resume,
               progress=not args.no_progress)
    from ringsim.store.runfile import open_run

    run_file = open_run(path)
    status = str(run_file.attrs.get("status"))
    print(f"{scenario.name}: {status}; run file {path}")
    if status == "failed":
        print(f"ringsim: error: {path}: the run failed: {run_file.attrs.get('failure')}",
              file=sys.stderr)
    return {"finished": EXIT_OK, "stopped": EXIT_INTERRUPTED}.get(status, EXIT_FAILURE)


def _open_runs(paths: list[str]):
    from ringsim.store.run_checks import check_arrays, check_box
    from ringsim.store.runfile import open_run

    # open_run checks each file (RunFileError, exit status 2, for a damaged one), and
    # store.run_checks its box and the shapes of its arrays
    runs = [open_run(path) for path in paths]
    for run in runs:
        check_box(run.attrs, run.path)
        check_arrays(run)
    return runs


def _print_status(run) -> None:
    """The run's status in the analyze header, and a warning on stderr unless finished."""
    status = str(run.attrs.get("status", "unknown"))
    orbits = run.timeseries.get("orbits")
    done = float(orbits[-1]) if orbits is not None and len(orbits) else 0.0
    planned = run.scenario.integration.orbits
    print(f"status: {status} at orbit {done:.4g} of {planned:g} ({run.path})")
    if status != "finished":
        why = {"stopped": "it was stopped (continue it with ringsim run SCENARIO --resume)",
               "running": "it is still running, or its process died (--resume continues "
                          "it from its last checkpoint)"}.get(status, "its status is unknown")
        print(f"ringsim: warning: {run.path} is not finished: {why}; the equilibrium below "
              f"is of the first {done:.4g} orbits only", file=sys.stderr)


def _sweep_summaries(paths: list[str]) -> list[str]:
    """The paths that are sweep summaries (``summary.h5``: attribute ``sweep_yaml``)."""
    import h5py

    found = []
    for path in paths:
        try:
            with h5py.File(path, "r") as f:
                if "sweep_yaml" in f.attrs and "scenario_yaml" not in f.attrs:
                    found.append(path)
        except OSError:
            continue  # not HDF5 or unreadable: _open_runs reports it
    return found


def _write_json(path: str, payload, indent: int = 2) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(payload, indent=indent, allow_nan=True) + "\n")


def _cmd_analyze(args) -> int:
    from ringsim.analysis.equilibrium import equilibrium, equilibrium_table

    check_outputs({"--json": args.json, "--plots": args.plots}, [args.run], args.force)
    (run,) = _open_runs([args.run])
    _print_status(run)
    eq = equilibrium(run)
    print(equilibrium_table(eq))
    _write_results(args, eq, "plot_run", run, eq)
    return EXIT_OK


def _write_results(args, payload, plot: str, *plot_args) -> None:
    """``--json`` (the payload) and ``--plots DIR`` (``ringsim.plots.<plot>(*plot_args,
    DIR)``) of analyze and compare."""
    if args.json:
        _write_json(args.json, payload)
    if args.plots:
        from ringsim import plots

        for path in getattr(plots, plot)(*plot_args, args.plots):
            print(f"wrote {path}")


def _cmd_compare(args) -> int:
    from ringsim.analysis.compare import comparison, comparison_table
    from ringsim.analysis.equilibrium import equilibrium

    check_outputs({"--json": args.json, "--plots": args.plots},
                  [*args.runs, args.systematics or ""], args.force)
    systematics = None
    if args.systematics:
        from ringsim.analysis.budget import load_budget

        systematics = load_budget(args.systematics)
    summaries = _sweep_summaries(args.runs)
    for path in summaries:
        print(f"ringsim: note: skipping {path}: a sweep summary, not a run file", file=sys.stderr)
    paths = [p for p in args.runs if p not in summaries]
    if not paths:
        raise InputError(args.runs[0], "RUN.h5", "only sweep summaries given; compare the "
                         "run files of the sweep (the other .h5 files of its directory)")
    runs = _open_runs(paths)
    equilibria = [equilibrium(run) for run in runs]
    comp = comparison(equilibria, systematics)
    print(comparison_table(comp))   # its warnings first, each printed once
    _write_results(args, comp, "plot_comparison", runs, equilibria)
    return EXIT_OK


def _cmd_observe(args) -> int:
    from ringsim.analysis.observe import observation_table, observe

    check_outputs({"--json": args.json, "--plots": args.plots}, [args.run], args.force)
    (run,) = _open_runs([args.run])
    _print_status(run)
    obs = observe(run, args.elevation, args.azimuth, args.snapshot, args.rays, args.precision,
                  args.reference)
    print(observation_table(obs))
    _write_results(args, obs, "plot_observation", run, obs)
    return EXIT_OK


def _cmd_export(args) -> int:
    from ringsim.engine import export

    if not (args.csv or args.rebound):
        raise InputError("<command line>", "export", "give --csv OUT.csv and/or "
                         "--rebound OUT.bin")
    check_outputs({"--csv": args.csv, "--rebound": args.rebound}, [args.run], args.force)
    (run,) = _open_runs([args.run])
    for option, path, suffix in (("--csv", args.csv, ".csv"), ("--rebound", args.rebound,
                                                               ".bin")):
        if path and Path(path).suffix.lower() != suffix:
            raise InputError(path, option, f"the file must end in {suffix}")
    if args.csv:
        print(f"wrote {export.export_csv(run, args.snapshot, args.csv)}")
    if args.rebound:
        path, info = export.export_rebound(run, args.snapshot, args.rebound)
        code = export.continuation_code(path, info)
        print(f"wrote {path}: t = {info['t']:.10g} s (orbit {info['orbits']:.6g} of the shear "
              "phase); continue it with\n" + "".join(f"  {line}\n" if line else "\n"
                                                    for line in code.splitlines()), end="")
    return EXIT_OK


def _check_folders(args, source: str) -> None:
    """A sweep's or study's ``--out`` and ``--plots`` folders are folders, never its file."""
    for option in ("--out", "--plots"):
        folder = getattr(args, option[2:], None)
        if folder:
            check_output(folder, option, [source], True, folder=True)


def _cmd_sweep(args) -> int:
    from ringsim.sweep import sweep_command

    _check_folders(args, args.sweep)
    return sweep_command(args)


def _cmd_study(args) -> int:
    from ringsim.study import study_command

    _check_folders(args, args.study)
    return study_command(args)


def _cmd_fit(args) -> int:
    from ringsim.analysis.fit import fit_command

    check_outputs({"--json": args.json, "--plot": args.plot,
                   "--write-restitution": args.write_restitution}, [args.data], args.force)
    return fit_command(args)


def _epsilon_arguments(sub) -> None:
    p = sub.add_parser("epsilon", help="epsilon(v) curves of the restitution laws "
                       "(Dilley 1993 Figs. 1 and 5)")
    p.add_argument("--plot", metavar="PNG", help="write the figure to this PNG file")
    p.add_argument("--json", metavar="OUT.json", help="write the curves as JSON")
    p.add_argument("--restitution", metavar="LAW", help="your own law instead of the "
                   "paper's figures: key=value pairs as in a scenario's restitution section "
                   "(model=dilley,xi0=0.16,p=0.65,kappa=0.1) or a YAML file with a "
                   "restitution section (a scenario: its sizes and density are the defaults)")
    p.add_argument("--radius", metavar="R", type=float, nargs="+", help="radii [m] of the "
                   "colliding identical spheres, one curve each")
    p.add_argument("--density", metavar="RHO", type=float, help="bulk density [kg/m^3] "
                   "(default 900, or the scenario's)")
    _add_force_option(p)
    p.set_defaults(func=_cmd_epsilon)


def _export_arguments(sub) -> None:
    p = sub.add_parser("export", help="a snapshot of a run as a particle CSV or a REBOUND "
                       "simulation file")
    p.add_argument("run", metavar="RUN.h5")
    p.add_argument("--snapshot", type=int, default=-1, metavar="I",
                   help="snapshot index (negative from the end; default -1, the last)")
    p.add_argument("--csv", metavar="OUT.csv", help="write the particles as CSV "
                   "(x_m ... mass_kg, the format of sheet.initial_state)")
    p.add_argument("--rebound", metavar="OUT.bin", help="write a REBOUND simulation that "
                   "continues the snapshot (see docs/export.md)")
    _add_force_option(p)
    p.set_defaults(func=_cmd_export)


def _add_threads_option(p) -> None:
    """``--threads N``: the ``integration.threads`` of every run a command makes."""
    p.add_argument("--threads", type=int, default=None, metavar="N", help="integration."
                   "threads of every run (changes the speed, never a result)")


def _run_arguments(sub) -> None:
    p = sub.add_parser("run", help="run a scenario and write its HDF5 run file")
    p.add_argument("scenario", metavar="SCENARIO.yaml")
    p.add_argument("-o", "--output", metavar="RUN.h5", help="run file (default: the "
                   "scenario's output.path)")
    p.add_argument("--force", action="store_true", help="overwrite an existing run file "
                   "(only a ringsim run file)")
    p.add_argument("--resume", action="store_true", help="continue a stopped run from its "
                   "last checkpoint")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (batch jobs)")
    _add_threads_option(p)
    p.set_defaults(func=_cmd_run)


def _analyze_arguments(sub) -> None:
    p = sub.add_parser("analyze", help="equilibrium table of one run")
    p.add_argument("run", metavar="RUN.h5")
    p.add_argument("--json", metavar="OUT.json", help="write the equilibrium as JSON")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    _add_force_option(p)
    p.set_defaults(func=_cmd_analyze)


def _observe_arguments(sub) -> None:
    p = sub.add_parser("observe", help="synthetic stellar occultations: T and tau_n at (B, phi)")
    p.add_argument("run", metavar="RUN.h5")
    p.add_argument("--elevation", type=float, nargs="+", metavar="DEG", help="opening angles "
                   "B [deg] (default 3.45 10 20 45 90)")
    p.add_argument("--azimuth", type=float, nargs="+", metavar="DEG", help="azimuths phi "
                   "[deg] from radial toward orbital motion (default every 15)")
    p.add_argument("--snapshot", type=int, metavar="K", help="one snapshot (default: all in "
                   "the equilibrium window)")
    rays = p.add_mutually_exclusive_group()
    rays.add_argument("--rays", type=int, metavar="N", help="rays per view and snapshot")
    rays.add_argument("--precision", type=float, metavar="P", help="relative error of tau_n")
    p.add_argument("--reference", type=int, default=0, metavar="K", help="K structure-free "
                   "copies per opening angle: the p-value of the azimuthal asymmetry "
                   "(default 0: none; costs K times the tracing)")
    p.add_argument("--json", metavar="OUT.json", help="write the views as JSON")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    _add_force_option(p)
    p.set_defaults(func=_cmd_observe)


def _compare_arguments(sub) -> None:
    p = sub.add_parser("compare", help="side-by-side equilibria with ratios")
    p.add_argument("runs", metavar="RUN.h5", nargs="+")
    p.add_argument("--json", metavar="OUT.json", help="write the comparison as JSON")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures into DIR")
    p.add_argument("--systematics", metavar="BUDGET.json", help="measured systematic "
                   "uncertainties of the ratios (ringsim.analysis.budget)")
    _add_force_option(p)
    p.set_defaults(func=_cmd_compare)


def _add_pool_options(p) -> None:
    """``--workers`` and ``--scheduler`` of the commands that run batches of runs."""
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: number of CPUs)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address "
                   "(e.g. tcp://127.0.0.1:8786); needs the 'dask' extra")


def _study_arguments(sub) -> None:
    p = sub.add_parser("study", help="run a study file (cases x seeds, ratios, variants) and "
                       "write its report (docs/studies.md)")
    p.add_argument("study", metavar="STUDY.yaml")
    p.add_argument("--out", metavar="DIR", help="report and run files (default: "
                   "<study>.report/, or <study>.quick.report/, beside the study file)")
    _add_pool_options(p)
    p.add_argument("--quick", action="store_true", help="the study's quick form (reduced "
                   "particles and length)")
    p.add_argument("--report-only", action="store_true", help="write the report from the "
                   "summaries alone; run nothing")
    p.add_argument("--partial", action="store_true", help="with --report-only: the report "
                   "of the cases whose runs all have summaries so far (default out: "
                   "<study>.partial.report/)")
    p.add_argument("--resummarise", action="store_true", help="remake the summary of every "
                   "finished run file in DIR/runs with today's analysis (cost kept)")
    p.add_argument("--only", nargs="+", metavar="CASE_OR_RUN", help="run only these "
                   "cases, or runs by their label (e.g. 'kappa0 seed 2'), and write no "
                   "report")
    _add_threads_option(p)
    p.set_defaults(func=_cmd_study)


def _sweep_arguments(sub) -> None:
    p = sub.add_parser("sweep", help="run a grid of scenarios (local processes or Dask)")
    p.add_argument("sweep", metavar="SWEEP.yaml")
    _add_pool_options(p)
    p.add_argument("--out", metavar="DIR", help="output directory (default: "
                   "runs/<sweep file name>)")
    p.add_argument("--plots", metavar="DIR", help="write PNG figures of the summary (c and "
                   "H against the swept parameter) into DIR")
    _add_threads_option(p)
    p.set_defaults(func=_cmd_sweep)


def _fit_arguments(sub) -> None:
    p = sub.add_parser("fit", help="fit restitution laws to measured epsilon(v, R, M)")
    p.add_argument("data", metavar="DATA.csv")
    p.add_argument("--model", default="dilley", help="dilley, bridges, constant, andrews, "
                   "tabor or all (default: dilley)")
    p.add_argument("--json", metavar="OUT.json", help="write the fit as JSON")
    p.add_argument("--plot", metavar="PNG", help="plot data and fitted curves")
    p.add_argument("--write-restitution", metavar="OUT.yaml",
                   help="write the best fit as a scenario 'restitution' section")
    _add_force_option(p)
    p.set_defaults(func=_cmd_fit)


#: The subcommands, in the order ``ringsim --help`` lists them: each adds its parser.
_SUBCOMMANDS = (_epsilon_arguments, _export_arguments, _run_arguments, _analyze_arguments,
                _observe_arguments, _compare_arguments, _sweep_arguments, _study_arguments,
                _fit_arguments)


def build_parser() -> argparse.ArgumentParser:
    """The parser of the ``ringsim`` command and its subcommands (docs/interface.md)."""
    parser = Parser(prog="ringsim", description="Collisional N-body simulations of a "
                     "planetary-ring patch with size- and mass-dependent restitution.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    parser.add_argument("--version", action="version", version=f"ringsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for add_arguments in _SUBCOMMANDS:
        add_arguments(sub)
    add_examples(sub)   # an example at the end of every --help
    return parser


def main(argv: list[str] | None = None) -> int:
    if argv is None and not isinstance(sys.stdout, ClosedPipeSafeStdout):
        sys.stdout = ClosedPipeSafeStdout(sys.stdout)
        if hasattr(signal, "SIGXFSZ"):   # a file-size limit fails the write (EFBIG), which
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # ends in one line, not a kill
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv  # accepted anywhere on the line
    argv = [a for a in argv if a != "--debug"]
    try:
        parser = build_parser()
        if not argv:   # `ringsim` alone: what it can do, not an error
            parser.print_help()
            return EXIT_OK
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
        print(f"ringsim: error: {type(exc).__name__}: {clip(str(exc), 300)} (rerun with "
              "--debug for a traceback)", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
