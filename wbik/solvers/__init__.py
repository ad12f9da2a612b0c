"""IK methods behind one interface: the solver template (:mod:`wbik.solvers.base`), the result and the
shared check (:mod:`wbik.solvers.result`, :mod:`wbik.solvers.check`), one module per method, and the
method registry (:mod:`wbik.solvers.method_registry`)."""
