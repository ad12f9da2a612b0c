"""IK methods behind one interface; see :mod:`wbik.solvers.base`."""

from wbik.solvers.base import (
    Candidate,
    IKResult,
    Solver,
    Tolerances,
    evaluate,
    methods,
    register,
    solver,
)

__all__ = ["Candidate", "IKResult", "Solver", "Tolerances", "evaluate", "methods", "register",
           "solver"]
