"""Whole-body IK behind one interface: one problem, one result, one shared check, several methods.

>>> import wbik
>>> from wbik.qp import ComTask
>>> robot = wbik.load(NAME)  # a robot with soles (robot.soles), e.g. a biped
>>> problem = wbik.WholeBody(robot, tasks=[ComTask([0.0, -0.03, 0.0], axes="xy")],
...                          contacts=SOLES, support=SOLES, margin=0.005)  # SOLES: its sole frames
>>> result = wbik.wholebody_solver("qp", robot).solve(problem, robot.nominal)
>>> result.success, result.com_margin, result.unsupported  # doctest: +SKIP

Modules: ``problem`` (:class:`WholeBody`, :class:`WholeBodyResult`, :func:`check_wholebody`),
``solvers`` (the solver interface, the base of the peers' methods and method qp), ``placo``, ``pink``
and ``mink`` (the peers' methods, each with its forms of wbik's tasks and constraints,
:mod:`wbik.qp.peers`), ``methods`` (the method registry: modules listed by name, each declaring its
methods), ``cases`` (the study's seeded case samplers, registered the same way).
"""

from wbik.wholebody.methods import WHOLEBODY_METHOD_REGISTRY
from wbik.wholebody.methods import WholeBodyMethod
from wbik.wholebody.methods import register_wholebody_method
from wbik.wholebody.methods import wholebody_methods
from wbik.wholebody.methods import wholebody_solver
from wbik.wholebody.methods import wholebody_solver_options
from wbik.wholebody.problem import MinimumDistance
from wbik.wholebody.problem import WholeBody
from wbik.wholebody.problem import WholeBodyResult
from wbik.wholebody.problem import check_wholebody
from wbik.wholebody.solvers import WholeBodySolver

__all__ = [
    "WHOLEBODY_METHOD_REGISTRY",
    "MinimumDistance",
    "WholeBody",
    "WholeBodyMethod",
    "WholeBodyResult",
    "WholeBodySolver",
    "check_wholebody",
    "register_wholebody_method",
    "wholebody_methods",
    "wholebody_solver",
    "wholebody_solver_options",
]
