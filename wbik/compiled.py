"""The switch between wbik's compiled kernels and their Python twins.

Five optional C extensions, built by ``pip install`` (``setup.py``) where a C compiler exists, replace
per-call Python arithmetic with the same arithmetic in C: ``wbik._pose_kernel`` (the fast-path test of
:func:`wbik.targets.as_target` and the arithmetic of the shared FK check,
:func:`wbik.geometry.error_parts`) and ``wbik.solvers.analytic._ur_kernel`` (the UR-type closed form's
scalar path) and ``wbik.solvers.analytic._eaik_kernel`` (the order of EAIK's branches wrapped into
the limits, and the screen's arithmetic, for the ``eaik`` method), all giving their twins' bits;
``wbik.qp._rows_kernel`` (the QP step's frame-task rows,
each level's H and c, the constraint stack's copies) and ``wbik.solvers._lm_kernel`` (one bounded
Levenberg-Marquardt trial of ``bounded_lm``), agreeing with their twins (Pinocchio, NumPy, LAPACK),
which sum in their own orders, to rounding. Tests compare every pair. Without them, or with
``WBIK_PURE_PYTHON=1`` in the environment, the Python twins run.
"""

from __future__ import annotations

import importlib
import os
import shutil
import sysconfig
from pathlib import Path

PURE_PYTHON_VARIABLE = "WBIK_PURE_PYTHON"
"""Set to 1 to run the Python twins even where the extensions are built."""


def compiled_twin(module: str, name: str):
    """The function ``name`` of the extension ``module``, or None where it is not built."""
    try:
        return getattr(importlib.import_module(module), name)
    except ImportError:
        return None


def chosen(python, compiled):
    """The twin to run: ``compiled`` unless it is None (not built) or ``WBIK_PURE_PYTHON=1`` asks for
    ``python``."""
    return python if compiled is None or pure_python() else compiled


def can_build() -> bool:
    """Whether this machine has what building the extensions needs: a C compiler and Python.h."""
    has_compiler = any(shutil.which(name) for name in ("cc", "gcc", "clang"))
    return has_compiler and (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()


def pure_python() -> bool:
    """Whether ``WBIK_PURE_PYTHON=1`` asks for the Python twins (read when a kernel is picked: at import
    of :mod:`wbik.targets` and :mod:`wbik.geometry`, when a closed form is built, when a QP frame
    task, priority level or constraint stack is made, when a ``bounded_lm`` solver is made)."""
    return os.environ.get(PURE_PYTHON_VARIABLE, "") == "1"
