"""wbik: whole-body inverse kinematics on Pinocchio, every IK method behind one interface.

>>> import wbik
>>> robot = wbik.load("ur5")
>>> solver = wbik.solver("dls", robot, chain="arm")
>>> result = solver.solve(robot.chain("arm").fk(robot.chain("arm").nominal))
"""

from wbik.errors import (
    InvalidConfigurationError,
    InvalidRotationError,
    InvalidTargetError,
    MissingDependencyError,
    RobotDescriptionError,
    UnknownChainError,
    UnknownFrameError,
    UnknownMethodError,
    UnknownRobotError,
    UnsupportedError,
    WbikError,
)
from wbik.models import load, robots
from wbik.robot import Chain, ChainSpec, Robot
from wbik.solvers import IKResult, Solver, Tolerances, methods, register, solver
from wbik.targets import Target, as_target
from wbik.wholebody import WholeBody, WholeBodyResult, check_wholebody, wholebody_methods, wholebody_solver

__version__ = "0.1.0"

__all__ = [
    "Chain", "ChainSpec", "IKResult", "InvalidConfigurationError", "InvalidRotationError",
    "InvalidTargetError", "MissingDependencyError", "Robot", "RobotDescriptionError", "Solver",
    "Target", "Tolerances", "UnknownChainError", "UnknownFrameError", "UnknownMethodError",
    "UnknownRobotError", "UnsupportedError", "WbikError", "as_target", "load", "methods",
    "register", "robots", "solver",
    "WholeBody", "WholeBodyResult", "check_wholebody", "wholebody_methods", "wholebody_solver",
]
