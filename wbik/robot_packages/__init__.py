"""The robot packages shipped with wbik (per robot ``model.py`` with ``build(**params) -> Robot``), declared
to :mod:`wbik.models` by ``ROBOTS``: a new robot package is one entry here and one branch of :func:`model`."""

from __future__ import annotations

from functools import partial
from types import ModuleType

from wbik.models import RobotEntry


def model(name: str) -> ModuleType:
    """The ``model`` module of the robot package ``name``, imported on first use."""
    if name == "golem3":
        import wbik.robot_packages.golem3.model as module
    elif name == "pincher":
        import wbik.robot_packages.pincher.model as module
    elif name == "bioloid":
        import wbik.robot_packages.bioloid.model as module
    elif name == "arm3r":
        import wbik.robot_packages.arm3r.model as module
    elif name == "ur5":
        import wbik.robot_packages.ur5.model as module
    else:
        import wbik.robot_packages.panda.model as module
    return module


def _shipped(name: str, description: str) -> RobotEntry:
    return RobotEntry(name, partial(model, name), description)


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
