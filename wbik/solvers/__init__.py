"""IK methods behind one interface: the solver template (:mod:`wbik.solvers.base`) and the method
registry (:mod:`wbik.solvers.method_registry`)."""

from wbik.solvers.base import Candidate, IKResult, Solver, Tolerances, evaluate
from wbik.solvers.method_registry import IKMethod, methods, register, register_method, solver, solver_options

__all__ = ["Candidate", "IKMethod", "IKResult", "Solver", "Tolerances", "evaluate", "methods", "register",
           "register_method", "solver", "solver_options"]
