"""wbik's compiled kernels, all in this folder, with the switch between them and their Python twins.

Six optional C extensions, built by ``pip install`` (``setup.py``) where a C compiler exists, each
replace a piece of per-call Python arithmetic with the same arithmetic in C. :data:`KERNELS` lists
them: the extension, what it computes, its Python twin (the code that runs without it) and the
benchmark goal rows it moves (``benchmarks/all.py``; docs/benchmarks.md gives each one's measured
gain). The C sources sit beside this file (``_<name>.c``, sharing ``_buffers.h``); a C function writes
into arrays the caller passes and returns a number, a bool or None, never a Python object of wbik's.

Twins with the same bits: ``pose`` and ``eaik`` (plain IEEE arithmetic in the same order, built without
FMA contraction); ``ur_type`` and ``stacked_planar`` too where NumPy's arctan2 and arccos are libm's (their
twin is the vectorised NumPy choice; NumPy's AVX-512 versions are one ulp off on some arguments). Twins to
rounding: ``qp_rows`` and ``lm_trial``, whose Python twins call Pinocchio, NumPy or LAPACK, which sum in
their own orders. Tests compare every pair (tests/test_compiled.py and one test file per kernel).

``WBIK_PURE_PYTHON=1`` in the environment runs every Python twin; a comma-separated list of kernel
names (``WBIK_PURE_PYTHON=eaik,pose``) runs the twins of those only, which is how a kernel's own gain
is measured. It is read when a kernel is picked (see :func:`pure_python`).
"""

from __future__ import annotations

import os
import shutil
import sysconfig
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

try:  # each extension is built where a C compiler exists (setup.py); None where it is not
    import wbik.kernels._pose as _pose
except ImportError:
    _pose = None
try:
    import wbik.kernels._ur_type as _ur_type
except ImportError:
    _ur_type = None
try:
    import wbik.kernels._stacked_planar as _stacked_planar
except ImportError:
    _stacked_planar = None
try:
    import wbik.kernels._eaik as _eaik
except ImportError:
    _eaik = None
try:
    import wbik.kernels._qp_rows as _qp_rows
except ImportError:
    _qp_rows = None
try:
    import wbik.kernels._lm_trial as _lm_trial
except ImportError:
    _lm_trial = None

PURE_PYTHON_VARIABLE = "WBIK_PURE_PYTHON"
"""Set to 1 to run every Python twin even where the extensions are built, or to kernel names."""


@dataclass(frozen=True)
class Kernel:
    """One compiled kernel: ``name`` (``WBIK_PURE_PYTHON``'s word for it), its extension module (None where
    it is not built), what it computes, where its Python twin lives, and the benchmark goal rows it moves."""

    name: str
    extension: ModuleType | None
    computes: str
    python_twin: str
    goal_rows: tuple[str, ...]


KERNELS = (
    Kernel("pose", _pose,
           "as_target's fast-path test of a pose; the shared FK check's arithmetic "
           "(p - p*, |p - p*|, R*^T R)",
           "wbik.targets._python_accepts_plain_se3, wbik.geometry._python_error_parts",
           ("interface overhead", "Golem-III closed-form solve")),
    Kernel("ur_type", _ur_type,
           "the UR-type closed form's choice: branches, wrapping into the limits, screen, nearest branch",
           "wbik.solvers.analytic.ur_type.branches_by_joint with "
           "wbik.solvers.analytic.solver.AnalyticSolver._choose (the vectorised choice)",
           ("UR5 closed-form solve", "UR5 closed-form solve_all", "UR5 closed-form solve_many")),
    Kernel("stacked_planar", _stacked_planar,
           "the stacked-planar (Golem-III arm) pose closed form's choice, as the UR-type kernel's",
           "wbik.solvers.analytic.stacked_planar.StackedPlanarPose.branches with "
           "wbik.solvers.analytic.solver.AnalyticSolver._choose (the vectorised choice)",
           ("Golem-III closed-form solve",)),
    Kernel("eaik", _eaik,
           "the eaik method's choice among EAIK's branches: order, wrapping, FK screen, check arithmetic",
           "wbik.kernels.eaik (order_python, choose_python)",
           ("eaik method solve",)),
    Kernel("qp_rows", _qp_rows,
           "the QP step's frame-task rows, each priority level's H and c, the constraint stack's copies",
           "wbik.qp.tasks, wbik.qp.step, wbik.qp.backends (Pinocchio and NumPy)",
           ("whole-body QP step", "converged whole-body IK")),
    Kernel("lm_trial", _lm_trial,
           "one damped, bounded Levenberg-Marquardt trial of bounded_lm",
           "wbik.solvers.levenberg_marquardt.LevenbergMarquardt.trial (NumPy and LAPACK)",
           ("bounded_lm mean time",)),
)
"""Every compiled kernel of wbik (tests/test_compiled.py checks that each C file here is listed)."""


def compiled_twin(kernel: str, name: str):
    """The function ``name`` of the extension of ``kernel`` (a name in :data:`KERNELS`), or None where it is
    not built."""
    extension = next(k.extension for k in KERNELS if k.name == kernel)
    return None if extension is None else getattr(extension, name)


def chosen(python, compiled, kernel: str):
    """The twin to run: ``compiled`` unless it is None (not built) or ``WBIK_PURE_PYTHON`` asks for
    ``python`` (see :func:`pure_python`)."""
    return python if compiled is None or pure_python(kernel) else compiled


def can_build() -> bool:
    """Whether this machine has what building the extensions needs: a C compiler and Python.h."""
    has_compiler = any(shutil.which(name) for name in ("cc", "gcc", "clang"))
    return has_compiler and (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()


def pure_python(kernel: str | None = None) -> bool:
    """Whether ``WBIK_PURE_PYTHON`` asks for the Python twin of ``kernel`` (1: of every kernel; a
    comma-separated list: of those named); without ``kernel``, whether it asks for every twin. Read
    when a kernel is picked: at import of :mod:`wbik.targets` and :mod:`wbik.geometry`, when a closed
    form or an ``eaik`` solver is built, when a QP frame task, priority level or constraint stack is
    made, when a ``bounded_lm`` solver is made."""
    value = os.environ.get(PURE_PYTHON_VARIABLE, "").strip()
    if value == "1":
        return True
    if kernel is None or not value:
        return False
    return kernel in {word.strip() for word in value.split(",")}
