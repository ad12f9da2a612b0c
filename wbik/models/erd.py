"""Access to example-robot-data's URDF files (pin 3.8 era, example-robot-data 4.3.0)."""

from __future__ import annotations

from pathlib import Path

from wbik.errors import MissingDependencyError


def robots_dir() -> Path:
    """example-robot-data's ``robots/`` folder."""
    try:
        import example_robot_data
        from example_robot_data.robots_loader import getModelPath
    except ImportError as exc:  # pragma: no cover - a pinned dependency
        raise MissingDependencyError(
            "example-robot-data is not installed; run 'bash scripts/setup.sh'") from exc
    del example_robot_data
    return Path(getModelPath("ur_description")).resolve()


def urdf_path(relative: str) -> Path:
    """Path of a URDF in example-robot-data, e.g. ``ur_description/urdf/ur5_robot.urdf``."""
    path = robots_dir() / relative
    if not path.is_file():
        raise MissingDependencyError(f"example-robot-data has no {relative}; reinstall it (4.3.0)")
    return path


def package_dirs() -> list[str]:
    """Folders that resolve ``package://example-robot-data/...`` mesh paths."""
    # meshes are named package://example-robot-data/robots/...; the parent of share/ resolves them
    share = robots_dir().parents[1]
    return [str(share), str(robots_dir().parent)]
