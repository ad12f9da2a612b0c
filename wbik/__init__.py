"""wbik: whole-body inverse kinematics on Pinocchio, every IK method behind one interface.

>>> import wbik
>>> robot = wbik.load("ur5")
>>> solver = wbik.solver("dls", robot, chain="arm")
>>> result = solver.solve(robot.chain("arm").fk(robot.chain("arm").nominal))

A solver solves a chain target or a :class:`wbik.WholeBody` problem; every :class:`IKResult` is judged by
one shared check. ``wbik.register`` adds a method, ``wbik.register_sampler`` a study case sampler.
"""

from wbik.catalog import install as _install_catalog
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
from wbik.solvers.base import Solver
from wbik.solvers.batch_results import IKResults
from wbik.solvers.check import check_problem
from wbik.solvers.method import IKMethod
from wbik.solvers.method_registry import methods, register, solver
from wbik.solvers.result import IKResult, Tolerances
from wbik.targets import Target, as_target
from wbik.wholebody.cases import CaseSampler, WholeBodyCase, register_sampler
from wbik.wholebody.problem import WholeBody

_install_catalog()  # what wbik ships, imported by name when a registry first needs it

__version__ = "0.1.0"

__all__ = [
    "Chain", "ChainSpec", "IKMethod", "IKResult", "IKResults", "InvalidConfigurationError",
    "InvalidRotationError", "InvalidTargetError", "MissingDependencyError", "Robot", "RobotDescriptionError",
    "Solver",
    "Target", "Tolerances", "UnknownChainError", "UnknownFrameError", "UnknownMethodError",
    "UnknownRobotError", "UnsupportedError", "WbikError", "as_target", "load", "methods",
    "register", "robots", "solver",
    "WholeBody", "check_problem", "CaseSampler", "WholeBodyCase", "register_sampler",
]
