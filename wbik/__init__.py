"""wbik: whole-body inverse kinematics on Pinocchio, every IK method behind one interface.

>>> import wbik
>>> robot = wbik.load("ur5")
>>> solver = wbik.solver("dls", robot, chain="arm")
>>> result = solver.solve(robot.chain("arm").fk(robot.chain("arm").nominal))

User code adds an IK method with ``wbik.register(name, Class)``, a whole-body method with
``wbik.register_wholebody_method(wbik.WholeBodyMethod(name, Class))`` and a whole-body study case
sampler with ``wbik.register_sampler(wbik.CaseSampler(name, robot, sample))``; all three reach a
parallel study's worker processes. (Scenario kinds: ``wbik.scenarios.register_kind``, a layer above
this package's facade.)
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
from wbik.wholebody import (
    WholeBody,
    WholeBodyMethod,
    WholeBodyResult,
    check_wholebody,
    register_wholebody_method,
    wholebody_methods,
    wholebody_solver,
)
from wbik.wholebody.cases import CaseSampler, WholeBodyCase, register_sampler

__version__ = "0.1.0"

__all__ = [
    "Chain", "ChainSpec", "IKResult", "InvalidConfigurationError", "InvalidRotationError",
    "InvalidTargetError", "MissingDependencyError", "Robot", "RobotDescriptionError", "Solver",
    "Target", "Tolerances", "UnknownChainError", "UnknownFrameError", "UnknownMethodError",
    "UnknownRobotError", "UnsupportedError", "WbikError", "as_target", "load", "methods",
    "register", "robots", "solver",
    "WholeBody", "WholeBodyResult", "check_wholebody", "wholebody_methods", "wholebody_solver",
    "CaseSampler", "WholeBodyCase", "WholeBodyMethod", "register_sampler", "register_wholebody_method",
]
