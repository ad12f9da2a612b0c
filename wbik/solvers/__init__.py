"""IK methods behind one interface: the solver template (:mod:`wbik.solvers.base`) and the method
registry (:mod:`wbik.solvers.method_registry`)."""

from wbik.solvers.base import Candidate
from wbik.solvers.base import IKResult
from wbik.solvers.base import Solver
from wbik.solvers.base import Tolerances
from wbik.solvers.base import evaluate
from wbik.solvers.method_registry import IKMethod
from wbik.solvers.method_registry import methods
from wbik.solvers.method_registry import register
from wbik.solvers.method_registry import register_method
from wbik.solvers.method_registry import solver
from wbik.solvers.method_registry import solver_options

__all__ = ["Candidate", "IKMethod", "IKResult", "Solver", "Tolerances", "evaluate", "methods", "register",
           "register_method", "solver", "solver_options"]
