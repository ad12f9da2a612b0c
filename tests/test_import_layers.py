"""The import layers of wbik, read from the source with ``ast`` (nothing is imported).

Layers, from the bottom (see docs/architecture.md):

- core (``LAYERS``, from the bottom): foundations (errors, dependencies, validation, schema, options,
  geometry, files, targets, registry, data, kernels); kinematics (dh, urdf, kinematic_tree, robot, models,
  collision, mujoco_model); solving (solvers, qp, wholebody); uses of solving (motion, study, viz,
  expectations, scenarios);
- robot packages: ``wbik.robot_packages`` (each robot's model, URDF and closed-form binding), which use
  the core;
- applications: ``wbik.apps`` (Golem-III, Pincher, Bioloid, riveting), which use the core and the
  robot packages;
- the top: the facade ``wbik``, the catalog of what wbik ships (``wbik.catalog``: it imports the robot
  packages and applications by name for the registries) and the command line (``wbik.cli``,
  ``wbik.commands``), which may use anything.

Each import is classified as *top-level* (module body, class bodies, ``try``/``if`` at module level),
*function-level* (the lazy imports that keep optional dependencies optional) or *typing* (under
``if TYPE_CHECKING:``). ``from A import B`` imports A (a package: its ``__init__``) and, when B is a
module, A.B too; importing a.b.c runs the packages a and a.b first, which counts as importing them too
(but for the importer's own packages, which are then already running).

Checked: (a) no import cycle of any kind, every level counted; (b) no module imports its own package
(it imports the defining module); (c) the project's own modules are imported by name, never named by a
string; (d) the core imports no robot package or application; (e) inside the core, imports go down
``LAYERS``; (f) only the top imports the top; (g) the study's report does not import the study's runner.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from dataclasses import dataclass
from functools import cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "wbik"

CORE = ("wbik.errors", "wbik.dependencies", "wbik.peer_output", "wbik.validation", "wbik.schema",
        "wbik.options", "wbik.geometry", "wbik.files", "wbik.targets", "wbik.registry", "wbik.kernels",
        "wbik.robot", "wbik.dh", "wbik.models", "wbik.data", "wbik.solvers", "wbik.qp", "wbik.motion",
        "wbik.study", "wbik.viz", "wbik.collision", "wbik.wholebody", "wbik.expectations", "wbik.scenarios",
        "wbik.urdf", "wbik.kinematic_tree", "wbik.mujoco_model")
ROBOT_PACKAGES = ("wbik.robot_packages",)
APPLICATIONS = ("wbik.apps", *ROBOT_PACKAGES)  # what the core must not import (robot packages too)
ENTRY_POINTS = ("wbik.cli", "wbik.commands", "wbik.catalog")
LAYERS = (  # the core's layers, from the bottom; a module imports its own layer and those below
    ("wbik.errors", "wbik.dependencies", "wbik.peer_output", "wbik.validation", "wbik.schema", "wbik.options",
     "wbik.geometry", "wbik.files", "wbik.targets", "wbik.registry", "wbik.data", "wbik.kernels"),
    ("wbik.dh", "wbik.urdf", "wbik.kinematic_tree", "wbik.robot", "wbik.models", "wbik.collision",
     "wbik.mujoco_model"),
    ("wbik.solvers", "wbik.qp", "wbik.wholebody"),
    ("wbik.motion", "wbik.study", "wbik.viz", "wbik.expectations", "wbik.scenarios"),
)
TOP = len(LAYERS)  # the facade, the catalog and the command line


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
            parts = target.split(".")
            for end in range(1, len(parts)):  # importing a.b.c runs a's and a.b's __init__ first
                parent = ".".join(parts[:end])
                if parent in known and name != parent and not name.startswith(parent + "."):
                    found.append(Import(name, parent, level, line))  # (one's own packages: already run)

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
                add(module, level, child.lineno)  # a package: its __init__
                for alias in child.names:  # "from wbik.study import results" imports the module too
                    if f"{module}.{alias.name}" in known:
                        add(f"{module}.{alias.name}", level, child.lineno)
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


def test_no_import_cycle_of_any_kind():
    """Module-level, function-level and TYPE_CHECKING imports all count (a lazy import that closes a cycle
    only hides it from the interpreter, not from a reader)."""
    edges: dict[str, set[str]] = defaultdict(set)
    for item in _graph():
        edges[item.source].add(item.target)
    cycles = _cycles(edges)
    details = [_where(i for i in _graph() if i.source in c and i.target in c) for c in cycles]
    assert not cycles, "modules importing each other:\n" + "\n\n".join(details)


def test_the_cycle_check_can_fail():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_module_imports_its_own_package():
    """A module imports the defining module (``wbik.qp.backends``), never its own package's ``__init__``
    (``from wbik.qp import backends`` inside ``wbik/qp``)."""
    wrong = [item for item in _graph() if item.source.startswith(item.target + ".")]
    assert not wrong, "modules importing their own package:\n" + _where(wrong)


def _docstring_nodes(tree: ast.AST) -> set[int]:
    """ids of the string constants that are docstrings (of modules, classes, functions, attributes)."""
    found = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list):
            for statement in body:
                if isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Constant):
                    found.add(id(statement.value))
    return found


def test_the_project_names_its_own_modules_by_import_not_by_string():
    """No string holds the name of one of wbik's modules (a registry list, importlib's argument): editors,
    graphs and this test see the ties. Entry points stay for installed plug-ins."""
    known = set(_modules())
    named = []
    for name, (path, _) in _modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docstrings = _docstring_nodes(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
                value = node.value.split(":")[0].strip()
                if "." in value and (value in known or (value.rpartition(".")[0] in known
                                                        and value.rpartition(".")[2].startswith("_"))):
                    named.append(f"{name}:{node.lineno}: {node.value!r}")
    assert not named, "modules of wbik named by a string (import them by name):\n" + "\n".join(named)


def test_the_core_imports_no_robot_package_and_no_application():
    wrong = [item for item in _graph() if _within(item.source, CORE) and _within(item.target, APPLICATIONS)]
    assert not wrong, ("the core imports a robot package or an application (list it in wbik.catalog, "
                       "which adds it to the registries):\n" + _where(wrong))


def test_every_module_is_core_robot_package_application_or_entry_point():
    stray = [m for m in _modules() if m != "wbik" and not _within(m, CORE + APPLICATIONS + ENTRY_POINTS)]
    assert not stray, f"modules outside every layer (add them to a layer above): {stray}"


def test_robot_packages_do_not_import_the_applications():
    wrong = [item for item in _graph() if item.level != "typing" and _within(item.source, ROBOT_PACKAGES)
             and _within(item.target, ("wbik.apps",))]
    assert not wrong, "a robot package imports an application:\n" + _where(wrong)


def _layer(module: str) -> int | None:
    if module == "wbik" or _within(module, ENTRY_POINTS):
        return TOP
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
    assert not found, ("a core module imports a higher core layer (see LAYERS and docs/architecture.md); "
                       "move the code down:\n" + _where(item for items in found.values() for item in items))


def test_only_the_entry_points_import_the_entry_points():
    wrong = [item for item in _graph() if _within(item.target, ENTRY_POINTS)
             and not (item.source == "wbik" or _within(item.source, ENTRY_POINTS))]
    assert not wrong, "the command line is the top layer; nothing below imports it:\n" + _where(wrong)


def test_the_study_report_does_not_import_the_runner():
    wrong = [item for item in _graph()
             if item.source == "wbik.study.report" and item.target == "wbik.study.runner"]
    assert not wrong, ("the report reads results; what it shares with the runner lives in "
                       "wbik.study.context:\n" + _where(wrong))
