"""The robot packages shipped with wbik: one package per robot with its model (``model.py``:
``build(**params) -> Robot``, which writes or loads its URDF; collision primitives), its URDF file as
package data next to it (e.g. ``golem3/golem3.urdf``, found with :func:`package_file`) and, where one
exists, its closed-form binding (``closed_form.py``, named in the robot's ``closed_forms``).

``ROBOTS`` declares them to the robot registry (:mod:`wbik.models`); a new robot package is one
line here. pyproject.toml ships every ``*.urdf`` and ``*.urdf.xml`` of a robot package in the wheel.
"""

from __future__ import annotations

import atexit
from contextlib import ExitStack
from importlib.resources import as_file
from importlib.resources import files
from pathlib import Path

from wbik.models import RobotEntry

PACKAGE = "wbik.robot_packages"


def _shipped(name: str, description: str) -> RobotEntry:
    """The entry of the robot package ``name`` of this folder: its builder is ``<name>/model.py``."""
    return RobotEntry(name, f"{PACKAGE}.{name}.model", description)


ROBOTS = (
    _shipped("golem3", "Golem-III service robot upper body: torso lift, chest yaw, two 5-joint arms, "
             "grippers, head (thesis DH, seed 000)"),
    _shipped("pincher", "PhantomX Pincher 4-DOF arm, tool frame 'noa' (seed 004)"),
    _shipped("bioloid", "Bioloid Premium Type A humanoid, 18 servos on a floating base (seed 003)"),
    _shipped("arm3r", "3-DOF articulated arm of the Newton-Raphson project, lengths as parameters "
             "(seed 001)"),
    _shipped("ur5", "Universal Robots UR5 (example-robot-data) with the riveting tool's 'tcp' frame "
             "(seed 002)"),
    _shipped("panda", "Franka Emika Panda 7-DOF arm (example-robot-data), a redundant reference chain"),
)

_EXTRACTED = ExitStack()
atexit.register(_EXTRACTED.close)


def package_file(package: str, name: str) -> Path:
    """The file ``name`` shipped in the package ``package`` (e.g. ``__package__`` of a robot's
    model.py), found with :mod:`importlib.resources`: the file itself where the package lies on a
    file system (the source tree, an editable install, an installed wheel; there the file need not
    exist yet, scripts/export_urdf.py writes it), else a copy extracted for the life of the process."""
    resource = files(package) / name
    if isinstance(resource, Path):
        return resource
    return _EXTRACTED.enter_context(as_file(resource))
