"""`ringsim study`: a two-case, two-seed quick study of a tiny sheet, run once per module
(``reference``) and copied where a test changes files; reuse, a kill and resume, the report
from the summaries alone, the local pool against Dask, lengthened runs and bad study files.

Each run is a 200-particle sheet for 0.3 orbit in line mode (a few seconds).
"""

import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

import ringsim
from ringsim.cli import main
from ringsim.config.schema import ScenarioError
from ringsim.config.study import load_study
from ringsim.study import run_study
from ringsim.study.runs import run_id

SCENARIO = """\
name: tiny
seed: 1
planet: {Omega: 2.0e-4}
particles:
  density: 900.0
  size_distribution: {kind: powerlaw, q: 3.0, r_min: 0.5, r_max: 5.0}
sheet: {optical_depth: 0.25, n_particles: 300}
restitution: {model: dilley, xi0: 0.16, p: 0.65, kappa: 0.0}
integration: {orbits: 1.0, collision_detection: line}
output: {timeseries_every: 0.01, snapshot_every: 0.1, checkpoint_every: 0.05}
"""

STUDY = """\
name: tiny-kappa
description: kappa = 0.1 against kappa = 0 on a tiny sheet
base: tiny.yaml
seeds: [1, 2]
cases:
  k0: {}
  k01: {restitution.kappa: 0.1}
ratios: [[k01, k0]]
variants:
  half_dt: {integration.dt: 5.0e-4}
length: {orbits: 0.6}
quick:
  sheet.n_particles: 200
  length: {orbits: 0.3}
report: prose.md
"""

PROSE = "The prose of the tiny study, **spliced** into its report.\n"
COMMAND = "ringsim study study.yaml --quick"
N_RUNS = 6  # 2 cases x 2 seeds, and the variant of both cases with seed 1


def write_study(folder: Path, study: str = STUDY, scenario: str = SCENARIO) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tiny.yaml").write_text(scenario)
    (folder / "prose.md").write_text(PROSE)
    path = folder / "study.yaml"
    path.write_text(study)
    return path


def copy_study(reference: dict, target: Path, summaries: bool = True,
               runs: bool = False) -> Path:
    """The reference study's files in ``target``, with its summaries and run files if asked
    (never its report)."""
    write_study(target)
    if summaries:
        shutil.copytree(reference["folder"] / "summaries", target / "summaries")
    if runs:
        shutil.copytree(reference["out"] / "runs", target / "study.quick.report" / "runs")
    return target / "study.yaml"


def run_files(out: Path) -> dict:
    return {p.name: p.stat().st_mtime_ns for p in sorted((out / "runs").glob("*.h5"))}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The quick study run once in 2 local worker processes."""
    folder = tmp_path_factory.mktemp("study")
    path = write_study(folder)
    result = run_study(path, quick=True, workers=2, echo=None, command=COMMAND)
    assert len(result.results) == N_RUNS and not result.n_failed and not result.n_stopped
    out = folder / "study.quick.report"
    return {"folder": folder, "study": path, "out": out,
            "json": (out / "report.json").read_bytes(),
            "md": (out / "report.md").read_text()}


def test_report_holds_ratios_equilibria_and_no_machine_details(reference):
    report = json.loads(reference["json"])
    assert report["form"] == "quick" and report["seeds"] == [1, 2]
    assert report["variant_seeds"] == [1]
    ratios = report["ratios"]
    assert len(ratios) == 9, "one entry per table quantity"
    c = next(r for r in ratios if r["quantity"] == "velocity_dispersion")
    assert {"numerator", "denominator", "quantity", "mean", "stat", "syst",
            "units"} <= set(c)
    assert (c["numerator"], c["denominator"], c["units"]) == ("k01", "k0", "dimensionless")
    assert c["stat"] > 0 and c["syst"] > 0 and set(c["syst_parts"]) == {"half_dt"}
    eq = report["cases"]["k0"]["equilibrium"]["velocity_dispersion"]
    assert eq["units"] == "m/s" and eq["n_replicas"] == 2 and eq["stderr"] > 0
    assert eq["weighting"].startswith("number")
    assert [r["seed"] for r in report["cases"]["k01"]["runs"]] == [1, 2]
    text = reference["json"].decode()
    assert str(reference["folder"]) not in text and "cpu" not in text.lower()
    assert json.dumps(report, sort_keys=True, indent=1) + "\n" == text, "sorted keys"


def test_report_md_has_prose_tables_cost_version_and_command(reference):
    md = reference["md"]
    assert PROSE.strip() in md
    assert "## Equilibria" in md and "## Ratios" in md and "| k01 / k0 |" in md
    assert "CPU-hours" in md and f"ringsim {ringsim.__version__}" in md
    assert f"`{COMMAND}`" in md and "--report-only" in md
    png = reference["out"] / "ratios.png"
    assert png.read_bytes()[:4] == b"\x89PNG" and "(ratios.png)" in md


def test_second_run_reuses_every_run_and_writes_the_same_report(reference):
    out = reference["out"]
    before = run_files(out)
    assert len(before) == N_RUNS
    result = run_study(reference["study"], quick=True, workers=2, echo=None,
                       command=COMMAND)
    assert result.results == [], "every run has its summary: nothing runs"
    assert run_files(out) == before, "no run file touched"
    assert (out / "report.json").read_bytes() == reference["json"]
    assert (out / "report.md").read_text() == reference["md"]


def test_report_from_the_summaries_alone_is_the_same(reference, tmp_path):
    study = copy_study(reference, tmp_path / "copy", summaries=True, runs=False)
    result = run_study(study, quick=True, report_only=True, echo=None, command=COMMAND)
    out = tmp_path / "copy" / "study.quick.report"
    assert not (out / "runs").exists(), "no run file needed"
    assert [p.name for p in result.files] == ["report.json", "report.md", "ratios.png"]
    assert (out / "report.json").read_bytes() == reference["json"]
    assert (out / "report.md").read_text() == reference["md"]


def test_quick_prose_goes_into_the_quick_report_only(reference, tmp_path):
    """``quick.report``: prose of the quick form, after the study's own prose."""
    study = copy_study(reference, tmp_path / "copy", summaries=True, runs=False)
    (study.parent / "quick.md").write_text("What the **quick form** leaves out.\n")
    study.write_text(study.read_text().replace("  length: {orbits: 0.3}\n",
                                               "  length: {orbits: 0.3}\n"
                                               "  report: quick.md\n"))
    run_study(study, quick=True, report_only=True, echo=None, command=COMMAND)
    text = (study.parent / "study.quick.report" / "report.md").read_text()
    assert PROSE.strip() + "\n\nWhat the **quick form** leaves out." in text
    assert text == reference["md"].replace(
        PROSE.strip(), PROSE.strip() + "\n\nWhat the **quick form** leaves out.")
    study.write_text(study.read_text().replace("  report: quick.md\n",
                                               "  report: missing.md\n"))
    with pytest.raises(ScenarioError, match=r"quick\.report"):
        run_study(study, quick=True, report_only=True, echo=None, command=COMMAND)


def test_rerun_reproduces_the_summaries_except_their_cost(reference, tmp_path):
    """A case run again from nothing on the same machine: its summaries are the same but
    for ``cost``."""
    study = copy_study(reference, tmp_path / "again", summaries=False)
    # only case k0: the other runs' summaries are copied in
    spec = load_study(study).specs(quick=True)
    k0 = {run_id(s.scenario) for s in spec if s.case == "k0" and s.variant is None}
    (tmp_path / "again" / "summaries").mkdir()
    for path in (reference["folder"] / "summaries").iterdir():
        if path.stem not in k0:
            shutil.copy(path, tmp_path / "again" / "summaries")
    result = run_study(study, quick=True, workers=2, echo=None, command=COMMAND)
    assert {r.run_id for r in result.results} == k0
    for rid in k0:
        old = json.loads((reference["folder"] / "summaries" / f"{rid}.json").read_text())
        new = json.loads((tmp_path / "again" / "summaries" / f"{rid}.json").read_text())
        assert new.pop("cost")["cpu_time_s"] > 0
        old.pop("cost")
        assert new == old


def test_resummarise_remakes_summaries_from_run_files_and_keeps_their_cost(reference,
                                                                           tmp_path):
    """A summary tampered with (as one made by an older analysis) comes back as the run
    file gives it with --resummarise, its cost kept; without the flag it is left alone."""
    study = copy_study(reference, tmp_path / "re", runs=True)
    folder = tmp_path / "re" / "summaries"
    victim = sorted(folder.iterdir())[0]
    true = json.loads(victim.read_text())
    stale = dict(true, in_equilibrium=not true["in_equilibrium"], reason="older finder")
    stale["cost"] = {"cpu_time_s": 123.0, "run_wall_time_s": 45.0}
    victim.write_text(json.dumps(stale, sort_keys=True, indent=1) + "\n")
    result = run_study(study, quick=True, workers=1, echo=None, command=COMMAND)
    assert result.results == [] and json.loads(victim.read_text()) == stale
    result = run_study(study, quick=True, workers=2, echo=None, command=COMMAND,
                       resummarise=True)
    assert len(result.results) == N_RUNS and not result.n_failed
    assert {r.action for r in result.results} == {"reuse"}
    again = json.loads(victim.read_text())
    assert again.pop("cost") == stale["cost"]
    true.pop("cost")
    assert again == true


def _running_with_checkpoint(runs: Path) -> list[Path]:
    """Run files whose status is running and that hold a checkpoint before their end."""
    found = []
    for path in runs.glob("*.h5") if runs.exists() else []:
        try:
            with h5py.File(path, "r") as f:
                if (f.attrs.get("status") == "running" and "checkpoint" in f
                        and f["timeseries"]["t"].shape[0] < 20):
                    found.append(path)
        except (OSError, KeyError):
            continue  # being created: the next poll sees it
    return found


def _status(path: Path) -> str:
    with h5py.File(path, "r") as f:
        return str(f.attrs["status"])


@pytest.mark.parametrize("how", ["SIGKILL to the process group", "SIGTERM to the study"])
def test_killed_study_resumes_to_the_same_report(reference, tmp_path, how):
    """A crash (SIGKILL of the study and its workers) leaves runs ``running``; a SIGTERM to
    the study alone stops its workers' runs at a checkpoint (``stopped``, exit status 130).
    Started again, the study resumes them and writes the uninterrupted report."""
    study = copy_study(reference, tmp_path / "killed", summaries=False)
    out = tmp_path / "killed" / "study.quick.report"
    proc = subprocess.Popen([sys.executable, "-m", "ringsim.cli", "study", str(study),
                             "--quick", "--workers", "2"], cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    deadline = time.monotonic() + 180
    try:
        while not _running_with_checkpoint(out / "runs"):
            assert proc.poll() is None, "the study ended before it could be killed"
            assert time.monotonic() < deadline, "no run reached a checkpoint"
            time.sleep(0.02)
    finally:
        if how.startswith("SIGKILL") or proc.poll() is not None:
            os.killpg(proc.pid, signal.SIGKILL)  # the study and its workers, as a crash would
        else:
            proc.send_signal(signal.SIGTERM)
        status = proc.wait(timeout=120)
    left = {"SIGKILL": ("running", -signal.SIGKILL), "SIGTERM": ("stopped", 130)}
    expected_status, expected_exit = left[how.split()[0]]
    assert status == expected_exit
    assert expected_status in {_status(p) for p in (out / "runs").glob("*.h5")}
    result = run_study(study, quick=True, workers=2, echo=None, command=COMMAND)
    assert "resume" in {r.action for r in result.results}
    assert all(r.status == "finished" for r in result.results)
    assert (out / "report.json").read_bytes() == reference["json"]


@pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                    reason="dask.distributed is not installed (pip install ringsim[dask])")
def test_dask_cluster_gives_the_same_report(reference, tmp_path):
    from dask.distributed import LocalCluster

    study = copy_study(reference, tmp_path / "dask", summaries=False)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        result = run_study(study, quick=True, scheduler=cluster.scheduler_address, echo=None,
                           command=COMMAND)
    assert len(result.results) == N_RUNS and not result.n_failed
    out = tmp_path / "dask" / "study.quick.report"
    assert (out / "report.json").read_bytes() == reference["json"]


def test_longer_study_lengthens_the_runs_and_shorter_is_refused(reference, tmp_path, capsys):
    study = copy_study(reference, tmp_path / "long", summaries=True, runs=True)
    out = tmp_path / "long" / "study.quick.report"
    old_rows = {p.name: h5py.File(p, "r")["timeseries"]["t"][...] for p in
                (out / "runs").glob("*.h5")}
    study.write_text(STUDY.replace("length: {orbits: 0.3}", "length: {orbits: 0.4}"))
    result = run_study(study, quick=True, workers=2, echo=None, command=COMMAND)
    assert [r.action for r in result.results] == ["extend"] * N_RUNS
    for name, t in old_rows.items():  # the same runs, continued
        with h5py.File(out / "runs" / name, "r") as f:
            assert f.attrs["status"] == "finished" and f["timeseries"]["t"].shape[0] > t.size
            assert (f["timeseries"]["t"][:t.size] == t).all()
    report = json.loads((out / "report.json").read_text())
    assert all(r["orbits"] >= 0.4 for r in report["cases"]["k0"]["runs"])
    study.write_text(STUDY.replace("length: {orbits: 0.3}", "length: {orbits: 0.35}"))
    before = (out / "report.json").read_bytes()
    assert main(["study", str(study), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "summaries" in err[0] and "only ever lengthened" in err[0]
    assert (out / "report.json").read_bytes() == before


BAD = [
    ("ratio: [[k01, k0]]\n", "ratio", "did you mean 'ratios'"),
    ("ratios: [[k02, k0]]\n", "ratios.0", "unknown case 'k02'"),
    ("cases: {k0: {}, k01: {restitution.kapa: 0.1}}\n", "cases.k01.restitution.kapa",
     "did you mean 'kappa'"),
    ("cases: {k0: {seed: 3}, k01: {}}\n", "cases.k0.seed", "set by the study"),
    ("variants: {half_dt: {integration.dt: -1.0}}\n", "variants.half_dt.integration.dt", ""),
    ("seeds: [1, 1]\n", "seeds", "repeats"),
    ("length: {orbits: 0}\n", "length.orbits", "out of range"),
    ("length: {until_equilibrium: true, orbits: 5}\n", "length.orbits", "max_orbits"),
    ("quick: {lenght: {orbits: 0.3}}\n", "quick.lenght", "did you mean 'length'"),
    ("quick: {sheet.n_particle: 10}\n", "quick.sheet.n_particle", "n_particles"),
    ("base: nothere.yaml\n", "base", "no scenario file"),
    ("report: nothere.md\n", "report", "no file"),
    ("variant_seeds: [3]\n", "variant_seeds", "among the seeds"),
    ("quantities: [velocity_dispersoin]\n", "quantities", "did you mean"),
    ("name: a/b\n", "name", "cannot name"),
]


def _replace_key(text: str, line: str) -> str:
    """The study text with the top-level key of ``line`` (and the lines indented under it)
    replaced by ``line`` (``ratio`` replaces ``ratios``)."""
    key = line.split(":")[0]
    drop = {key, "ratios"} if key == "ratio" else {key}
    kept, dropping = [], False
    for row in text.splitlines(keepends=True):
        if not row.startswith(" "):
            dropping = row.split(":")[0] in drop
        if not dropping:
            kept.append(row)
    return "".join(kept) + line


def assert_refused(study: Path, capsys, key: str, words: str) -> None:
    """``ringsim study STUDY --quick`` on a bad study file: exit status 2, one line naming
    ``key`` of study.yaml and holding ``words``, no traceback, nothing written beside it."""
    out = study.parent / "out"
    assert main(["study", str(study), "--quick", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    assert f"study.yaml: {key}:" in err[0] and words in err[0], err[0]
    assert not out.exists() and not (study.parent / "summaries").exists(), "nothing written"


@pytest.mark.parametrize("line, key, words", BAD, ids=[b[1] for b in BAD])
def test_bad_study_file_is_bad_input(tmp_path, capsys, line, key, words):
    study = write_study(tmp_path, _replace_key(STUDY, line))
    assert_refused(study, capsys, key, words)


def test_overrides_valid_only_together_are_accepted_and_a_bad_one_is_named(tmp_path, capsys):
    # 5 particles alone make a box narrower than a 5 m particle; with r_max 1 m they do not
    together = "quick: {sheet.n_particles: 5, particles.size_distribution.r_max: 1.0}\n"
    study = load_study(write_study(tmp_path / "ok", _replace_key(STUDY, together)))
    (spec, *_) = study.specs(quick=True)
    assert spec.scenario.sheet.n_particles == 5
    assert spec.scenario.particles.size_distribution.r_max == 1.0
    alone = "quick: {sheet.n_particles: 5}\n"
    assert main(["study", str(write_study(tmp_path / "bad", _replace_key(STUDY, alone))),
                 "--quick"]) == 2
    assert "study.yaml: quick.sheet.n_particles:" in capsys.readouterr().err


def test_quick_without_a_quick_section_and_bad_options_are_bad_input(tmp_path, capsys):
    study = write_study(tmp_path, STUDY.split("quick:")[0] + "report: prose.md\n")
    assert main(["study", str(study), "--quick"]) == 2
    assert "study.yaml: quick:" in capsys.readouterr().err
    for option in ("--workers", "--threads"):
        assert main(["study", str(study), option, "0"]) == 2
        assert option in capsys.readouterr().err
    assert main(["study", str(study), "--report-only"]) == 2
    assert "no summary" in capsys.readouterr().err
    assert not (tmp_path / "study.report").exists()


def test_run_file_of_a_process_killed_before_its_first_output_is_run_again(reference,
                                                                           tmp_path):
    """A file as ``create`` leaves it (status running, no row, snapshot or checkpoint): the
    run is restarted, not refused as damaged."""
    study = copy_study(reference, tmp_path / "early", summaries=True, runs=True)
    out = tmp_path / "early" / "study.quick.report"
    victim = sorted((out / "runs").glob("*.h5"))[0]
    (tmp_path / "early" / "summaries" / f"{victim.stem}.json").unlink()
    with h5py.File(victim, "a") as f:
        for name in [n for n in f if n.startswith("checkpoint")]:
            del f[name]
        for name in list(f["snapshots"]):
            del f["snapshots"][name]
        for name in [n for n in f["timeseries"] if not n.endswith("edges")]:
            del f["timeseries"][name]
        f.attrs["status"] = "running"
    result = run_study(study, quick=True, workers=1, echo=None, command=COMMAND)
    assert [(r.run_id, r.action, r.status) for r in result.results] == \
        [(victim.stem, "restart", "finished")]
    assert (out / "report.json").read_bytes() == reference["json"]


def test_bundled_study_report_comes_back_from_its_committed_summaries(tmp_path):
    """studies/kappa-powerlaw: both forms are valid, and --report-only rewrites the committed
    quick report from the committed summaries (the same text but for the version that wrote
    it; ``ringsim study studies/kappa-powerlaw/study.yaml --quick --report-only`` brings it
    up to date)."""
    root = Path(__file__).resolve().parent.parent
    study = root / "studies" / "kappa-powerlaw" / "study.yaml"
    committed = study.parent / "study.quick.report"
    assert len(load_study(study).specs(quick=False)) == 12
    run_study(study, out=tmp_path, quick=True, report_only=True, echo=None,
              command="ringsim study studies/kappa-powerlaw/study.yaml --quick")
    old = json.loads((committed / "report.json").read_text())
    new = json.loads((tmp_path / "report.json").read_text())
    assert new.pop("ringsim_version") == ringsim.__version__
    version = old.pop("ringsim_version")
    assert new == old
    assert (tmp_path / "report.md").read_text() == (committed / "report.md").read_text(
        ).replace(f"ringsim {version} ", f"ringsim {ringsim.__version__} ")


def test_cost_of_a_run_with_only_its_last_sessions_is_a_lower_bound():
    """A run file begun before runs kept their CPU time and resumed since: its summary has
    ``cpu_time_s`` null and the measured part of its last sessions; the cost section
    shows the sum as a lower bound, and a run without either as not recorded."""
    from ringsim.study.markdown import cost_section

    summaries = {"a": {"cost": {"cpu_time_s": 7200.0}},
                 "b": {"cost": {"cpu_time_s": None, "cpu_time_s_part": 3600.0}},
                 "c": {"cost": {"cpu_time_s": None}}}
    report = {"cases": {"k0": {"runs": [{"run": "a"}]}, "k01": {"runs": [{"run": "b"}]},
                        "k02": {"runs": [{"run": "a"}, {"run": "c"}]}},
              "variants": {}}
    lines = cost_section(report, summaries)
    assert "| k0 | 1 | 2 |" in lines
    assert "| k01 | 1 | ≥ 1 (1 run(s): their last sessions only) |" in lines
    assert "| k02 | 2 | 2 (+ 1 run(s) not recorded) |" in lines
    total = next(line for line in lines if line.startswith("Total:"))
    assert total.startswith("Total: ≥ 3 CPU-hours for 3 distinct runs. 1 run(s) count only")


def test_cost_of_a_variant_counts_the_runs_it_shares_with_its_case_once():
    """A variant that does not change a case keeps that case's runs: its row names them as
    counted in the case's row instead of counting their CPU time a second time, and the
    total counts every distinct run once."""
    from ringsim.study.markdown import cost_section

    summaries = {"a": {"cost": {"cpu_time_s": 7200.0}},
                 "b": {"cost": {"cpu_time_s": 3600.0}},
                 "v": {"cost": {"cpu_time_s": 1800.0}}}
    report = {"cases": {"k0": {"runs": [{"run": "a"}]}, "k01": {"runs": [{"run": "b"}]}},
              "variants": {"box": {"runs": {"k0": [{"run": "v"}], "k01": [{"run": "b"}]}},
                           "both": {"runs": {"k0": [{"run": "a"}, {"run": "v"}]}}}}
    lines = cost_section(report, summaries)
    assert "| k0 [box] | 1 | 0.5 |" in lines
    assert "| k01 [box] | 1 | the runs of k01, counted in its row |" in lines
    assert "| k0 [both] | 2 | 0.5 (+ 1 run(s) of k0, counted in its row) |" in lines
    total = next(line for line in lines if line.startswith("Total:"))
    assert total == "Total: 3.5 CPU-hours for 3 distinct runs."


def test_an_error_at_the_round_off_of_its_value_is_shown_as_zero():
    """The seeds' scatter of a quantity every seed has alike (the geometric optical depth
    0.5 of three seeds: 4.5e-17) is round-off, shown as 0; an error above 1e-12 of the
    value is shown as it is, and so is any error of a zero value."""
    from ringsim.study.markdown import _pm

    assert _pm({"mean": 0.5, "stderr": 4.5e-17}) == "0.5 ± 0"
    assert _pm({"mean": 0.5, "stderr": 1e-11}) == "0.5 ± 1e-11"
    assert _pm({"mean": 0.0, "stderr": 1e-17}) == "0 ± 1e-17"
    assert _pm({"mean": 0.5, "stderr": None}) == "0.5 ± n/a"
