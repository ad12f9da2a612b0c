"""The data files wbik ships: scenario files (``tasks/``), study definitions (``comparisons/``) and the
robot descriptions written for this project (``urdf/``): the repository's top-level folders, or their
copies at ``wbik/data/<folder>/`` in a built wheel (setup.py)."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from wbik.errors import InvalidSettingError

FOLDERS = ("tasks", "comparisons", "urdf")
SCENARIO_SUFFIXES = (".yaml", ".yml", ".json", ".toml")
STUDY_SUFFIXES = (".yaml", ".yml", ".toml")


def data_dir(folder: str) -> Path:
    """The folder ``tasks``, ``comparisons`` or ``urdf``: the wheel's copy, else the source tree's."""
    if folder not in FOLDERS:
        raise InvalidSettingError(f"unknown data folder {folder!r}; one of {', '.join(FOLDERS)}")
    packaged = files(__name__) / folder
    if isinstance(packaged, Path) and packaged.is_dir():  # a wheel installed on a file system
        return packaged
    return Path(__file__).resolve().parents[2] / folder  # the source tree (or an editable install)


def _shipped(folder: str, suffixes: tuple[str, ...]) -> dict[str, Path]:
    paths = sorted(data_dir(folder).glob("*"))
    return {path.stem: path for path in paths if path.is_file() and path.suffix.lower() in suffixes}


def shipped_tasks() -> dict[str, Path]:
    """Scenario files shipped with wbik, by name (``bioloid_balance`` -> .../tasks/bioloid_balance.yaml)."""
    return _shipped("tasks", SCENARIO_SUFFIXES)


def shipped_studies() -> dict[str, Path]:
    """Study files shipped with wbik, by name (``default`` -> .../comparisons/default.yaml)."""
    return _shipped("comparisons", STUDY_SUFFIXES)


def _resolve(name_or_path: str | Path, shipped: dict[str, Path], folder: str) -> Path:
    """An existing path as given, else the shipped file of that name, file name or ``FOLDER/NAME.yaml``
    path; otherwise the path as given (the caller reports it missing)."""
    path = Path(name_or_path).expanduser()
    if path.exists() or path.parent not in (Path("."), Path(folder)):
        return path
    candidate = shipped.get(path.stem if path.suffix else path.name)
    return candidate if candidate is not None and (not path.suffix or candidate.name == path.name) else path


def task_path(name_or_path: str | Path) -> Path:
    """A scenario file (:func:`_resolve`)."""
    return _resolve(name_or_path, shipped_tasks(), "tasks")


def study_path(name_or_path: str | Path) -> Path:
    """A study file (:func:`_resolve`)."""
    return _resolve(name_or_path, shipped_studies(), "comparisons")


def description_file(name: str) -> Path:
    """A robot description in ``urdf/`` (e.g. ``golem3.urdf``; ``scripts/export_urdf.py`` writes them)."""
    return data_dir("urdf") / name
