"""Fuzzing the command line with hostile inputs (issue 43, item 8): scenarios with alias
bombs, deep nesting, huge numbers and degenerate durations; measurement CSVs for ``ringsim
fit``; initial-state CSVs; crafted run files (attributes, shapes, links).

Every example must end with exit status 0 or 2 (never a traceback's exit 1, a hang or a
crash), with one line on stderr for status 2, and change no file outside the run's own
(``RUN.h5`` and its ``.parts``, ``.lock`` and ``.tmp``) and the requested outputs.
Examples are derandomized; the default run is small (the whole file well under a minute),
and each test has a longer twin marked ``slow`` (``pytest -m slow tests/test_fuzz_inputs.py``).
"""

from __future__ import annotations

import contextlib
import io
import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ringsim.cli import main

ROOT = Path(__file__).resolve().parent.parent
FIT_DATA = ROOT / "docs" / "data" / "hatzes_like.csv"

#: A tiny ring: 40 particles of 1-2 m, 0.02 orbit (a run takes about a second).
TINY = {
    "name": "fuzz", "seed": 1, "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0, "size_distribution": {
        "kind": "powerlaw", "q": 3.0, "r_min": 1.0, "r_max": 2.0}},
    "sheet": {"optical_depth": 0.25, "n_particles": 40},
    "integration": {"orbits": 0.02},
    "output": {"timeseries_every": 0.01, "snapshot_every": 0.02},
}

_COMMON = dict(derandomize=True, deadline=None, database=None,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                      HealthCheck.function_scoped_fixture,
                                      HealthCheck.data_too_large])
#: The default (CI) and the long (``slow``) number of examples of each test.
QUICK = settings(max_examples=12, **_COMMON)
LONG = settings(max_examples=300, **_COMMON)


def _listing(folder: Path, own: tuple[str, ...]) -> dict[str, tuple[int, int]]:
    """Size and modification time of every path under ``folder`` but the ``own`` ones
    (names and their ``.parts``, ``.lock``, ``.tmp`` companions)."""
    def is_own(path: Path) -> bool:
        name = str(path.relative_to(folder))
        return any(name == o or name.startswith(o + ".") or name.startswith(o + "/")
                   for o in own)
    return {str(p.relative_to(folder)): (p.lstat().st_size, p.lstat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if not is_own(p)}


def _command(folder: Path, argv: list[str], own: tuple[str, ...]) -> tuple[int, str]:
    """Run the command line in-process: exit 0 or 2, one line for 2, nothing outside
    ``own`` changed; returns (status, stderr)."""
    before = _listing(folder, own)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(argv)
    text = err.getvalue()
    assert status in (0, 2), f"exit {status}: {text[-800:]}"
    if status == 2:
        lines = [line for line in text.splitlines() if line.startswith("ringsim: error:")]
        assert len(lines) == 1 and "Traceback" not in text, text[-800:]
        assert len(lines[0]) < 600, lines[0][:200]
    assert _listing(folder, own) == before, "a file outside the run's own was changed"
    return status, text


# --- scenarios ----------------------------------------------------------------------------------

def _paths(d: dict, prefix: str = "") -> list[str]:
    out = []
    for key, value in d.items():
        path = f"{prefix}.{key}" if prefix else key
        out.append(path)
        if isinstance(value, dict):
            out.extend(_paths(value, path))
    return out


PATHS = _paths(TINY) + ["description", "integration.dt", "sheet.aspect",
                        "output.checkpoint_every"]

#: Values that are hostile as YAML text: (text, is a number) pairs spliced in verbatim.
HOSTILE_TEXT = st.one_of(
    st.integers(1, 14).map(lambda n: "[" * (n * 100) + "]" * (n * 100)),
    st.integers(25, 6000).map(lambda n: "9" * n),
    st.integers(150, 20000).map(lambda n: "n" * n),
    st.tuples(st.integers(1, 12), st.integers(2, 12)).map(
        lambda lf: "{" + ", ".join(['l0: &l0 "lol"'] + [
            f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * lf[1]) + "]"
            for i in range(1, lf[0] + 1)]) + "}"),
    st.sampled_from([".nan", ".inf", "-.inf", "1e-300", "1e300", "0", "-0.0", "5e-324",
                     "0x" + "f" * 40, "0o" + "7" * 40, "~", "''", "!!binary aGVsbG8=",
                     "!!python/object:os.system ls", "*undefined", "&a [*a]"]),
)
#: Durations and counts at and beyond their bounds (orbits stay short: a valid run must
#: end in seconds).
DURATIONS = st.one_of(
    st.fixed_dictionaries({"integration.dt": st.sampled_from(
        [1e-300, 1e-12, 1e-6, 5e-4, 1e-3, 5e-3, 0.02, 0.1, "auto"])}),
    st.fixed_dictionaries({"output.timeseries_every": st.sampled_from(
        [1e-300, 1e-5, 9.9e-4, 1e-3, 0.005, 0.02, 1e300])}),
    st.fixed_dictionaries({"output.snapshot_every": st.sampled_from(
        [1e-300, 1e-5, 1e-3, 0.01, 1e300]),
        "output.checkpoint_every": st.sampled_from([1e-300, 1e-3, 0.01, 5.0])}),
    st.fixed_dictionaries({"sheet.n_particles": st.sampled_from(
        [-1, 0, 1, 2, 3, 30, 10**9, 10**12, 2**63, 10**29])}),
    st.fixed_dictionaries({"integration.orbits": st.sampled_from(
        [1e-300, 1e-4, 0.003, 1e9, 1e300])}),
)


def _set(d: dict, dotted: str, value) -> None:
    *parents, leaf = dotted.split(".")
    for part in parents:
        if not isinstance(d.get(part), dict):
            d[part] = {}
        d = d[part]
    d[leaf] = value


@st.composite
def scenario_texts(draw) -> str:
    """TINY with either hostile YAML spliced in at one key, or durations at their bounds."""
    d = yaml.safe_load(yaml.safe_dump(TINY))
    if draw(st.booleans()):
        for dotted, value in draw(DURATIONS).items():
            _set(d, dotted, value)
        return yaml.safe_dump(d, sort_keys=False)
    key = draw(st.sampled_from(PATHS))
    _set(d, key, "HOSTILE")
    return yaml.safe_dump(d, sort_keys=False).replace("HOSTILE", draw(HOSTILE_TEXT), 1)


def _check_scenario(tmp_path_factory, text: str) -> None:
    folder = tmp_path_factory.mktemp("scenario")
    (folder / "s.yaml").write_text(text)
    status, _ = _command(folder, ["run", str(folder / "s.yaml"), "-o",
                                  str(folder / "out.h5"), "--no-progress"], own=("out.h5",))
    if status == 2:
        assert not (folder / "out.h5").exists(), "bad input must write no run file"


@QUICK
@given(scenario_texts())
def test_hostile_scenarios_exit_0_or_2(tmp_path_factory, text):
    _check_scenario(tmp_path_factory, text)


@pytest.mark.slow
@LONG
@given(scenario_texts())
def test_hostile_scenarios_exit_0_or_2_long(tmp_path_factory, text):
    _check_scenario(tmp_path_factory, text)


# --- CSVs -------------------------------------------------------------------------------------

CELL_JUNK = st.sampled_from(["", "nan", "inf", "-inf", "1e999", "-1", "0", "x", "1,2",
                             '"', "9" * 400, "1e-320", "\t", "NaN", " 0.5 ", "0x10"])


@st.composite
def damaged_csv(draw, original: bytes) -> bytes:
    """A CSV damaged in its cells, rows, header or bytes."""
    lines = original.decode().splitlines()
    body = [i for i, line in enumerate(lines) if line and not line.startswith("#")]
    for _ in range(draw(st.integers(1, 3))):
        action = draw(st.sampled_from(["cell", "drop", "duplicate", "header", "bytes",
                                       "columns", "truncate"]))
        i = draw(st.sampled_from(body))
        if action == "cell":
            cells = lines[i].split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(CELL_JUNK)
            lines[i] = ",".join(cells)
        elif action == "drop":
            lines[i] = ""
        elif action == "duplicate":
            lines.insert(i, lines[i])
        elif action == "header":
            cells = lines[body[0]].split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(
                ["", "x_m", "v", "sigma", "epsilon", "wx_rad_s", "é", "R1_m"]))
            lines[body[0]] = ",".join(cells)
        elif action == "columns":
            lines[i] = lines[i] + "," + draw(CELL_JUNK)
        elif action == "truncate":
            lines = lines[: max(1, i)]
            body = [j for j in body if j < len(lines)] or [0]
    data = ("\n".join(lines) + "\n").encode()
    if draw(st.booleans()):
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.sampled_from([b"\xff", b"\xe9", b"\x00", b"\xef\xbb\xbf",
                                                  b"\r", b"\xc3"])) + data[at:]
    return data


def _check_fit_csv(tmp_path_factory, data: bytes) -> None:
    folder = tmp_path_factory.mktemp("fit")
    (folder / "d.csv").write_bytes(data)
    _command(folder, ["fit", str(folder / "d.csv"), "--model", "constant", "--json",
                      str(folder / "out.json")], own=("out.json",))


@QUICK
@given(damaged_csv(FIT_DATA.read_bytes()))
def test_damaged_fit_csvs_exit_0_or_2(tmp_path_factory, data):
    _check_fit_csv(tmp_path_factory, data)


@pytest.mark.slow
@LONG
@given(damaged_csv(FIT_DATA.read_bytes()))
def test_damaged_fit_csvs_exit_0_or_2_long(tmp_path_factory, data):
    _check_fit_csv(tmp_path_factory, data)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A finished run of TINY, its CSV of the last snapshot and that snapshot's time."""
    folder = tmp_path_factory.mktemp("tiny")
    (folder / "tiny.yaml").write_text(yaml.safe_dump(TINY))
    run = folder / "tiny.h5"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["run", str(folder / "tiny.yaml"), "-o", str(run), "--no-progress"]) == 0
        assert main(["export", str(run), "--csv", str(folder / "tiny.csv")]) == 0
    csv = (folder / "tiny.csv").read_bytes()
    t = float(csv.decode().splitlines()[1].split("t = ")[1].split(" s")[0])
    return {"run": run, "csv": csv, "t": t}


def _initial_state_case(tmp_path_factory, tiny_run, data: bytes) -> None:
    folder = tmp_path_factory.mktemp("initial")
    (folder / "start.csv").write_bytes(data)
    d = yaml.safe_load(yaml.safe_dump(TINY))
    d["sheet"] = {"optical_depth": 0.25,
                  "initial_state": {"file": "start.csv", "t": tiny_run["t"]}}
    (folder / "s.yaml").write_text(yaml.safe_dump(d))
    _command(folder, ["run", str(folder / "s.yaml"), "-o", str(folder / "out.h5"),
                      "--no-progress"], own=("out.h5",))


@st.composite
def initial_csvs(draw, tiny_run) -> bytes:
    return draw(damaged_csv(tiny_run["csv"]))


def test_damaged_initial_csvs_exit_0_or_2(tmp_path_factory, tiny_run):
    @QUICK
    @given(st.data())
    def inner(data):
        _initial_state_case(tmp_path_factory, tiny_run,
                            data.draw(damaged_csv(tiny_run["csv"])))
    inner()


@pytest.mark.slow
def test_damaged_initial_csvs_exit_0_or_2_long(tmp_path_factory, tiny_run):
    @LONG
    @given(st.data())
    def inner(data):
        _initial_state_case(tmp_path_factory, tiny_run,
                            data.draw(damaged_csv(tiny_run["csv"])))
    inner()


# --- crafted run files --------------------------------------------------------------------------

ATTRIBUTE_VALUES = st.sampled_from([math.nan, math.inf, -1.0, 0, 3.7, 1e300, -(2**62), "",
                                    "running", "x" * 5000, b"\xff\xfe", np.int8(-1),
                                    np.array([1.0, 2.0]), True])
ATTRIBUTES = ["status", "Omega", "Lx", "Ly", "root_size", "N_root_x", "N_root_y", "seed",
              "format_version", "name", "stop_reason", "scenario_yaml", "units"]


@st.composite
def run_file_damage(draw, kinds=("attribute", "yaml", "timeseries", "snapshot")
                    ) -> list[tuple]:
    """A list of changes to a run file: root attributes, dataset shapes and types, and
    (with "link" among ``kinds``) soft links inside the file."""
    changes = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(kinds))
        if kind == "attribute":
            changes.append(("attribute", draw(st.sampled_from(ATTRIBUTES)),
                            draw(ATTRIBUTE_VALUES)))
        elif kind == "yaml":
            changes.append(("attribute", "scenario_yaml", draw(scenario_texts())))
        elif kind == "timeseries":
            changes.append(("timeseries", draw(st.sampled_from(
                ["t", "orbits", "velocity_dispersion", "thickness", "optical_depth"])),
                draw(st.sampled_from(["short", "long", "2d", "text", "nan", "empty"]))))
        elif kind == "snapshot":
            changes.append(("snapshot", draw(st.sampled_from(
                ["x", "vx", "radius", "mass"])), draw(st.sampled_from(
                    ["short", "2d", "nan", "negative", "text"]))))
        else:
            changes.append(("link", draw(st.sampled_from(
                ["timeseries/thickness", "snapshots/000000/x"])),
                draw(st.sampled_from(["soft-missing", "soft-loop"]))))
    return changes


def _reshaped(data: np.ndarray, how: str):
    if not np.issubdtype(data.dtype, np.number):   # damaged before: numbers again
        data = np.zeros(data.shape)
    return {"short": data[: max(0, data.shape[0] - 1)], "long": np.concatenate([data, data]),
            "2d": np.stack([data, data], axis=-1), "text": np.array([b"x"] * data.shape[0]),
            "nan": np.full(data.shape, np.nan), "empty": data[:0],
            "negative": -np.abs(data) - 1.0}[how]


def _damage(path: Path, changes: list[tuple]) -> None:
    with h5py.File(path, "r+") as f:
        for kind, name, how in changes:
            if kind == "attribute":
                f.attrs[name] = how
                continue
            where = (f"timeseries/{name}" if kind == "timeseries"
                     else f"snapshots/{sorted(f['snapshots'])[-1]}/{name}"
                     if kind == "snapshot" else name)
            if where not in f:
                continue
            if kind == "link":
                del f[where]
                f[where] = h5py.SoftLink("/nowhere" if how == "soft-missing" else "/" + where)
                continue
            data = f[where][...]
            del f[where]
            f[where] = _reshaped(data, how)


def _check_run_file(tmp_path_factory, tiny_run, changes: list[tuple]) -> None:
    folder = tmp_path_factory.mktemp("runfile")
    run = folder / "r.h5"
    shutil.copy(tiny_run["run"], run)
    _damage(run, changes)
    for argv in (["analyze", str(run), "--json", str(folder / "eq.json")],
                 ["export", str(run), "--csv", str(folder / "snap.csv")]):
        _command(folder, argv, own=("r.h5", "eq.json", "snap.csv"))


def test_crafted_run_files_exit_0_or_2(tmp_path_factory, tiny_run):
    @QUICK
    @given(run_file_damage())
    def inner(changes):
        _check_run_file(tmp_path_factory, tiny_run, changes)
    inner()


@pytest.mark.slow
def test_crafted_run_files_exit_0_or_2_long(tmp_path_factory, tiny_run):
    @LONG
    @given(run_file_damage())
    def inner(changes):
        _check_run_file(tmp_path_factory, tiny_run, changes)
    inner()


#: Damage that includes soft links (dangling, or a loop): reading through them is the
#: link checks' part of issue 43 (runfile's readers), not this branch's.
WITH_LINKS = ("attribute", "timeseries", "snapshot", "link")


@pytest.mark.slow
def test_crafted_run_file_links_exit_0_or_2(tmp_path_factory, tiny_run):
    @LONG
    @given(run_file_damage(WITH_LINKS))
    def inner(changes):
        _check_run_file(tmp_path_factory, tiny_run, changes)
    inner()
