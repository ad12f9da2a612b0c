"""The robot packages shipped with wbik (per robot ``model.py`` with ``build(**params) -> Robot``), declared
to :mod:`wbik.models` by ``ROBOTS``: a new robot package is one entry here."""

from __future__ import annotations

from wbik.models import RobotEntry


def _golem3():
    import wbik.robot_packages.golem3.model as model
    return model


def _pincher():
    import wbik.robot_packages.pincher.model as model
    return model


def _bioloid():
    import wbik.robot_packages.bioloid.model as model
    return model


def _arm3r():
    import wbik.robot_packages.arm3r.model as model
    return model


def _ur5():
    import wbik.robot_packages.ur5.model as model
    return model


def _panda():
    import wbik.robot_packages.panda.model as model
    return model


ROBOTS = (
    RobotEntry("golem3", _golem3, "Golem-III service robot upper body: torso lift, chest yaw, two 5-joint "
               "arms, grippers, head (thesis DH, seed 000)"),
    RobotEntry("pincher", _pincher, "PhantomX Pincher 4-DOF arm, tool frame 'noa' (seed 004)"),
    RobotEntry("bioloid", _bioloid, "Bioloid Premium Type A humanoid, 18 servos on a floating base "
               "(seed 003)"),
    RobotEntry("arm3r", _arm3r, "3-DOF articulated arm of the Newton-Raphson project, lengths as parameters "
               "(seed 001)"),
    RobotEntry("ur5", _ur5, "Universal Robots UR5 (example-robot-data) with the riveting tool's 'tcp' frame "
               "(seed 002)"),
    RobotEntry("panda", _panda, "Franka Emika Panda 7-DOF arm (example-robot-data), a redundant reference "
               "chain"),
)
