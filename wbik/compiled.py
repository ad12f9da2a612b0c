"""The switch between wbik's compiled kernels and their Python twins.

Two optional C extensions, built by ``pip install`` (``setup.py``) where a C compiler exists, replace
per-call Python arithmetic with the same arithmetic in C (same bits, tests compare both):
``wbik._pose_kernel`` (the fast-path test of :func:`wbik.targets.as_target` and the arithmetic of the
shared FK check, :func:`wbik.geometry.error_parts`) and
``wbik.solvers.analytic._ur_kernel`` (the UR-type closed form's scalar path). Without them, or with
``WBIK_PURE_PYTHON=1`` in the environment, the Python twins run.
"""

from __future__ import annotations

import os

PURE_PYTHON_VARIABLE = "WBIK_PURE_PYTHON"
"""Set to 1 to run the Python twins even where the extensions are built."""


def pure_python() -> bool:
    """Whether ``WBIK_PURE_PYTHON=1`` asks for the Python twins (read when a kernel is picked: at import
    of :mod:`wbik.targets` and :mod:`wbik.geometry`, when a closed form is built)."""
    return os.environ.get(PURE_PYTHON_VARIABLE, "") == "1"
