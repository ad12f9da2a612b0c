"""Robots by name, and ``load``: each module of ``ROBOT_MODULES`` declares ``ROBOTS``, a tuple of
:class:`RobotEntry` (``wbik.robot_packages`` the built-in ones); user code adds one with
:func:`register_robot`. ``load`` also takes a URDF path or ``"example-robot-data:NAME"``."""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import wbik.models.erd as erd
from wbik.errors import InvalidOptionError, RobotDescriptionError, UnknownRobotError
from wbik.registry import DeclaredRegistry
from wbik.robot import Robot, robot_from_urdf_text


@dataclass(frozen=True)
class RobotEntry:
    """A robot known by name: ``model``, a function returning the module with ``build(**params) -> Robot``
    (for user code: the module's name), which may also define ``collision_primitives(robot)`` and
    ``collision_obstacles()``."""

    name: str
    model: str | Callable[[], ModuleType]
    description: str

    def module(self) -> ModuleType:
        return importlib.import_module(self.model) if isinstance(self.model, str) else self.model()


ROBOT_MODULES: list = []
"""The modules declaring ``ROBOTS`` (:mod:`wbik.catalog` adds the robot packages)."""

ROBOT_REGISTRY: DeclaredRegistry[RobotEntry] = DeclaredRegistry(
    "robot", "ROBOTS", ROBOT_MODULES, "wbik.models.ROBOT_MODULES", RobotEntry,
    unknown=lambda name, known: UnknownRobotError(name, known, hint="or pass the path of a .urdf file"))


def robot_entries() -> dict[str, RobotEntry]:
    return ROBOT_REGISTRY.entries()


def register_robot(name: str, model: str, description: str = "", replace: bool = False) -> None:
    """Make ``load(name)`` call ``build`` of the module ``model`` ("package.module")."""
    ROBOT_REGISTRY.register(RobotEntry(name, model, description), replace=replace)


def robots() -> dict[str, str]:
    """Robot names with a one-line description."""
    return {name: entry.description for name, entry in robot_entries().items()}


URDF_PARAMS = ("chains", "floating_base", "nominal", "name", "package_dirs", "soles", "closed_forms", "facts")
"""Keyword options ``load`` takes with a URDF path (:func:`wbik.robot.robot_from_urdf_text`)."""


def builder_parameters(name_or_path: str | Path) -> set[str]:
    """The keyword parameters ``load(name_or_path, **params)`` accepts (robot_params of a study)."""
    entry = robot_entries().get(str(name_or_path))
    if entry is not None:
        return {p.name for p in inspect.signature(entry.module().build).parameters.values()
                if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    return set(URDF_PARAMS)


def check_parameters(name_or_path: str | Path, params: dict) -> None:
    """InvalidOptionError unless every key of ``params`` is a parameter of the robot's builder."""
    accepted = builder_parameters(name_or_path)
    for key in params:
        if key not in accepted:
            raise InvalidOptionError(
                f"robot {str(name_or_path)!r} takes no parameter {key!r}; its parameters: "
                f"{', '.join(sorted(accepted)) or '(none)'}", option=str(key), accepted=sorted(accepted))


def load(name_or_path: str | Path, **params) -> Robot:
    """A built-in robot by name (``params`` go to its builder), an example-robot-data robot (``"erd:talos"``
    or ``"example-robot-data:talos"``: its loader's floating base, its SRDF reference posture as the nominal)
    or a URDF file path (``params``: :data:`URDF_PARAMS`). Unknown parameters raise InvalidOptionError, bad
    values RobotDescriptionError."""
    if not isinstance(name_or_path, str | Path):
        raise UnknownRobotError(repr(name_or_path), list(robot_entries()),
                                hint="pass a robot name (a string) or the path of a .urdf file")
    key = str(name_or_path)
    entry = robot_entries().get(key)
    if entry is not None:
        check_parameters(key, params)
        return entry.module().build(**params)
    name = erd.example_robot_name(key) if isinstance(name_or_path, str) else None
    if name is not None:
        example = erd.example_robot(name)
        check_parameters(example.urdf, params)
        text = example.urdf.read_text(encoding="utf-8")
        params.setdefault("floating_base", example.floating_base)
        if "nominal" not in params and params["floating_base"] == example.floating_base:
            params["nominal"] = erd.reference_posture(example, text)
        params.setdefault("package_dirs", erd.package_dirs())
        urdf = example.urdf.resolve()
        return robot_from_urdf_text(params.pop("name", name), text, urdf_path=urdf, **params)
    path = Path(key).expanduser()
    if path.suffix.lower() in (".urdf", ".xml") or path.exists():
        if not path.is_file():
            raise RobotDescriptionError(f"URDF path {str(path)!r} is a directory; pass a .urdf file"
                                        if path.is_dir() else f"URDF file {str(path)!r} does not exist")
        check_parameters(path, params)
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise RobotDescriptionError(
                f"URDF file {str(path)!r} is not UTF-8 text (byte {exc.start}: {exc.reason}); pass a "
                "URDF (XML) file") from None
        except OSError as exc:
            raise RobotDescriptionError(f"cannot read URDF file {str(path)!r}: {exc.strerror}") from None
        return robot_from_urdf_text(params.pop("name", path.stem), text, urdf_path=path.resolve(), **params)
    raise UnknownRobotError(key, list(robot_entries()), hint="or pass the path of a .urdf file")
