"""wbik works installed from a wheel, not only from the source tree.

A wheel is built (``uv build --wheel``, with the C++ kernel) from a copy of the files a build reads,
so nothing is written into the working tree. It is installed (no dependencies) into a fresh venv made by this
interpreter without pip; a ``.pth`` there adds the test venv's site-packages *after* the new venv's
own, so the dependencies are reused while ``import wbik`` finds the installed copy first (the
editable install's finder is consulted only after the path). The commands run from ``tmp_path``
with the new venv's ``wbik`` script, so neither the source tree nor the cwd can supply data: the
tasks, study files and the robots' URDFs must come from the wheel (``wbik/data/``: ``tasks/``,
``comparisons/``, ``urdf/``). The URDF cache goes to ``WBIK_CACHE_DIR``, and a run
that uses no PlaCo writes nothing there.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from wbik.kernels.twins import can_build

ROOT = Path(__file__).resolve().parents[1]
BUILD_INPUTS = ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "build_backend", "wbik", "tasks",
                "urdf")
TIMEOUT_S = 600
UV = Path(sys.executable).parent / "uv"
HAS_COMPILER = can_build()
"""Whether the wheel can build the C kernels."""


def _run(command: list, cwd: Path, env: dict, timeout: float = TIMEOUT_S) -> subprocess.CompletedProcess:
    result = subprocess.run([str(part) for part in command], cwd=cwd, env=env, capture_output=True,
                            text=True, timeout=timeout)
    assert result.returncode == 0, (f"{' '.join(map(str, command))} exited {result.returncode}\n"
                                    f"stdout:\n{result.stdout[-4000:]}\nstderr:\n{result.stderr[-4000:]}")
    return result


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict:
    """A venv holding only the wheel of wbik (dependencies from the test venv); its env and paths."""
    work = tmp_path_factory.mktemp("installed")
    source = work / "source"
    source.mkdir()
    for name in BUILD_INPUTS:
        origin = ROOT / name
        if origin.is_dir():
            shutil.copytree(origin, source / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so"))
        else:
            shutil.copy2(origin, source / name)
    (source / "comparisons").mkdir()
    for study in (ROOT / "comparisons").glob("*.yaml"):  # the study files; reports/ is not shipped
        shutil.copy2(study, source / "comparisons" / study.name)
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(PIP_DISABLE_PIP_VERSION_CHECK="1", WBIK_CACHE_DIR=str(work / "cache"), MPLBACKEND="Agg")
    wheels = work / "wheels"
    # uv, as the set-up: its isolated build environment links the build requirements (Pinocchio's, Boost's
    # and Eigen's headers for the C++ kernel) from its cache where pip would unpack them (65 s against 32)
    build = _run([UV, "build", "--wheel", "--python", sys.executable, "--system-certs", "--build-constraint",
                  ROOT / "requirements.lock", "--out-dir", wheels, "."], cwd=source, env=env)
    wheel = next(wheels.glob("wbik-*.whl"))
    build_output = build.stdout + build.stderr

    venv = work / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=work, env=env)
    python = venv / "bin" / "python"
    purelib = Path(_run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                        cwd=work, env=env).stdout.strip())
    # the test venv's packages (with their own .pth files: cmeel's prefix, the PyKDL shim), appended
    # after the new venv's site-packages
    dependencies = [sysconfig.get_paths()["purelib"], *site.getsitepackages()]
    lines = [f"import site; site.addsitedir({path!r})" for path in dict.fromkeys(dependencies)]
    (purelib / "zz_wbik_test_dependencies.pth").write_text("\n".join(lines) + "\n")
    _run([sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "-q", wheel],
         cwd=work, env=env)
    run_dir = work / "run"
    run_dir.mkdir()
    return {"env": env, "python": python, "wbik": venv / "bin" / "wbik", "purelib": purelib,
            "cwd": run_dir, "cache": work / "cache", "build_output": build_output}


def test_the_installed_copy_is_imported_and_carries_its_data(installed):
    script = ("import wbik, wbik.data as d, wbik.study.definition as s; "
              "from wbik.robot_packages.arm3r import model as arm3r; "
              "from wbik.robot_packages.pincher import model as pincher; "
              "from wbik.robot_packages.ur5 import model as ur5; "
              "print(wbik.__file__); print(d.data_dir('tasks')); print(d.data_dir('comparisons')); "
              "print(s.DEFAULT_STUDY); print(sorted(d.shipped_tasks())); "
              "print(wbik.load('golem3').urdf_path); print(wbik.load('bioloid').urdf_path); "
              "print(arm3r.URDF_PATH); print(pincher.URDF_PATH); print(ur5.TOOL_URDF_PATH); "
              "wbik.load('arm3r'); wbik.load('pincher'); "
              "from wbik.solvers.analytic import ur_type as k; "
              "print(k._ur_kernel is not None, getattr(k._ur_kernel, '__file__', '')); "
              "from wbik.kernels.twins import KERNELS; "
              "print(*[getattr(k.extension, '__file__', 'missing') for k in KERNELS "
              "if k.name in ('pose', 'qp_rows', 'lm_trial', 'chain_fk')])")
    out = _run([installed["python"], "-c", script], cwd=installed["cwd"], env=installed["env"]).stdout
    lines = out.splitlines()
    package = installed["purelib"] / "wbik"
    assert Path(lines[0]).is_relative_to(package), lines[0]
    for line in lines[1:4]:
        assert Path(line).is_relative_to(package / "data"), line
        assert Path(line).exists(), line
    assert "bioloid_balance" in lines[4] and "ur5_riveting" in lines[4]
    # the project's robot descriptions are the wheel's copy of the top-level urdf/
    urdf = package / "data" / "urdf"
    expected = [urdf / "golem3.urdf", urdf / "bioloid.urdf", urdf / "arm3r.urdf", urdf / "pincher.urdf",
                urdf / "ur5_rivet_tool.urdf.xml"]
    assert [Path(line) for line in lines[5:10]] == expected
    assert all(path.is_file() for path in expected)
    assert not list((package / "robot_packages").rglob("*.urdf*")), "robot packages keep code only"
    assert not installed["cache"].exists(), "creating a Robot wrote into the URDF cache"
    if HAS_COMPILER:  # the wheel compiled every kernel (the copy had no .so)
        built, kernel_file = lines[10].split()
        assert built == "True" and Path(kernel_file).is_relative_to(package), lines[10]
        kernels = lines[11].split()
        assert len(kernels) == 4 and all(Path(other).is_relative_to(package) for other in kernels), lines[11]
        assert Path(kernels[-1]).stat().st_size < 2_000_000, "the C++ kernel carries debug information"
    else:
        assert lines[10].startswith("False") and lines[11].split() == ["missing"] * 4, lines[10:]


def test_wbik_tasks_then_run_a_shipped_task_by_name(installed):
    listing = _run([installed["wbik"], "tasks"], cwd=installed["cwd"], env=installed["env"]).stdout
    assert "bioloid_balance" in listing and "wholebody_ik" in listing
    paths = _run([installed["wbik"], "tasks", "--paths"], cwd=installed["cwd"], env=installed["env"]).stdout
    balance = next(line for line in paths.splitlines() if line.endswith("bioloid_balance.yaml"))
    assert Path(balance).is_relative_to(installed["purelib"] / "wbik" / "data" / "tasks")
    report = installed["cwd"] / "balance.json"
    out = _run([installed["wbik"], "run", "bioloid_balance", "--output", report],
               cwd=installed["cwd"], env=installed["env"]).stdout
    assert "com_margin" in out and report.is_file()
    # the documented source-tree path works too, where no tasks/ folder exists
    _run([installed["wbik"], "run", "tasks/bioloid_balance.yaml"], cwd=installed["cwd"], env=installed["env"])


def test_wbik_study_default_from_anywhere(installed):
    """The default study file comes from the wheel and runs with its loky workers (10 poses: what is
    checked is that it is found and runs, not its figures)."""
    output = installed["cwd"] / "study"
    _run([installed["wbik"], "study", "--poses", "10", "--output", output, "--no-progress"],
         cwd=installed["cwd"], env=installed["env"])
    assert (output / "report.md").is_file() and (output / "study.json").is_file()


def test_wbik_view_ur5_html(installed):
    page = installed["cwd"] / "ur5.html"
    _run([installed["wbik"], "view", "ur5", "--html", page], cwd=installed["cwd"], env=installed["env"])
    assert page.stat().st_size > 10_000


# -- the URDF cache (in-process, no wheel needed) ---------------------------------------------------
def test_cache_dir_precedence(monkeypatch, tmp_path):
    from wbik.robot import cache_dir

    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("WBIK_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    assert cache_dir() == tmp_path / "home" / ".cache" / "wbik"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")  # the XDG spec: relative paths are invalid
    assert cache_dir() == tmp_path / "home" / ".cache" / "wbik"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "wbik"
    monkeypatch.setenv("WBIK_CACHE_DIR", str(tmp_path / "mine"))
    assert cache_dir() == tmp_path / "mine"
    assert not any(path.exists() for path in (tmp_path / "home", tmp_path / "xdg", tmp_path / "mine"))


def test_robots_write_no_urdf_until_a_library_asks_for_a_file(monkeypatch, tmp_path):
    import wbik
    from wbik.robot import write_cached_urdf

    monkeypatch.setenv("WBIK_CACHE_DIR", str(tmp_path / "cache"))
    robot = wbik.load("arm3r", lengths=(0.31, 0.2, 0.1))  # built from text: no URDF file
    assert robot.urdf_path is None
    wbik.solver("trac_ik", robot)  # TRAC-IK reads the URDF text
    assert not (tmp_path / "cache").exists()
    path = write_cached_urdf(robot.name, robot.urdf_text)  # what PlaCo's loader (a file reader) gets
    assert path.parent == tmp_path / "cache" / "urdf" and path.read_text() == robot.urdf_text
    assert write_cached_urdf(robot.name, robot.urdf_text) == path  # content-addressed: one file


def test_building_the_wheel_warns_of_nothing_in_our_metadata(installed):
    output = installed["build_output"]
    assert "Compiling" in output or "running build" in output, output[-2000:]  # the verbose log was read
    for warning in ("SetuptoolsDeprecationWarning", "project.license", "License classifiers"):
        assert warning not in output, output[output.find(warning) - 500:output.find(warning) + 500]
