"""The case key ``start`` of a study file: a case whose runs start from another case's run.

A two-case quick study (no variants) of a tiny sheet (50 identical 1 m spheres, constant epsilon, no
self-gravity, line mode): ``small`` draws its particles and runs 0.1 orbit; ``long`` starts
from ``small``'s last snapshot tiled [1, 2] (a box twice as long in y) and runs on to
0.25 orbit of its clock.  Each run takes well under a second.
"""

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_study import assert_refused

from ringsim.cli import main
from ringsim.config.study import load_study
from ringsim.store.runfile import open_run
from ringsim.study import run_study
from ringsim.study.runs import collect
from ringsim.study.waves import plan_waves

SCENARIO = """\
name: tiny
seed: 1
planet: {Omega: 2.0e-4}
particles:
  density: 900.0
  size_distribution: {kind: monodisperse, radius: 1.0}
sheet: {optical_depth: 0.25, n_particles: 60}
restitution: {model: constant, epsilon: 0.5}
integration: {orbits: 1.0, collision_detection: line}
output: {timeseries_every: 0.01, snapshot_every: 0.05, checkpoint_every: 0.05}
"""

STUDY = """\
name: tiny-start
base: tiny.yaml
seeds: [1, 2]
cases:
  small: {}
  long: {start: {case: small, tile: [1, 2]}, integration.orbits: 0.25}
ratios: [[long, small]]
variants:
  eps: {restitution.epsilon: 0.6}
length: {orbits: 0.2}
quick:
  sheet.n_particles: 50
  length: {orbits: 0.1}
  variants: {}
"""


def write_study(folder: Path, study: str = STUDY) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tiny.yaml").write_text(SCENARIO)
    path = folder / "study.yaml"
    path.write_text(study)
    return path


def ids_by_label(study_path: Path, quick: bool = True) -> dict:
    """Run id of each spec label, and the runs (``study.runs.collect``)."""
    specs = load_study(study_path).specs(quick)
    runs, ids = collect(specs)
    return {spec.label: rid for spec, rid in zip(specs, ids, strict=True)}, runs


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The quick study run once with one worker process."""
    folder = tmp_path_factory.mktemp("start")
    path = write_study(folder)
    result = run_study(path, quick=True, workers=1, echo=None)
    assert len(result.results) == 4 and not result.n_failed and not result.n_stopped
    out = folder / "study.quick.report"
    return {"folder": folder, "study": path, "out": out,
            "json": (out / "report.json").read_bytes()}


def test_started_run_is_the_tiled_last_snapshot_of_its_origin(reference):
    labels, runs = ids_by_label(reference["study"])
    small = open_run(reference["out"] / "runs" / f"{labels['small seed 1']}.h5")
    long = open_run(reference["out"] / "runs" / f"{labels['long seed 1']}.h5")
    assert runs[labels["long seed 1"]].origin == labels["small seed 1"]
    assert long.scenario.sheet.initial_state.file == f"{labels['small seed 1']}.h5"
    a, b = small.snapshot(-1), long.snapshot(0)
    n = len(a["x"])
    assert n == 50 and len(b["x"]) == 2 * n, "tile [1, 2]: twice the particles"
    ly = float(small.attrs["Ly"])
    assert float(long.attrs["Ly"]) == pytest.approx(2 * ly, rel=1e-12)
    assert float(long.attrs["Lx"]) == pytest.approx(float(small.attrs["Lx"]), rel=1e-12)
    # Copies sit at (j - (n_y - 1) / 2) Ly along y (docs/scenario.md, tile): the first at
    # -Ly/2, the second at +Ly/2; everything else is the snapshot's, bit for bit.
    for key in ("x", "z", "vx", "vy", "vz", "radius", "mass"):
        assert np.array_equal(b[key][:n], a[key]) and np.array_equal(b[key][n:], a[key])
    np.testing.assert_allclose(b["y"][:n], a["y"] - ly / 2, rtol=0, atol=1e-9 * ly)
    np.testing.assert_allclose(b["y"][n:], a["y"] + ly / 2, rtol=0, atol=1e-9 * ly)
    assert long.attrs["status"] == "finished" and long.n_snapshots >= 2


def test_variant_of_a_started_case_starts_from_the_same_variant(reference):
    labels, runs = ids_by_label(reference["study"], quick=False)
    assert runs[labels["long [eps] seed 1"]].origin == labels["small [eps] seed 1"]
    report = json.loads(reference["json"])
    assert report["cases"]["long"]["start"] == {"case": "small", "seed": None,
                                                "snapshot": -1, "tile": [1, 2]}
    assert "start" not in report["cases"]["small"]


def test_rerun_reuses_every_run_and_report_only_needs_no_run_file(reference, tmp_path):
    before = {p.name: p.stat().st_mtime_ns for p in (reference["out"] / "runs").glob("*.h5")}
    again = run_study(reference["study"], quick=True, workers=1, echo=None)
    assert again.results == [], "nothing run again"
    assert (reference["out"] / "report.json").read_bytes() == reference["json"]
    after = {p.name: p.stat().st_mtime_ns for p in (reference["out"] / "runs").glob("*.h5")}
    assert after == before
    # Elsewhere, with the summaries only: the same ids, the same bytes.
    copy = write_study(tmp_path / "elsewhere")
    shutil.copytree(reference["folder"] / "summaries", tmp_path / "elsewhere" / "summaries")
    run_study(copy, quick=True, report_only=True, echo=None)
    assert (tmp_path / "elsewhere" / "study.quick.report" / "report.json").read_bytes() \
        == reference["json"]


def test_run_files_moved_elsewhere_are_found_and_a_started_run_remade_there(reference,
                                                                         tmp_path):
    """Another folder and --out: the run files are compared by scenario (no path in
    them), and a started run made again finds its start file beside it; the same
    report."""
    copy = write_study(tmp_path / "moved")
    labels, _ = ids_by_label(copy)
    gone = labels["long seed 1"]
    shutil.copytree(reference["folder"] / "summaries", tmp_path / "moved" / "summaries")
    (tmp_path / "moved" / "summaries" / f"{gone}.json").unlink()
    out = tmp_path / "elsewhere"
    shutil.copytree(reference["out"] / "runs", out / "runs")
    (out / "runs" / f"{gone}.h5").unlink()
    result = run_study(copy, out=out, quick=True, workers=1, echo=None)
    assert [(r.run_id, r.action, r.status) for r in result.results] == \
        [(gone, "run", "finished")]
    assert (out / "report.json").read_bytes() == reference["json"]


def test_a_started_gravitating_case_shows_its_runs_optical_depth():
    """A started run's scenario has no sheet.optical_depth: "Against Cassini" describes the
    case by the run's own optical depth (the summary's, as analyze gives it)."""
    from ringsim.study.cassini import describe_case

    summary = {"optical_depth": 0.4987,
               "scenario": {"particles": {"size_distribution": {"kind": "monodisperse",
                                                                "radius": 1.0}},
                            "restitution": {"model": "bridges"},
                            "sheet": {"gravity": True, "initial_state": {"file": "a.h5"}}}}
    entry = describe_case(summary)
    assert entry["optical_depth"] == 0.4987 and entry["gravity"] is True
    summary["scenario"]["sheet"]["optical_depth"] = 0.5
    assert describe_case(summary)["optical_depth"] == 0.5, "the scenario's, when it has one"


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                    reason="dask.distributed is not installed (pip install ringsim[dask])")
def test_dask_cluster_runs_the_waves_and_gives_the_same_report(reference, tmp_path):
    from dask.distributed import LocalCluster

    study = write_study(tmp_path / "dask")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        result = run_study(study, quick=True, scheduler=cluster.scheduler_address, echo=None)
    assert [r.status for r in result.results] == ["finished"] * 4
    labels, _ = ids_by_label(study)
    first = {labels["small seed 1"], labels["small seed 2"]}
    assert {r.run_id for r in result.results[:2]} == first, "the origins in the first wave"
    out = tmp_path / "dask" / "study.quick.report"
    assert (out / "report.json").read_bytes() == reference["json"]


def test_an_origin_whose_file_is_gone_is_made_again_first(reference, tmp_path):
    """Only the origins' summaries are left: the started runs need their files, so the
    origins are made again in the first wave, the started runs in the second."""
    copy = write_study(tmp_path / "copy")
    labels, runs = ids_by_label(copy)
    (tmp_path / "copy" / "summaries").mkdir()
    for rid, run in runs.items():
        if run.origin is None:
            shutil.copy(reference["folder"] / "summaries" / f"{rid}.json",
                        tmp_path / "copy" / "summaries")
    waves = plan_waves(runs, tmp_path / "copy" / "out" / "runs",
                       tmp_path / "copy" / "summaries")
    assert [[t.action for t in wave] for wave in waves] == [["run"] * 2, ["run"] * 2]
    assert {t.run_id for t in waves[0]} == {rid for rid, r in runs.items() if r.origin is None}


def test_lengthened_origin_gives_a_new_started_run(tmp_path):
    labels, _ = ids_by_label(write_study(tmp_path / "a"))
    longer, _ = ids_by_label(write_study(tmp_path / "b", STUDY.replace(
        "length: {orbits: 0.1}", "length: {orbits: 0.15}")))
    assert longer["small seed 1"] == labels["small seed 1"], "the same run, lengthened"
    assert longer["long seed 1"] != labels["long seed 1"], "starts from another snapshot"


def test_fixed_seed_starts_every_seed_from_one_run(tmp_path):
    labels, runs = ids_by_label(write_study(tmp_path, STUDY.replace(
        "{case: small, tile: [1, 2]}", "{case: small, seed: 2, snapshot: 1}")))
    assert runs[labels["long seed 1"]].origin == runs[labels["long seed 2"]].origin \
        == labels["small seed 2"]
    assert labels["long seed 1"] != labels["long seed 2"], "the seed is the run's own"


@pytest.mark.parametrize("start, key, words", [
    ("{case: smal}", "cases.long.start.case", "did you mean 'small'"),
    ("{case: long}", "cases.long.start.case", "starts from itself"),
    ("{case: small, tile: [0, 2]}", "cases.long.start.tile", "[0, 2]"),
    ("{case: small, tile: [1, 17]}", "cases.long.start.tile", "[1, 17]"),
    ("{case: small, tiles: [1, 2]}", "cases.long.start.tiles", "tile"),
    ("{case: small}, sheet.n_particles: 100", "cases.long.sheet.n_particles",
     "given with start"),
    ("{case: small}, sheet.initial_state: {file: x.h5}", "cases.long.sheet.initial_state",
     "given with start"),
])
def test_bad_start_is_bad_input(tmp_path, capsys, start, key, words):
    text = STUDY.replace("{case: small, tile: [1, 2]}", start)
    study = write_study(tmp_path, text)
    assert_refused(study, capsys, key, words)


def test_a_cycle_of_starts_is_bad_input(tmp_path, capsys):
    text = STUDY.replace("  small: {}", "  small: {start: {case: long}}")
    study = write_study(tmp_path, text)
    assert main(["study", str(study), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "study.yaml: cases.small.start:" in err[0], err
    assert "cycle: small -> long -> small" in err[0], err[0]
