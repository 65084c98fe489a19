"""One worked example per ``ringsim`` subcommand, shown at the end of its ``--help``.

Every example is a command a user can paste from the repository root: the files it names
are bundled (``scenarios/``, ``studies/``, ``docs/data/``) or written by the example
before it (``runs/kappa0.h5`` by the ``run`` example).
"""

from __future__ import annotations

#: Subcommand -> its example lines (a command and a comment saying what it does).
EXAMPLES: dict[str, str] = {
    "epsilon": (
        "ringsim epsilon --plot epsilon.png                  # the paper's Figs. 1 and 5\n"
        "ringsim epsilon --restitution model=dilley,kappa=0.1 --radius 0.5 1 5"),
    "export": (
        "ringsim export runs/kappa0.h5 --csv last.csv --rebound last.bin\n"
        "                              # the last snapshot as a CSV and as a REBOUND file"),
    "run": (
        "ringsim run scenarios/kappa0.yaml --threads 2        # writes runs/kappa0.h5\n"
        "ringsim run scenarios/kappa0.yaml --resume           # continues a stopped run"),
    "analyze": (
        "ringsim analyze runs/kappa0.h5 --json eq.json --plots figs/kappa0"),
    "observe": (
        "ringsim observe runs/kappa0.h5 --elevation 3.45 20 --plots figs/observe\n"
        "                              # occultations at two opening angles B [deg]"),
    "compare": (
        "ringsim compare runs/kappa0.h5 runs/kappa0.1.h5 --plots figs/compare "
        "--json compare.json"),
    "sweep": (
        "ringsim sweep scenarios/sweep-kappa.yaml --workers 2 --plots figs/sweep"),
    "study": (
        "ringsim study studies/kappa-powerlaw/study.yaml --quick --report-only\n"
        "                              # the report again from the committed summaries"),
    "fit": (
        "ringsim fit docs/data/hatzes_like.csv --model all --plot fit.png"),
}


def add_examples(subparsers) -> None:
    """Give every subcommand parser of ``subparsers`` its example as the ``--help`` epilog
    (kept as written: one command a line)."""
    import argparse

    for name, command in subparsers.choices.items():
        command.epilog = epilog(name)
        command.formatter_class = argparse.RawDescriptionHelpFormatter


def epilog(command: str) -> str | None:
    """The ``--help`` epilog of ``command`` (its example), or None if it has none."""
    example = EXAMPLES.get(command)
    if example is None:
        return None
    return "example:\n" + "".join(f"  {line}\n" for line in example.splitlines())
