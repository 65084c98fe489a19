"""Every subcommand's ``--help`` ends in an example, and the example is a valid command.

The examples are parsed by the real parser, so an option renamed or removed breaks this
test; the files an example reads are checked to exist in the repository (or to be written
by an example before it).
"""

from __future__ import annotations

import contextlib
import io
import shlex
from pathlib import Path

import pytest

from ringsim.cli import build_parser, main
from ringsim.cli_examples import EXAMPLES
from ringsim.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


def _subcommands() -> dict:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.dest == "command"]
    return dict(sub.choices)


def _example_commands(text: str) -> list[list[str]]:
    """The ``ringsim ...`` commands of an example, without comments."""
    return [shlex.split(line, comments=True) for line in text.splitlines()
            if line.strip().startswith("ringsim ")]


@pytest.mark.parametrize("name", sorted(_subcommands()))
def test_every_subcommand_help_ends_in_an_example(name):
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as done:
        main([name, "--help"])
    assert done.value.code == 0
    help_text = out.getvalue()
    assert "example:" in help_text, f"ringsim {name} --help has no example"
    commands = _example_commands(help_text.split("example:", 1)[1])
    assert commands and all(c[1] == name for c in commands), help_text


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_examples_parse_and_name_existing_files(name):
    parser = build_parser()
    written = {"runs/kappa0.h5", "runs/kappa0.1.h5"}   # by the run example, from the scenarios
    for argv in _example_commands(EXAMPLES[name]):
        args = parser.parse_args(argv[1:])
        for key in ("scenario", "sweep", "study", "data", "run"):
            value = getattr(args, key, None)
            if value is not None:
                assert (ROOT / value).is_file() or value in written, (name, value)
        for value in getattr(args, "runs", None) or []:
            assert value in written, (name, value)


def test_an_example_with_a_renamed_option_fails_to_parse():
    (argv,) = _example_commands("example:\n  ringsim run x.yaml --workers 2  # not of run\n")
    assert argv == ["ringsim", "run", "x.yaml", "--workers", "2"]
    with pytest.raises(InputError):
        build_parser().parse_args(argv[1:])
