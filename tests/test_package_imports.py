"""The direction of imports between tognet's packages, read from the source with ``ast`` (nothing imported).

* Planning, evaluation, the policies and the job runner never import ``tognet.collect``: collection builds
  its rounds out of them, not the other way round (module-level, lazy imports inside functions, relative
  imports and module names given as strings to a lazy loader alike).
* No module imports a private name (one starting with ``_``) of another tognet package.
* No code outside ``tognet/tasks`` branches on a task's name (read from the source the same way).
* Every import points down the layers (:data:`LAYERS`, geometry at the bottom, the command line on top),
  and no file imports itself through others (no loops between files).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

import tognet

ROOT = Path(tognet.__file__).resolve().parent
#: Packages (and modules) that collection builds on, so they must not import it.
BELOW_COLLECT = ("planning", "evaluate", "policies", "jobs", "io.py")
MODULE_PATH = re.compile(r"tognet(\.[A-Za-z_]\w*)*")


@dataclass(frozen=True)
class Imported:
    """One thing a module imports: the module's dotted name, the name taken from it (or None), the line."""

    module: str
    name: str | None
    line: int

    def targets(self) -> tuple[str, ...]:
        """The dotted names this import may load: the module, and ``module.name`` (a submodule)."""
        return (self.module,) if self.name is None else (self.module, f"{self.module}.{self.name}")


def module_name(path: Path, root: Path = ROOT) -> str:
    """``tognet.a.b`` of ``root/a/b.py`` (``tognet.a`` of ``root/a/__init__.py``)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(["tognet", *parts])


def imports(source: str, module: str, is_package: bool = False) -> list[Imported]:
    """Everything ``module``'s source imports, wherever the statement is (functions included), with
    relative imports resolved; strings that are a whole tognet module path count as imports of it (the
    lazy loaders' tables, ``importlib.import_module``)."""
    package = module if is_package else module.rpartition(".")[0]
    found: list[Imported] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [Imported(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            found += [Imported(base, a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and MODULE_PATH.fullmatch(
                node.value):
            found.append(Imported(node.value, None, node.lineno))
    return found


def top_package(dotted: str) -> str:
    """``tognet.X`` of any ``tognet.X...`` name (a package or a module directly in tognet)."""
    return ".".join(dotted.split(".")[:2])


def collect_imports(source: str, module: str, is_package: bool = False) -> list[str]:
    """Where ``module`` imports ``tognet.collect`` (``"line N: what"``)."""
    found = []
    for i in imports(source, module, is_package):
        hit = [t for t in i.targets() if t == "tognet.collect" or t.startswith("tognet.collect.")]
        if hit:
            found.append(f"line {i.line}: {hit[-1]}")
    return found


def private_imports(source: str, module: str, is_package: bool = False) -> list[str]:
    """Private names (and private modules) ``module`` imports from another tognet package."""
    own = top_package(module)
    out = []
    for i in imports(source, module, is_package):
        if not i.module.startswith("tognet.") or top_package(i.module) == own:
            continue
        private = [p for p in i.module.split(".")[1:] if p.startswith("_") and not p.startswith("__")]
        if i.name is not None and i.name.startswith("_") and not i.name.startswith("__"):
            private.append(i.name)
        if private:
            out.append(f"line {i.line}: {', '.join(private)} from {i.module}")
    return out


def modules(*under: str) -> list[Path]:
    """The source files of the packages (or modules) ``under`` tognet/, or all of them."""
    paths: list[Path] = []
    for name in under or ("",):
        where = ROOT / name
        paths += [where] if where.is_file() else sorted(where.rglob("*.py"))
    return paths


def _check(paths: list[Path], finder: Callable[[str, str, bool], list[str]]) -> dict[str, list[str]]:
    bad = {}
    for path in paths:
        found = finder(path.read_text(), module_name(path), path.name == "__init__.py")
        if found:
            bad[str(path.relative_to(ROOT.parent))] = found
    return bad


def test_planning_evaluate_policies_and_jobs_do_not_import_collect():
    paths = modules(*BELOW_COLLECT)
    assert len(paths) > 20  # the packages are where the test looks
    assert _check(paths, collect_imports) == {}


def test_no_module_imports_another_packages_private_names():
    paths = modules()
    assert len(paths) > 100
    assert _check(paths, private_imports) == {}


# --- the checks themselves catch what they are meant to ---------------------------------------------------
@pytest.mark.parametrize("source", [
    "from tognet.collect.jobs import run_job",
    "import tognet.collect.rounds as rounds",
    "def f():\n    from tognet.collect import collect_round\n    return collect_round",
    "from tognet import collect",
    "from ..collect import jobs",
    "_WHERE = {'run_job': 'tognet.collect.jobs'}",
    "import importlib\nm = importlib.import_module('tognet.collect')",
])
def test_an_import_of_collect_is_found_however_it_is_written(source):
    assert collect_imports(source, "tognet.evaluate.harness")


@pytest.mark.parametrize("source", [
    "from tognet.jobs.workers import LocalExecutor",
    "'''Runs in a worker (tognet.collect.workers is gone).'''",
    "from .config import EvalConfig",
])
def test_imports_that_are_not_of_collect_pass(source):
    assert not collect_imports(source, "tognet.evaluate.harness")


def test_private_names_are_found_across_packages_only():
    assert private_imports("from tognet.data.episodes import _sha256", "tognet.collect.store")
    assert private_imports("def f():\n    from tognet.data.episodes import _x as x", "tognet.collect.store")
    assert private_imports("from ..data.episodes import _read_manifest", "tognet.collect.store")
    assert private_imports("from tognet.sim import _impl", "tognet.collect.jobs")
    assert private_imports("import tognet.sim._impl", "tognet.collect.jobs")
    assert not private_imports("from tognet.data.episodes import _summarise", "tognet.data.writer")
    assert not private_imports("from .episodes import _summarise", "tognet.data.writer")
    assert not private_imports("from tognet.data.episodes import summarise", "tognet.collect.store")
    assert not private_imports("from tognet.data import __doc__", "tognet.collect.store")
    assert not private_imports("from typing import _T", "tognet.collect.store")


def _task_name_branches(tree: ast.AST, names: set[str]) -> list[tuple[int, str]]:
    """Where code compares a value with a task's name, indexes by one, or keys a dict literal with one."""
    def named(node: ast.AST | None) -> bool:
        if isinstance(node, ast.Constant):
            return node.value in names
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            return any(named(e) for e in node.elts)
        return False

    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare) and (named(node.left) or any(named(c) for c in node.comparators)):
            found.append((node.lineno, "compares with a task name"))
        elif isinstance(node, ast.Subscript) and named(node.slice):
            found.append((node.lineno, "indexes by a task name"))
        elif isinstance(node, ast.Dict) and any(named(k) for k in node.keys):
            found.append((node.lineno, "keys a dict with a task name"))
        elif isinstance(node, ast.Match) and any(named(getattr(c.pattern, "value", None))
                                                 for c in node.cases):
            found.append((node.lineno, "matches a task name"))
    return sorted(found)


def test_no_code_outside_tasks_branches_on_a_task_name():
    """What a task is evaluated by, its subsets, its default and its props live in tognet/tasks; the rest
    asks the registry (the grasp-only pseudo-task is the constant GRASP_ONLY)."""
    from tognet.tasks import GRASP_ONLY, TASK_NAMES

    names = {*TASK_NAMES, GRASP_ONLY}
    bad = []
    for path in sorted(ROOT.rglob("*.py")):
        if path.relative_to(ROOT).parts[0] == "tasks":
            continue
        for line, what in _task_name_branches(ast.parse(path.read_text()), names):
            bad.append(f"{path.relative_to(ROOT.parent)}:{line} {what}")
    assert not bad, "\n".join(bad)
    # The check can fail: a branch on a name, written as the evaluation used to, is caught.
    caught = _task_name_branches(ast.parse('x = 1 if task == "sweeping" else 2\ny = r["tasks"]["hammering"]\n'
                                           'z = {"pulling": 1}'), names)
    assert [w for _, w in caught] == ["compares with a task name", "indexes by a task name",
                                      "keys a dict with a task name"]


# --- the layers: imports point down, and no file imports itself through others --------------------------
#: tognet's packages (and top-level modules) by layer, bottom to top. A module imports from its own layer
#: and the layers below only, function-level imports included; the command line is the top floor.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "lazy_names", "config", "io"),
    ("geometry",),
    ("objects",),
    ("tasks",),
    ("robot",),
    ("sim",),
    ("grasping",),
    ("data",),
    ("models",),
    ("model",),
    ("policies",),
    ("planning",),
    ("jobs",),
    ("envs", "demo"),
    ("collect", "evaluate", "viz"),
    ("serve",),
    ("cli", "entry"),
)
LAYER = {f"tognet.{name}": i for i, names in enumerate(LAYERS) for name in names}


def layer_of(dotted: str) -> int | None:
    """The layer of a tognet module (None for ``tognet`` itself, which only names things lazily)."""
    top = top_package(dotted)
    if top == "tognet":
        return None
    if top not in LAYER:
        raise AssertionError(f"{top} is in no layer: add it to LAYERS")
    return LAYER[top]


def upward_imports(source: str, module: str, is_package: bool = False) -> list[str]:
    """Where ``module`` imports from a higher layer than its own."""
    own = layer_of(module)
    out = []
    for i in imports(source, module, is_package):
        for target in i.targets():
            if not target.startswith("tognet.") or own is None:
                continue
            theirs = layer_of(target)
            if theirs is not None and theirs > own:
                out.append(f"line {i.line}: {target} (layer {theirs} above {own})")
                break
    return out


def file_graph(paths: list[Path]) -> dict[str, set[str]]:
    """Which tognet module imports which (function-level imports and lazy tables included)."""
    names = {module_name(p): p for p in paths}
    graph: dict[str, set[str]] = {m: set() for m in names}
    for m, path in names.items():
        for i in imports(path.read_text(), m, path.name == "__init__.py"):
            graph[m] |= {t for t in i.targets() if t in names and t != m}
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import loops of ``graph``: its strongly connected parts of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while not part or part[-1] != v:
                part.append(stack.pop())
            if len(part) > 1:
                found.append(sorted(part))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_every_import_points_down_the_layers():
    paths = modules()
    assert {layer_of(module_name(p)) for p in paths} >= set(range(len(LAYERS)))  # every layer has files
    assert _check(paths, upward_imports) == {}


def test_no_file_imports_itself_through_others():
    assert loops(file_graph(modules())) == []


@pytest.mark.parametrize("source, module", [
    ("def f():\n    from tognet.planning import make_planner", "tognet.sim.world"),
    ("from tognet.cli.util import task_list", "tognet.evaluate.harness"),
    ("_WHERE = {'x': 'tognet.model.predict'}", "tognet.grasping.crops"),
    ("from ..policies import view", "tognet.data.stream"),
])
def test_an_upward_import_is_found_however_it_is_written(source, module):
    assert upward_imports(source, module)


def test_imports_down_or_beside_pass():
    assert not upward_imports("from tognet.geometry import Camera", "tognet.planning.user")
    assert not upward_imports("from tognet.collect.config import PRESETS", "tognet.evaluate.harness")
    assert not upward_imports("from .methods import make_planner", "tognet.planning.user")


def test_a_loop_is_found():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert loops(graph) == [["a", "b", "c"]]
    assert loops({"a": {"b"}, "b": set()}) == []
