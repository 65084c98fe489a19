"""Bounded work on any input (issue 43, items 3 and 7): hostile or absurd values end in
exit status 2 with one line naming the key or file, quickly, with nothing written; a run
that fails inside the loop leaves its file ``failed`` with the reason.

Each case here hung ringsim, exhausted its memory or ended in exit status 1 with a
traceback's last line before `config.bounds`, `config.intervals`, `engine.memory`,
`engine.failure`, `store.run_checks` and the output checks of `store.paths` existed.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from ringsim.cli import main
from ringsim.config.bounds import MAX_DEPTH, MAX_VALUES
from ringsim.config.intervals import AUTO_DT_MAX_ORBITS
from ringsim.config.scenario import scenario_from_text
from ringsim.config.schema import ScenarioError
from ringsim.engine.memory import BYTES_PER_PARTICLE, check_particle_memory
from ringsim.errors import InputError, clip, excerpt

#: A tiny ring: 40 particles of 1-2 m, 0.02 orbit, a row every 0.01 orbit.
TINY = {
    "name": "tiny", "seed": 1, "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0, "size_distribution": {
        "kind": "powerlaw", "q": 3.0, "r_min": 1.0, "r_max": 2.0}},
    "sheet": {"optical_depth": 0.25, "n_particles": 40},
    "integration": {"orbits": 0.02},
    "output": {"timeseries_every": 0.01, "snapshot_every": 0.02},
}
#: Seconds a refusal may take on a loaded machine; each case hung for minutes (alias
#: bombs: more than 120 s at 5.9 GB, issue 43) or never ended before.
QUICK_S = 20.0


def _text(**changes) -> str:
    """TINY as YAML with dotted keys replaced (value None: the key removed)."""
    d = yaml.safe_load(yaml.safe_dump(TINY))
    for dotted, value in changes.items():
        *parents, leaf = dotted.split(".")
        node = d
        for part in parents:
            node = node.setdefault(part, {})
        if value is None:
            node.pop(leaf, None)
        else:
            node[leaf] = value
    return yaml.safe_dump(d, sort_keys=False)


def _listing(folder: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``folder`` with its size and modification time."""
    return {str(p.relative_to(folder)): (p.lstat().st_size, p.lstat().st_mtime_ns)
            for p in sorted(folder.rglob("*"))}


def _bad_input(capsys, folder: Path, argv: list[str], names: str) -> str:
    """Run the command line: exit 2 within QUICK_S, one line naming ``names``, no file
    under ``folder`` created or changed; returns the line."""
    before = _listing(folder)
    start = time.perf_counter()
    status = main(argv)
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    assert names in lines[0], lines[0]
    assert len(lines[0]) < 500, f"the line is {len(lines[0])} characters long"
    assert elapsed < QUICK_S, f"{elapsed:.1f} s to refuse"
    assert _listing(folder) == before, "bad input must write nothing"
    return lines[0]


def _run(capsys, folder: Path, text: str, names: str, *extra: str) -> str:
    scenario = folder / "s.yaml"
    scenario.write_text(text)
    return _bad_input(capsys, folder, ["run", str(scenario), "-o", str(folder / "out.h5"),
                                       "--no-progress", *extra], names)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A finished run of TINY and a CSV of its last snapshot (with its time)."""
    folder = tmp_path_factory.mktemp("tiny")
    scenario = folder / "tiny.yaml"
    scenario.write_text(_text())
    run = folder / "tiny.h5"
    assert main(["run", str(scenario), "-o", str(run), "--no-progress"]) == 0
    csv = folder / "tiny.csv"
    assert main(["export", str(run), "--csv", str(csv)]) == 0
    t = float(csv.read_text().splitlines()[1].split("t = ")[1].split(" s")[0])
    return {"run": run, "csv": csv, "t": t}


# --- D3: YAML alias bombs and bounded error messages ------------------------------------------

def _bomb(levels: int = 10) -> dict:
    """A 'billion laughs' value: ``levels`` levels of ten-fold aliases (10^levels strings
    from a few hundred characters), as a flow mapping text."""
    lines = ['l0: &l0 "lol"']
    lines += [f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 10) + "]"
              for i in range(1, levels + 1)]
    return "{" + ", ".join(lines) + "}"


@pytest.mark.parametrize("key", ["description", "seed", "planet.Omega"])
def test_alias_bomb_in_a_scenario_is_refused_quickly(capsys, tmp_path, key):
    text = _text(**{key: "BOMB"}).replace("BOMB", _bomb())
    line = _run(capsys, tmp_path, text, f": {key}.")
    assert "aliases" in line and str(MAX_VALUES) in line


def test_alias_bomb_in_a_sweep_and_a_study_file_is_refused(capsys, tmp_path):
    (tmp_path / "base.yaml").write_text(_text())
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(f"base: base.yaml\ngrid: {{seed: [1, 2]}}\ncolour: {_bomb()}\n")
    _bad_input(capsys, tmp_path, ["sweep", str(sweep), "--out", str(tmp_path / "o")],
               "colour.")
    study = tmp_path / "study.yaml"
    study.write_text(f"name: s\nbase: base.yaml\nseeds: [1]\ncases: {_bomb()}\n")
    _bad_input(capsys, tmp_path, ["study", str(study), "--out", str(tmp_path / "o")],
               "cases.")


def test_alias_bomb_in_epsilon_restitution_file_is_refused(capsys, tmp_path):
    law = tmp_path / "law.yaml"
    law.write_text(f"restitution: {{model: dilley, kappa: {_bomb()}}}\n")
    _bad_input(capsys, tmp_path, ["epsilon", "--restitution", str(law), "--radius", "1"],
               "restitution.kappa.")


def test_alias_bomb_in_a_stored_scenario_is_refused(capsys, tmp_path, tiny_run):
    run = tmp_path / "bomb.h5"
    shutil.copy(tiny_run["run"], run)
    with h5py.File(run, "r+") as f:
        f.attrs["scenario_yaml"] = _text(description="BOMB").replace("BOMB", _bomb())
    _bad_input(capsys, tmp_path, ["analyze", str(run)], str(run))
    _bad_input(capsys, tmp_path, ["compare", str(tiny_run["run"]), str(run)], str(run))


def test_a_few_aliases_are_still_yaml():
    text = _text(output=None) + "output: {timeseries_every: &every 0.01, snapshot_every: *every}\n"
    sc = scenario_from_text(text)
    assert sc.output.snapshot_every == sc.output.timeseries_every == 0.01


def test_excerpt_is_bounded_whatever_the_value():
    wide = ["lol"]
    for _ in range(30):            # 10^30 strings once expanded; shared lists cost nothing
        wide = [wide] * 10
    start = time.perf_counter()
    for value in (wide, "x" * 10**7, 10**5000, {"k" * 10**6: 1}, b"\0" * 10**7):
        text = excerpt(value, 60)
        assert len(text) <= 60 and "\n" not in text
    assert time.perf_counter() - start < 1.0
    assert excerpt(10**5000) == "<an integer of about 5001 digits>"
    assert excerpt("2e-4") == "'2e-4'" and excerpt(0.25) == "0.25"
    assert len(clip("y" * 10**7, 300)) <= 300 and clip(" a\n b ") == "a b"


# --- D10: one line naming the key or file, exit 2, nothing written ----------------------------

@pytest.mark.parametrize("case, changes, names", [
    ("1000-deep nesting", {"description": "DEEP"}, "description["),
    ("5000-digit integer", {"seed": "BIG"}, ": seed: an integer of 5000 digits"),
    ("r_min 1e-300", {"particles.size_distribution.r_min": 1e-300},
     "particles.size_distribution.r_min: 1e-300 m is out of range"),
    ("5000-character name", {"name": "n" * 5000}, ": name: 5000 characters"),
])
def test_absurd_scenario_values_exit_2(capsys, tmp_path, case, changes, names):
    text = _text(**changes).replace("DEEP", "[" * 1000 + "]" * 1000)
    text = text.replace("BIG", "9" * 5000)
    line = _run(capsys, tmp_path, text, names)
    assert str(tmp_path / "s.yaml") in line


def test_nesting_at_the_limit_is_yaml_and_past_it_is_refused():
    inner = "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)   # with the top mapping: the limit
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(_text(description="X").replace("X", inner))
    assert "not a string" in str(info.value), "the limit itself is only a type error"
    with pytest.raises(ScenarioError, match=f"deeper than {MAX_DEPTH} levels"):
        scenario_from_text(_text(description="X").replace("X", "[" + inner + "]"))


def _initial_csv(folder: Path, tiny_run, *, raw: bytes | None = None,
                 vx: str | None = None) -> str:
    """A scenario starting from a copy of the tiny run's CSV, changed; returns its text."""
    csv = folder / "start.csv"
    if raw is not None:
        csv.write_bytes(raw)
    else:
        lines = tiny_run["csv"].read_text().splitlines()
        cells = lines[3].split(",")
        cells[3] = vx
        lines[3] = ",".join(cells)
        csv.write_text("\n".join(lines) + "\n")
    return _text(**{"sheet.n_particles": None,
                    "sheet.initial_state": {"file": "start.csv", "t": tiny_run["t"]}})


def test_non_utf8_initial_csv_exits_2(capsys, tmp_path, tiny_run):
    raw = tiny_run["csv"].read_bytes().replace(b"ringsim snapshot", b"ringsim \xe9snapshot")
    line = _run(capsys, tmp_path, _initial_csv(tmp_path, tiny_run, raw=raw),
                "sheet.initial_state.file: ")
    assert "not UTF-8" in line


@pytest.mark.parametrize("vx, words", [("1e27", "speed of light"),
                                       ("1e5", "steps, more than")])
def test_absurd_velocities_in_an_initial_file_exit_2(capsys, tmp_path, tiny_run, vx, words):
    # 1e5 m/s: dt: auto keeps 2 v dt below 0.1 of the smallest radius (1 m), so
    # dt < 5e-7 s, more than 1e9 steps in 0.02 orbit (628 s)
    line = _run(capsys, tmp_path, _initial_csv(tmp_path, tiny_run, vx=vx),
                "sheet.initial_state.file: ")
    assert words in line


@pytest.mark.parametrize("attribute, value", [("Lx", float("nan")), ("Ly", float("inf")),
                                              ("root_size", -1.0), ("N_root_x", 0),
                                              ("Omega", float("nan"))])
def test_nan_box_in_a_run_file_exits_2(capsys, tmp_path, tiny_run, attribute, value):
    run = tmp_path / "box.h5"
    shutil.copy(tiny_run["run"], run)
    with h5py.File(run, "r+") as f:
        f.attrs[attribute] = value
    _bad_input(capsys, tmp_path, ["analyze", str(run)], f"{run}: {attribute}: ")
    _bad_input(capsys, tmp_path, ["compare", str(tiny_run["run"]), str(run)],
               f"{run}: {attribute}: ")
    start = _text(**{"sheet.n_particles": None, "sheet.optical_depth": None,
                     "sheet.initial_state": {"file": "box.h5"}})
    _run(capsys, tmp_path, start, f"{run}: {attribute}: ")


@pytest.mark.parametrize("dataset, damage, key", [
    ("timeseries/orbits", lambda a: a[:-1], "orbits"),
    ("timeseries/orbits", lambda a: np.stack([a, a], axis=-1), "orbits"),
    ("timeseries/thickness", lambda a: np.array([b"x"] * a.size), "thickness"),
    ("timeseries/optical_depth", lambda a: np.full(a.shape, np.nan), "optical_depth"),
    ("timeseries/collisions", lambda a: -a - 1, "collisions"),
    ("snapshots/000001/vx", lambda a: a[:-1], "snapshots/vx"),
    ("snapshots/000001/mass", lambda a: np.array([b"x"] * a.size), "snapshots/mass"),
])
def test_run_file_arrays_of_the_wrong_shape_exit_2(capsys, tmp_path, tiny_run, dataset,
                                                   damage, key):
    run = tmp_path / "shapes.h5"
    shutil.copy(tiny_run["run"], run)
    with h5py.File(run, "r+") as f:
        data = damage(f[dataset][...])
        del f[dataset]
        f[dataset] = data
    for argv in (["analyze", str(run)], ["export", str(run), "--csv",
                                         str(tmp_path / "x.csv")]):
        _bad_input(capsys, tmp_path, argv, f"{run}: {key}: ")


@pytest.mark.parametrize("argv, option", [
    (["analyze", "RUN", "--json", "DIR"], "--json"),
    (["analyze", "RUN", "--plots", "FILE"], "--plots"),
    (["compare", "RUN", "RUN", "--json", "DIR"], "--json"),
    (["compare", "RUN", "RUN", "--plots", "FILE"], "--plots"),
    (["analyze", "RUN", "--json", "FILE/x.json"], "--json"),
    (["epsilon", "--json", "DIR"], "--json"),
    (["export", "RUN", "--csv", "DIR"], "--csv"),
])
def test_json_into_a_folder_and_plots_into_a_file_exit_2(capsys, tmp_path, tiny_run, argv,
                                                        option):
    (tmp_path / "d.csv").mkdir()
    (tmp_path / "f.png").write_bytes(b"not a folder")
    paths = {"RUN": str(tiny_run["run"]), "DIR": str(tmp_path / "d.csv"),
             "FILE": str(tmp_path / "f.png"), "FILE/x.json": str(tmp_path / "f.png" / "x")}
    _bad_input(capsys, tmp_path, [paths.get(a, a) for a in argv], f": {option}: ")


# --- D7: the step and the output intervals --------------------------------------------------

@pytest.mark.parametrize("changes, key", [
    ({"integration.dt": 1e-300}, "integration.dt"),
    ({"output.timeseries_every": 1e-5}, "output.timeseries_every"),
    ({"output.timeseries_every": 1e-300}, "output.timeseries_every"),
    ({"integration.dt": 1e-3, "output.timeseries_every": 5e-4}, "output.timeseries_every"),
    ({"integration.dt": 1e-3, "output.snapshot_every": 5e-4}, "output.snapshot_every"),
    ({"integration.orbits": 1e6, "output.timeseries_every": 0.01},
     "output.timeseries_every"),
    ({"integration.orbits": 1e6, "output.timeseries_every": 1.0}, "output.snapshot_every"),
])
def test_degenerate_intervals_exit_2_naming_the_key(capsys, tmp_path, changes, key):
    line = _run(capsys, tmp_path, _text(**changes), f": {key}: ")
    assert "orbits" in line


def test_an_interval_of_a_few_steps_is_accepted_and_a_shorter_one_refused():
    """Issue 43, D7: output intervals at least MIN_OUTPUT_STEPS (3) steps long."""
    from ringsim.config.intervals import MIN_OUTPUT_STEPS

    assert MIN_OUTPUT_STEPS == 3
    every = MIN_OUTPUT_STEPS * AUTO_DT_MAX_ORBITS
    sc = scenario_from_text(_text(**{"output.timeseries_every": every}))
    assert sc.output.timeseries_every == every
    sc = scenario_from_text(_text(**{"integration.dt": 2e-3,
                                     "output.timeseries_every": 6e-3}))
    assert sc.output.timeseries_every == 6e-3
    with pytest.raises(ScenarioError) as info:
        scenario_from_text(_text(**{"integration.dt": 2e-3, "output.timeseries_every": 5e-3}))
    assert info.value.key == "output.timeseries_every"


def test_a_billion_particles_are_refused_before_any_allocation(capsys, tmp_path):
    line = _run(capsys, tmp_path, _text(**{"sheet.n_particles": 10**9}),
                ": sheet.n_particles: 1000000000 particles need about")
    assert "GiB" in line


def test_particle_memory_bound():
    sc = scenario_from_text(_text(**{"sheet.n_particles": 1000}))
    check_particle_memory(sc, available=1000 * BYTES_PER_PARTICLE)
    with pytest.raises(InputError) as info:
        check_particle_memory(sc, available=1000 * BYTES_PER_PARTICLE - 1)
    assert info.value.key == "sheet.n_particles"


# --- D12: a run that fails says so ------------------------------------------------------------

@pytest.mark.filterwarnings("ignore::RuntimeWarning")   # the diagnostics' overflows
def test_rebound_error_leaves_the_file_failed_with_the_reason(capsys, tmp_path):
    # Omega = 1e300 1/s: the orbit lasts 6e-300 s; REBOUND's integration of the sheet
    # detector stops with "An error occurred during the integration."
    scenario = tmp_path / "s.yaml"
    scenario.write_text(_text(**{"planet.Omega": 1e300,
                                 "integration.collision_detection": "line"}))
    out = tmp_path / "out.h5"
    status = main(["run", str(scenario), "-o", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 1, err
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "failed"
        failure = str(f.attrs["failure"])
        messages = [m.decode() if isinstance(m, bytes) else str(m)
                    for m in f["guards"]["message"][...]]
    assert failure.startswith("GenericError: An error occurred during the integration")
    assert any(m.startswith("FAILED at orbit") and failure in m for m in messages)


def test_an_error_in_the_first_output_leaves_the_file_failed(monkeypatch, capsys, tmp_path):
    """The window between the run file's creation and the loop: an error in the first
    output (here a diagnostic that raises) leaves the file failed with the reason."""
    from ringsim.engine.runner import Runner

    def broken_output(self, first=False):
        raise RuntimeError("a diagnostic broke")

    monkeypatch.setattr(Runner, "_output", broken_output)   # ringsim's own code, not REBOUND
    scenario = tmp_path / "s.yaml"
    scenario.write_text(_text())
    out = tmp_path / "out.h5"
    assert main(["run", str(scenario), "-o", str(out), "--no-progress"]) == 1
    capsys.readouterr()
    with h5py.File(out, "r") as f:
        assert f.attrs["status"] == "failed"
        assert str(f.attrs["failure"]) == "RuntimeError: a diagnostic broke"


def test_a_snapshot_with_nan_positions_is_bad_input(capsys, tmp_path):
    """A damaged snapshot (NaN in x, found by the fuzzing suite) is refused in one line
    naming the dataset, not a ValueError deep in a diagnostic."""
    scenario = tmp_path / "s.yaml"
    scenario.write_text(_text())
    out = tmp_path / "out.h5"
    assert main(["run", str(scenario), "-o", str(out), "--no-progress"]) == 0
    with h5py.File(out, "r+") as f:
        name = sorted(f["snapshots"])[-1]
        x = f["snapshots"][name]["x"][...]
        x[0] = float("nan")
        f["snapshots"][name]["x"][...] = x
    capsys.readouterr()
    assert main(["analyze", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"/snapshots/{name}/x" in err[0] and "not finite" in err[0]
