"""The architecture of docs/architecture.md, enforced mechanically.

1. Imports go one way along the data path, config/physics -> engine -> store -> analysis ->
   plots, with the command line and the sweep as front ends on top.  Every module under
   src/ringsim/ is parsed with ``ast`` (nothing is imported); an import of a forbidden
   layer fails the test unless it is listed in ``ALLOWED`` with its reason.  No module of
   the package imports the repository's script folder (``SCRIPT_DIRS``): it is not
   installed.
2. The size rules are a ratchet.  A module stays within ``MODULE_LINES`` lines and a
   function within ``FUNCTION_LINES``; the modules and functions already larger are listed
   in ``tests/size_ratchet.json`` with their size when they were recorded.  A listed one
   may not grow, and when it shrinks its entry must be lowered to its new size (or removed
   once it fits the base limit), so that an allowance only ever tightens.  No entry may
   come near the old hard limits (``MODULE_CEILING``, ``FUNCTION_CEILING``): a module that
   reaches them is split by concept, not squeezed.  This holds for the scripts under
   ``benchmarks/`` too (``SCRIPT_DIRS``): they are code users read and rerun.
3. No import cycle between the package's modules, counting imports inside functions (not
   those under ``if TYPE_CHECKING:``, which never run).
"""

from __future__ import annotations

import ast
import functools
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "ringsim"
#: Script directories held to the size limits as well (not to the layers: they are users
#: of the package, at the end of the data path, and only in a source checkout).
SCRIPT_DIRS = ("benchmarks",)

#: Layer of each top-level name under ringsim.  "base" holds the helpers every layer may
#: use (errors, argument checks, the Markdown section writer, the declaration of the reported
#: quantities, the package root).
LAYERS = {
    "config": "config", "physics": "physics", "restitution": "physics", "engine": "engine",
    "gravity": "gravity",  # the self-gravity solvers in REBOUND: at the engine's level
    "store": "store", "analysis": "analysis", "plots": "plots", "cli": "cli",
    "sweep": "sweep", "testing": "testing",
    "errors": "base", "checks": "base", "report": "base", "quantities": "base",
    "__init__": "base",
    "__version__": "base", "_resolver": "engine",
    "userlaw": "cli",  # the `ringsim epsilon --restitution` command's law, table and figure
    "cli_examples": "cli",  # the example at the end of every subcommand's --help
    "cli_io": "cli",   # the command line's stdout and argument parser
    # front ends of batches of runs, like the sweep: the shared run-file policy and studies
    "batch": "sweep", "study": "sweep",
}

_FRONT_ENDS = {"cli", "sweep"}
#: Layer -> the layers it must not import.
FORBIDDEN = {
    "base": {"config", "physics", "engine", "gravity", "store", "analysis", "plots", "testing"}
    | _FRONT_ENDS,
    "physics": {"config", "engine", "gravity", "store", "analysis", "plots", "testing"}
    | _FRONT_ENDS,
    "config": {"engine", "gravity", "store", "analysis", "plots", "testing"} | _FRONT_ENDS,
    "engine": {"analysis", "plots", "testing"} | _FRONT_ENDS,
    "gravity": {"analysis", "plots", "testing"} | _FRONT_ENDS,
    "store": {"engine", "gravity", "analysis", "plots", "testing"} | _FRONT_ENDS,
    "analysis": {"engine", "gravity", "testing"} | _FRONT_ENDS,
    "plots": {"engine", "gravity", "testing"} | _FRONT_ENDS,
    "testing": {"store", "analysis", "plots"} | _FRONT_ENDS,
    "sweep": {"cli", "testing"},
    "cli": {"testing"},
}

#: Imports across the forbidden lines that are there on purpose:
#: (importing module, imported module) -> (where: "module" or "function", reason).
ALLOWED = {
    ("ringsim.engine.runner", "ringsim.analysis.snapshot"): (
        "module",
        "the run loop writes one time-series row per output from snapshot_summary, a pure "
        "numpy function of the particle arrays that imports nothing of the engine"),
    ("ringsim.engine.ending", "ringsim.analysis.equilibrium"): (
        "function",
        "integration.until_equilibrium stops a run on the same stationarity verdict that "
        "analyze reports (one verdict, declared once in analysis.equilibrium)"),
    ("ringsim.engine.initial_file", "ringsim.analysis.tiling"): (
        "function",
        "a start from another run's snapshot is refused while that run's tiled copies are "
        "still alike, on the verdict analyze reports (declared once in analysis.tiling, "
        "which imports nothing of the engine)"),
    ("ringsim.config.scenario", "ringsim.engine.native"): (
        "function",
        "the one deliberate exception of the data path: scenario validation asks the C "
        "library for line mode's step limit (loaded only when a scenario is validated)"),
}

#: The base limits of every module and function (lines, docstrings and comments included).
MODULE_LINES = 500
FUNCTION_LINES = 60
#: No recorded allowance may reach these.
MODULE_CEILING = 560
FUNCTION_CEILING = 72
#: The recorded allowances: {"modules": {path: lines}, "functions": {path::name: lines}}.
RATCHET = ROOT / "tests" / "size_ratchet.json"


@functools.cache
def _modules() -> tuple[tuple[str, Path], ...]:
    """(dotted name, path) of every module under ringsim/."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append((".".join(parts), path))
    return tuple(out)


def layer_of(module: str) -> str:
    """The layer of a dotted name under ringsim ("ringsim" itself is base)."""
    parts = module.split(".")
    return LAYERS[parts[1]] if len(parts) > 1 else "base"


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imports(module: str, path: Path) -> list[tuple[str, str, int]]:
    """(imported ringsim module, "module" or "function", line) of every runtime import.

    ``from A import b`` counts as an import of ``A.b`` when ``A.b`` is a module of the
    package, else of ``A``.  Imports under ``if TYPE_CHECKING:`` are not run and are
    skipped.
    """
    known = {name for name, _ in _modules()}
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []

    def visit(node: ast.AST, where: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                continue
            inner = "function" if isinstance(
                child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda) else where
            if isinstance(child, ast.Import):
                found.extend((a.name, where, child.lineno) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    anchor = package.split(".")[:len(package.split(".")) - child.level + 1]
                    base = ".".join([*anchor, base] if base else anchor)
                for a in child.names:
                    full = f"{base}.{a.name}"
                    found.append((full if full in known else base, where, child.lineno))
            visit(child, inner)

    visit(ast.parse(path.read_text()), "module")
    return [(name, where, line) for name, where, line in found
            if name == "ringsim" or name.startswith("ringsim.")]


def test_every_module_has_a_layer():
    unknown = {name for name, _ in _modules() if name.count(".")
               and name.split(".")[1] not in LAYERS}
    assert not unknown, f"modules without a layer (add them to LAYERS): {sorted(unknown)}"


def test_imports_follow_the_data_path():
    bad = []
    for module, path in _modules():
        forbidden = FORBIDDEN[layer_of(module)]
        for imported, where, line in imports(module, path):
            if layer_of(imported) not in forbidden:
                continue
            allowed = ALLOWED.get((module, imported))
            if allowed is None or (allowed[0] == "module" and where != "module") \
                    or (allowed[0] == "function" and where != "function"):
                bad.append(f"{path.relative_to(ROOT)}:{line}: {module} "
                           f"({layer_of(module)}) imports {imported} "
                           f"({layer_of(imported)}) at {where} level")
    assert not bad, "imports against the data path:\n" + "\n".join(bad)


def script_imports(path: Path) -> list[tuple[str, int]]:
    """(imported name, line) of every absolute import of a script folder in ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.extend((a.name, node.lineno) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            found.append((node.module, node.lineno))
    return [(name, line) for name, line in found if name.split(".")[0] in SCRIPT_DIRS]


def test_no_package_module_imports_a_script_folder():
    bad = [f"{path.relative_to(ROOT)}:{line}: imports {name}"
           for _, path in _modules() for name, line in script_imports(path)]
    assert not bad, ("the script folders are not installed; the package imports them:\n"
                     + "\n".join(bad))


def test_the_script_checker_sees_script_imports(tmp_path):
    path = tmp_path / "probe.py"
    path.write_text("import benchmarks.common\nfrom benchmarks import gravity\n"
                    "from .analysis import x\nfrom ringsim.analysis import snapshot\n"
                    "import validation\ndef f():\n    import benchmarks.scale\n")
    assert script_imports(path) == [("benchmarks.common", 1), ("benchmarks", 2),
                                    ("benchmarks.scale", 7)]


def test_the_checker_sees_imports_at_both_levels(tmp_path):
    # a test that cannot fail is a defect: the walker must find both kinds of import
    path = tmp_path / "probe.py"
    path.write_text("from ringsim.engine import sheet\n"
                    "import typing\n"
                    "if typing.TYPE_CHECKING:\n    import ringsim.plots\n"
                    "def f():\n    from ringsim.analysis.snapshot import snapshot_summary\n")
    found = imports("ringsim.physics.probe", path)
    assert ("ringsim.engine.sheet", "module", 1) in found
    assert ("ringsim.analysis.snapshot", "function", 6) in found
    assert not any(name == "ringsim.plots" for name, _, _ in found), "TYPE_CHECKING only"


def import_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports at run time (module or function level;
    the package root ``ringsim``, whose names load lazily, left out)."""
    known = {name for name, _ in _modules()}
    return {module: {name for name, _, _ in imports(module, path)
                     if name in known and name not in (module, "ringsim")}
            for module, path in _modules()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` as [a, b, ..., a], or None if it is acyclic (a depth-
    first search; a module met again while still on the path closes a cycle)."""
    state: dict[str, str] = {}      # "open": on the current path, "done": fully explored
    path: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = "open"
        path.append(module)
        for imported in sorted(graph.get(module, ())):
            if state.get(imported) == "open":
                return path[path.index(imported):] + [imported]
            if imported not in state:
                cycle = visit(imported)
                if cycle:
                    return cycle
        path.pop()
        state[module] = "done"
        return None

    for module in sorted(graph):
        if module not in state:
            cycle = visit(module)
            if cycle:
                return cycle
    return None


def test_no_import_cycles():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle (imports inside functions count): " + " -> ".join(
        cycle or [])


def test_the_cycle_finder_finds_cycles():
    # a test that cannot fail is a defect: a cycle through three modules, and none without it
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert find_cycle(graph) == ["a", "b", "c", "a"]
    graph["c"] = set()
    assert find_cycle(graph) is None


def _sizes():
    modules, functions = {}, {}
    scripts = [path for d in SCRIPT_DIRS for path in sorted((ROOT / d).rglob("*.py"))]
    for path in [path for _, path in _modules()] + scripts:
        rel = path.relative_to(ROOT).as_posix()
        source = path.read_text()
        modules[rel] = len(source.splitlines())

        def walk(node, prefix, rel=rel):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                    name = f"{prefix}{child.name}"
                    functions[f"{rel}::{name}"] = child.end_lineno - child.lineno + 1
                    walk(child, f"{name}.")
                elif isinstance(child, ast.ClassDef):
                    walk(child, f"{prefix}{child.name}.")
                else:
                    walk(child, prefix)

        walk(ast.parse(source), "")
    return modules, functions


@pytest.fixture(scope="module")
def sizes():
    return _sizes()


def _ratchet() -> dict[str, dict[str, int]]:
    return json.loads(RATCHET.read_text())


def _over(sizes: dict[str, int], allowed: dict[str, int], base: int) -> dict[str, str]:
    return {name: f"{n} > {allowed.get(name, base)}" for name, n in sizes.items()
            if n > allowed.get(name, base)}


def test_modules_within_their_limit(sizes):
    over = _over(sizes[0], _ratchet()["modules"], MODULE_LINES)
    assert not over, f"modules over their limit (split them by concept): {over}"


def test_functions_within_their_limit(sizes):
    over = _over(sizes[1], _ratchet()["functions"], FUNCTION_LINES)
    assert not over, f"functions over their limit (split them): {over}"


def tightened(recorded: dict[str, int], actual: dict[str, int], base: int) -> dict[str, int]:
    """The allowances after the code shrank: each entry at its current size, none at or
    below the base limit, none for code that is gone."""
    return {name: min(limit, actual[name]) for name, limit in recorded.items()
            if name in actual and min(limit, actual[name]) > base}


@pytest.mark.parametrize("kind, index, base, ceiling", [
    ("modules", 0, MODULE_LINES, MODULE_CEILING),
    ("functions", 1, FUNCTION_LINES, FUNCTION_CEILING)])
def test_the_ratchet_only_tightens(sizes, kind, index, base, ceiling):
    recorded = _ratchet()[kind]
    high = {name: n for name, n in recorded.items() if n > ceiling}
    assert not high, f"{kind} allowed past the ceiling of {ceiling} lines: {high}"
    tight = tightened(recorded, sizes[index], base)
    assert recorded == tight, (
        f"{kind} shrank: write their new allowances into {RATCHET.name}: "
        f"{json.dumps(tight, indent=1, sort_keys=True)}")


def test_the_ratchet_tightens_what_shrank():
    recorded = {"a.py": 540, "b.py": 530, "gone.py": 520}
    assert tightened(recorded, {"a.py": 540, "b.py": 490}, 500) == {"a.py": 540}
    assert tightened(recorded, {"a.py": 520, "b.py": 530, "gone.py": 520}, 500) == recorded | {
        "a.py": 520}
