"""Every command of the tutorial and of the README runs, in order, at reduced size.

The shell blocks of ``docs/tutorial.md`` and ``README.md`` are parsed, not copied: a
command renamed or an option dropped in the program breaks this test until the text is
changed too.  The test-only reduction (``REDUCE``) is the one difference from what a user
runs: every scenario file the commands use (the bundled ``scenarios/`` copied into
``tmp_path``, and each file a ``cat > FILE <<'YAML'`` block writes) gets fewer particles and
orbits, and a study file's quick form likewise.  The installation and the checks of the
README's set-up lines (``pip``, ``ruff``, ``mypy``, ``sphinx-build``, ``pytest``) are what CI
runs (``tests/test_readme.py``) and are skipped here; any other program fails the test.

Numbers the tutorial states that do not come from a long run are checked against their
source: the number of figures ``analyze`` writes (counted), the damping factor
(M̄/60 g)^-κ (computed from the law's constants), and ε at 2 cm/s (read from the
``ringsim epsilon`` table the tutorial's own command prints).
"""

from __future__ import annotations

import contextlib
import glob
import io
import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from ringsim.cli import main

ROOT = Path(__file__).resolve().parents[1]

#: The test-only reduction of every scenario (upper bounds; a smaller value is kept).
REDUCE = {("sheet", "n_particles"): 100, ("integration", "orbits"): 2.0,
          ("output", "snapshot_every"): 0.5}
#: A study file's quick form, reduced.
REDUCE_QUICK = {"sheet.n_particles": 100, "length": {"orbits": 2}}
#: Programs of the set-up lines, run by CI and not by this test.
SKIPPED = {"python3", "pip", ".", "source", "ruff", "mypy", "sphinx-build", "pytest"}
NUMBER_WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6,
                "seven": 7, "eight": 8, "nine": 9, "ten": 10, "eleven": 11, "twelve": 12}


def shell_steps(markdown: str) -> list[tuple[str, ...]]:
    """The steps of a page's ``bash`` blocks in order: ("file", NAME, TEXT) for a
    ``cat > NAME <<'TAG'`` here-document and ("ringsim", ARG...) for a command."""
    steps: list[tuple[str, ...]] = []
    for block in re.findall(r"```bash\n(.*?)```", markdown, re.S):
        lines = iter(block.splitlines())
        for line in lines:
            heredoc = re.match(r"cat > (\S+) <<'(\w+)'$", line.strip())
            if heredoc:
                body = []
                for inner in lines:
                    if inner == heredoc.group(2):
                        break
                    body.append(inner + "\n")
                steps.append(("file", heredoc.group(1), "".join(body)))
                continue
            for part in line.split("&&"):
                words = shlex.split(part, comments=True)
                if not words or words[0] in SKIPPED:
                    continue
                assert words[0] == "ringsim", f"a command this test does not know: {part!r}"
                steps.append(tuple(words))
    return steps


def reduce_file(path: Path) -> None:
    """Apply the test-only reduction to a scenario or study file in place."""
    data = yaml.safe_load(path.read_text())
    if not isinstance(data, dict):
        return
    if "cases" in data:   # a study: its quick form
        data["quick"] = {**data.get("quick", {}), **REDUCE_QUICK}
    for (section, key), limit in REDUCE.items():
        if isinstance(data.get(section), dict) and key in data[section]:
            data[section][key] = min(data[section][key], limit)
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def run_steps(steps, workdir: Path) -> dict[str, str]:
    """Run the steps in ``workdir`` (the working directory); returns each command's stdout
    by its command line."""
    printed = {}
    for step in steps:
        if step[0] == "file":
            (workdir / step[1]).write_text(step[2])
            reduce_file(workdir / step[1])
            continue
        argv = []
        for word in step[1:]:
            argv += sorted(glob.glob(word, root_dir=workdir)) if "*" in word else [word]
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            status = main(argv)
        assert status == 0, f"{shlex.join(step)} exited {status}:\n{out.getvalue()[-2000:]}"
        printed[shlex.join(step)] = out.getvalue()
    return printed


@pytest.fixture
def workdir(tmp_path, monkeypatch) -> Path:
    """The repository's bundled inputs, copied and reduced (studies keep their size: their
    committed summaries are found by the hash of the full scenario, so nothing runs)."""
    shutil.copytree(ROOT / "scenarios", tmp_path / "scenarios")
    for path in (tmp_path / "scenarios").glob("*.yaml"):
        reduce_file(path)
    shutil.copytree(ROOT / "studies" / "kappa-powerlaw", tmp_path / "studies" / "kappa-powerlaw")
    full = tmp_path / "full-scenarios"
    shutil.copytree(ROOT / "scenarios", full)
    study = tmp_path / "studies" / "kappa-powerlaw" / "study.yaml"
    study.write_text(study.read_text().replace("../../scenarios/", "../../full-scenarios/"))
    shutil.copytree(ROOT / "docs" / "data", tmp_path / "docs" / "data")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_the_step_parser_sees_commands_and_files():
    page = ("```bash\npip install . && ringsim run a.yaml --force   # [2 s]\n"
            "cat > b.yaml <<'YAML'\nname: b\nYAML\n```\n")
    assert shell_steps(page) == [("ringsim", "run", "a.yaml", "--force"),
                                 ("file", "b.yaml", "name: b\n")]
    with pytest.raises(AssertionError, match="does not know"):
        shell_steps("```bash\nringsimm run a.yaml\n```\n")


def test_the_tutorial_runs_at_reduced_size(workdir):
    text = (ROOT / "docs" / "tutorial.md").read_text()
    printed = run_steps(shell_steps(text), workdir)

    # "writes N PNG figures into `DIR`": N counted
    word, folder = re.search(r"writes (\w+) PNG figures into\s+`([^`]+)`", text).groups()
    assert NUMBER_WORDS[word] == len(list((workdir / folder).glob("*.png")))
    # the damping factor (M/60 g)^-kappa of two identical ice spheres (reduced mass m/2)
    factors = re.search(r"factor ([\d.]+), ([\d.]+) and ([\d.]+) for R = 0.5, 1 and 5 m",
                        text.replace("\n", " "))
    kappa, density = 0.1, 900.0
    masses = 4.0 / 3.0 * np.pi * np.array([0.5, 1.0, 5.0]) ** 3 * density / 2.0
    expected = (masses / 0.06) ** -kappa
    np.testing.assert_allclose([float(f) for f in factors.groups()], expected, atol=0.005)
    # "at 2 cm/s, eps = A instead of B for R = 0.5 m": the last column of the two tables
    eps = re.search(r"at 2 cm/s, ε = ([\d.]+) instead of ([\d.]+) for R = 0.5 m",
                    text.replace("\n", " ")).groups()
    tables = [out for cmd, out in printed.items() if cmd.startswith("ringsim epsilon")]
    last = [float(out.splitlines()[2].split()[-1]) for out in tables]   # R = 0.5 m row
    assert [float(e) for e in eps] == pytest.approx([last[1], last[0]], abs=0.005)


def test_the_readme_commands_run_at_reduced_size(workdir):
    printed = run_steps(shell_steps((ROOT / "README.md").read_text()), workdir)
    assert (workdir / "runs" / "kappa0.h5").is_file()
    # the speed units docs/figures.md says each command's table prints
    figures = (ROOT / "docs" / "figures.md").read_text().replace("\n", " ")
    stated = re.search(r"`analyze` and `compare` in (\S+), `epsilon` in (\S+) .*?`fit` in "
                       r"(\S+) ", figures).groups()
    for command, unit in zip(("analyze", "epsilon", "fit"), stated, strict=True):
        (out,) = [out for cmd, out in printed.items()
                  if cmd.startswith(f"ringsim {command}") and "--restitution" not in cmd]
        assert re.search(rf"[\[ ]{re.escape(unit)}\b", out), (command, unit)


def test_the_million_run_is_quoted_as_measured():
    """The README and docs/scenario.md quote the measurement of scenarios/million.yaml in
    docs/performance.md (its one source): wall minutes, CPU-minutes, memory, file size."""
    perf = (ROOT / "docs" / "performance.md").read_text().replace("\n", " ")
    measured = re.search(r"\*\*(\d+) min (\d+) s wall, .*?\(([\d.]+) CPU-minutes.*?peak "
                         r"resident set (\d+) MB.*?is (\d+) MB\.", perf)
    assert measured, "docs/performance.md's million.yaml measurement"
    minutes, seconds, cpu, rss, size = measured.groups()
    wall = round(int(minutes) + int(seconds) / 60)
    readme = (ROOT / "README.md").read_text()
    assert f"one orbit in {wall} minutes of wall time ({cpu} CPU-minutes, " in readme
    assert f"{round(int(rss), -1)} MB of memory" in readme and f"one {size} MB run file" in readme
    scenario = (ROOT / "docs" / "scenario.md").read_text()
    assert f"in {wall} minutes of wall time ({cpu} CPU-minutes;" in scenario
