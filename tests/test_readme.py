"""The README's Python example runs as printed, from the repository root.

The example is read out of README.md (its one ``python`` block), so the test follows the
text a user copies.  It runs in a fresh interpreter whose working directory is the
repository root, where a source folder named ``ringsim`` would shadow the installed package
(the src layout prevents that); only the output path is moved into ``tmp_path``.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def readme_python_block() -> str:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert len(blocks) == 1, "the README has one Python example"
    return blocks[0]


def test_readme_python_example_runs_from_the_repository_root(tmp_path):
    code = readme_python_block()
    assert '"runs/quick.h5"' in code, "the example's output path, which the test moves"
    output = tmp_path / "quick.h5"
    code = code.replace('"runs/quick.h5"', repr(str(output)))
    code += "\nimport json\nprint(json.dumps({'in_equilibrium': eq['in_equilibrium'], " \
            "'units': eq['velocity_dispersion']['units']}))\n"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["units"] == "m/s"
    assert output.is_file()


def test_ci_runs_the_readmes_test_command():
    """The README's second set-up command (install, checks, API reference, tests) is the
    command .ci/run runs from a clean clone, letter for letter."""
    commands = re.findall(r"```bash\n(.*?)\n```", (ROOT / "README.md").read_text(), re.S)
    setup = [c for c in commands if c.startswith("python3 -m venv")]
    assert len(setup) == 2, "the README has exactly two set-up commands"
    assert "pytest" in setup[1] and "mypy" in setup[1] and "sphinx-build" in setup[1]
    assert f"bash -c '{setup[1]}'" in (ROOT / ".ci" / "run").read_text()
