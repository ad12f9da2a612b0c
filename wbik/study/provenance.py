"""What made a study's rows (``provenance.json``): wbik's version and commit, the machine, the command and
a code fingerprint, a digest of the syntax trees (docstrings aside) of the modules the rows come from
(followed along imports) and of the compiled kernels' C sources."""

from __future__ import annotations

import ast
import contextlib
import hashlib
import os
import platform
import re
import shlex
import subprocess
import sys
from collections.abc import Iterable
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

from wbik.study.spec import Study

PROVENANCE = "provenance.json"
PACKAGE = Path(__file__).resolve().parents[1]
"""The ``wbik`` package folder whose source is fingerprinted."""
_KERNEL = re.compile(r"^wbik\.kernels\._\w+$")
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def source_of(module: str) -> Path | None:
    """The source file of the wbik module ``module`` (None if it is no module of the package)."""
    parts = module.split(".")
    if parts[0] != "wbik":
        return None
    base = PACKAGE.joinpath(*parts[1:])
    return next((path for path in (base / "__init__.py", base.with_suffix(".py")) if path.is_file()), None)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def references(tree: ast.AST) -> tuple[set[str], set[str]]:
    """(wbik modules, kernel C files) a module's tree imports."""
    modules: set[str] = set()
    kernels: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [f"{node.module}.{alias.name}" if source_of(f"{node.module}.{alias.name}")
                     or _KERNEL.match(f"{node.module}.{alias.name}") else node.module for alias in node.names]
        else:
            names = []
        for name in names:  # a compiled kernel (wbik.kernels._name) is its C or C++ source
            if _KERNEL.match(name):
                kernels.add(name.rsplit(".", 1)[1] + ".c")
            else:
                modules.add(name)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return {module for module in modules if source_of(module)}, kernels


def without_docstrings(tree: ast.Module) -> ast.Module:
    """``tree`` without its statements that are lone strings (docstrings)."""
    for node in ast.walk(tree):
        for name in ("body", "orelse", "finalbody"):
            body = getattr(node, name, None)
            if isinstance(body, list) and body and isinstance(body[0], ast.stmt):
                kept = [s for s in body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant)
                                                and isinstance(s.value.value, str))]
                setattr(node, name, kept or ([ast.Pass()] if name == "body" else []))
    return tree


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def code_digests(roots) -> dict[str, str]:
    """{module or kernel file: digest} of the modules reached from ``roots`` and the kernels they import."""
    digests: dict[str, str] = {}
    pending, kernels = list(roots), set()
    while pending:
        module = pending.pop()
        path = source_of(module)
        if module in digests or path is None:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        imported, named = references(tree)
        digests[module] = _digest(ast.dump(without_docstrings(tree), include_attributes=False).encode())
        pending.extend(imported)
        kernels |= named
    folder = PACKAGE / "kernels"
    while kernels:
        name = kernels.pop()
        path = folder / name
        if not path.is_file() and path.suffix == ".c":  # a C++ kernel
            name, path = name + "pp", folder / f"{name}pp"
        if f"kernels/{name}" in digests or not path.is_file():
            continue
        text = path.read_text(encoding="utf-8")
        digests[f"kernels/{name}"] = _digest(text.encode())
        kernels.update(_INCLUDE.findall(text))
    return dict(sorted(digests.items()))


def code_roots(study: Study, machinery: Iterable[str]) -> list[str]:
    """The modules the fingerprint of ``study``'s code starts from: ``machinery`` (the runner), the robot
    registry, and per case its kind, the methods' solvers and the robot's module."""
    from wbik.models import robot_entries
    from wbik.study.case_kinds import case_kind

    objects: list = []
    roots = set(machinery) | {robot_entries.__module__}
    for case in study.cases:
        kind = case_kind(case)
        objects += [type(kind), *kind.code_roots(case)]
        objects += [kind.method_factory(method.method) for method in study.methods]
        if (entry := robot_entries().get(case.robot)) is not None:
            roots.add(entry.module().__name__)
    roots.update(getattr(item, "__module__", None) or "" for item in objects if item is not None)
    return sorted(root for root in roots if source_of(root))


def code_fingerprint(digests: dict[str, str]) -> str:
    """One digest of :func:`code_digests`'s."""
    return _digest("\n".join(f"{name} {digest}" for name, digest in sorted(digests.items())).encode())


def git_commit() -> str | None:
    """The commit of the package's checkout, "+ uncommitted changes" if tracked files differ; None: no git."""
    root = PACKAGE.parent

    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, check=True,
                              timeout=10).stdout.strip()

    try:
        commit = git("rev-parse", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + (" + uncommitted changes" if dirty else "")


def cpu_model() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo, else what platform says)."""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def machine() -> dict:
    """The machine and the versions the rows were computed with."""
    import numpy
    import pinocchio

    from wbik.solvers.workers import usable_cores

    return {"cpu": cpu_model(), "cpu_count": os.cpu_count(), "usable_cores": usable_cores(),
            "os": platform.platform(), "python": platform.python_version(), "numpy": numpy.__version__,
            "pinocchio": pinocchio.__version__}


def command_line() -> str:
    """The command this process runs, as typed (``wbik study ...`` for the console script)."""
    return shlex.join([Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python", *sys.argv[1:]])


def provenance(study: Study, machinery: Iterable[str]) -> dict:
    """The record of what made ``study``'s rows in this process (``machinery``: :func:`code_roots`)."""
    try:
        version = metadata.version("wbik")
    except metadata.PackageNotFoundError:  # a source tree on the path, not installed
        version = "unknown"
    digests = code_digests(code_roots(study, machinery))
    return {"wbik": version, "commit": git_commit(), "machine": machine(), "command": command_line(),
            "made": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
            "code_fingerprint": code_fingerprint(digests), "code": digests}


def provenance_lines(record: dict) -> list[str]:
    """The record in words, for the report's head."""
    box = record.get("machine", {})
    return [f"made by: {record.get('command')} ({record.get('made')})",
            f"wbik {record.get('wbik')}, commit {record.get('commit') or 'unknown (not a git checkout)'}; "
            f"code fingerprint {record.get('code_fingerprint')} ({len(record.get('code', {}))} modules and "
            "kernels the rows come from, wbik.study.provenance)",
            f"machine: {box.get('cpu')}, {box.get('cpu_count')} CPUs ({box.get('usable_cores')} usable), "
            f"{box.get('os')}; Python {box.get('python')}, NumPy {box.get('numpy')}, Pinocchio "
            f"{box.get('pinocchio')}"]
