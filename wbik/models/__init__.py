"""Built-in robots and ``load``.

Each built-in robot is a module here with ``build(**params) -> Robot``. ``load`` also takes a
path to any URDF file (one serial chain is found automatically, or pass ``chains=``).
"""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

from wbik.data import data_dir
from wbik.errors import InvalidOptionError, RobotDescriptionError, UnknownRobotError
from wbik.robot import Robot, robot_from_urdf_text

URDF_DIR = data_dir("urdf")
"""The ``urdf/`` folder (the repository's, or the installed package's copy): descriptions written for
this project."""

BUILTIN: dict[str, tuple[str, str]] = {
    # name -> (module, one-line description)
    "golem3": ("wbik.models.golem3", "Golem-III service robot upper body: torso lift, chest yaw, "
                                     "two 5-joint arms, grippers, head (thesis DH, seed 000)"),
    "pincher": ("wbik.models.pincher", "PhantomX Pincher 4-DOF arm, tool frame 'noa' (seed 004)"),
    "bioloid": ("wbik.models.bioloid", "Bioloid Premium Type A humanoid, 18 servos on a floating "
                                       "base (seed 003)"),
    "arm3r": ("wbik.models.arm3r", "3-DOF articulated arm of the Newton-Raphson project, lengths as "
                                   "parameters (seed 001)"),
    "ur5": ("wbik.models.ur5", "Universal Robots UR5 (example-robot-data) with the riveting tool's "
                               "'tcp' frame (seed 002)"),
    "panda": ("wbik.models.panda", "Franka Emika Panda 7-DOF arm (example-robot-data), a redundant "
                                   "reference chain"),
}


def robots() -> dict[str, str]:
    """Built-in robot names with a one-line description."""
    return {name: description for name, (_, description) in BUILTIN.items()}


URDF_PARAMS = ("chains", "floating_base", "nominal", "name", "package_dirs", "info")
"""Keyword options ``load`` takes with a URDF path (see :func:`wbik.robot.robot_from_urdf_text`)."""


def builder_parameters(name_or_path: str | Path) -> set[str]:
    """The keyword parameters ``load(name_or_path, **params)`` accepts (robot_params of a study)."""
    key = str(name_or_path)
    if key in BUILTIN:
        builder = importlib.import_module(BUILTIN[key][0]).build
        return {p.name for p in inspect.signature(builder).parameters.values()
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
    """A built-in robot by name (``params`` go to its builder) or a Robot from a URDF file path.

    For a URDF path, optional ``params``: ``chains`` (list of ChainSpec), ``floating_base``,
    ``nominal``, ``name``. Unknown parameters raise InvalidOptionError listing the known ones;
    each builder checks its values (RobotDescriptionError).
    """
    if not isinstance(name_or_path, str | Path):
        raise UnknownRobotError(repr(name_or_path), list(BUILTIN),
                                hint="pass a robot name (a string) or the path of a .urdf file")
    key = str(name_or_path)
    if key in BUILTIN:
        check_parameters(key, params)
        module = importlib.import_module(BUILTIN[key][0])
        return module.build(**params)
    path = Path(key).expanduser()
    if path.suffix.lower() in (".urdf", ".xml") or path.exists():
        if path.is_dir():
            raise RobotDescriptionError(f"URDF path {str(path)!r} is a directory; pass a .urdf file")
        if not path.is_file():
            raise RobotDescriptionError(f"URDF file {str(path)!r} does not exist")
        check_parameters(path, params)
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise RobotDescriptionError(
                f"URDF file {str(path)!r} is not UTF-8 text (byte {exc.start}: {exc.reason}); pass a "
                "URDF (XML) file") from None
        except OSError as exc:
            raise RobotDescriptionError(f"cannot read URDF file {str(path)!r}: {exc.strerror}") from None
        return robot_from_urdf_text(params.pop("name", path.stem), text,
                                    urdf_path=path.resolve(), **params)
    raise UnknownRobotError(key, list(BUILTIN), hint="or pass the path of a .urdf file")
