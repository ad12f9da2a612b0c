"""The data files wbik ships: scenario files (``tasks/``, keyframes in ``tasks/data/``), study
definitions (``comparisons/*.yaml``) and the robot descriptions written for this project (``urdf/``:
Golem-III, Pincher, Bioloid, arm3r and the UR5's riveting tool; robot packages keep the code that
builds and reads them).

In the source tree (and an editable install) they are the repository's top-level folders, where the
README documents them. A built wheel carries a copy of each at ``wbik/data/<folder>/`` (setup.py
copies them at build time), found here with :mod:`importlib.resources`. :func:`data_dir` returns the
packaged copy when there is one, else the source tree's folder.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

FOLDERS = ("tasks", "comparisons", "urdf")
SCENARIO_SUFFIXES = (".yaml", ".yml", ".json", ".toml")
STUDY_SUFFIXES = (".yaml", ".yml", ".toml")


def data_dir(folder: str) -> Path:
    """The folder ``tasks``, ``comparisons`` or ``urdf``: the installed copy, else the source tree's."""
    if folder not in FOLDERS:
        raise ValueError(f"unknown data folder {folder!r}; one of {', '.join(FOLDERS)}")
    packaged = files(__name__) / folder
    if isinstance(packaged, Path) and packaged.is_dir():  # a wheel installed on a file system
        return packaged
    return Path(__file__).resolve().parents[2] / folder  # the source tree (or an editable install)


def _shipped(folder: str, suffixes: tuple[str, ...]) -> dict[str, Path]:
    root = data_dir(folder)
    paths = sorted(p for p in root.glob("*") if p.is_file() and p.suffix.lower() in suffixes) \
        if root.is_dir() else []
    return {path.stem: path for path in paths}


def shipped_tasks() -> dict[str, Path]:
    """Scenario files shipped with wbik, by name (``bioloid_balance`` -> .../tasks/bioloid_balance.yaml)."""
    return _shipped("tasks", SCENARIO_SUFFIXES)


def shipped_studies() -> dict[str, Path]:
    """Study files shipped with wbik, by name (``default`` -> .../comparisons/default.yaml)."""
    return _shipped("comparisons", STUDY_SUFFIXES)


def _resolve(name_or_path: str | Path, shipped: dict[str, Path], folder: str) -> Path:
    path = Path(name_or_path).expanduser()
    if path.exists() or path.parent not in (Path("."), Path(folder)):
        return path
    # a shipped name ("bioloid_balance"), its file name, or its documented source-tree path
    # ("tasks/bioloid_balance.yaml"), which thus also works where wbik is installed from a wheel
    candidate = shipped.get(path.stem if path.suffix else path.name)
    if candidate is not None and (not path.suffix or candidate.name == path.name):
        return candidate
    return path


def task_path(name_or_path: str | Path) -> Path:
    """A scenario file: an existing path as given, else the shipped task of that name (or file name,
    or ``tasks/NAME.yaml`` path); otherwise the path as given (the caller reports it missing)."""
    return _resolve(name_or_path, shipped_tasks(), "tasks")


def study_path(name_or_path: str | Path) -> Path:
    """A study file: an existing path as given, else the shipped study of that name (or file name, or
    ``comparisons/NAME.yaml`` path); otherwise the path as given (the caller reports it missing)."""
    return _resolve(name_or_path, shipped_studies(), "comparisons")


def description_file(name: str) -> Path:
    """A robot description shipped in ``urdf/`` (e.g. ``golem3.urdf``); for the generated ones
    (Golem-III, Bioloid) the file need not exist yet: ``scripts/export_urdf.py`` writes it."""
    return data_dir("urdf") / name
