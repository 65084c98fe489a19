"""The snags of a first day: a closed pipe, a sweep summary among run files, a stopped run,
progress in a log file, labelled sweep warnings, ``fit --model all`` without radii."""

import io
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest

import ringsim
from ringsim.cli import main
from ringsim.engine.progress import ProgressLog
from ringsim.physics import restitution as rs
from ringsim.store.runfile import set_attributes
from ringsim.sweep import PointTask, _LabelledStream, run_point


def _cli(*args, **kwargs) -> subprocess.CompletedProcess:
    """``python -m ringsim.cli`` run outside the source tree, so that it imports the
    installed ringsim (a clean checkout has no compiled extension)."""
    kwargs.setdefault("cwd", tempfile.gettempdir())
    return subprocess.run([sys.executable, "-m", "ringsim.cli", *args], capture_output=True,
                          text=True, timeout=300, **kwargs)


@pytest.fixture(scope="module")
def run_file(tmp_path_factory, line_scenario) -> Path:
    out = tmp_path_factory.mktemp("runs") / "small.h5"
    return ringsim.run(line_scenario(name="small"), output=out, progress=False)


def test_closed_stdout_still_writes_figures_and_json(run_file, tmp_path):
    figs, out = tmp_path / "figs", tmp_path / "eq.json"
    proc = subprocess.Popen([sys.executable, "-m", "ringsim.cli", "analyze", str(run_file),
                             "--plots", str(figs), "--json", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the first line (| head -0)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert json.loads(out.read_text())["name"] == "small"
    assert sorted(p.suffix for p in figs.iterdir()) and all(
        p.read_bytes()[:4] == b"\x89PNG" for p in figs.iterdir())


def test_head_after_two_lines(run_file, tmp_path):
    shell = (f"{sys.executable} -m ringsim.cli analyze {run_file} --plots {tmp_path / 'f'} "
             f"| head -n 2; echo status=${{PIPESTATUS[0]}}")
    done = subprocess.run(["bash", "-c", shell], capture_output=True, text=True, timeout=300)
    lines = done.stdout.splitlines()
    assert lines[-1] == "status=0" and len(lines) == 3, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    assert len(list((tmp_path / "f").glob("*.png"))) >= 3


def _fake_summary(path: Path) -> Path:
    with h5py.File(path, "w") as f:
        f.attrs["sweep_yaml"] = "base: small.yaml\ngrid: {seed: [1]}\n"
        f.attrs["units"] = "SI"
        f.create_dataset("seed", data=np.array([1]))
    return path


def test_compare_skips_a_sweep_summary_with_a_note(run_file, tmp_path, capsys):
    summary = _fake_summary(tmp_path / "summary.h5")
    out = tmp_path / "cmp.json"
    assert main(["compare", str(run_file), str(summary), str(run_file), "--json",
                 str(out)]) == 0
    captured = capsys.readouterr()
    assert f"skipping {summary}: a sweep summary" in captured.err
    assert out.exists()


def test_compare_of_only_summaries_is_bad_input(tmp_path, capsys):
    summary = _fake_summary(tmp_path / "summary.h5")
    assert main(["compare", str(summary)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"ringsim: error: {summary}: RUN.h5: only sweep summaries")


def test_analyze_header_says_status_and_warns_when_not_finished(run_file, tmp_path, capsys):
    assert main(["analyze", str(run_file)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("status: finished at orbit 0.301 of 0.3 (")
    assert "warning" not in captured.err
    stopped = tmp_path / "stopped.h5"
    stopped.write_bytes(run_file.read_bytes())
    set_attributes(stopped, status="stopped")
    assert main(["analyze", str(stopped)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("status: stopped at orbit 0.301 of 0.3 (")
    assert "is not finished: it was stopped" in captured.err and "--resume" in captured.err


def test_progress_in_a_log_is_plain_lines(tmp_path, line_scenario):
    scenario = tmp_path / "s.yaml"
    scenario.write_text(line_scenario(name="small").to_yaml())
    done = _cli("run", str(scenario), "-o", str(tmp_path / "r.h5"))  # stderr is a pipe
    assert done.returncode == 0, done.stderr
    assert "\r" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if "orbits (" in line]
    assert lines and lines[-1].startswith("small: 0.30/0.3 orbits (100%)"), done.stderr


def test_progress_log_writes_at_most_every_interval():
    stream = io.StringIO()
    log = ProgressLog("demo", total=10.0, initial=0.0, interval=3600.0, stream=stream)
    for _ in range(100):
        log.update(0.1)
    assert stream.getvalue() == "", "nothing before the interval has passed"
    log.set_postfix_str("5 coll/s")
    log.close()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 1 and lines[0].startswith("demo: 10.00/10 orbits (100%) after 0:00:0")
    assert lines[0].endswith(", 5 coll/s")
    every = ProgressLog("demo", total=10.0, initial=0.0, interval=0.0, stream=io.StringIO())
    for _ in range(3):
        every.update(1.0)
    assert len(every.stream.getvalue().splitlines()) == 3


def test_labelled_stream_prefixes_every_line():
    out = io.StringIO()
    stream = _LabelledStream(out, "seed=2.h5")
    stream.write("ringsim: WARNING: one\nringsim: two")
    stream.write(" continued\n")
    assert out.getvalue() == "seed=2.h5: ringsim: WARNING: one\nseed=2.h5: ringsim: two " \
                             "continued\n"


def test_sweep_point_warnings_carry_the_run_file_name(tmp_path, capfd, line_scenario):
    sc = line_scenario(name="hot", integration={"orbits": 0.1, "dt": 1.0e-3,
                                                "collision_detection": "tree"},
                       **{"sheet.initial_dispersion": 50.0})
    path = tmp_path / "seed=5.h5"
    task = PointTask(index=0, params={"seed": 5}, scenario=sc,
                     path=str(path), action="run")
    assert run_point(task).status == "finished"
    err = capfd.readouterr().err
    warnings = [line for line in err.splitlines() if "WARNING" in line]
    assert warnings and all(line.startswith("seed=5.h5: ringsim: WARNING") for line in warnings)


def _write_csv(path: Path, with_sizes: bool) -> Path:
    rng = np.random.default_rng(7)
    v = np.logspace(-4, -2, 30)
    eps = rs.bridges_epsilon(v, v_c=1e-4, exponent=0.25) + rng.normal(0, 0.005, v.size)
    eps = np.clip(eps, 0.0, 1.0)
    header = "v_m_s,R1_m,R2_m,M1_kg,M2_kg,epsilon" if with_sizes else "v_m_s,epsilon"
    rows = [f"{a:.6g},0.025,inf,0.06,inf,{e:.6f}" if with_sizes else f"{a:.6g},{e:.6f}"
            for a, e in zip(v, eps, strict=True)]
    path.write_text("# bridges-like synthetic data\n" + header + "\n" + "\n".join(rows) + "\n")
    return path


def test_fit_all_without_radii_fits_the_laws_that_need_none(tmp_path, capsys):
    data = _write_csv(tmp_path / "nosizes.csv", with_sizes=False)
    out = tmp_path / "fit.json"
    assert main(["fit", str(data), "--model", "all", "--json", str(out)]) == 0
    captured = capsys.readouterr()
    assert "skipped dilley: the file has no radius and mass columns" in captured.out
    fits = json.loads(out.read_text())
    assert sorted(f["model"] for f in fits) == ["andrews", "bridges", "constant", "tabor"]
    best = {f["model"]: f for f in fits}["bridges"]["parameters"]
    assert best["exponent"]["value"] == pytest.approx(0.25, abs=0.03)


def test_fit_dilley_without_radii_is_still_bad_input(tmp_path, capsys):
    data = _write_csv(tmp_path / "nosizes.csv", with_sizes=False)
    assert main(["fit", str(data), "--model", "dilley"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "R_bar_m" in err[0]


def test_fit_all_with_radii_fits_all_five(tmp_path, capsys):
    data = _write_csv(tmp_path / "sizes.csv", with_sizes=True)
    out = tmp_path / "fit.json"
    assert main(["fit", str(data), "--model", "all", "--json", str(out)]) in (0, 1)
    assert len(json.loads(out.read_text())) == 5
    assert "skipped" not in capsys.readouterr().out


def test_ringsim_alone_prints_the_help_and_succeeds(capsys):
    """``ringsim`` with no command lists the commands (exit 0), not an error."""
    assert main([]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: ringsim") and "study" in out and "analyze" in out


def test_a_run_file_given_to_run_points_to_analyze_and_resume(tmp_path, capsys):
    """``ringsim run RUN.h5``: exit 2, one line naming ``analyze`` and ``--resume``, and
    the file is left as it was."""
    path = tmp_path / "r.h5"
    with h5py.File(path, "w") as f:
        f.attrs["status"] = "finished"
    before = path.read_bytes()
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ringsim analyze" in err[0] and "--resume" in err[0]
    assert path.read_bytes() == before


def test_python_callers_are_told_the_python_keyword(tmp_path, line_scenario):
    """``ringsim.run`` on an existing file names ``force=True`` beside ``--force``."""
    path = tmp_path / "exists.h5"
    path.write_bytes(b"")
    with pytest.raises(ringsim.InputError, match=r"force=True"):
        ringsim.run(line_scenario(), output=path, progress=False)


def test_run_threads_option_gives_the_same_bits(tmp_path, line_scenario, capsys):
    """``ringsim run --threads 2`` stores the thread count in the run's scenario and writes
    the same datasets as the scenario's own count; ``--threads 0`` is bad input."""
    from ringsim.testing import run_file_datasets

    scenario_file = tmp_path / "line.yaml"
    scenario_file.write_text(line_scenario().to_yaml())
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    assert main(["run", str(scenario_file), "-o", str(one), "--no-progress"]) == 0
    assert main(["run", str(scenario_file), "-o", str(two), "--no-progress",
                 "--threads", "2"]) == 0
    assert ringsim.open_run(two).scenario.integration.threads == 2
    assert run_file_datasets(one) == run_file_datasets(two)
    capsys.readouterr()
    assert main(["run", str(scenario_file), "-o", str(tmp_path / "bad.h5"),
                 "--threads", "0"]) == 2
    assert "--threads" in capsys.readouterr().err
    assert not (tmp_path / "bad.h5").exists()
