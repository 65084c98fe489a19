"""Property tests: mutated scenario and sweep files give a valid scenario or ONE clear error.

Hand-written YAML goes wrong in every way: wrong types, missing and extra keys, NaN, inf,
negative or huge numbers, broken YAML, wrong nesting.  Whatever the mutation, the only
allowed outcomes are a valid ``Scenario`` (or ``Sweep``) or a ``ScenarioError`` whose one-line
message names the key concerned; through the command line, exit status 2 with one line on
stderr, no traceback and no output file.  Examples are derandomized (reproducible in CI).
"""

from __future__ import annotations

import contextlib
import io
import math

import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from ringsim.cli import main
from ringsim.config.scenario import Scenario, scenario_from_text
from ringsim.config.schema import ScenarioError
from ringsim.config.sweep import Sweep, load_sweep

VALID = {
    "name": "fuzz",
    "seed": 3,
    "planet": {"Omega": 2.0e-4},
    "particles": {"density": 900.0, "size_distribution": {
        "kind": "powerlaw", "q": 3.0, "r_min": 1.0, "r_max": 2.0}},
    "sheet": {"optical_depth": 0.25, "n_particles": 100, "aspect": 1.0, "gravity": False},
    "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1},
    "integration": {"orbits": 0.1, "dt": "auto", "collision_detection": "tree"},
    "output": {"path": "runs/fuzz.h5", "timeseries_every": 0.05, "snapshot_every": 0.1},
}

SETTINGS = dict(derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                       HealthCheck.function_scoped_fixture])


def _paths(d: dict, prefix: str = "") -> list[str]:
    """Every dotted key of a nested mapping (sections and leaves)."""
    out = []
    for key, value in d.items():
        path = f"{prefix}.{key}" if prefix else key
        out.append(path)
        if isinstance(value, dict):
            out.extend(_paths(value, path))
    return out


PATHS = _paths(VALID)

JUNK = st.one_of(
    st.none(), st.booleans(), st.text(max_size=8),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([math.nan, math.inf, -math.inf, -1.0, 0.0, 1e308, -1e-308, 5e-324,
                     1e30, 2**63, -(2**63)]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.integers(-3, 3), max_size=3),
    st.dictionaries(st.sampled_from(["a", "kind", "radius", "model"]), st.integers(-2, 2),
                    max_size=2),
)


def _get_parent(d: dict, path: str) -> tuple[dict, str]:
    *parents, leaf = path.split(".")
    for key in parents:
        d = d[key]
    return d, leaf


@st.composite
def mutated(draw) -> tuple[dict, str]:
    """A copy of VALID with one mutation; returns it and the dotted key it concerns."""
    d = yaml.safe_load(yaml.safe_dump(VALID))   # deep copy
    path = draw(st.sampled_from(PATHS))
    parent, leaf = _get_parent(d, path)
    action = draw(st.sampled_from(["delete", "replace", "extra", "wrap", "unnest"]))
    if action == "delete":
        del parent[leaf]
    elif action == "replace":
        parent[leaf] = draw(JUNK)
    elif action == "extra":
        target = parent[leaf] if isinstance(parent[leaf], dict) else parent
        extra = draw(st.sampled_from(["colour", "Omega2", "kapa", "radius", "q", "seeds"]))
        assume(extra not in target)
        target[extra] = draw(JUNK)
        path = f"{path}.{extra}" if target is not parent else (
            f"{path.rsplit('.', 1)[0]}.{extra}" if "." in path else extra)
    elif action == "wrap":
        parent[leaf] = [parent[leaf]]
    else:  # a section's keys moved one level up, or a leaf moved into the wrong section
        value = parent.pop(leaf)
        if isinstance(value, dict):
            d.update({k: v for k, v in value.items() if k not in d})
        else:
            d["output" if "output" != path.split(".")[0] else "sheet"][leaf] = value
    return d, path


def _related(error_key: str, path: str) -> bool:
    """The error names the mutated key, one of its sections, something inside it, or a
    sibling (cross-key constraints such as r_min < r_max)."""
    if error_key in ("<yaml>", "<file>"):
        return False
    a, b = error_key.split("."), path.split(".")
    n = min(len(a), len(b))
    if a[:n] == b[:n]:
        return True
    return a[:-1] == b[:-1] or a[:-1] == b[:len(a) - 1] or b[:-1] == a[:len(b) - 1]


def _one_line(exc: ScenarioError) -> None:
    text = str(exc)
    assert "\n" not in text and text.strip() == text and len(text) < 400, text


@settings(max_examples=500, **SETTINGS)
@given(mutated())
def test_mutated_scenarios_are_valid_or_name_the_key(case):
    d, path = case
    text = yaml.safe_dump(d)
    try:
        sc = scenario_from_text(text, source="fuzz.yaml")
    except ScenarioError as exc:
        _one_line(exc)
        assert exc.file == "fuzz.yaml"
        # a mutation that moves keys around may be reported at the section it landed in
        assert _related(exc.key, path) or path.split(".")[0] in str(exc) \
            or exc.key.split(".")[0] in ("output", "sheet") or exc.key in str(exc), \
            f"mutating {path!r} gave an error about {exc.key!r}: {exc}"
    else:
        assert isinstance(sc, Scenario)
        assert sc.seed >= 0 and math.isfinite(sc.orbital_frequency) \
            and sc.orbital_frequency > 0, f"mutating {path!r} gave an invalid scenario"


TEXT_DAMAGE = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0.0, 1.0)),
    st.tuples(st.just("insert"), st.sampled_from(["\t", ":", "- ", "[", "{", "'", '"', "&a",
                                                  "*b", "!!python/object:os.system ",
                                                  "\x00", "%YAML 9.9\n", "---\n", "?"])),
    st.tuples(st.just("indent"), st.integers(1, 3)),
)


@settings(max_examples=200, **SETTINGS)
@given(TEXT_DAMAGE, st.floats(0.0, 1.0))
def test_damaged_yaml_text_gives_one_line_error(damage, where):
    text = yaml.safe_dump(VALID)
    cut = int(where * len(text))
    kind, arg = damage
    if kind == "truncate":
        text = text[:cut]
    elif kind == "insert":
        text = text[:cut] + arg + text[cut:]
    else:
        lines = text.splitlines(keepends=True)
        i = min(int(where * len(lines)), len(lines) - 1)
        lines[i] = " " * arg + lines[i]
        text = "".join(lines)
    try:
        scenario_from_text(text, source="damaged.yaml")
    except ScenarioError as exc:
        _one_line(exc)
        assert exc.file == "damaged.yaml" and exc.key


@st.composite
def mutated_sweep(draw) -> tuple[object, str]:
    grid = {"restitution.kappa": [0.0, 0.1], "seed": [1, 2]}
    d: dict = {"base": "base.yaml", "grid": grid}
    action = draw(st.sampled_from(["grid_value", "grid_key", "base", "top", "delete",
                                   "scalar_grid", "empty_list"]))
    key = "grid"
    if action == "grid_value":
        key = draw(st.sampled_from(list(grid)))
        grid[key] = [draw(JUNK)] if draw(st.booleans()) else draw(JUNK)
    elif action == "grid_key":
        key = draw(st.sampled_from(["restitution.kapa", "sheet", "colour", "sheet.n_particles",
                                    "particles.size_distribution.q", "output.path", ""]))
        grid[key] = [draw(JUNK), draw(JUNK)]
    elif action == "base":
        key = "base"
        d["base"] = draw(st.one_of(JUNK, st.sampled_from(["nope.yaml", "sweep.yaml", ""])))
    elif action == "top":
        key = draw(st.sampled_from(["colour", "grids"]))
        d[key] = draw(JUNK)
    elif action == "delete":
        key = draw(st.sampled_from(["base", "grid"]))
        del d[key]
    elif action == "scalar_grid":
        d["grid"] = draw(JUNK)
    else:
        grid["seed"] = []
        key = "seed"
    return d, key


@settings(max_examples=200, **SETTINGS)
@given(mutated_sweep())
def test_mutated_sweeps_are_valid_or_name_the_key(tmp_path_factory, case):
    d, key = case
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "base.yaml").write_text(yaml.safe_dump(VALID))
    sweep_file = folder / "sweep.yaml"
    sweep_file.write_text(yaml.safe_dump(d))
    try:
        sweep = load_sweep(sweep_file)
        for _params, scenario in sweep.points():
            assert isinstance(scenario, Scenario)
    except ScenarioError as exc:
        _one_line(exc)
        # the sweep file, or (for a base that cannot be read or is invalid) the base file
        base = d.get("base")
        assert exc.file == str(sweep_file) or (
            isinstance(base, str) and base and exc.file == str(folder / base)), exc
        assert key in str(exc) or exc.key in ("grid", "base", "<yaml>", "<file>") \
            or key == "", f"mutating {key!r} gave {exc}"
    else:
        assert isinstance(sweep, Sweep) and len(sweep) >= 1


@settings(max_examples=60, **SETTINGS)
@given(mutated())
def test_bad_scenarios_on_the_command_line_exit_2(tmp_path_factory, case):
    """The same mutations through ``ringsim run``: exit 2, one line, no traceback, no file."""
    d, _path = case
    text = yaml.safe_dump(d)
    try:
        scenario_from_text(text, source="x")
    except ScenarioError:
        pass
    else:
        assume(False)   # a valid scenario would run: not this test's business
    folder = tmp_path_factory.mktemp("cli")
    bad = folder / "bad.yaml"
    bad.write_text(text)
    out = folder / "out" / "never.h5"
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(["run", str(bad), "-o", str(out), "--no-progress"])
    lines = err.getvalue().strip().splitlines()
    assert status == 2
    assert len(lines) == 1 and str(bad) in lines[0] and "Traceback" not in err.getvalue()
    assert not out.exists() and not out.parent.exists(), "no output for bad input"
