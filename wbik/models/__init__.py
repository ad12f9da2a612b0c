"""Built-in robots and ``load``.

Each built-in robot is a module here with ``build(**params) -> Robot``. ``load`` also takes a
path to any URDF file (one serial chain is found automatically, or pass ``chains=``).
"""

from __future__ import annotations

import importlib
from pathlib import Path

from wbik.errors import RobotDescriptionError, UnknownRobotError
from wbik.robot import Robot, robot_from_urdf_text

URDF_DIR = Path(__file__).resolve().parents[2] / "urdf"
"""The repository's ``urdf/`` folder: descriptions written for this project."""

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


def load(name_or_path: str | Path, **params) -> Robot:
    """A built-in robot by name (``params`` go to its builder) or a Robot from a URDF file path.

    For a URDF path, optional ``params``: ``chains`` (list of ChainSpec), ``floating_base``,
    ``nominal``, ``name``.
    """
    key = str(name_or_path)
    if key in BUILTIN:
        module = importlib.import_module(BUILTIN[key][0])
        return module.build(**params)
    path = Path(key).expanduser()
    if path.suffix.lower() in (".urdf", ".xml") or path.exists():
        if not path.is_file():
            raise RobotDescriptionError(f"URDF file {str(path)!r} does not exist")
        return robot_from_urdf_text(params.pop("name", path.stem), path.read_text(),
                                    urdf_path=path.resolve(), **params)
    raise UnknownRobotError(key, list(BUILTIN), hint="or pass the path of a .urdf file")
