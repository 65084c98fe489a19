"""Hardening: damaged run files, format versions, one writer per file, runtime invariants.

``tests/data/format_1_0.h5`` is a run file of format 1.0 (no ``format_version``), made by
ringsim at commit ed9d680 (60 particles, 0.4 orbit, scenario embedded in the file) and
repacked with gzip to stay small; every reader must keep opening it.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.config.scenario import with_overrides
from ringsim.engine import invariants
from ringsim.engine.runner import Runner
from ringsim.store import runfile
from ringsim.store.lock import RunFileLock, lock_path, writer_of
from ringsim.testing import assert_same_datasets

DATA = Path(__file__).resolve().parent / "data"
FORMAT_1_0 = DATA / "format_1_0.h5"


#: The hardening tests' variant of the ring: 60 particles of 1-2 m, Dilley kappa = 0.1,
#: 0.2 orbit.
TINY = {"name": "tiny", "seed": 11, "particles.size_distribution.r_max": 2.0,
        "sheet.n_particles": 60, "restitution.kappa": 0.1, "integration.orbits": 0.2}


@pytest.fixture(scope="module")
def tiny_scenario(ring_scenario):
    """Factory: the `TINY` ring with dotted overrides, ``tiny_scenario(**{key: value})``."""
    return lambda **overrides: ring_scenario(TINY, overrides)


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def good_run(tmp_path_factory, tiny_scenario):
    """A finished tiny run and the scenario file that made it."""
    folder = tmp_path_factory.mktemp("good")
    sc = tiny_scenario()
    scenario_file = folder / "tiny.yaml"
    scenario_file.write_text(sc.to_yaml())
    path = ringsim.run(sc, output=folder / "good.h5", progress=False)
    return {"path": path, "scenario_file": scenario_file, "scenario": sc}


# --- damaged files ------------------------------------------------------------------------------

def _truncated(src, dst):
    data = src.read_bytes()
    dst.write_bytes(data[: len(data) // 2])


def _empty(src, dst):
    dst.write_bytes(b"")


def _random_bytes(src, dst):
    dst.write_bytes(np.random.default_rng(1).bytes(4096))


def _text(src, dst):
    dst.write_text("name: not a run file\nseed: 1\n")


def _edit(change):
    def make(src, dst):
        shutil.copyfile(src, dst)
        with h5py.File(dst, "a") as f:
            change(f)
    return make


def _flip_checkpoint_byte(f):
    ds = f["checkpoint"]
    ds[100] = (int(ds[100]) + 1) % 256


def _garbage_checkpoint_with_matching_digest(f):
    ds = f["checkpoint"]
    garbage = np.frombuffer(b"not REBOUND" * 20, np.uint8)
    ds.resize(garbage.size, axis=0)
    ds[...] = garbage
    ds.attrs["sha256"] = hashlib.sha256(garbage.tobytes()).hexdigest()


DAMAGE = {
    # name: (how to make it, what the one line must say)
    "truncated": (_truncated, "truncated or damaged"),
    "empty": (_empty, "empty"),
    "random-bytes": (_random_bytes, "not an HDF5 file"),
    "text": (_text, "not an HDF5 file"),
    "no-timeseries": (_edit(lambda f: f.__delitem__("timeseries")), "/timeseries"),
    "no-t": (_edit(lambda f: f.__delitem__("timeseries/t")), "/timeseries/t"),
    "no-guards": (_edit(lambda f: f.__delitem__("guards")), "/guards"),
    "no-snapshot-field": (_edit(lambda f: f.__delitem__("snapshots/000001/vx")),
                          "/snapshots/000001/vx"),
    "no-scenario": (_edit(lambda f: f.attrs.__delitem__("scenario_yaml")), "scenario_yaml"),
    "short-series": (_edit(lambda f: f["timeseries/thickness"].resize(3, axis=0)),
                     "/timeseries/thickness"),
    "newer-format": (_edit(lambda f: f.attrs.__setitem__("format_version", "2.0")),
                     "format 2.0"),
}
# damage only --resume (and a sweep resuming the point) can see
CHECKPOINT_DAMAGE = {
    "checkpoint-bytes": (_edit(_flip_checkpoint_byte), "SHA-256"),
    "checkpoint-incomplete": (_edit(lambda f: f["checkpoint"].attrs.__delitem__("rows")),
                              "/checkpoint"),
    "checkpoint-does-not-load": (_edit(_garbage_checkpoint_with_matching_digest),
                                 "does not load"),
}


def _expect_bad_input(capsys, status, path, words):
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert status == 2, captured.err
    assert "Traceback" not in captured.err + captured.out
    assert len(lines) == 1 and str(path) in lines[0] and words in lines[0], lines


@pytest.mark.parametrize("damage", list(DAMAGE), ids=list(DAMAGE))
@pytest.mark.parametrize("command", ["analyze", "compare", "resume"])
def test_damaged_run_file_exits_2_and_is_not_changed(good_run, tmp_path, capsys, damage,
                                                     command):
    make, words = DAMAGE[damage]
    bad = tmp_path / "bad.h5"
    make(good_run["path"], bad)
    before = sha256(bad)
    if command == "analyze":
        status = main(["analyze", str(bad), "--json", str(tmp_path / "eq.json")])
    elif command == "compare":
        status = main(["compare", str(good_run["path"]), str(bad), "--json",
                       str(tmp_path / "eq.json")])
    else:
        status = main(["run", str(good_run["scenario_file"]), "-o", str(bad), "--resume",
                       "--no-progress"])
    _expect_bad_input(capsys, status, bad, words)
    assert sha256(bad) == before, "the damaged file was changed"
    assert not (tmp_path / "eq.json").exists(), "no output for bad input"
    assert not lock_path(bad).exists() and not Path(f"{bad}.tmp").exists()


@pytest.mark.parametrize("damage", list(CHECKPOINT_DAMAGE), ids=list(CHECKPOINT_DAMAGE))
def test_damaged_checkpoint_refuses_resume(good_run, tmp_path, capsys, damage):
    make, words = CHECKPOINT_DAMAGE[damage]
    bad = tmp_path / "bad.h5"
    make(good_run["path"], bad)
    before = sha256(bad)
    status = main(["run", str(good_run["scenario_file"]), "-o", str(bad), "--resume",
                   "--no-progress"])
    _expect_bad_input(capsys, status, bad, words)
    assert sha256(bad) == before


@pytest.fixture(scope="module")
def sweep_files(tmp_path_factory, good_run):
    """A one-point sweep whose point file is the good run (seed 11)."""
    folder = tmp_path_factory.mktemp("sweep")
    shutil.copyfile(good_run["scenario_file"], folder / "base.yaml")
    (folder / "sweep.yaml").write_text("base: base.yaml\ngrid:\n  seed: [11]\n")
    return folder


@pytest.mark.parametrize("damage", ["truncated", "empty", "text", "no-t", "newer-format",
                                    "checkpoint-bytes", "checkpoint-incomplete"])
def test_sweep_on_a_damaged_point_file_exits_2(good_run, sweep_files, tmp_path, capsys,
                                               damage):
    make, words = {**DAMAGE, **CHECKPOINT_DAMAGE}[damage]
    out = tmp_path / "out"
    out.mkdir()
    point = out / "seed=11.h5"
    make(good_run["path"], point)
    if damage.startswith("checkpoint"):   # a crashed run: the sweep would resume it
        with h5py.File(point, "a") as f:
            f.attrs["status"] = "running"
    before = sha256(point)
    status = main(["sweep", str(sweep_files / "sweep.yaml"), "--workers", "1", "--out",
                   str(out)])
    _expect_bad_input(capsys, status, point, words)
    assert sha256(point) == before
    assert sorted(p.name for p in out.iterdir()) == ["seed=11.h5"], "nothing written"


# --- format versions ----------------------------------------------------------------------------

def test_new_files_carry_the_format_version(good_run):
    with h5py.File(good_run["path"], "r") as f:
        assert f.attrs["format_version"] == runfile.FORMAT_VERSION == "1.2"
        assert f["checkpoint"].attrs["sha256"] == hashlib.sha256(
            f["checkpoint"][...].tobytes()).hexdigest()
        assert runfile.CHECKPOINT_STATISTICS in f
    assert ringsim.open_run(good_run["path"]).format_version == "1.2"


def test_format_1_0_file_still_opens(tmp_path, capsys):
    run = ringsim.open_run(FORMAT_1_0)
    assert run.format_version == "1.0" and run.attrs["status"] == "finished"
    assert run.n_snapshots == 3 and run.timeseries["t"].size == 21
    assert main(["analyze", str(FORMAT_1_0), "--json", str(tmp_path / "eq.json")]) == 0
    eq = json.loads((tmp_path / "eq.json").read_text())
    assert eq["name"] == "format_1_0" and eq["velocity_dispersion"]["mean"] > 0


def test_format_1_0_file_can_be_extended(tmp_path):
    """--resume continues a 1.0 file; the new time series gets NaN for the old rows."""
    path = tmp_path / "old.h5"
    shutil.copyfile(FORMAT_1_0, path)
    sc = with_overrides(ringsim.open_run(path).scenario, {"integration.orbits": 0.5})
    ringsim.run(sc, output=path, resume=True, progress=False)
    run = ringsim.open_run(path)
    assert run.format_version == "1.2" and run.attrs["status"] == "finished"
    residual = run.timeseries["momentum_residual"]
    assert residual.size == run.timeseries["t"].size == 26
    assert np.all(np.isnan(residual[:21])) and np.all(np.isfinite(residual[21:]))


@pytest.mark.parametrize("version, readable", [("1.0", True), ("1.7", True), ("2.0", False),
                                               ("11.0", False), ("one", False)])
def test_reader_refuses_only_a_newer_major_version(tmp_path, version, readable):
    path = tmp_path / "v.h5"
    shutil.copyfile(FORMAT_1_0, path)
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = version
    if readable:
        assert ringsim.open_run(path).format_version == version
    else:
        with pytest.raises(runfile.RunFileError, match="format_version"):
            ringsim.open_run(path)


# --- one writer per file -------------------------------------------------------------------------

HOLD_LOCK = """
import sys
from ringsim.store.lock import RunFileLock
lock = RunFileLock(sys.argv[1]).acquire()
print("locked", flush=True)
sys.stdin.readline()
lock.release()
"""


def test_a_file_being_written_is_refused(good_run, tmp_path, capsys):
    path = tmp_path / "busy.h5"
    shutil.copyfile(good_run["path"], path)
    before = sha256(path)
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        assert f"process {holder.pid}" in writer_of(path)
        for argv in (["analyze", str(path)],
                     ["run", str(good_run["scenario_file"]), "-o", str(path), "--resume",
                      "--no-progress"],
                     ["run", str(good_run["scenario_file"]), "-o", str(path), "--force",
                      "--no-progress"]):
            _expect_bad_input(capsys, main(argv), path, "being written by process")
        assert sha256(path) == before
    finally:
        holder.communicate("\n", timeout=30)
    assert writer_of(path) is None and not lock_path(path).exists()


def test_stale_lock_of_a_killed_writer_is_taken_over(good_run, tmp_path):
    path = tmp_path / "stale.h5"
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "locked"
    holder.send_signal(signal.SIGKILL)
    holder.wait()
    assert lock_path(path).exists(), "a killed writer leaves its lock file"
    assert writer_of(path) is None, "nobody holds it"
    assert main(["run", str(good_run["scenario_file"]), "-o", str(path),
                 "--no-progress"]) == 0
    assert not lock_path(path).exists()
    # a lock record of a dead pid on this host is stale also to the fallback check
    from ringsim.store import lock as lock_module

    lock_path(path).write_text(json.dumps({"pid": holder.pid, "host": os.uname().nodename,
                                           "started_utc": "2020-01-01T00:00:00+00:00"}))
    assert not lock_module._record_says_alive(lock_path(path))
    with RunFileLock(path) as held:
        assert held.held


def test_two_concurrent_runs_one_writes_the_other_exits_2(tmp_path, tiny_scenario):
    sc = tiny_scenario(**{"integration.orbits": 1.0, "sheet.n_particles": 150})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    out = tmp_path / "both.h5"
    argv = [sys.executable, "-m", "ringsim.cli", "run", str(scenario_file), "-o", str(out),
            "--force", "--no-progress"]
    procs = [subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [p.communicate(timeout=300) + (p.returncode,) for p in procs]
    codes = sorted(r[2] for r in results)
    assert codes == [0, 2], results
    refused = next(r for r in results if r[2] == 2)
    lines = refused[1].strip().splitlines()
    assert len(lines) == 1 and "being written by process" in lines[0] and str(out) in lines[0]
    run = ringsim.open_run(out)
    assert run.attrs["status"] == "finished" and run.timeseries["orbits"][-1] == \
        pytest.approx(1.0)


# --- runtime invariants -----------------------------------------------------------------------

def _corrupt_nan(sim):
    sim.particles[7].vz = float("nan")


def _corrupt_drop(sim):
    sim.remove(7)


def _corrupt_momentum(sim):
    sim.particles[7].vx += 1e-6   # [m/s]: about 1e-8 m/s in the sheet's mean, far above round-off


CORRUPTIONS = {"nan": (_corrupt_nan, "not finite"),
               "dropped-particle": (_corrupt_drop, "particle count changed from 60 to 59"),
               "momentum": (_corrupt_momentum, "momentum of the sheet")}


@pytest.mark.parametrize("name", list(CORRUPTIONS))
def test_injected_violation_stops_the_run(tmp_path, monkeypatch, capsys, name, tiny_scenario):
    corrupt, words = CORRUPTIONS[name]
    sc = tiny_scenario(**{"integration.orbits": 0.3})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    advance = Runner._advance

    def corrupting(self, t_next):
        advance(self, t_next)
        if self.state.rows == 12:   # after the checkpoint at 0.2 orbit (row 10)
            corrupt(self.sim)

    monkeypatch.setattr(Runner, "_advance", corrupting)
    path = tmp_path / "bad.h5"
    assert main(["run", str(scenario_file), "-o", str(path), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert words in err and "FAILED" in err and "Traceback" not in err
    run = ringsim.open_run(path)
    assert run.attrs["status"] == "failed" and words in run.attrs["failure"]
    assert any("FAILED" in m and words in m for _, m in run.guard_events)
    # the rows before the violation are kept; the bad state never reaches the file
    assert run.timeseries["t"].size == 12
    assert np.all(np.isfinite(run.timeseries["velocity_dispersion"]))
    checkpoint = runfile.read_checkpoint(path)
    assert checkpoint.state["rows"] == 11, "the checkpoint is the last good one (0.2 orbit)"
    assert checkpoint.state["t"] < run.timeseries["t"][-1]


def test_normal_runs_conserve_momentum_far_below_the_tolerance(tmp_path, tiny_scenario):
    """A tree and a line run: the invariant never trips, residuals stay at round-off."""
    for mode in ("tree", "line"):
        sc = tiny_scenario(**{"integration.orbits": 1.0, "sheet.n_particles": 150,
                              "integration.collision_detection": mode})
        run = ringsim.open_run(ringsim.run(sc, output=tmp_path / f"{mode}.h5",
                                           progress=False))
        assert run.attrs["status"] == "finished", mode
        assert run.timeseries["collisions"].sum() > 100, "collisions exercised the balance"
        residual = run.timeseries["momentum_residual"]
        assert residual[0] == 0.0 and np.all(residual < 1e-15), (mode, residual.max())


@pytest.mark.slow
def test_long_hot_run_never_trips_the_invariants(tmp_path, tiny_scenario):
    sc = tiny_scenario(**{"integration.orbits": 5.0, "sheet.n_particles": 400,
                          "restitution": {"model": "constant", "epsilon": 0.9},
                          "sheet.initial_dispersion": 5.0})
    run = ringsim.open_run(ringsim.run(sc, output=tmp_path / "hot.h5", progress=False))
    assert run.attrs["status"] == "finished"
    assert np.all(run.timeseries["momentum_residual"] < 1e-14)


def test_sheet_momentum_is_an_epicycle_and_ignores_boundary_wraps():
    """Particles on free epicycles about different guiding centres: the mean follows the
    predicted epicycle; a radial wrap (x - Lx, vy + 1.5 Omega Lx) changes nothing."""
    rng = np.random.default_rng(4)
    Omega, n, Lx = 2.0e-4, 50, 300.0
    x_gc, y_gc = rng.uniform(-100, 100, n), rng.uniform(-100, 100, n)
    amplitude, phase0 = rng.uniform(0, 10, n), rng.uniform(0, 2 * np.pi, n)
    mass = rng.uniform(1e3, 1e4, n)

    def state(t):
        ph = Omega * t + phase0
        x = x_gc + amplitude * np.cos(ph)
        return {"x": x, "y": y_gc - 1.5 * Omega * x_gc * t - 2 * amplitude * np.sin(ph),
                "z": amplitude * np.sin(ph), "vx": -amplitude * Omega * np.sin(ph),
                "vy": -1.5 * Omega * x_gc - 2 * amplitude * Omega * np.cos(ph),
                "vz": amplitude * Omega * np.cos(ph), "mass": mass}

    ref = invariants.sheet_momentum(state(0.0), Omega, 0.0)
    now = invariants.sheet_momentum(state(7000.0), Omega, 7000.0)
    assert abs(ref.u) > 1e-4, "a non-trivial mean epicycle"
    assert invariants.momentum_residual(now, ref, Omega) < 1e-15
    wrapped = state(7000.0)
    wrapped["x"][3] -= Lx
    wrapped["vy"][3] += 1.5 * Omega * Lx
    assert invariants.momentum_residual(
        invariants.sheet_momentum(wrapped, Omega, 7000.0), now, Omega) < 1e-15
    kicked = state(7000.0)
    kicked["vx"][3] += 1e-6
    assert invariants.momentum_residual(
        invariants.sheet_momentum(kicked, Omega, 7000.0), now, Omega) == pytest.approx(
            1e-6 * mass[3] / mass.sum(), rel=1e-6)


# --- crash consistency --------------------------------------------------------------------------

DIE_INSIDE_A_COMMIT = """
import os, signal, sys
import numpy as np
from ringsim.store import runfile
path, where = sys.argv[1], sys.argv[2]
original = getattr(runfile, where)

def dying(f, *args):
    original(f, *args)
    f.flush()                        # the half-made commit reaches the disk
    os.kill(os.getpid(), signal.SIGKILL)

setattr(runfile, where, dying)
arrays = {k: np.full(60, 1.0) for k in runfile.SNAPSHOT_FIELDS}
checkpoint = runfile.read_checkpoint(path)
runfile.RunFileWriter(path).commit(
    rows=[{"t": 1e9, "orbits": 99.0}], events=[(1e9, 99.0, "never")],
    snapshot=(99, 1e9, arrays),
    checkpoint=runfile.Checkpoint(b"new" * 1000, {**checkpoint.state, "rows": 999},
                                  checkpoint.statistics))
"""


@pytest.mark.parametrize("where", ["_write_snapshot", "_write_checkpoint",
                                   "_append_timeseries"])
def test_killed_inside_a_write_leaves_the_previous_state(good_run, tmp_path, where):
    path = tmp_path / "crash.h5"
    shutil.copyfile(good_run["path"], path)
    before = sha256(path)
    proc = subprocess.run([sys.executable, "-c", DIE_INSIDE_A_COMMIT, str(path), where],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    assert Path(f"{path}.tmp").exists(), "the writer died inside its commit"
    assert sha256(path) == before, "the run file is the state before the commit"
    run = ringsim.open_run(path)
    assert run.n_snapshots == 3 and runfile.read_checkpoint(path).state["rows"] == 11


def _checkpoint_state(path):
    """The state a checkpoint loads: particles, time, step, seed, counters."""
    from ringsim.engine import sheet
    from ringsim.engine.binary import simulation_from_binary

    ck = runfile.read_checkpoint(path)
    sim = simulation_from_binary(ck.binary, path)
    arrays = sheet.particle_arrays(sim)
    return ({k: v.tobytes() for k, v in arrays.items()},
            (sim.t, sim.dt, sim.N, sim.collisions_log_n, sim.collisions_plog),
            {k: v for k, v in ck.state.items()})


def _assert_consistent(path):
    """A stopped file: readable, its checkpoint within its rows and snapshots."""
    run = ringsim.open_run(path)
    ck = runfile.read_checkpoint(path)
    assert ck is not None
    rows, snaps = int(ck.state["rows"]), int(ck.state["snapshots"])
    assert 1 <= rows <= run.timeseries["t"].size and snaps <= run.n_snapshots
    assert run.timeseries["t"][rows - 1] <= ck.state["t"] + 1e-9
    assert run.snapshot(snaps - 1)["t"] <= ck.state["t"] + 1e-9


def _identity(path):
    """(inode, mtime) of a file, None if absent: every commit replaces the file."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    return st.st_ino, st.st_mtime_ns


def _interrupted_chain(tiny_scenario, tmp_path, sig, seed, n_stops=5):
    """Run, stop with ``sig`` at ``n_stops`` seeded moments (resuming in between), resume to
    the end; compare with the uninterrupted run dataset by dataset."""
    sc = tiny_scenario(**{"integration.orbits": 1.0, "sheet.n_particles": 200,
                          "output.timeseries_every": 0.01, "output.checkpoint_every": 0.05,
                          "output.log_collisions": 50})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    reference = ringsim.run(sc, output=tmp_path / "ref.h5", progress=False)
    path = tmp_path / "stopped.h5"
    rng = np.random.default_rng(seed)
    n_rows = round(1.0 / 0.01) + 1
    # a commit every 5 rows: the poll sees a target up to 5 rows late, the stop follows
    # up to 5 rows later; each stop costs up to ~10 rows, all must come before the end
    targets = np.sort(rng.choice(np.arange(3, n_rows - 50), n_stops, replace=False))
    cadence = None   # wall time [s] between two commits of the run
    stops = mid_interval = 0
    for k, target in enumerate(targets):
        argv = [sys.executable, "-m", "ringsim.cli", "run", str(scenario_file), "-o",
                str(path), "--no-progress"] + (["--resume"] if k else [])
        proc = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        deadline = time.time() + 120
        seen: list[tuple[int, float]] = []   # (rows in the file, when first seen)
        old = _identity(path)   # the file as the previous process left it
        while proc.poll() is None and time.time() < deadline:
            if _identity(path) == old:
                time.sleep(0.01)
                continue
            try:   # never a half-written file to read: commits replace the file whole
                with h5py.File(path, "r", locking=False) as f:
                    rows = f["timeseries/t"].shape[0] if f.attrs["status"] == "running" \
                        else 0
            except (FileNotFoundError, KeyError):
                rows = 0
            if rows and (not seen or rows != seen[-1][0]):
                seen.append((rows, time.time()))
            if rows >= target or len(seen) >= 2:   # at the latest one commit after start
                break
            time.sleep(0.01)
        if len(seen) >= 2:
            cadence = seen[-1][1] - seen[-2][1]
        # somewhere within the next commit interval: mostly inside the integration
        time.sleep(rng.uniform(0.0, cadence or 0.1))
        if proc.poll() is None:
            proc.send_signal(sig)
            stops += 1
        _out, err = proc.communicate(timeout=120)
        if sig == signal.SIGINT and proc.returncode == -signal.SIGINT:
            pass   # the signal came while Python started or shut down, outside ringsim
        elif sig == signal.SIGINT and proc.returncode != 0:
            assert proc.returncode == 130, err
            status = ringsim.open_run(path).attrs["status"]
            # "finished": the signal came after the last commit (the run had ended)
            assert status in ("stopped", "finished"), status
            ck = runfile.read_checkpoint(path)
            rows = ringsim.open_run(path).timeseries["t"]
            mid_interval += status == "stopped" and ck.state["t"] > rows[-1]
        elif sig == signal.SIGKILL:
            assert proc.returncode in (0, -signal.SIGKILL), err
        _assert_consistent(path)
    assert stops >= 3, "the run was stopped several times"
    # (whether a SIGINT lands inside REBOUND's integration, i.e. mid-interval, or in the
    # Python part of an output is up to the machine: test_stop_inside_an_interval_...
    # makes the mid-interval case certain)
    assert main(["run", str(scenario_file), "-o", str(path), "--resume",
                 "--no-progress"]) == 0
    assert_same_datasets(reference, path)
    assert _checkpoint_state(reference) == _checkpoint_state(path)


def test_sigkill_at_random_moments_then_resume_is_identical(tmp_path, tiny_scenario):
    _interrupted_chain(tiny_scenario, tmp_path, signal.SIGKILL, seed=5)


def test_sigint_at_random_moments_then_resume_is_identical(tmp_path, tiny_scenario):
    _interrupted_chain(tiny_scenario, tmp_path, signal.SIGINT, seed=6)


def test_resolver_statistics_restore_bit_for_bit():
    import rebound

    from ringsim.engine.resolver import collision_records, install_resolver

    sim = rebound.Simulation()
    sim.add(m=1.0, r=1.0, x=0.0, vx=0.01)
    sim.add(m=2.0, r=1.0, x=1.5, vx=-0.01)
    handle = install_resolver(sim, {"model": "dilley", "xi0": 0.16, "p": 0.65,
                                    "kappa": 0.1}, log_capacity=3)
    for _ in range(5):
        sim.particles[0].vx, sim.particles[1].vx = 0.01, -0.01
        handle.resolve_batch(collision_records([[0, 1]]))
    saved = handle.stats_state()
    other = install_resolver(rebound.Simulation(), {"model": "dilley"}, log_capacity=3)
    other.set_stats(saved)
    a, b = handle.stats(), other.stats()
    assert a["count"] == b["count"] == 5 and a["sum_epsilon"] == b["sum_epsilon"]
    assert np.array_equal(a["log"], b["log"]) and a["log_written"] == 5
    assert np.array_equal(a["histograms"]["v_n"]["counts"], b["histograms"]["v_n"]["counts"])
    with pytest.raises(ValueError, match="log"):
        install_resolver(rebound.Simulation(), {"model": "dilley"}).set_stats(saved)


def test_stop_inside_an_interval_then_resume_is_identical(tmp_path, tiny_scenario):
    """REBOUND turns SIGINT into KeyboardInterrupt after a complete step, inside an interval:
    the checkpoint then carries the interval's statistics, and the resumed row spanning the
    stop (collisions, mean_epsilon, histograms, multi_encounters) equals the uninterrupted
    one."""
    sc = tiny_scenario(**{"integration.orbits": 0.3, "sheet.n_particles": 150,
                          "output.log_collisions": 20})
    reference = ringsim.run(sc, output=tmp_path / "ref.h5", progress=False)

    class StoppedMidInterval(Runner):
        def _advance(self, t_next):
            if self.state.rows == 7:
                self.sim.integrate(t_next - 0.5 * self.ts_every, exact_finish_time=0)
                raise KeyboardInterrupt
            super()._advance(t_next)

    path = tmp_path / "stopped.h5"
    runner = StoppedMidInterval(sc, path, progress=False)
    runner.start_new()
    assert runner.loop() == "stopped"
    ck = runfile.read_checkpoint(path)
    rows = ringsim.open_run(path).timeseries["t"]
    assert ck.state["t"] > rows[-1] and int(ck.statistics["count"]) > 0, \
        "stopped inside an interval that had collisions"
    ringsim.run(sc, output=path, resume=True, progress=False)
    assert_same_datasets(reference, path)
    assert _checkpoint_state(reference) == _checkpoint_state(path)


@pytest.mark.parametrize("name, value, readable", [
    ("law_inside_all", -1, True),               # a row written before the series existed
    ("law_inside_all", -(2**62) + 5, True),     # an interval resumed without the count
    ("law_speeds_below", -1, True),
    ("law_speeds_below", -(2**62) + 5, False),  # only the joint count has that marker
    ("law_inside_all", -2, False),
    ("collisions", -1, True)])
def test_counts_not_counted_are_read_and_other_negative_counts_refused(
        good_run, tmp_path, capsys, name, value, readable):
    path = tmp_path / "r.h5"
    _edit(lambda f: f[f"timeseries/{name}"].__setitem__(0, value))(good_run["path"], path)
    status = main(["analyze", str(path)])
    if readable:
        assert status == 0, capsys.readouterr().err
    else:
        _expect_bad_input(capsys, status, path, name)
