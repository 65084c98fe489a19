"""Issue 16, snapshot I/O at scale: large snapshots and checkpoints in part files.

A run whose items all go into part files (``external_bytes=0``) must give the same datasets
as the same run written in one file, resume bit for bit, survive a kill inside a commit
with the previous state intact, and a missing part file is a damaged run file (exit 2).
"""

import hashlib
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.config.scenario import with_overrides
from ringsim.engine.runner import Runner
from ringsim.store import bulk, runfile
from ringsim.testing import run_file_datasets

#: The ring in line mode, a checkpoint with every snapshot.
PARTS = {"name": "parts", "integration.collision_detection": "line",
         "output.checkpoint_every": 0.1}


def _run_in_parts(scenario, path):
    """ringsim.run's steps, with every snapshot and checkpoint in a part file."""
    runner = Runner(scenario, path, progress=False)
    runner.writer = runfile.RunFileWriter(path, external_bytes=0)
    runner.start_new()
    assert runner.loop() == "finished"


@pytest.fixture(scope="module")
def runs(tmp_path_factory, ring_scenario):
    folder = tmp_path_factory.mktemp("parts")
    sc = ring_scenario(PARTS)
    ringsim.run(sc, output=folder / "one.h5", progress=False)
    _run_in_parts(sc, folder / "parts.h5")
    return {"scenario": sc, "one": folder / "one.h5", "parts": folder / "parts.h5"}


def test_items_in_part_files_read_as_in_one_file(runs):
    path = runs["parts"]
    run = ringsim.open_run(path)
    assert run.n_snapshots == 4
    files = sorted(p.name for p in bulk.parts_folder(path).iterdir())
    # one file per snapshot and only the last checkpoint's: the replaced ones were removed
    assert len(files) == 5 and sum(name.startswith("checkpoint_") for name in files) == 1
    with h5py.File(path, "r") as f:
        assert isinstance(f.get("snapshots/000002", getlink=True), h5py.ExternalLink)
        assert f["snapshots/000002/x"].compression == "gzip"
    one, parts = run_file_datasets(runs["one"]), run_file_datasets(path)
    assert one.keys() == parts.keys() and len([k for k in one if "snapshots/" in k]) == 32
    for name in one:
        assert one[name] == parts[name], name
    assert runfile.read_checkpoint(path).state == runfile.read_checkpoint(runs["one"]).state


def test_resume_from_part_files_is_bit_identical(runs, tmp_path):
    path = tmp_path / "short.h5"
    short = with_overrides(runs["scenario"], {"integration.orbits": 0.16})
    _run_in_parts(short, path)
    ringsim.run(runs["scenario"], output=path, resume=True, progress=False)
    reference, resumed = run_file_datasets(runs["one"]), run_file_datasets(path)
    assert reference.keys() == resumed.keys()
    for name in reference:
        if not name.startswith("guards/"):   # the extension is a guard event
            assert reference[name] == resumed[name], f"{name} differs after --resume"
    assert [m for _, m in ringsim.open_run(path).guard_events] == [
        "run extended from 0.16 to 0.3 orbits"]


DIE_INSIDE_A_COMMIT = """
import os, signal, sys
import numpy as np
from ringsim.store import runfile
path = sys.argv[1]
original = runfile._write_checkpoint

def dying(f, *args):
    original(f, *args)            # the snapshot and checkpoint part files are complete
    f.flush()
    os.kill(os.getpid(), signal.SIGKILL)

runfile._write_checkpoint = dying
arrays = {k: np.full(60, 1.0) for k in runfile.SNAPSHOT_FIELDS}
checkpoint = runfile.read_checkpoint(path)
runfile.RunFileWriter(path, external_bytes=0).commit(
    rows=[{"t": 1e9, "orbits": 99.0}], snapshot=(99, 1e9, arrays),
    checkpoint=runfile.Checkpoint(b"new" * 1000, {**checkpoint.state, "rows": 999},
                                  checkpoint.statistics))
"""


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_killed_inside_a_commit_leaves_the_previous_state(runs, tmp_path):
    path = tmp_path / "crash.h5"
    _run_in_parts(runs["scenario"], path)
    before = _sha256(path)
    linked = sorted(p.name for p in bulk.parts_folder(path).iterdir())
    proc = subprocess.run([sys.executable, "-c", DIE_INSIDE_A_COMMIT, str(path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    assert _sha256(path) == before, "the run file is the state before the commit"
    left = sorted(p.name for p in bulk.parts_folder(path).iterdir())
    assert len(left) == len(linked) + 2, "the dead commit's two part files are left over"
    run = ringsim.open_run(path)
    assert run.n_snapshots == 4 and runfile.read_checkpoint(path).state["rows"] == 16
    runfile.set_attributes(path, status="stopped")   # any later commit removes them
    assert sorted(p.name for p in bulk.parts_folder(path).iterdir()) == linked


def test_missing_part_file_is_a_damaged_run_file(runs, tmp_path, capsys):
    path = tmp_path / "damaged.h5"
    _run_in_parts(runs["scenario"], path)
    victim = next(p for p in bulk.parts_folder(path).iterdir()
                  if p.name.startswith("snapshot_000001"))
    victim.unlink()
    with pytest.raises(runfile.RunFileError, match="damaged"):
        ringsim.open_run(path)
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0], err


def test_small_items_stay_in_the_run_file(runs):
    assert not bulk.parts_folder(runs["one"]).exists()
    with h5py.File(runs["one"], "r") as f:
        assert isinstance(f.get("snapshots/000001", getlink=True), h5py.HardLink)
        assert np.all(f["snapshots/000001/radius"][...] > 0)


def test_commit_thread_keeps_the_order_and_hands_over_errors():
    import time

    from ringsim.store.background import CommitThread

    writes, log = CommitThread(), []
    writes.submit(lambda: (time.sleep(0.05), log.append(1)))
    writes.submit(lambda: log.append(2))          # waits for the first
    writes.wait()
    assert log == [1, 2]

    def failing():
        raise OSError("No space left on device")

    writes.submit(failing)
    with pytest.raises(OSError, match="No space"):
        writes.submit(lambda: log.append(3))      # the next commit reports the failure ...
    assert log == [1, 2], "... and is not made after it"
    writes.submit(lambda: log.append(4), wait=True)
    assert log == [1, 2, 4]


def test_commit_thread_join_waits_without_raising():
    import time

    from ringsim.store.background import CommitThread

    writes, log = CommitThread(), []

    def slow_failure():
        time.sleep(0.05)
        log.append("written")
        raise OSError("late")

    writes.submit(slow_failure)
    writes.join()                     # leaving on another error: wait, do not mask it
    assert log == ["written"]
    with pytest.raises(OSError, match="late"):
        writes.wait()


def test_a_finished_run_is_packed_into_one_file(runs, tmp_path):
    # ringsim.run copies the part files of a finished run into the run file itself, so the
    # user keeps one file: same datasets as the run written in one file, no folder left
    path = tmp_path / "parts.h5"   # links name the folder after the file: same name
    path.write_bytes(runs["parts"].read_bytes())
    folder = bulk.parts_folder(runs["parts"])
    target = bulk.parts_folder(path)
    target.mkdir()
    for part in folder.iterdir():
        (target / part.name).write_bytes(part.read_bytes())
    assert runfile.pack(path) == 5     # 4 snapshots and the checkpoint (no spins)
    assert not target.exists()
    with h5py.File(path, "r") as f:
        assert not bulk.linked_parts(f)
        assert f["snapshots/000002/x"].compression == "gzip"
    one, packed = run_file_datasets(runs["one"]), run_file_datasets(path)
    assert one.keys() == packed.keys()
    for name in one:
        assert one[name] == packed[name], name
    assert runfile.read_checkpoint(path).binary == runfile.read_checkpoint(runs["parts"]).binary
    assert runfile.pack(path) == 0


def test_ringsim_run_leaves_no_part_files(tmp_path, monkeypatch, ring_scenario):
    # a run whose snapshots go into part files while it runs ends as one file
    monkeypatch.setattr(bulk, "EXTERNAL_BYTES", 0)   # every item in a part file
    sc = ring_scenario(PARTS)
    seen = []
    monkeypatch.setattr(runfile, "pack", lambda p, pack=runfile.pack: seen.append(pack(p)))
    path = ringsim.run(sc, output=tmp_path / "run.h5", progress=False)
    assert seen == [5] and not bulk.parts_folder(path).exists()
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "finished" and not bulk.linked_parts(f)
        assert len(f["snapshots"]) == 4
