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

from wbik.errors import InvalidConfigurationError
from wbik.errors import InvalidRotationError
from wbik.errors import InvalidTargetError
from wbik.errors import MissingDependencyError
from wbik.errors import RobotDescriptionError
from wbik.errors import UnknownChainError
from wbik.errors import UnknownFrameError
from wbik.errors import UnknownMethodError
from wbik.errors import UnknownRobotError
from wbik.errors import UnsupportedError
from wbik.errors import WbikError
from wbik.models import load
from wbik.models import robots
from wbik.robot import Chain
from wbik.robot import ChainSpec
from wbik.robot import Robot
from wbik.solvers import IKResult
from wbik.solvers import Solver
from wbik.solvers import Tolerances
from wbik.solvers import methods
from wbik.solvers import register
from wbik.solvers import solver
from wbik.targets import Target
from wbik.targets import as_target
from wbik.wholebody import WholeBody
from wbik.wholebody import WholeBodyMethod
from wbik.wholebody import WholeBodyResult
from wbik.wholebody import check_wholebody
from wbik.wholebody import register_wholebody_method
from wbik.wholebody import wholebody_methods
from wbik.wholebody import wholebody_solver
from wbik.wholebody.cases import CaseSampler
from wbik.wholebody.cases import WholeBodyCase
from wbik.wholebody.cases import register_sampler

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
