"""Clean stops: SIGINT and SIGTERM at any moment of a run end it after at most one step with
a checkpoint, and the resumed run equals the uninterrupted one (docs/interface.md, "Stops
and full disks").
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import threading
import time

import h5py
import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.engine.runner import Runner
from ringsim.engine.stop import StopRequest
from ringsim.store import runfile
from ringsim.testing import assert_same_datasets

#: A tiny ring for stop tests: 80 particles of 1-2 m, 0.3 orbit, a row every 0.02 orbit, a
#: checkpoint every 0.1 orbit.
STOPS = {"name": "stops", "seed": 21, "particles.size_distribution.r_max": 2.0,
         "sheet.n_particles": 80, "restitution.kappa": 0.1, "integration.orbits": 0.3,
         "output.timeseries_every": 0.02, "output.checkpoint_every": 0.1,
         "output.log_collisions": 20}


@pytest.fixture(scope="module")
def stops_scenario(ring_scenario):
    return lambda **overrides: ring_scenario(STOPS, overrides)


def _assert_resumes_to(reference, scenario_file, path) -> None:
    """``ringsim run --resume`` finishes the run file ``path`` of ``scenario_file``, and it
    then holds every dataset of the uninterrupted run ``reference`` (==)."""
    assert main(["run", str(scenario_file), "-o", str(path), "--resume",
                 "--no-progress"]) == 0
    assert_same_datasets(reference, path)


class SignalledRunner(Runner):
    """A runner that sends itself ``sig`` at one chosen moment of its loop:

    * ``("output", k)``: inside the k-th output of this session (Python code, between two
      integrate calls);
    * ``("before", k)``: just before the k-th integrate call;
    * ``("step", k)``: from another thread, once REBOUND has made k steps in this session
      (inside an integrate call); ``sent_t`` [s] is ``sim.t`` when it is sent.
    """

    def __init__(self, scenario, path, moment, sig):
        super().__init__(scenario, path, progress=False)
        self.moment, self.sig = moment, sig
        self.calls = self.outputs = 0
        self.sent_t: float | None = None
        self.poller: threading.Thread | None = None

    def _send(self) -> None:
        self.sent_t = self.sim.t
        os.kill(os.getpid(), self.sig)

    def _output(self, first: bool = False) -> None:
        super()._output(first)
        self.outputs += 1
        if self.moment == ("output", self.outputs):
            self._send()

    def _advance(self, t_next: float) -> None:
        self.calls += 1
        kind, k = self.moment
        if kind == "before" and self.calls == k:
            self._send()
        if kind == "step" and self.poller is None:
            target = int(self.sim.steps_done) + k
            self.poller = threading.Thread(target=self._poll, args=(target,), daemon=True)
            self.poller.start()
        super()._advance(t_next)

    def _poll(self, target: int) -> None:
        deadline = time.monotonic() + 60
        while int(self.sim.steps_done) < target and time.monotonic() < deadline:
            time.sleep(0.0005)
        self._send()


def _run_session(scenario, path, moment, sig, resume: bool) -> SignalledRunner:
    with StopRequest() as stop:
        runner = SignalledRunner(scenario, path, moment, sig)
        if resume:
            runner.start_resume()
        else:
            runner.start_new()
        runner.status = runner.loop(stop)
    if runner.poller is not None:
        runner.poller.join(timeout=60)
    return runner


#: Ten moments of the chain: (kind, k) as in `SignalledRunner`, and the signal.
MOMENTS = [(("output", 2), signal.SIGINT), (("step", 3), signal.SIGINT),
           (("before", 2), signal.SIGINT), (("step", 1), signal.SIGTERM),
           (("output", 3), signal.SIGTERM), (("step", 7), signal.SIGINT),
           (("before", 1), signal.SIGTERM), (("output", 1), signal.SIGINT),
           (("step", 2), signal.SIGTERM), (("output", 2), signal.SIGINT)]


def test_signal_at_ten_moments_stops_within_a_step_and_resumes_identically(
        tmp_path, stops_scenario):
    """SIGINT or SIGTERM sent at ten moments of one run (between integrate calls, just
    before one, and inside one) stops it each time with a checkpoint no later than one step
    after the signal (the step in progress completes; tolerance 1e-9 of a step for the
    times' rounding); resumed each time, the run equals the uninterrupted one dataset by
    dataset."""
    sc = stops_scenario()
    reference = ringsim.run(sc, output=tmp_path / "ref.h5", progress=False)
    path = tmp_path / "chain.h5"
    for k, (moment, sig) in enumerate(MOMENTS):
        runner = _run_session(sc, path, moment, sig, resume=k > 0)
        assert runner.sent_t is not None, f"moment {k} {moment} was never reached"
        assert runner.status == "stopped", f"moment {k} {moment}: {runner.status}"
        ck = runfile.read_checkpoint(path)
        dt = float(ck.state["dt"]) if "dt" in ck.state else runner.sim.dt
        assert runner.sent_t - 1e-9 * dt <= ck.state["t"] <= runner.sent_t + dt * (1 + 1e-9), \
            f"moment {k} {moment}: stopped at t = {ck.state['t']} s, signal at " \
            f"t = {runner.sent_t} s, dt = {dt} s"
        assert ringsim.open_run(path).attrs["status"] == "stopped"
    ringsim.run(sc, output=path, resume=True, progress=False)
    assert_same_datasets(reference, path)


def _identity(path):
    """(inode, mtime) of a file, None if absent: every commit replaces the file."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    return st.st_ino, st.st_mtime_ns


@pytest.mark.slow
def test_sigint_to_ringsim_run_at_ten_moments_exits_130_and_resumes_identically(
        tmp_path, stops_scenario):
    """``ringsim run`` sent SIGINT at ten seeded moments (each a new process, resumed from
    the last stop) exits 130 each time, with a checkpoint, within 10 s of the signal (a
    step takes milliseconds here; the bound covers the final commit and the exit on a
    shared machine); resumed to the end, the run equals the uninterrupted one."""
    sc = stops_scenario(**{"integration.orbits": 1.5, "sheet.n_particles": 150})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    reference = ringsim.run(sc, output=tmp_path / "ref.h5", progress=False)
    path = tmp_path / "stopped.h5"
    rng = np.random.default_rng(43)
    for k in range(10):
        old = _identity(path)
        argv = [sys.executable, "-m", "ringsim.cli", "run", str(scenario_file), "-o",
                str(path), "--no-progress"] + (["--resume"] if k else [])
        proc = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 120
        while _identity(path) == old and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)   # the session's first commit: its loop has started
        time.sleep(rng.uniform(0.0, 0.3))
        assert proc.poll() is None, f"stop {k}: the run ended before the signal"
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 130, f"stop {k}: exit {proc.returncode}: {err}"
        assert time.monotonic() - sent < 10.0
        assert "--resume" in out and "Traceback" not in err
        assert ringsim.open_run(path).attrs["status"] == "stopped"
        assert runfile.read_checkpoint(path) is not None
    _assert_resumes_to(reference, scenario_file, path)


SWEEP_SCENARIO = """\
name: stops
seed: 1
planet: {Omega: 2.0e-4}
particles:
  density: 900.0
  size_distribution: {kind: powerlaw, q: 3.0, r_min: 1.0, r_max: 2.0}
sheet: {optical_depth: 0.25, n_particles: 80}
restitution: {model: dilley, xi0: 0.16, p: 0.65, kappa: 0.0}
integration: {orbits: 0.3}
output: {timeseries_every: 0.02, snapshot_every: 0.1, checkpoint_every: 0.1}
"""

SWEEP = """\
base: stops.yaml
grid:
  seed: [1, 2, 3, 4]
"""


def _group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes of the process group ``pgid``, from /proc."""
    members = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()   # after the command's name
        if int(fields[2]) == pgid and fields[0] != "Z":
            members.append(int(entry))
    return members


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_sweep_parent_killed_leaves_no_process_and_the_rerun_finishes(tmp_path, sig):
    """A sweep's parent sent SIGTERM (or SIGKILL) while its two workers run: after 5 s no
    process of its process group is left (the workers stop their runs at a checkpoint and
    exit, also when their parent is gone); after SIGTERM the parent exits 130 and writes the
    summary of what finished; running the sweep again finishes every point."""
    (tmp_path / "stops.yaml").write_text(SWEEP_SCENARIO)
    (tmp_path / "sweep.yaml").write_text(SWEEP)
    out = tmp_path / "runs"
    log = (tmp_path / "sweep.log").open("w")   # a file: orphans would hold a pipe open
    proc = subprocess.Popen([sys.executable, "-m", "ringsim.cli", "sweep", "sweep.yaml",
                             "--workers", "2", "--out", str(out)], cwd=tmp_path,
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    deadline = time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline \
            and not any(out.glob("*.h5")):
        time.sleep(0.02)
    time.sleep(0.5)
    assert proc.poll() is None, "the sweep ended before the signal"
    sent = time.monotonic()
    proc.send_signal(sig)
    proc.wait(timeout=60)
    log.close()
    err = (tmp_path / "sweep.log").read_text()
    time.sleep(max(0.0, sent + 5.0 - time.monotonic()))
    left = _group_members(proc.pid)
    for pid in left:   # do not leave them to the next test
        os.kill(pid, signal.SIGKILL)
    assert not left, f"processes left 5 s after {sig.name}: {left}"
    if sig == signal.SIGTERM:
        assert proc.returncode == 130, err
        assert (out / "summary.csv").exists(), "no summary of what finished"
        rows = list(csv.DictReader((out / "summary.csv").open()))
        assert len(rows) == 4 and {r["status"] for r in rows} <= {"finished", "stopped"}
    assert main(["sweep", str(tmp_path / "sweep.yaml"), "--workers", "2",
                 "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [r["status"] for r in rows] == ["finished"] * 4


def _file_size_limit(limit: int):
    """A ``preexec_fn`` that limits the size of every file the process writes [bytes]."""
    import resource

    return lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_FSIZE semantics")
def test_full_disk_ends_the_run_with_one_line_and_resume_finishes_it(tmp_path,
                                                                      stops_scenario):
    """A file size limit (``ulimit -f``, as a full disk: the write fails) at 90 % of the
    finished file's size: ``ringsim run`` exits 1 with one line naming --resume, no
    segmentation fault and no traceback, no ``.tmp`` left, and the run file keeps its last
    commit (a readable checkpoint); with the limit gone, --resume finishes a run equal to
    the uninterrupted one."""
    sc = stops_scenario(**{"integration.orbits": 0.4, "sheet.n_particles": 100,
                           "output.snapshot_every": 0.02})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    reference = ringsim.run(sc, output=tmp_path / "ref.h5", progress=False)
    limit = int(0.9 * reference.stat().st_size)
    path = tmp_path / "full.h5"
    done = subprocess.run([sys.executable, "-m", "ringsim.cli", "run", str(scenario_file),
                           "-o", str(path), "--no-progress"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300,
                          preexec_fn=_file_size_limit(limit))
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "--resume" in lines[0] and "Errno 27" in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full.h5", "ref.h5", "s.yaml"]
    assert path.stat().st_size <= limit
    kept = ringsim.open_run(path)
    assert kept.attrs["status"] == "running" and runfile.read_checkpoint(path) is not None
    assert 1 <= kept.timeseries["t"].size < ringsim.open_run(reference).timeseries["t"].size
    _assert_resumes_to(reference, scenario_file, path)


#: Writes a run file with a small snapshot, then under a file size limit of 200 kB commits a
#: snapshot of 100,000 particles that goes into a part file (external_bytes 0): the commit
#: must raise OSError EFBIG after HDF5 closed the part file and the copy.
PART_FILE_SCRIPT = """
import errno, resource, signal, sys
import h5py
import numpy as np
from ringsim.store.runfile import RunFileWriter
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
path = sys.argv[1]
writer = RunFileWriter(path, external_bytes=0)
writer.create(scenario_yaml="name: x", seed=1, attributes={}, size_bin_edges=None,
              histogram_edges={})
fields = ("x", "y", "z", "vx", "vy", "vz", "radius", "mass")
rng = np.random.default_rng(5)
writer.commit(snapshot=(0, 0.0, {k: rng.random(10) for k in fields}))
resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))
try:
    writer.commit(snapshot=(1, 1.0, {k: rng.random(100_000) for k in fields}))
except OSError as exc:
    assert exc.errno == errno.EFBIG, exc
    with h5py.File(path, "r") as f:
        print("EFBIG", len(f["snapshots"]))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_FSIZE semantics")
def test_full_disk_while_writing_a_part_file_raises_and_keeps_the_commit(tmp_path):
    """A part file (a large snapshot, ``store.bulk``) that cannot be written: the commit
    raises OSError (EFBIG) instead of crashing h5py at exit (exit 0, no traceback), the new
    part file and the temporary copy are removed, and the run file keeps its one snapshot
    (in the part file of the first commit)."""
    path = tmp_path / "run.h5"
    done = subprocess.run([sys.executable, "-c", PART_FILE_SCRIPT, str(path)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["EFBIG", "1"] and "Traceback" not in done.stderr
    names = sorted(p.name for p in tmp_path.rglob("*"))   # external_bytes 0: the first
    assert names[:2] == ["run.h5", "run.h5.parts"] and len(names) == 3   # snapshot's part
    assert names[2].startswith("snapshot_000000_"), names


STUDY = """\
name: stops-study
description: two cases of the stop tests' sheet
base: stops.yaml
seeds: [1, 2]
cases:
  k0: {}
  k01: {restitution.kappa: 0.1}
ratios: [[k01, k0]]
length: {orbits: 2.0}     # runs long enough to be under way when the study is killed
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_study_killed_alone_leaves_no_process_and_the_rerun_finishes(tmp_path):
    """SIGKILL to a study alone (not its workers): its workers, whose parent is gone, stop
    their runs at a checkpoint and exit; after 5 s no process of its group is left, and the
    study started again resumes them and writes its report (exit 0)."""
    (tmp_path / "stops.yaml").write_text(SWEEP_SCENARIO)
    (tmp_path / "study.yaml").write_text(STUDY)
    out = tmp_path / "report"
    proc = subprocess.Popen([sys.executable, "-m", "ringsim.cli", "study", "study.yaml",
                             "--workers", "2", "--out", str(out)], cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    deadline = time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline \
            and not any(out.glob("runs/*.h5")):
        time.sleep(0.02)
    time.sleep(0.5)
    assert proc.poll() is None, "the study ended before the signal"
    sent = time.monotonic()
    proc.kill()
    proc.wait(timeout=60)
    time.sleep(max(0.0, sent + 5.0 - time.monotonic()))
    left = _group_members(proc.pid)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, f"processes left 5 s after SIGKILL: {left}"
    statuses = {ringsim.open_run(p).attrs["status"] for p in out.glob("runs/*.h5")}
    assert "stopped" in statuses and "running" not in statuses, statuses
    assert main(["study", str(tmp_path / "study.yaml"), "--workers", "2",
                 "--out", str(out)]) == 0
    assert (out / "report.json").exists()


#: Runs a scenario with checkpoints on wall time at every output (CHECKPOINT_WALL_INTERVAL
#: 0 s instead of 600 s, so that the test needs no ten minutes).
WALL_CHECKPOINT_SCRIPT = """
import sys
from ringsim.engine import runner
from ringsim.cli import main
runner.CHECKPOINT_WALL_INTERVAL = 0.0
sys.exit(main(["run", sys.argv[1], "-o", sys.argv[2], "--no-progress"]))
"""


def _checkpoint_time(path) -> float:
    """t [s] of the last checkpoint of a run file being written (-1 if none yet): read
    past the writer's lock, which the atomic commits (copy and rename) allow."""
    try:
        with h5py.File(path, "r") as f:
            return float(f["checkpoint"].attrs["t"]) if "checkpoint" in f else -1.0
    except OSError:         # not there yet, or renamed in the moment
        return -1.0


def test_run_killed_without_signal_resumes_from_its_last_wall_time_checkpoint(
        tmp_path, stops_scenario):
    """SIGKILL (no final checkpoint) to a run whose only orbit-scheduled checkpoint is at its
    start: with checkpoints on wall time the file keeps a checkpoint past its start, and
    --resume finishes a run equal (==) to the uninterrupted one."""
    sc = stops_scenario(**{"integration.orbits": 0.6, "sheet.n_particles": 100,
                           "output.checkpoint_every": 10.0})
    scenario_file = tmp_path / "s.yaml"
    scenario_file.write_text(sc.to_yaml())
    reference = ringsim.run(sc, output=tmp_path / "ref.h5", progress=False)
    path = tmp_path / "killed.h5"
    proc = subprocess.Popen([sys.executable, "-c", WALL_CHECKPOINT_SCRIPT, str(scenario_file),
                             str(path)], cwd=tmp_path, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline:
        if _checkpoint_time(path) > 0.1 * sc.orbital_period:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the run ended before the kill"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    kept = runfile.read_checkpoint(path)
    assert kept is not None
    assert 0.1 * sc.orbital_period < kept.state["t"] < 0.5 * sc.orbital_period, \
        "a checkpoint within the run, not its final one"
    assert ringsim.open_run(path).attrs["status"] == "running"
    _assert_resumes_to(reference, scenario_file, path)
