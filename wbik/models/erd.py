"""example-robot-data's URDF files and robots (example-robot-data 4.3.0)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.errors import MissingDependencyError, RobotDescriptionError, UnknownRobotError


def _robots_loader():
    try:
        from example_robot_data import robots_loader
    except ImportError as exc:  # pragma: no cover - a pinned dependency
        raise MissingDependencyError(
            "example-robot-data is not installed; run 'bash scripts/setup.sh'") from exc
    return robots_loader


def robots_dir() -> Path:
    """example-robot-data's ``robots/`` folder."""
    return Path(_robots_loader().getModelPath("ur_description")).resolve()


def urdf_path(relative: str | Path) -> Path:
    """Path of a URDF in example-robot-data, e.g. ``ur_description/urdf/ur5_robot.urdf``."""
    path = robots_dir() / relative
    if not path.is_file():
        raise MissingDependencyError(f"example-robot-data has no {relative}; reinstall it (4.3.0)")
    return path


def package_dirs() -> list[str]:
    """Folders that resolve ``package://example-robot-data/robots/...`` mesh paths."""
    return [str(robots_dir().parents[1]), str(robots_dir().parent)]


PREFIXES = ("example-robot-data:", "erd:")


def example_robot_name(name: str) -> str | None:
    """The example-robot-data robot named by ``name`` ("example-robot-data:NAME" or "erd:NAME"), or None."""
    return next((name[len(prefix):] for prefix in PREFIXES if name.startswith(prefix)), None)


def example_robot_names() -> list[str]:
    """Every robot example-robot-data 4.3.0 ships a loader for (URDF and SDF)."""
    return sorted(_robots_loader().ROBOTS)


@dataclass(frozen=True)
class ExampleRobot:
    """One example-robot-data robot's files and how its loader builds it."""

    name: str
    urdf: Path
    srdf: Path | None
    floating_base: bool
    reference_posture: str | None


def example_robot(name: str) -> ExampleRobot:
    """The files of example-robot-data's robot ``name``; UnknownRobotError naming the known ones."""
    loaders = _robots_loader().ROBOTS
    if name not in loaders:
        raise UnknownRobotError(f"example-robot-data:{name}",
                                [f"example-robot-data:{known}" for known in sorted(loaders)])
    loader = loaders[name]
    if not loader.urdf_filename:
        raise RobotDescriptionError(
            f"example-robot-data's {name!r} is described in SDF ({loader.sdf_filename}); wbik loads URDF "
            "files only")
    urdf = urdf_path(Path(loader.path) / loader.urdf_subpath / loader.urdf_filename)
    srdf = (robots_dir() / loader.path / loader.srdf_subpath / loader.srdf_filename
            if loader.srdf_filename else None)
    return ExampleRobot(name, urdf, srdf if srdf is not None and srdf.is_file() else None,
                        bool(loader.free_flyer), loader.ref_posture if srdf is not None else None)


def reference_posture(robot: ExampleRobot, text: str) -> np.ndarray | None:
    """The SRDF's reference posture (the loader's ``q0``) in Pinocchio's own parse of the URDF, or None."""
    if robot.srdf is None or robot.reference_posture is None:
        return None
    model = pin.buildModelFromXML(text, *([pin.JointModelFreeFlyer()] if robot.floating_base else []))
    pin.loadReferenceConfigurations(model, str(robot.srdf), False)
    if robot.reference_posture not in model.referenceConfigurations:
        return None
    return pin.normalize(model, model.referenceConfigurations[robot.reference_posture].copy())
