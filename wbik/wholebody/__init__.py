"""Whole-body IK behind one interface: one problem, one result, one shared check, several methods.

>>> import wbik
>>> from wbik.qp import ComTask
>>> robot = wbik.load("bioloid")
>>> problem = wbik.WholeBody(robot, tasks=[ComTask([0.0, -0.03, 0.0], axes="xy")],
...                          contacts=["r_sole", "l_sole"], support=["r_sole", "l_sole"], margin=0.005)
>>> result = wbik.wholebody_solver("qp", robot).solve(problem, robot.nominal)
>>> result.success, result.com_margin, result.unsupported  # doctest: +SKIP

Modules: ``problem`` (:class:`WholeBody`, :class:`WholeBodyResult`, :func:`check_wholebody`),
``solvers`` (qp, placo, pink, thesis_legs and the registry), ``scenarios`` (the study's seeded
case samplers).
"""

from wbik.wholebody.problem import MinimumDistance, WholeBody, WholeBodyResult, check_wholebody
from wbik.wholebody.solvers import (
    WholeBodySolver,
    wholebody_methods,
    wholebody_solver,
    wholebody_solver_options,
)

__all__ = [
    "MinimumDistance",
    "WholeBody",
    "WholeBodyResult",
    "WholeBodySolver",
    "check_wholebody",
    "wholebody_methods",
    "wholebody_solver",
    "wholebody_solver_options",
]
