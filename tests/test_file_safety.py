"""What ringsim writes, reads and refuses (docs/interface.md): its own files only, never
through a link; no output over an input or over an existing file without --force; no link
out of a run file; no array larger than the run; checkpoint attributes checked.

Each case ends with exit status 2, one line on stderr naming the file, and every file
outside the run's own left byte for byte as it was (SHA-256 before and after).
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.errors import InputError
from ringsim.store import bulk, contents, paths, runfile
from ringsim.store.lock import lock_path

#: A tiny ring (60 particles, 0.2 orbit) as in tests/test_hardening.py.
TINY = {"name": "tiny", "seed": 11, "particles.size_distribution.r_max": 2.0,
        "sheet.n_particles": 60, "restitution.kappa": 0.1, "integration.orbits": 0.2}


@pytest.fixture(scope="module")
def good(tmp_path_factory, ring_scenario):
    """A finished tiny run and the scenario file that made it."""
    folder = tmp_path_factory.mktemp("safety")
    sc = ring_scenario(TINY)
    scenario_file = folder / "tiny.yaml"
    scenario_file.write_text(sc.to_yaml())
    path = ringsim.run(sc, output=folder / "good.h5", progress=False)
    return {"path": path, "scenario_file": scenario_file}


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _victim(tmp_path: Path) -> Path:
    """A folder of files ringsim has no business with."""
    folder = tmp_path / "victim"
    folder.mkdir()
    for name in ("thesis.tex", "data.h5", "checkpoint_0123456789ab.h5"):
        (folder / name).write_text(f"precious {name}\n")
    return folder


def _snapshot_of(folder: Path) -> dict[str, str]:
    return {p.name: sha256(p) for p in sorted(folder.iterdir())}


def _bad_input(capsys, status: int, *words: str) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert status == 2, captured.err
    assert "Traceback" not in captured.err + captured.out
    assert len(lines) == 1, lines
    for word in words:
        assert word in lines[0], lines
    return lines[0]


def _run(good, out: Path, *options: str) -> int:
    return main(["run", str(good["scenario_file"]), "-o", str(out), "--no-progress",
                 *options])


# --- D1: ringsim's own files, never through a link ----------------------------------------------

@pytest.mark.parametrize("role", ["parts", "lock", "tmp"])
@pytest.mark.parametrize("mode", ["new", "force", "resume"])
def test_a_link_in_place_of_an_own_file_is_refused(good, tmp_path, capsys, role, mode):
    """A run (new, --force, --resume) refuses a symbolic link in place of RUN.h5.parts,
    RUN.h5.lock or RUN.h5.tmp, which would otherwise let a commit empty the folder a parts
    link names or overwrite the target of a lock or tmp link."""
    victim = _victim(tmp_path)
    out = tmp_path / "run.h5"
    if mode != "new":
        shutil.copyfile(good["path"], out)
    target = victim if role == "parts" else victim / "thesis.tex"
    link = out.with_name(f"{out.name}.{role}")
    link.symlink_to(target)
    before = _snapshot_of(victim)
    run_before = sha256(out) if out.exists() else None
    status = _run(good, out, *{"new": (), "force": ("--force",),
                               "resume": ("--resume",)}[mode])
    _bad_input(capsys, status, str(link), "symbolic link")
    assert _snapshot_of(victim) == before, "a file outside the run was changed"
    assert link.is_symlink(), "the link itself is left as it was"
    assert (sha256(out) if out.exists() else None) == run_before


def test_the_run_file_itself_as_a_link_is_refused(good, tmp_path, capsys):
    victim = _victim(tmp_path)
    shutil.copyfile(good["path"], victim / "data.h5")   # a run file, but behind a link
    before = _snapshot_of(victim)
    out = tmp_path / "run.h5"
    out.symlink_to(victim / "data.h5")
    for options in (("--force",), ("--resume",)):
        _bad_input(capsys, _run(good, out, *options), str(out), "symbolic link")
    assert _snapshot_of(victim) == before and out.is_symlink()


def test_force_replaces_only_a_run_file(good, tmp_path, capsys):
    """-o SCENARIO --force, -o a FIFO (a non-regular file, as /dev/null is) and -o an HDF5
    file that is not a run file are refused; a run file is replaced."""
    scenario = tmp_path / "s.yaml"
    shutil.copyfile(good["scenario_file"], scenario)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["data"] = np.arange(5.0)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for target, words in ((scenario, "not a ringsim run file"),
                          (other, "not a ringsim run file"),
                          (fifo, "not a regular file")):
        before = None if target == fifo else sha256(target)
        status = main(["run", str(scenario), "-o", str(target), "--force", "--no-progress"])
        _bad_input(capsys, status, str(target), words)
        assert before is None or sha256(target) == before
        assert not lock_path(target).exists()
    assert Path(fifo).is_fifo()
    run_copy = tmp_path / "old.h5"
    shutil.copyfile(good["path"], run_copy)
    assert main(["run", str(scenario), "-o", str(run_copy), "--force", "--no-progress"]) == 0


def test_dev_null_is_never_replaced():
    """-o /dev/null --force is refused (as root, a replacement would turn the device node
    into a regular file).
    The check alone is called: a regression must not replace the machine's /dev/null (the
    run path is covered by the FIFO above)."""
    with pytest.raises(InputError, match="not a regular file"):
        paths.check_replaceable(os.devnull)
    assert Path(os.devnull).is_char_device()


def test_only_own_part_files_are_removed(good, tmp_path):
    """A commit removes part files it no longer links, and nothing else of the folder."""
    out = tmp_path / "run.h5"
    shutil.copyfile(good["path"], out)
    folder = bulk.parts_folder(out)
    folder.mkdir()
    (folder / "notes.txt").write_text("mine\n")
    stale = folder / "checkpoint_0123456789ab.h5"
    stale.write_bytes(b"left by a commit that did not happen")
    runfile.set_attributes(out, status="finished")
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]


# --- D4: outputs never over inputs, existing ones only with --force -------------------------------

def test_json_over_the_run_file_is_refused(good, tmp_path, capsys):
    run = tmp_path / "r.h5"
    shutil.copyfile(good["path"], run)
    alias = tmp_path / "alias.json"
    os.link(run, alias)                  # the same file under another name
    before = sha256(run)
    for argv in (["analyze", str(run), "--json", str(run)],
                 ["analyze", str(run), "--json", str(alias), "--force"],
                 ["compare", str(run), str(good["path"]), "--json", str(run), "--force"],
                 ["compare", str(good["path"]), str(run), "--json", str(alias)],
                 ["export", str(run), "--csv", str(tmp_path / "x.csv"), "--rebound",
                  str(alias), "--force"]):
        line = _bad_input(capsys, main(argv), "is an input of this command")
        assert str(run) in line or str(alias) in line
        assert sha256(run) == before
    assert not (tmp_path / "x.csv").exists(), "nothing written after a refusal"


def test_existing_outputs_need_force(good, tmp_path, capsys):
    for argv, target in ((["analyze", str(good["path"]), "--json"], "eq.json"),
                         (["compare", str(good["path"]), "--json"], "cmp.json"),
                         (["export", str(good["path"]), "--csv"], "snap.csv"),
                         (["epsilon", "--json"], "eps.json")):
        out = tmp_path / target
        out.write_text("keep me\n")
        _bad_input(capsys, main([*argv, str(out)]), str(out), "--force")
        assert out.read_text() == "keep me\n"
        assert main([*argv, str(out), "--force"]) == 0
        capsys.readouterr()
        assert out.read_text() != "keep me\n"


def test_missing_output_folders_are_made_and_a_file_in_the_path_is_refused(good, tmp_path,
                                                                            capsys):
    # docs/interface.md "Output folders": made as mkdir -p makes them
    for argv, target in ((["analyze", str(good["path"]), "--json"], "a/b/eq.json"),
                         (["observe", str(good["path"]), "--elevation", "30", "--azimuth",
                           "0", "--rays", "100", "--json"], "c/d/obs.json"),
                         (["epsilon", "--json"], "e/eps.json")):
        out = tmp_path / target
        assert main([*argv, str(out)]) == 0
        capsys.readouterr()
        assert out.stat().st_size > 0
    blocker = tmp_path / "afile"
    blocker.write_text("keep me\n")
    before = sorted(tmp_path.rglob("*"))
    _bad_input(capsys, main(["analyze", str(good["path"]), "--json",
                             str(blocker / "eq.json")]), "afile is not a folder")
    assert sorted(tmp_path.rglob("*")) == before and blocker.read_text() == "keep me\n"


def test_plots_folder_may_not_be_an_input(good, tmp_path, capsys):
    run = tmp_path / "r.h5"
    shutil.copyfile(good["path"], run)
    before = sha256(run)
    _bad_input(capsys, main(["analyze", str(run), "--plots", str(run)]), str(run))
    assert sha256(run) == before


# --- D2: links in a run file ----------------------------------------------------------------------

def _outside(tmp_path: Path) -> Path:
    """An HDF5 file outside the run, shaped like a snapshot of 3 particles."""
    path = tmp_path / "outside" / "secret.h5"
    path.parent.mkdir()
    with h5py.File(path, "w") as f:
        f.attrs["t"] = 0.0
        for name in bulk.SNAPSHOT_FIELDS:
            f[name] = np.full(3, 42.0)
        f["checkpoint"] = np.zeros(10, np.uint8)
    return path


def _with_link(good, tmp_path: Path, make_link) -> Path:
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    with h5py.File(bad, "a") as f:
        make_link(f, _outside(tmp_path))
    return bad


def _put(group: h5py.Group, name: str, link) -> None:
    if name in group:
        del group[name]
    group[name] = link


LINKS = {
    "absolute": lambda f, out: _put(f["snapshots"], "000002", h5py.ExternalLink(str(out), "/")),
    "dot-dot": lambda f, out: _put(f["snapshots"], "000002",
                                   h5py.ExternalLink("outside/../outside/secret.h5", "/")),
    "parts-dot-dot": lambda f, out: _put(
        f["snapshots"], "000002", h5py.ExternalLink("run.h5.parts/../outside/secret.h5", "/")),
    "checkpoint": lambda f, out: _put(f, "checkpoint", h5py.ExternalLink(str(out),
                                                                         "/checkpoint")),
    "soft-to-external": lambda f, out: (
        _put(f, "elsewhere", h5py.ExternalLink(str(out), "/")),
        _put(f["snapshots"], "000002", h5py.SoftLink("/elsewhere"))),
    "soft-dangling": lambda f, out: _put(f["snapshots"], "000002",
                                         h5py.SoftLink("/nowhere/000002")),
}


@pytest.mark.parametrize("kind", list(LINKS))
@pytest.mark.parametrize("command", ["analyze", "export", "resume"])
def test_links_out_of_the_run_file_are_refused(good, tmp_path, capsys, kind, command):
    """Links that leave the run file are refused, so that analyze and export never read
    the outside file, export never writes its values to CSV, and --resume never packs it
    into the run."""
    bad = _with_link(good, tmp_path, LINKS[kind])
    before = sha256(bad)
    csv = tmp_path / "snap.csv"
    argv = {"analyze": ["analyze", str(bad)],
            "export": ["export", str(bad), "--snapshot", "2", "--csv", str(csv)],
            "resume": ["run", str(good["scenario_file"]), "-o", str(bad), "--resume",
                       "--no-progress"]}[command]
    _bad_input(capsys, main(argv), str(bad), "refused")
    assert sha256(bad) == before and not csv.exists()


def test_a_snapshot_read_checks_its_links_again(good, tmp_path):
    """A snapshot is read from the file as it is then: a link put in after the run was
    opened is refused too."""
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    run = ringsim.open_run(bad)
    with h5py.File(bad, "a") as f:
        LINKS["absolute"](f, _outside(tmp_path))
    assert run.snapshot(1)["x"].size == 60
    with pytest.raises(runfile.RunFileError, match="/snapshots/000002: an external link"):
        run.snapshot(2)


def test_a_part_file_that_is_a_link_is_refused(good, tmp_path, capsys):
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    folder = bulk.parts_folder(bad)
    folder.mkdir()
    name = "snapshot_000002_0123456789ab.h5"
    (folder / name).symlink_to(_outside(tmp_path))
    with h5py.File(bad, "a") as f:
        del f["snapshots/000002"]
        f["snapshots/000002"] = h5py.ExternalLink(f"{folder.name}/{name}", "/")
    _bad_input(capsys, main(["export", str(bad), "--csv", str(tmp_path / "s.csv")]),
               str(bad), "symbolic link")


# --- D2: array sizes --------------------------------------------------------------------------

def test_export_checks_the_particle_count(good, tmp_path, capsys):
    """A snapshot of 61 particles in a run of 60 is refused, not exported as 61 rows."""
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    with h5py.File(bad, "a") as f:
        g = f["snapshots/000001"]
        for name in bulk.SNAPSHOT_FIELDS:
            values = g[name][...]
            del g[name]
            g[name] = np.append(values, values[:1])
    csv = tmp_path / "s.csv"
    _bad_input(capsys, main(["export", str(bad), "--snapshot", "1", "--csv", str(csv)]),
               str(bad), "/snapshots/000001/x", "61 particles, the run 60")
    assert not csv.exists()


def test_a_declared_giant_array_is_refused_before_it_is_read(good, tmp_path, capsys):
    """A guard column declaring MAX_ROWS + 1 rows (a few bytes of the file, 800 MB once
    read): refused from its shape."""
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    with h5py.File(bad, "a") as f:
        del f["guards/orbits"]
        f["guards"].create_dataset("orbits", shape=(contents.MAX_ROWS + 1,), dtype="f8",
                                   chunks=(1024,))
    _bad_input(capsys, main(["analyze", str(bad)]), str(bad), "/guards/orbits")


# --- D9: checkpoint attributes ----------------------------------------------------------------

CHECKPOINT_ATTRIBUTES = {
    "root_size": (-1.0, "root_size"),
    "N_root_x": (1.0e9, "N_root_x"),
    "N_root_x-int": (10**9, "N_root_x"),
    "rows": (3.7, "rows"),
    "rows-too-many": (10**6, "rows"),
    "rand_seed": (-5, "rand_seed"),
    "t": (float("nan"), "/checkpoint t"),
}


@pytest.mark.parametrize("case", list(CHECKPOINT_ATTRIBUTES))
def test_bad_checkpoint_attributes_refuse_resume(good, tmp_path, capsys, case):
    """Bad checkpoint attributes refuse --resume: otherwise root_size = -1 turns a finished
    file back to running, N_root_x = 1e9 gives no optical-depth rows and rows = 3.7
    repeats rows."""
    value, words = CHECKPOINT_ATTRIBUTES[case]
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    with h5py.File(bad, "a") as f:
        f["checkpoint"].attrs[case.split("-")[0]] = value
    before = sha256(bad)
    _bad_input(capsys, _run(good, bad, "--resume"), str(bad), words)
    assert sha256(bad) == before


def test_an_inconsistent_box_is_refused(good, tmp_path, capsys):
    """root_size and N_root_x that do not give the box's Lx."""
    bad = tmp_path / "run.h5"
    shutil.copyfile(good["path"], bad)
    with h5py.File(bad, "a") as f:
        f["checkpoint"].attrs["root_size"] = 0.5 * float(f["checkpoint"].attrs["root_size"])
    _bad_input(capsys, _run(good, bad, "--resume"), str(bad), "N_root_x", "Lx")


def test_a_good_checkpoint_passes_every_check(good):
    """The checks accept what ringsim writes (read_checkpoint runs all of them)."""
    checkpoint = runfile.read_checkpoint(good["path"])
    assert checkpoint is not None and checkpoint.state["n_particles"] == 60


SWEEP_TEXT = "base: s.yaml\ngrid:\n  seed: [1, 2]\n"
STUDY_TEXT = "name: t\nbase: s.yaml\nseeds: [1]\ncases: {a: {}}\n"


@pytest.mark.parametrize("command, text, option", [
    ("sweep", SWEEP_TEXT, "--out"), ("sweep", SWEEP_TEXT, "--plots"),
    ("study", STUDY_TEXT, "--out")])   # a study has no --plots
def test_a_sweep_or_study_never_writes_its_folders_over_its_file(tmp_path, capsys, command,
                                                                  text, option):
    (tmp_path / "s.yaml").write_text("name: s\n")
    source = tmp_path / f"{command}.yaml"
    source.write_text(text)
    before = source.read_bytes()
    assert main([command, str(source), option, str(source)]) == 2
    line = _bad_input(capsys, 2, option)
    assert "is an input" in line or "not a folder" in line
    assert source.read_bytes() == before


def test_a_plots_folder_with_figures_needs_force(good, tmp_path, capsys):
    """D1/D4: --plots DIR is a target like --json: a folder that holds figures already is
    written into only with --force, and the figures are left as they were without it."""
    figs = tmp_path / "figs"
    assert main(["analyze", str(good["path"]), "--plots", str(figs)]) == 0
    capsys.readouterr()
    before = _snapshot_of(figs)
    assert before, "analyze wrote figures"
    _bad_input(capsys, main(["analyze", str(good["path"]), "--plots", str(figs)]), "--plots",
               "--force")
    assert _snapshot_of(figs) == before
    assert main(["analyze", str(good["path"]), "--plots", str(figs), "--force"]) == 0
