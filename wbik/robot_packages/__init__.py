"""The robot packages shipped with wbik: one package per robot with its model (``model.py``:
``build(**params) -> Robot``, which writes or loads its URDF; collision primitives) and, where one
exists, its closed-form binding (``closed_form.py``, named in the robot's ``closed_forms``). The robot
descriptions written for this project lie in the repository's top-level ``urdf/`` (shipped in the
wheel; :func:`wbik.data.description_file` finds them).

``ROBOTS`` declares them to the robot registry (:mod:`wbik.models`); a new robot package is one
line here.
"""

from __future__ import annotations

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
