"""The core install beside a user's own packages: wbik's wheel, built from this tree and installed with no
extras in a fresh virtual environment (pinned by requirements.lock), holds no peer, runs the README's ten
lines (minus the methods whose extras are absent) and ``wbik solve``, and says which extra a missing peer
needs. Everything runs from outside the source tree, so the installed wheel is what is imported."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from wbik.kernels.twins import can_build

ROOT = Path(__file__).resolve().parents[1]
UV = Path(sys.executable).parent / "uv"
"""The installer (the dev extra's uv, as the set-up uses): it resolves the wheel's metadata as pip does, and
links the files from its cache instead of unpacking every wheel again."""
PEER_DISTRIBUTIONS = ("placo", "mink", "mujoco", "pin-pink", "eaik", "ik-geo", "pytracik", "osqp",
                      "proxsuite", "quadprog", "dask")
CORE_DISTRIBUTIONS = ("pin", "numpy", "scipy", "qpsolvers", "daqp", "example-robot-data", "meshcat",
                      "matplotlib", "pyyaml", "tqdm", "wbik")


def _run(command: list, cwd: Path, check: bool = True, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(part) for part in command], cwd=cwd, capture_output=True, text=True,
                          check=check, timeout=900,
                          env={"PATH": "/usr/bin:/bin", "HOME": str(Path.home()), **env})


@pytest.fixture(scope="module")
def core(tmp_path_factory) -> Path:
    """A folder holding ``venv``: the wheel installed with no extras."""
    work = tmp_path_factory.mktemp("core_install")
    # without the C++ kernel (WBIK_BUILD_CXX=0), as a machine without a C++ compiler installs it: every
    # method runs, the chain's FK through Pinocchio's binding (tests/test_installed.py builds it)
    _run([UV, "build", "-q", "--wheel", "--python", sys.executable, "--system-certs", "--build-constraint",
          ROOT / "requirements.lock", "--out-dir", work / "dist", ROOT], work, WBIK_BUILD_CXX="0")
    wheel = next((work / "dist").glob("wbik-*.whl"))
    _run([sys.executable, "-m", "venv", "--without-pip", work / "venv"], work)
    _run([UV, "pip", "install", "-q", "--system-certs", "--python", work / "venv/bin/python",
          "-c", ROOT / "requirements.lock", wheel], work)
    return work


def _distributions(core: Path) -> set[str]:
    listed = _run([UV, "pip", "list", "--python", core / "venv/bin/python", "--format=json"], core).stdout
    return {entry["name"].lower().replace("_", "-") for entry in json.loads(listed)}


def test_the_core_install_holds_the_core_and_no_peer(core):
    installed = _distributions(core)
    assert set(CORE_DISTRIBUTIONS) <= installed, sorted(set(CORE_DISTRIBUTIONS) - installed)
    assert installed.isdisjoint(PEER_DISTRIBUTIONS), sorted(installed & set(PEER_DISTRIBUTIONS))


def test_the_readmes_ten_lines_run_with_the_methods_installed(core):
    block = re.search(r"## Ten lines\n\n```python\n(.*?)```", (ROOT / "README.md").read_text(), re.DOTALL)
    assert block is not None, "README.md lost its '## Ten lines' block"
    lines = block.group(1)
    loop = re.search(r"for method in (\(.*?\)):", lines)
    assert loop is not None and '"trac_ik"' in loop.group(1)  # the README names a method of an extra
    installed = f"[m for m in {loop.group(1)} if m in wbik.methods(installed=True)]"
    runnable = lines.replace(loop.group(0), f"for method in {installed}:")
    (core / "ten_lines.py").write_text(runnable)
    printed = _run([core / "venv/bin/python", "ten_lines.py"], core).stdout.splitlines()
    assert [line.split()[:2] for line in printed] == [["analytic", "True"], ["bounded_lm", "True"]]


def test_wbik_solve_and_a_missing_peer(core):
    wbik = core / "venv/bin/wbik"
    target = ["--xyz", "0.4", "0.2", "0.3"]
    solved = _run([wbik, "solve", "ur5", "--chain", "arm", "--method", "bounded_lm", *target, "--json"], core)
    answer = json.loads(solved.stdout)
    assert answer["success"] and answer["position_error"] < 1e-6
    refused = _run([wbik, "solve", "ur5", "--chain", "arm", "--method", "placo", *target], core, check=False)
    assert refused.returncode != 0 and "pip install 'wbik[placo]'" in refused.stderr, refused.stderr
    listed = _run([wbik, "methods"], core).stdout
    for extra in ("placo", "pink", "mink", "eaik", "ikgeo", "tracik"):
        assert f"pip install 'wbik[{extra}]'" in listed, extra


def test_without_the_cxx_kernel_the_chain_fk_is_pinocchios_binding(core):
    """The wheel built with WBIK_BUILD_CXX=0 has no compiled chain FK; a chain then places its tip through
    Pinocchio's binding and the C kernels still run."""
    script = ("import wbik; from wbik.kernels.twins import KERNELS; "
              "built = {k.name: k.extension is not None for k in KERNELS}; "
              "chain = wbik.load('ur5').chain('arm'); "
              "print(built.pop('chain_fk'), chain.compiled_fk, all(built.values()))")
    printed = _run([core / "venv/bin/python", "-c", script], core).stdout.split()
    assert printed[:2] == ["False", "None"]
    assert printed[2] == str(can_build())
