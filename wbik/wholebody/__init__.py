"""Whole-body problems: :class:`~wbik.wholebody.problem.WholeBody` (tasks under open constraints) and the
study's seeded case samplers (:mod:`wbik.wholebody.cases`). Every method solves them through the one
interface, ``wbik.solver(method, robot).solve(problem, q0)``, judged by the shared check
(:func:`wbik.solvers.check.check_problem`)."""
