"""`ringsim run`: reproducibility, bit-exact resume, guards, bad input and the bundled scenarios."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

import ringsim
from ringsim.cli import main
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.testing import run_file_datasets

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def test_same_scenario_twice_gives_identical_files(tmp_path, small_scenario):
    sc = small_scenario()
    a = ringsim.run(sc, output=tmp_path / "a.h5", progress=False)
    b = ringsim.run(sc, output=tmp_path / "b.h5", progress=False)
    da, db = run_file_datasets(a), run_file_datasets(b)
    assert da.keys() == db.keys()
    for name in da:
        assert da[name] == db[name], f"dataset {name} differs between identical runs"
    run = ringsim.open_run(a)
    assert run.timeseries["collisions"].sum() > 0, "collisions happened"
    assert run.n_snapshots == 4  # t = 0, 0.2, 0.4, 0.6 orbits
    with h5py.File(a, "r") as f:
        assert f.attrs["units"] == "SI" and f.attrs["seed"] == 7
        assert "name: small" in f.attrs["scenario_yaml"]
        for name, ds in f["timeseries"].items():
            assert "units" in ds.attrs, f"/timeseries/{name} has no units"
        for field in ("x", "vx", "radius", "mass"):
            assert f["snapshots/000000"][field].attrs["units"] in ("m", "m/s", "kg")


def test_different_seed_gives_different_run(tmp_path, small_scenario):
    a = ringsim.run(small_scenario(**{"integration.orbits": 0.1}), output=tmp_path / "a.h5",
                    progress=False)
    b = ringsim.run(small_scenario(**{"integration.orbits": 0.1, "seed": 8}),
                    output=tmp_path / "b.h5", progress=False)
    assert ringsim.open_run(a).snapshot(-1)["x"].tobytes() != \
        ringsim.open_run(b).snapshot(-1)["x"].tobytes()


def test_sigkill_then_resume_is_bit_identical(tmp_path, small_scenario):
    sc = small_scenario(**{"integration.orbits": 1.2, "output.snapshot_every": 0.2,
                           "sheet.n_particles": 300})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    reference = ringsim.run(load_scenario(scenario_file), output=tmp_path / "ref.h5",
                            progress=False)

    killed = tmp_path / "killed.h5"
    env = dict(os.environ, HDF5_USE_FILE_LOCKING="FALSE")
    proc = subprocess.Popen([sys.executable, "-m", "ringsim.cli", "run", str(scenario_file),
                             "-o", str(killed), "--no-progress"], env=env, cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.time() + 120
    checkpoint_rows = 0
    while time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
        try:
            with h5py.File(killed, "r", locking=False) as f:
                if "checkpoint" in f:
                    checkpoint_rows = int(f["checkpoint"].attrs["rows"])
        except (OSError, KeyError):
            continue
        if checkpoint_rows >= 6:  # past the 0.2-orbit checkpoint, before the end
            break
    assert proc.poll() is None, f"the run ended before it could be killed: {proc.stderr.read()}"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert 6 <= checkpoint_rows < 24

    assert main(["run", str(scenario_file), "-o", str(killed), "--resume",
                 "--no-progress"]) == 0
    ref, res = ringsim.open_run(reference), ringsim.open_run(killed)
    assert res.n_snapshots == ref.n_snapshots
    for i in range(ref.n_snapshots):
        a, b = ref.snapshot(i), res.snapshot(i)
        for field in ("x", "y", "z", "vx", "vy", "vz"):
            assert np.array_equal(a[field], b[field]), f"snapshot {i} {field} differs"
    for name, series in ref.timeseries.items():
        assert np.array_equal(series, res.timeseries[name], equal_nan=True), name


def test_hot_ring_never_wraps_in_z(tmp_path, small_scenario):
    """Nearly elastic collisions heat the ring; the vertical guard must enlarge the box."""
    sc = small_scenario(**{"restitution": {"model": "constant", "epsilon": 0.95},
                           "sheet.initial_dispersion": 20.0, "sheet.z_box": 30.0,
                           "integration.orbits": 1.0, "sheet.n_particles": 200})
    path = ringsim.run(sc, output=tmp_path / "hot.h5", progress=False)
    run = ringsim.open_run(path)
    ts = run.timeseries
    assert any("vertical guard" in m for _, m in run.guard_events), "the guard acted"
    assert ts["z_half_period"][-1] > ts["z_half_period"][0], "the box was enlarged"
    # at every output every particle's vertical amplitude was inside the (old) box
    assert np.all(ts["max_vertical_amplitude"] < ts["z_half_period"]), "no particle wrapped"
    for i in range(run.n_snapshots):
        z = run.snapshot(i)["z"]
        assert np.all(np.abs(z) < 0.5 * ts["z_half_period"].max())


def test_fixed_dt_violation_is_reported(tmp_path, small_scenario):
    sc = small_scenario(**{"integration.dt": 1.0e-3, "sheet.initial_dispersion": 50.0,
                           "integration.orbits": 0.1})
    run = ringsim.open_run(ringsim.run(sc, output=tmp_path / "w.h5", progress=False))
    assert any("WARNING: fixed dt" in m for _, m in run.guard_events)


def test_refuses_to_overwrite_without_force(tmp_path, capsys, small_scenario):
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(small_scenario(**{"integration.orbits": 0.05}).to_yaml())
    out = tmp_path / "out.h5"
    out.write_bytes(b"precious")
    assert main(["run", str(scenario_file), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0] and "--force" in err[0]
    assert out.read_bytes() == b"precious"
    # --force replaces only a ringsim run file, never these bytes
    assert main(["run", str(scenario_file), "-o", str(out), "--no-progress", "--force"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a ringsim run file" in err[0]
    assert out.read_bytes() == b"precious"
    run_file = tmp_path / "run.h5"
    assert main(["run", str(scenario_file), "-o", str(run_file), "--no-progress"]) == 0
    assert main(["run", str(scenario_file), "-o", str(run_file), "--no-progress",
                 "--force"]) == 0
    assert h5py.is_hdf5(run_file)


@pytest.fixture
def text(request, small_scenario):
    """The parameter if it is text, else YAML text of the small scenario with one thing
    broken by the parameter, a ``mutate(dict)``."""
    if isinstance(request.param, str):
        return request.param
    d = small_scenario().to_dict()
    request.param(d)
    return yaml.safe_dump(d)


@pytest.mark.parametrize("text, key", [
    (lambda d: d.pop("name"), "name"),
    (lambda d: d.update(colour="red"), "colour"),
    (lambda d: d["particles"].update(size_distribution={"kind": "monodisperse",
                                                        "radius": -1.0}),
     "particles.size_distribution.radius"),
    (lambda d: d["particles"]["size_distribution"].update(r_min=5.0, r_max=1.0),
     "particles.size_distribution.r_m"),
    (lambda d: d["sheet"].update(optical_depth=0.0), "sheet.optical_depth"),
    (lambda d: d["restitution"].update(kappa="abc"), "restitution.kappa"),
    ("name: x\nseed: [1\n", "<yaml>"),
], ids=["missing-name", "unknown-key", "negative-radius", "rmin>rmax", "tau=0",
        "kappa-not-number", "bad-yaml"], indirect=["text"])
def test_bad_scenarios_exit_2_with_one_line(tmp_path, capsys, text, key):
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    out = tmp_path / "never.h5"
    assert main(["run", str(bad), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and key in lines[0], lines
    assert not out.exists(), "no output file for bad input"


def test_missing_scenario_file_exits_2(tmp_path, capsys):
    assert main(["run", str(tmp_path / "nope.yaml"), "--no-progress"]) == 2
    assert "nope.yaml" in capsys.readouterr().err


@pytest.mark.parametrize("scenario_file", sorted(SCENARIOS.glob("*.yaml")),
                         ids=lambda p: p.name)
def test_bundled_scenarios_smoke(tmp_path, scenario_file):
    """Every bundled scenario runs at tiny size (60 particles, or the fewest of 120-960 its
    box accepts (P3M's cutoff, the largest particle), 0.05 orbit).  A preset with a
    reduced twin (``NAME-small.yaml``: the Saturn rings, whose 10 m particles need a box of
    hundreds of particles) is run through its twin here; tests/test_bundled_scenarios.py
    validates the preset against the twin and runs it briefly (slow)."""
    if scenario_file.with_name(scenario_file.stem + "-small.yaml").exists():
        pytest.skip(f"runs as its reduced twin {scenario_file.stem}-small.yaml")
    try:
        sc = load_scenario(scenario_file)
    except ringsim.ScenarioError:
        pytest.skip("not a scenario (a sweep file)")
    for n in (60, 120, 240, 480, 960):
        try:
            tiny = with_overrides(sc, {"sheet.n_particles": n, "integration.orbits": 0.05,
                                       "output.timeseries_every": 0.025,
                                       "output.snapshot_every": 0.05})
            break
        except ringsim.ScenarioError:
            if n == 960:
                raise
    run = ringsim.open_run(ringsim.run(tiny, output=tmp_path / "t.h5", progress=False))
    assert run.n_snapshots == 2
    assert np.all(np.isfinite(run.timeseries["velocity_dispersion"]))


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupt_stops_cleanly_and_resumes(tmp_path, sig, small_scenario):
    """Ctrl-C (or SIGTERM) stops with a checkpoint; --resume ends on the same states."""
    sc = small_scenario(**{"integration.orbits": 1.0, "sheet.n_particles": 300})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    reference = ringsim.run(load_scenario(scenario_file), output=tmp_path / "ref.h5",
                            progress=False)
    out = tmp_path / "int.h5"
    proc = subprocess.Popen([sys.executable, "-m", "ringsim.cli", "run", str(scenario_file),
                             "-o", str(out), "--no-progress"],
                            env=dict(os.environ, HDF5_USE_FILE_LOCKING="FALSE"), cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
        try:
            with h5py.File(out, "r", locking=False) as f:
                if "checkpoint" in f and int(f["checkpoint"].attrs["rows"]) >= 1 \
                        and f["timeseries/t"].shape[0] >= 4:
                    break
        except (OSError, KeyError):
            continue
    assert proc.poll() is None, "the run finished before it could be interrupted"
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr  # CONTRACT: 130 interrupted
    assert "--resume" in stdout and "Traceback" not in stderr
    stopped = ringsim.open_run(out)
    assert stopped.attrs["status"] == "stopped"
    assert stopped.timeseries["orbits"][-1] < 1.0
    assert main(["run", str(scenario_file), "-o", str(out), "--resume", "--no-progress"]) == 0
    ref, res = ringsim.open_run(reference), ringsim.open_run(out)
    assert res.attrs["status"] == "finished"
    for field in ("x", "y", "z", "vx", "vy", "vz"):
        assert np.array_equal(ref.snapshot(-1)[field], res.snapshot(-1)[field]), field
    for name in ("t", "velocity_dispersion", "thickness", "collisions_log_n"):
        assert np.array_equal(ref.timeseries[name], res.timeseries[name]), name


def test_extending_a_finished_run_equals_a_longer_run(tmp_path, small_scenario):
    """--resume with a larger integration.orbits continues a finished run bit-exactly."""
    short = small_scenario(**{"integration.orbits": 0.4})
    long = small_scenario(**{"integration.orbits": 0.8})
    direct = ringsim.open_run(ringsim.run(long, output=tmp_path / "direct.h5", progress=False))
    path = ringsim.run(short, output=tmp_path / "ext.h5", progress=False)
    ringsim.run(long, output=path, resume=True, progress=False)
    extended = ringsim.open_run(path)
    assert extended.scenario == long and extended.attrs["status"] == "finished"
    assert any("extended from 0.4 to 0.8 orbits" in m for _, m in extended.guard_events)
    for field in ("x", "y", "z", "vx", "vy", "vz"):
        assert np.array_equal(direct.snapshot(-1)[field], extended.snapshot(-1)[field])
    for name, series in direct.timeseries.items():
        assert np.array_equal(series, extended.timeseries[name], equal_nan=True), name
    with pytest.raises(ringsim.InputError, match="integration.orbits"):
        ringsim.run(short, output=path, resume=True, progress=False)
    other = small_scenario(**{"integration.orbits": 0.8, "restitution.kappa": 0.0})
    with pytest.raises(ringsim.InputError, match="only integration.orbits may grow"):
        ringsim.run(other, output=path, resume=True, progress=False)


def test_cpu_time_adds_up_over_a_runs_sessions(tmp_path, small_scenario):
    """`cpu_time_s` (a root attribute) is the run's CPU time over all its sessions: a
    lengthened run's is its first session's plus what the second spent, which is within
    the CPU time the process spent on the call that lengthened it."""
    import time

    short = small_scenario(**{"integration.orbits": 0.4})
    long = small_scenario(**{"integration.orbits": 0.8})
    cpu0 = time.process_time()
    path = ringsim.run(short, output=tmp_path / "ext.h5", progress=False)
    first_call = time.process_time() - cpu0
    first = float(ringsim.open_run(path).attrs["cpu_time_s"])
    assert 0.0 < first <= first_call
    cpu0 = time.process_time()
    ringsim.run(long, output=path, resume=True, progress=False)
    second_call = time.process_time() - cpu0
    total = float(ringsim.open_run(path).attrs["cpu_time_s"])
    assert first < total <= first + second_call


def test_until_equilibrium_stops_when_stationary_and_says_why(tmp_path, line_scenario):
    """A cold dense ring settles within an orbit or two: with until_equilibrium the run stops
    long before its maximum, at an output where analyze calls it stationary; without it,
    it runs to the end.  Both files say why they stopped."""
    base = line_scenario(name="settle", seed=2, **{
        "sheet.optical_depth": 0.8, "sheet.n_particles": 150, "integration.orbits": 60.0,
        "integration.until_equilibrium": True, "output.snapshot_every": 5.0})
    path = ringsim.run(base, output=tmp_path / "settle.h5", progress=False)
    run = ringsim.open_run(path)
    assert run.attrs["status"] == "finished"
    assert run.attrs["stop_reason"].startswith("until_equilibrium: c and H stationary")
    orbits = run.timeseries["orbits"]
    assert orbits[-1] < 30.0, "stopped well before the maximum"
    assert ringsim.equilibrium(run)["in_equilibrium"], "analyze agrees"
    assert (orbits.size - 1) % 10 == 0, "decided at a check output"
    ringsim.run(base, output=path, resume=True, progress=False)
    assert ringsim.open_run(path).timeseries["orbits"].size == orbits.size, \
        "resuming a run that reached equilibrium stops at once, at the same output"
    short = with_overrides(base, {"integration.orbits": 1.0,
                                  "integration.until_equilibrium": False})
    path = ringsim.run(short, output=tmp_path / "plain.h5", progress=False)
    assert ringsim.open_run(path).attrs["stop_reason"] == "reached integration.orbits = 1"
