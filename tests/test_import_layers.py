"""The import layers of wbik, read from the source with ``ast`` (nothing is imported).

Layers, from the bottom (see docs/architecture.md):

- core (``LAYERS``, from the bottom): foundations (errors, validation, geometry, files, targets,
  registry, data); kinematics (dh, urdf, kinematic_tree, robot, models, collision); solving (solvers,
  qp, wholebody, and the ``wbik`` facade); uses of solving (motion, study, viz, expectations, schema,
  scenario_schema, scenarios);
- robot packages: ``wbik.robot_packages`` (each robot's model, URDF and closed-form binding), which use
  the core; the core names them only by registry strings;
- applications: ``wbik.apps`` (Golem-III, Pincher, Bioloid, riveting), which use the core and the
  robot packages;
- entry points: ``wbik.cli`` and ``wbik.commands``, which may use anything.

Each import is classified as *top-level* (runs when the module is imported: module body, class
bodies, ``try``/``if`` at module level), *function-level* (runs when a function is called: the lazy
imports that keep optional dependencies optional) or *typing* (under ``if TYPE_CHECKING:``, never
at run time). Registry strings ("module:Class", imported with importlib on first use) are not
imports here: they are the intended way for the core to name code it must not depend on.

Checked: (a) no cycle among top-level imports; (b) the core imports no application at top level,
and at function level only at the places listed below with their reason (so the debt is written
down, and a new place or a paid-off one fails the test until this list says so); (c) inside the
core, imports go down ``LAYERS`` (up only at the listed places); (d) only the entry points import
the entry points; (e) the study's report does not import the study's runner (they share
:mod:`wbik.study.context`); (f) the core's modules, and the study's among themselves, import each other
without a cycle, function-level imports included (the study's case kinds sit below the runner and the
report).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from dataclasses import dataclass
from functools import cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "wbik"

CORE = ("wbik.errors", "wbik.validation", "wbik.geometry", "wbik.files", "wbik.targets", "wbik.registry",
        "wbik.kernels", "wbik.robot", "wbik.dh", "wbik.models", "wbik.data", "wbik.solvers", "wbik.qp",
        "wbik.motion", "wbik.study", "wbik.viz", "wbik.collision", "wbik.wholebody", "wbik.schema",
        "wbik.scenario_schema", "wbik.expectations", "wbik.scenarios", "wbik.urdf", "wbik.kinematic_tree",
        "wbik.mujoco_model")
ROBOT_PACKAGES = ("wbik.robot_packages",)
APPLICATIONS = ("wbik.apps", *ROBOT_PACKAGES)  # what the core must not import (robot packages too)
ENTRY_POINTS = ("wbik.cli", "wbik.commands")
LAYERS = (  # the core's layers, from the bottom; a module imports its own layer and those below
    ("wbik.errors", "wbik.validation", "wbik.geometry", "wbik.files", "wbik.targets", "wbik.registry",
     "wbik.data", "wbik.kernels"),
    ("wbik.dh", "wbik.urdf", "wbik.kinematic_tree", "wbik.robot", "wbik.models", "wbik.collision",
     "wbik.mujoco_model"),
    ("wbik.solvers", "wbik.qp", "wbik.wholebody"),
    ("wbik.motion", "wbik.study", "wbik.viz", "wbik.expectations", "wbik.schema", "wbik.scenario_schema",
     "wbik.scenarios"),
)
FACADE_LAYER = 2  # ``wbik/__init__.py`` re-exports models, solvers and wholebody
UPWARD_EXCEPTIONS: dict[tuple[str, str], str] = {
    # (module, module of a higher core layer it imports in a function): reason. None today.
}

TOP_LEVEL_EXCEPTIONS: dict[tuple[str, str], str] = {
    # (core module, application module): reason. None today.
}
FUNCTION_LEVEL_EXCEPTIONS: dict[tuple[str, str], str] = {
    # (core module, application module): reason. None today.
}


@dataclass(frozen=True)
class Import:
    source: str
    target: str
    level: str  # "top", "function" or "typing"
    line: int


def _modules() -> dict[str, tuple[Path, bool]]:
    """Module name -> (file, is a package's __init__)."""
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        modules[".".join(parts)] = (path, is_package)
    return modules


def _imports_of(name: str, path: Path, is_package: bool, known: set[str]) -> list[Import]:
    found: list[Import] = []

    def add(target: str, level: str, line: int) -> None:
        if target in known:
            found.append(Import(name, target, level, line))

    def absolute(node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        base = name.split(".") if is_package else name.split(".")[:-1]
        base = base[:len(base) - (node.level - 1)]
        return ".".join(base + ([node.module] if node.module else []))

    def visit(nodes, level: str) -> None:
        for child in nodes:
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
                visit(ast.iter_child_nodes(child), "function")
                continue
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                visit(child.body, "typing")
                visit(child.orelse, level)
                continue
            if isinstance(child, ast.Import):
                for alias in child.names:
                    add(alias.name, level, child.lineno)
            elif isinstance(child, ast.ImportFrom):
                module = absolute(child)
                for alias in child.names:  # "from wbik.study import results" imports the module
                    submodule = f"{module}.{alias.name}"
                    add(submodule if submodule in known else module, level, child.lineno)
            visit(ast.iter_child_nodes(child), level)

    visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)).body, "top")
    return found


@cache
def _graph() -> tuple[Import, ...]:
    modules = _modules()
    known = set(modules)
    return tuple(dict.fromkeys(  # one entry per (source, target, level, line)
        item for name, (path, is_package) in modules.items()
        for item in _imports_of(name, path, is_package, known) if item.target != name))


def _within(module: str, prefixes: tuple[str, ...]) -> bool:
    return any(module == prefix or module.startswith(prefix + ".") for prefix in prefixes)


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in sorted(edges.get(node, ())):
            if successor not in index:
                connect(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            connect(node)
    return components


def _where(items) -> str:
    return "\n".join(f"  {item.source} -> {item.target} (line {item.line}, {item.level})" for item in items)


def test_the_parser_sees_the_package():
    """Guards the other tests against passing on an empty graph."""
    graph = _graph()
    assert len(_modules()) > 100
    assert Import("wbik.study.runner", "wbik.study.context", "top", 0) in {
        Import(i.source, i.target, i.level, 0) for i in graph}
    assert any(i.level == "function" for i in graph) and any(i.level == "top" for i in graph)
    assert all(item.target.startswith("wbik") for item in graph)


def test_no_cycle_among_top_level_imports():
    edges: dict[str, set[str]] = defaultdict(set)
    for item in _graph():
        if item.level == "top":
            edges[item.source].add(item.target)
    cycles = _cycles(edges)
    details = [_where(i for i in _graph() if i.level == "top" and i.source in c and i.target in c)
               for c in cycles]
    assert not cycles, "modules importing each other at top level:\n" + "\n\n".join(details)


def _core_to_applications(level: str) -> dict[tuple[str, str], list[Import]]:
    found: dict[tuple[str, str], list[Import]] = defaultdict(list)
    for item in _graph():
        if item.level == level and _within(item.source, CORE) and _within(item.target, APPLICATIONS):
            found[item.source, item.target].append(item)
    return found


def test_the_core_does_not_import_the_applications_at_top_level():
    found = _core_to_applications("top")
    new = {pair: items for pair, items in found.items() if pair not in TOP_LEVEL_EXCEPTIONS}
    assert not new, ("the core imports an application at top level (move the code into the "
                     "application, or name it by a registry string):\n"
                     + _where(item for items in new.values() for item in items))
    paid = set(TOP_LEVEL_EXCEPTIONS) - set(found)
    assert not paid, f"no longer imported, remove from TOP_LEVEL_EXCEPTIONS: {sorted(paid)}"


def test_the_core_imports_the_applications_only_at_the_listed_function_level_places():
    found = _core_to_applications("function")
    new = {pair: items for pair, items in found.items() if pair not in FUNCTION_LEVEL_EXCEPTIONS}
    assert not new, ("a new function-level import of an application from the core; avoid it, or list "
                     "it in FUNCTION_LEVEL_EXCEPTIONS with its reason:\n"
                     + _where(item for items in new.values() for item in items))
    paid = set(FUNCTION_LEVEL_EXCEPTIONS) - set(found)
    assert not paid, f"no longer imported, remove from FUNCTION_LEVEL_EXCEPTIONS: {sorted(paid)}"


def test_every_module_is_core_robot_package_application_or_entry_point():
    stray = [m for m in _modules() if m != "wbik" and not _within(m, CORE + APPLICATIONS + ENTRY_POINTS)]
    assert not stray, f"modules outside every layer (add them to a layer above): {stray}"


def test_robot_packages_do_not_import_the_applications():
    wrong = [item for item in _graph() if item.level != "typing" and _within(item.source, ROBOT_PACKAGES)
             and _within(item.target, ("wbik.apps",))]
    assert not wrong, "a robot package imports an application:\n" + _where(wrong)


def _layer(module: str) -> int | None:
    if module == "wbik":
        return FACADE_LAYER
    for number, prefixes in enumerate(LAYERS):
        if _within(module, prefixes):
            return number
    return None


def test_the_core_layers_cover_the_core_and_imports_go_down_them():
    assert not [m for m in _modules() if _within(m, CORE) and _layer(m) is None]
    found: dict[tuple[str, str], list[Import]] = defaultdict(list)
    for item in _graph():
        source, target = _layer(item.source), _layer(item.target)
        if item.level != "typing" and None not in (source, target) and target > source:
            found[item.source, item.target].append(item)
    new = {pair: items for pair, items in found.items() if pair not in UPWARD_EXCEPTIONS}
    assert not new, ("a core module imports a higher core layer (see LAYERS and docs/architecture.md); "
                     "move the code down, or list it in UPWARD_EXCEPTIONS with its reason:\n"
                     + _where(item for items in new.values() for item in items))
    paid = set(UPWARD_EXCEPTIONS) - set(found)
    assert not paid, f"no longer imported, remove from UPWARD_EXCEPTIONS: {sorted(paid)}"


def test_only_the_entry_points_import_the_entry_points():
    wrong = [item for item in _graph() if item.level != "typing" and _within(item.target, ENTRY_POINTS)
             and not _within(item.source, ENTRY_POINTS)]
    assert not wrong, "the command line is the top layer; nothing below imports it:\n" + _where(wrong)


def test_the_study_report_does_not_import_the_runner():
    wrong = [item for item in _graph()
             if item.source == "wbik.study.report" and item.target == "wbik.study.runner"]
    assert not wrong, ("the report reads results; what it shares with the runner lives in "
                       "wbik.study.context:\n" + _where(wrong))


def test_no_cycle_in_the_core_counting_function_level_imports():
    """The core's modules import each other without a cycle, lazily or not (a lazy import that closes a
    cycle only hides it from the interpreter, not from a reader)."""
    edges: dict[str, set[str]] = defaultdict(set)
    inside = [item for item in _graph() if item.level != "typing"
              and _within(item.source, CORE) and _within(item.target, CORE)]
    for item in inside:
        edges[item.source].add(item.target)
    cycles = _cycles(edges)
    details = [_where(i for i in inside if i.source in c and i.target in c) for c in cycles]
    assert not cycles, "core modules importing each other (top or function level):\n" + "\n\n".join(details)


def test_no_cycle_inside_the_study_counting_function_level_imports():
    """The runner, the applicability check and the report ask a case's kind; the kinds import what
    they share from below (context, blocks), never back from the runner or the report, lazily or not."""
    edges: dict[str, set[str]] = defaultdict(set)
    inside = [item for item in _graph() if item.level != "typing"
              and _within(item.source, ("wbik.study",)) and _within(item.target, ("wbik.study",))]
    for item in inside:
        edges[item.source].add(item.target)
    cycles = _cycles(edges)
    details = [_where(i for i in inside if i.source in c and i.target in c) for c in cycles]
    assert not cycles, "study modules importing each other (top or function level):\n" + "\n\n".join(details)


def test_the_core_names_no_application_not_even_in_a_string():
    """Applications plug in from outside (entry points, wbik.registry.plugin_modules): no module outside
    wbik/apps names one, by import or in any string (a registry list, a docstring, a comment-like
    string)."""
    named = []
    for name, (path, _) in _modules().items():
        if _within(name, ("wbik.apps",)):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and (
                    "wbik.apps" in node.value or "wbik/apps" in node.value):
                named.append(f"{name}:{node.lineno}: {node.value.strip()[:80]!r}")
    assert not named, "the core names an application (declare it as an entry point instead):\n" + \
        "\n".join(named)
