"""`ringsim sweep`: a grid of tiny runs, its summary, reuse and resume of run files, failures.

The sweep is a 40-particle sheet run for 0.05 orbit at 2 kappas x 2 seeds; it is run once per
module (``swept``) and copied where a test changes files.
"""

import csv
import hashlib
import os
import shutil
import sys
import types
from pathlib import Path

import h5py
import numpy as np
import pytest

import ringsim
from ringsim import sweep
from ringsim.analysis.equilibrium import equilibrium
from ringsim.cli import main
from ringsim.engine.runner import Runner
from ringsim.store import runfile, summary

SCENARIO = """\
name: tiny
seed: 1
planet: {Omega: 2.0e-4}
particles:
  density: 900.0
  size_distribution: {kind: powerlaw, q: 3.0, r_min: 1.0, r_max: 2.0}
sheet: {optical_depth: 0.25, n_particles: 40}
restitution: {model: dilley, xi0: 0.16, p: 0.65, kappa: 0.0}
integration: {orbits: 0.05}
output: {timeseries_every: 0.01, snapshot_every: 0.025, checkpoint_every: 0.03}
"""

SWEEP = """\
# a 2 x 2 grid over the tiny scenario
base: tiny.yaml
grid:
  restitution.kappa: [0.0, 0.1]
  seed: [1, 2]
"""

POINTS = [(0.0, 1), (0.0, 2), (0.1, 1), (0.1, 2)]  # grid order: the last key varies fastest
FILES = [f"restitution.kappa={k}_seed={s}.h5" for k, s in POINTS]


def write_sweep(directory: Path, scenario: str = SCENARIO, text: str = SWEEP) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "tiny.yaml").write_text(scenario)
    path = directory / "sweep.yaml"
    path.write_text(text)
    return path


def read_summary(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def timeseries_bytes(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        return {name: ds[...].tobytes() for name, ds in f["timeseries"].items()}


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The sweep run once with the command line from its directory (default output dir)."""
    root = tmp_path_factory.mktemp("sweep")
    sweep_file = write_sweep(root)
    cwd = Path.cwd()
    try:
        os.chdir(root)
        status = main(["sweep", "sweep.yaml", "--workers", "2"])
    finally:
        os.chdir(cwd)
    return {"root": root, "sweep_file": sweep_file, "out": root / "runs" / "sweep",
            "status": status}


def copy_of(swept, tmp_path) -> Path:
    out = tmp_path / "runs"
    shutil.copytree(swept["out"], out)
    return out


def test_sweep_writes_one_run_per_point_and_a_summary(swept):
    assert swept["status"] == 0, "every point finished"
    out = swept["out"]
    assert sorted(p.name for p in out.glob("*.h5")) == sorted(FILES + ["summary.h5"])
    rows = read_summary(out / "summary.csv")
    assert len(rows) == 4, "one summary row per grid point"
    for row, (kappa, seed), name in zip(rows, POINTS, FILES, strict=True):
        assert float(row["restitution.kappa"]) == kappa and int(row["seed"]) == seed
        assert row["run_file"] == name and row["status"] == "finished"
        run = ringsim.open_run(out / name)
        assert run.attrs["status"] == "finished"
        assert run.scenario.restitution.kappa == kappa and run.scenario.seed == seed, \
            "the run file was made with the point's parameters"
        assert run.timeseries["orbits"][-1] == pytest.approx(0.05, abs=0.011)
        eq = equilibrium(run)
        assert row["in_equilibrium"] == str(eq["in_equilibrium"]).lower()
        for key, stem, _unit in summary.EQUILIBRIUM_COLUMNS:
            for part in ("mean", "stderr"):
                got, want = float(row[f"{stem}_{part}"]), eq[key][part]
                assert got == want or (np.isnan(got) and np.isnan(want)), \
                    f"{name}: {stem}_{part} differs from compare.equilibrium"
    # the header names carry units
    assert {"velocity_dispersion_m_s_mean", "thickness_m_stderr",
            "collision_frequency_per_orbit_mean"} <= set(rows[0])


def test_grid_points_share_initial_conditions_only_through_their_seed(swept):
    """The initial state depends on the seed alone: same seed, other kappa -> identical."""
    first = {name: ringsim.open_run(swept["out"] / name).snapshot(0) for name in FILES}
    for field in ("x", "vz", "radius"):
        assert np.array_equal(first[FILES[0]][field], first[FILES[2]][field]), "seed 1"
        assert np.array_equal(first[FILES[1]][field], first[FILES[3]][field]), "seed 2"
        assert not np.array_equal(first[FILES[0]][field], first[FILES[1]][field])


def test_summary_h5_has_units_parameters_and_the_sweep_text(swept):
    rows = read_summary(swept["out"] / "summary.csv")
    with h5py.File(swept["out"] / "summary.h5", "r") as f:
        assert f.attrs["sweep_yaml"] == SWEEP
        assert "name: tiny" in f.attrs["base_scenario_yaml"]
        np.testing.assert_array_equal(f["parameters/restitution.kappa"][...], [0, 0, 0.1, 0.1])
        np.testing.assert_array_equal(f["parameters/seed"][...], [1, 2, 1, 2])
        assert f["parameters/restitution.kappa"].attrs["units"] == "dimensionless"
        assert f["velocity_dispersion_m_s_mean"].attrs["units"] == "m/s"
        assert f["thickness_m_mean"].attrs["units"] == "m"
        missing = []
        f.visititems(lambda name, obj: missing.append(name)
                     if isinstance(obj, h5py.Dataset) and "units" not in obj.attrs else None)
        assert not missing, f"datasets without units: {missing}"
        np.testing.assert_array_equal(
            f["velocity_dispersion_m_s_mean"][...],
            [float(r["velocity_dispersion_m_s_mean"]) for r in rows])
        assert [s.decode() for s in f["run_file"][...]] == FILES


def test_rerun_reuses_finished_files(swept, tmp_path):
    out = copy_of(swept, tmp_path)
    before = {name: (out / name).stat().st_mtime_ns for name in FILES}
    result = sweep.run_sweep(swept["sweep_file"], out=out, workers=2, echo=None)
    assert [r.action for r in result.results] == ["reuse"] * 4, "nothing was rerun"
    assert {name: (out / name).stat().st_mtime_ns for name in FILES} == before
    old, new = read_summary(swept["out"] / "summary.csv"), read_summary(out / "summary.csv")
    for a, b in zip(old, new, strict=True):
        assert b["action"] == "reuse"
        assert {k: v for k, v in a.items() if k not in ("action", "wall_time_s")} == \
            {k: v for k, v in b.items() if k not in ("action", "wall_time_s")}


def test_stopped_point_is_resumed_bit_exactly(swept, tmp_path):
    """A point left 'stopped' (or 'running' after a crash) continues from its checkpoint and
    ends with exactly the time series of the uninterrupted run."""
    out = copy_of(swept, tmp_path)
    name = FILES[3]
    reference = timeseries_bytes(out / name)
    # redo the point, stopping half-way (its last checkpoint then lies before the end)
    scenario = runfile.open_run(out / name).scenario
    (out / name).unlink()
    runner = Runner(scenario, out / name, progress=False)
    runner.start_new()
    runner.t_end = 2 * runner.ts_every  # an output time, as a real stop would be
    runner.loop()
    runfile.set_attributes(out / name, status="stopped")
    with h5py.File(out / name, "r") as f:
        rows = int(f["checkpoint"].attrs["rows"])
    assert rows < len(reference["t"]) // 8, "the checkpoint precedes the end"
    result = sweep.run_sweep(swept["sweep_file"], out=out, workers=1, echo=None)
    assert [r.action for r in result.results] == ["reuse", "reuse", "reuse", "resume"]
    assert result.results[3].status == "finished" and result.n_failed == 0
    assert timeseries_bytes(out / name) == reference, "resume is bit-exact"


def test_failed_point_is_reported_and_the_others_complete(swept, tmp_path, capsys):
    out = copy_of(swept, tmp_path)
    broken = out / FILES[1]
    with h5py.File(broken, "a") as f:  # a crashed run whose checkpoint is garbage
        f.attrs["status"] = "running"
        attrs = dict(f["checkpoint"].attrs)
        del f["checkpoint"]
        ds = f.create_dataset("checkpoint", data=np.frombuffer(b"garbage!" * 16, np.uint8))
        ds.attrs.update(attrs)
        # intact bytes that REBOUND cannot load (damaged bytes are refused at planning,
        # exit status 2: tests/test_hardening.py)
        ds.attrs["sha256"] = hashlib.sha256(b"garbage!" * 16).hexdigest()
    status = main(["sweep", str(swept["sweep_file"]), "--workers", "2", "--out", str(out)])
    assert status == 1, "a failed point makes the sweep fail"
    rows = read_summary(out / "summary.csv")
    assert [r["status"] for r in rows] == ["finished", "failed", "finished", "finished"]
    assert rows[1]["error"] and np.isnan(float(rows[1]["velocity_dispersion_m_s_mean"]))
    captured = capsys.readouterr()
    assert "[4/4]" in captured.out and FILES[1] in captured.err


def test_crash_before_the_first_checkpoint_reruns_the_point(swept, tmp_path):
    out = copy_of(swept, tmp_path)
    name = FILES[2]
    reference = timeseries_bytes(out / name)
    with h5py.File(out / name, "a") as f:
        f.attrs["status"] = "running"
        del f["checkpoint"]
    result = sweep.run_sweep(swept["sweep_file"], out=out, workers=1, echo=None)
    assert result.results[2].action == "restart" and result.results[2].status == "finished"
    assert timeseries_bytes(out / name) == reference, "the rerun is the same run"


def test_changed_base_scenario_refuses_to_touch_old_files(swept, tmp_path, capsys):
    out = copy_of(swept, tmp_path)
    sweep_file = write_sweep(tmp_path / "changed",
                             scenario=SCENARIO.replace("orbits: 0.05", "orbits: 0.06"))
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert main(["sweep", str(sweep_file), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and FILES[0] in err[0] and "integration.orbits" in err[0]
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_bad_grid_key_is_bad_input(tmp_path, capsys):
    sweep_file = write_sweep(tmp_path, text=SWEEP.replace("restitution.kappa", "restitution.kapa"))
    assert main(["sweep", str(sweep_file), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sweep.yaml" in err[0] and "restitution.kapa" in err[0]
    assert "Traceback" not in err[0]
    assert not (tmp_path / "out").exists(), "nothing written"


def test_repeated_grid_value_is_bad_input(tmp_path, capsys):
    sweep_file = write_sweep(tmp_path, text=SWEEP.replace("seed: [1, 2]", "seed: [1, 1]"))
    assert main(["sweep", str(sweep_file), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "grid" in err and "repeated" in err
    assert not (tmp_path / "out").exists()


def test_zero_workers_is_bad_input(tmp_path, capsys):
    sweep_file = write_sweep(tmp_path)
    assert main(["sweep", str(sweep_file), "--workers", "0", "--out", str(tmp_path / "o")]) == 2
    assert "--workers" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_scheduler_without_dask_is_bad_input(tmp_path, capsys, monkeypatch):
    sweep_file = write_sweep(tmp_path)
    for name in ("dask", "dask.distributed"):  # an import of None raises ImportError
        monkeypatch.setitem(sys.modules, name, None)
    status = main(["sweep", str(sweep_file), "--scheduler", "tcp://127.0.0.1:8786",
                   "--out", str(tmp_path / "out")])
    assert status == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler" in err[0] and "pip install ringsim[dask]" in err[0]
    assert not (tmp_path / "out").exists(), "nothing written"


def test_scheduler_path_maps_the_worker_function(swept, tmp_path, monkeypatch):
    """With --scheduler the points go through Client(address).map of `run_point`; a stand-in
    for dask.distributed that runs the tasks in this process checks that path."""
    calls = {}

    class Future:
        def __init__(self, fn, arg):
            self.fn, self.arg = fn, arg

        def result(self):
            return self.fn(self.arg)

    class Client:
        def __init__(self, address):
            calls["address"] = address

        def map(self, fn, items, pure=True):
            calls["fn"], calls["pure"], calls["n"] = fn, pure, len(items)
            return [Future(fn, item) for item in items]

        def close(self):
            calls["closed"] = True

    distributed = types.ModuleType("dask.distributed")
    distributed.Client = Client
    distributed.as_completed = lambda futures: iter(reversed(futures))
    dask = types.ModuleType("dask")
    dask.distributed = distributed
    monkeypatch.setitem(sys.modules, "dask", dask)
    monkeypatch.setitem(sys.modules, "dask.distributed", distributed)

    out = tmp_path / "dask-runs"
    result = sweep.run_sweep(swept["sweep_file"], out=out, scheduler="tcp://sched:8786",
                             echo=None)
    assert calls == {"address": "tcp://sched:8786", "fn": sweep.run_point, "pure": False,
                     "n": 4, "closed": True}
    assert [r.status for r in result.results] == ["finished"] * 4
    for name in FILES:  # the same runs as the local processes made
        assert timeseries_bytes(out / name) == timeseries_bytes(swept["out"] / name)


def test_point_file_names_are_safe_and_distinct():
    assert sweep.point_file_name({"restitution.kappa": 0.1, "seed": 2}) == \
        "restitution.kappa=0.1_seed=2.h5"
    assert sweep.point_file_name({"planet.Omega": 2e-4}) == "planet.Omega=0.0002.h5"
    odd = [{"name": "a/b"}, {"name": "a b"}, {"name": "a_b"}, {"name": "a-b"}]
    names = [sweep.point_file_name(p) for p in odd]
    assert len(set(names)) == 4, "lossy spellings get a hash"
    assert all("/" not in n and " " not in n for n in names)
    assert names[3] == "name=a-b.h5"
    long = sweep.point_file_name({"description": "x" * 400})
    assert len(long) < 200 and long.endswith(".h5")
    assert sweep.point_file_name({"seed": 1}) != sweep.point_file_name({"seed": 1.0})


def test_threads_option_reuses_the_points_and_refuses_a_bad_count(swept, tmp_path, capsys):
    """``--threads`` sets ``integration.threads`` of every point: finished points made on
    another thread count are reused (it changes no result); 0 threads is bad input, with one
    line naming ``--threads`` and nothing written."""
    out = copy_of(swept, tmp_path)
    result = sweep.run_sweep(swept["sweep_file"], out=out, workers=1, echo=None, threads=2)
    assert [r.action for r in result.results] == ["reuse"] * 4
    assert [t.scenario.integration.threads for t in sweep.plan_sweep(
        sweep.load_sweep(swept["sweep_file"]), out, threads=2)] == [2] * 4
    fresh = tmp_path / "never"
    assert main(["sweep", str(swept["sweep_file"]), "--threads", "0", "--out",
                 str(fresh)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--threads" in err[0]
    assert not fresh.exists()
