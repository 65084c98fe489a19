"""The one runner of the validation, from the repository root::

    python -m validation ladder [--quick] [--cases N ...] [--report-only]
    python -m validation cooling [--quick]

Each command is the ``main`` of one module of this folder; ``python -m validation COMMAND
--help`` lists its options.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

#: Command -> (module of this folder whose ``main(argv)`` runs it, what it writes).
COMMANDS = {
    "ladder": ("ladder", "the reference case 5 (REBOUND's example): section 'Reference "
               "cases' of docs/validation.md"),
    "cooling": ("cooling", "the homogeneous cooling of rough spheres: the table and figure of "
                "docs/friction.md"),
}


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command with the rest of the arguments; its exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m validation", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="The validation of ringsim against published ring physics (run from "
        "the repository root).",
        epilog="commands:\n" + "\n".join(f"  {name}: {what}"
                                          for name, (_, what) in COMMANDS.items()))
    parser.add_argument("command", choices=list(COMMANDS))
    parser.add_argument("arguments", nargs=argparse.REMAINDER,
                        help="the command's own arguments (COMMAND --help lists them)")
    args = parser.parse_args(argv)
    module = importlib.import_module(f"validation.{COMMANDS[args.command][0]}")
    return module.main(args.arguments, prog=f"python -m validation {args.command}") or 0


if __name__ == "__main__":
    sys.exit(main())
