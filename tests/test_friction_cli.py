"""Bad friction input on the command line: exit status 2, one line on stderr naming the
file and the key (docs/interface.md), no traceback, no run file written."""

from __future__ import annotations

import subprocess
import sys
import tempfile

import pytest

SCENARIO = """\
name: rough
seed: 1
planet: {{Omega: 2.0e-4}}
particles: {{{inertia}size_distribution: {{kind: monodisperse, radius: 1.0}}}}
sheet: {{n_particles: 60, optical_depth: 0.2}}
restitution: {{model: constant, epsilon: 0.5}}
integration: {{orbits: 0.1, collision_detection: line}}
output: {{timeseries_every: 0.05, snapshot_every: 0.1}}
{friction}
"""


@pytest.mark.parametrize("inertia, friction, key", [
    ("", "friction: {model: sticky}", "friction.model"),
    ("", "friction: {model: constant, beta: 1.5}", "friction.beta"),
    ("", "friction: {model: coulomb, mu: -1}", "friction.mu"),
    ("inertia_factor: 0.4, ", "", "particles.inertia_factor"),
], ids=["unknown-model", "beta-1.5", "mu-minus-1", "inertia-without-friction"])
def test_bad_friction_input_exits_2_with_one_line(tmp_path, inertia, friction, key):
    scenario = tmp_path / "rough.yaml"
    scenario.write_text(SCENARIO.format(inertia=inertia, friction=friction))
    out = tmp_path / "rough.h5"
    proc = subprocess.run([sys.executable, "-m", "ringsim.cli", "run", str(scenario), "-o",
                           str(out)], capture_output=True, text=True, timeout=300,
                          cwd=tempfile.gettempdir())
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("ringsim: error: ") and str(scenario) in lines[0]
    assert f": {key}: " in lines[0], lines[0]
    assert "Traceback" not in proc.stderr
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["rough.yaml"]


def test_the_same_scenario_with_good_friction_runs(tmp_path):
    """The harness can pass: a valid friction section gives exit 0 and a run file."""
    scenario = tmp_path / "rough.yaml"
    scenario.write_text(SCENARIO.format(inertia="inertia_factor: 0.35, ",
                                        friction="friction: {model: coulomb, mu: 0.5}"))
    out = tmp_path / "rough.h5"
    proc = subprocess.run([sys.executable, "-m", "ringsim.cli", "run", str(scenario), "-o",
                           str(out), "--no-progress"], capture_output=True, text=True,
                          timeout=300, cwd=tempfile.gettempdir())
    assert proc.returncode == 0, proc.stderr
    assert out.exists()


def test_resume_refuses_spins_written_before_the_precession(tmp_path):
    """A checkpoint whose spins have no ``frame`` attribute holds rotating-frame spins of
    the checkpoint time (ringsim before the precession was followed): resuming it would
    turn them by Omega t, so it is refused as bad input, the file unchanged."""
    import h5py

    from ringsim.store import runfile

    scenario = tmp_path / "rough.yaml"
    scenario.write_text(SCENARIO.format(inertia="", friction="friction: {model: constant, "
                                        "beta: 0.0}"))
    out = tmp_path / "rough.h5"

    def cli(*args):
        return subprocess.run([sys.executable, "-m", "ringsim.cli", *args], capture_output=True,
                              text=True, timeout=300, cwd=tempfile.gettempdir())

    assert cli("run", str(scenario), "-o", str(out), "--no-progress").returncode == 0
    with h5py.File(out, "r+") as f:
        del f[runfile.CHECKPOINT_SPINS].attrs["frame"]
    before = out.read_bytes()
    scenario.write_text(scenario.read_text().replace("orbits: 0.1", "orbits: 0.2"))
    proc = cli("run", str(scenario), "-o", str(out), "--resume", "--no-progress")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"/{runfile.CHECKPOINT_SPINS}" in lines[0], proc.stderr
    assert out.read_bytes() == before
