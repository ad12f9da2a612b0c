"""The package metadata gives compatible ranges, the lock the exact set: pyproject.toml's dependencies and
extras are ranges (no ``==``), each peer is an extra and ``all`` holds every one, and requirements.lock
(what the README's set-up installs) satisfies every range."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
PEERS = {"placo": "placo", "mink": "mink", "pink": "pin-pink", "eaik": "eaik", "ikgeo": "ik-geo",
         "tracik": "pytracik"}


def _project() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _lock() -> dict[str, Version]:
    pins = {}
    for line in (ROOT / "requirements.lock").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, version = line.partition("==")
            pins[canonicalize_name(name)] = Version(version.strip())
    return pins


def _requirements() -> list[tuple[str, Requirement]]:
    project = _project()
    found = [("dependencies", Requirement(text)) for text in project["dependencies"]]
    for extra, texts in project["optional-dependencies"].items():
        found += [(f"extra {extra}", Requirement(text)) for text in texts]
    return found


def test_every_requirement_is_a_range_with_a_floor_and_a_ceiling():
    for where, requirement in _requirements():
        if canonicalize_name(requirement.name) == "wbik":
            continue
        operators = {spec.operator for spec in requirement.specifier}
        assert "==" not in operators and "===" not in operators, f"{where}: {requirement} pins one version"
        assert ">=" in operators and "<" in operators, f"{where}: {requirement} needs a floor and a ceiling"


def test_the_lock_satisfies_every_range():
    pins = _lock()
    for where, requirement in _requirements():
        name = canonicalize_name(requirement.name)
        if name == "wbik":
            continue
        assert name in pins, f"{where}: {requirement.name} is not in requirements.lock"
        pinned = pins[name]
        assert requirement.specifier.contains(pinned, prereleases=True), \
            f"{where}: requirements.lock has {requirement.name}=={pinned}, outside {requirement.specifier}"


def test_each_peer_is_an_extra_outside_the_core_and_all_holds_every_extra():
    project = _project()
    core = {canonicalize_name(Requirement(text).name) for text in project["dependencies"]}
    extras = project["optional-dependencies"]
    for extra, package in PEERS.items():
        names = {canonicalize_name(Requirement(text).name) for text in extras[extra]}
        assert canonicalize_name(package) in names
        assert canonicalize_name(package) not in core, f"{package} is a peer: an extra, not a dependency"
    everything = Requirement(extras["all"][0])
    assert canonicalize_name(everything.name) == "wbik"
    assert everything.extras == set(extras) - {"all", "dev"}
    assert "all" in (ROOT / "scripts" / "setup.sh").read_text()  # the README's set-up installs them all


HEAVY_ON_FIRST_USE = ("placo", "pink", "mink", "mujoco", "eaik", "ik_geo", "pytracik", "PyKDL", "qpsolvers",
                      "daqp", "osqp", "proxsuite", "quadprog", "matplotlib", "meshcat", "scipy", "yaml")
"""What ``import wbik`` and ``wbik --help`` leave for the first call that needs it: every peer, every QP
backend, plotting, the viewer, SciPy and YAML."""


def _imported_by(code: str) -> set[str]:
    """The top-level packages a fresh interpreter holds after running ``code``."""
    shown = "import sys; print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))"
    done = subprocess.run([sys.executable, "-c", f"{code}\n{shown}"], capture_output=True, text=True,
                          check=True, timeout=120)
    return set(done.stdout.split())


def test_import_wbik_and_its_help_import_no_peer_backend_plotting_or_viewer():
    loaded = _imported_by("import wbik")
    assert {"wbik", "numpy", "pinocchio"} <= loaded  # (the check sees what is imported)
    assert loaded.isdisjoint(HEAVY_ON_FIRST_USE), sorted(loaded & set(HEAVY_ON_FIRST_USE))
    helped = _imported_by("import contextlib, io\nfrom wbik.cli import main\n"
                          "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
                          "    main(['--help'])")
    assert helped.isdisjoint(HEAVY_ON_FIRST_USE), sorted(helped & set(HEAVY_ON_FIRST_USE))


def test_the_first_qp_solve_imports_its_backend_where_it_is_needed():
    loaded = _imported_by("import wbik\nfrom wbik.qp import IKProblem, PositionTask\n"
                          "robot = wbik.load('ur5')\n"
                          "problem = IKProblem(robot.model, [PositionTask('tool0', [0.4, 0.1, 0.4])])\n"
                          "problem.solve(robot.nominal)")
    assert "daqp" in loaded and "qpsolvers" not in loaded  # DAQP is called directly


def test_the_cxx_kernels_build_requirements_are_the_locked_pinocchio_and_one_eigen(monkeypatch):
    """The C++ kernel compiles Pinocchio's headers: the build backend asks for the libpinocchio that the
    lock's pin (the runtime binding the kernel must match bit for bit) depends on, and one Eigen; with
    WBIK_BUILD_CXX=0 it asks for neither (a machine without them builds wbik)."""
    monkeypatch.syspath_prepend(str(ROOT / "build_backend"))
    import wbik_backend

    backend = tomllib.loads((ROOT / "pyproject.toml").read_text())["build-system"]
    assert backend["build-backend"] == "wbik_backend" and backend["backend-path"] == ["build_backend"]
    pinned = {canonicalize_name(r.name): str(r.specifier) for r in map(Requirement, wbik_backend.CXX_HEADERS)}
    pins = _lock()
    assert pinned["libpinocchio"] == f"=={pins['libpinocchio']}" == f"=={pins['pin']}"
    assert pinned["cmeel-eigen"].startswith("==3.4.")
    monkeypatch.setenv("WBIK_BUILD_CXX", "1")
    assert wbik_backend.cxx_requirements() == (wbik_backend.CXX_HEADERS if shutil.which("c++") else [])
    monkeypatch.setenv("WBIK_BUILD_CXX", "0")
    assert wbik_backend.cxx_requirements() == []
