"""wbik's compiled kernels (``_<name>.c``, or ``.cpp``; built where a compiler exists) and their Python twins:
``WBIK_PURE_PYTHON=1`` runs every twin, a comma-separated list (``eaik,pose``) those only."""

from __future__ import annotations

import contextlib
import os
import shutil
import sysconfig
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

# each None where not built (no compiler)
_pose = _ur_type = _stacked_planar = _eaik = _qp_rows = _lm_trial = _chain_fk = None
with contextlib.suppress(ImportError):
    import wbik.kernels._pose as _pose
with contextlib.suppress(ImportError):
    import wbik.kernels._ur_type as _ur_type
with contextlib.suppress(ImportError):
    import wbik.kernels._stacked_planar as _stacked_planar
with contextlib.suppress(ImportError):
    import wbik.kernels._eaik as _eaik
with contextlib.suppress(ImportError):
    import wbik.kernels._qp_rows as _qp_rows
with contextlib.suppress(ImportError):
    import wbik.kernels._lm_trial as _lm_trial
with contextlib.suppress(ImportError):
    import wbik.kernels._chain_fk as _chain_fk

PURE_PYTHON_VARIABLE = "WBIK_PURE_PYTHON"


@dataclass(frozen=True)
class Kernel:
    """One compiled kernel (its C file says what it computes), its Python twin and goal rows it moves."""

    name: str
    extension: ModuleType | None
    python_twin: str
    goal_rows: tuple[str, ...]


KERNELS = (
    Kernel("pose", _pose,
           "wbik.targets._python_accepts_plain_se3, wbik.geometry._python_pose_errors, "
           "wbik.solvers.check._python_inside_limits, wbik.robot._python_plain_finite",
           ("interface overhead", "Golem-III closed-form solve", "UR5 closed-form solve")),
    Kernel("ur_type", _ur_type,
           "wbik.solvers.analytic.ur_type.branches_by_joint with "
           "wbik.solvers.analytic.solver.AnalyticSolver._choose (the vectorised choice)",
           ("UR5 closed-form solve", "UR5 closed-form solve_all", "UR5 closed-form solve_many")),
    Kernel("stacked_planar", _stacked_planar,
           "wbik.solvers.analytic.stacked_planar.StackedPlanarPose.branches with "
           "wbik.solvers.analytic.solver.AnalyticSolver._choose (the vectorised choice)",
           ("Golem-III closed-form solve",)),
    Kernel("eaik", _eaik, "wbik.kernels.eaik (order_python, choose_python)", ("eaik method solve",)),
    Kernel("qp_rows", _qp_rows,
           "wbik.qp.tasks, wbik.qp.step, wbik.qp.backends, and through wbik.qp.row_plan the rows of "
           "wbik.qp.contacts, wbik.qp.balance and wbik.qp.limits (Pinocchio and NumPy)",
           ("whole-body QP step", "converged whole-body IK")),
    Kernel("lm_trial", _lm_trial,
           "wbik.solvers.levenberg_marquardt.LevenbergMarquardt.trial (NumPy and LAPACK), "
           "wbik.solvers.bounded_lm.BoundedLMSolver._attempt (on Pinocchio's kinematics)",
           ("bounded_lm mean time",)),
    Kernel("chain_fk", _chain_fk,
           "wbik.robot.Chain.root_tip and wbik.robot.Chain.tip_errors (Pinocchio's binding, "
           "wbik.geometry.pose_errors); wbik.kernels.chain_fk copies a chain's model into the kernel",
           ("interface overhead", "UR5 closed-form solve", "Golem-III closed-form solve")),
)
"""Every compiled kernel of wbik (tests/test_compiled.py checks that each C file here is listed)."""


def compiled_twin(kernel: str, name: str):
    """The function ``name`` of ``kernel``'s extension, or None where it is not built (or built from an
    older C file without it: rebuild)."""
    extension = next(k.extension for k in KERNELS if k.name == kernel)
    return getattr(extension, name, None)


def chosen(python, compiled, kernel: str):
    """``compiled``, unless it is None or ``WBIK_PURE_PYTHON`` asks for ``python``."""
    return python if compiled is None or pure_python(kernel) else compiled


def can_build() -> bool:
    """Whether this machine has what building the extensions needs: a C compiler and Python.h."""
    has_compiler = any(shutil.which(name) for name in ("cc", "gcc", "clang"))
    return has_compiler and (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file()


def pure_python(kernel: str | None = None) -> bool:
    """Whether ``WBIK_PURE_PYTHON`` asks for ``kernel``'s Python twin (without ``kernel``: every twin's)."""
    value = os.environ.get(PURE_PYTHON_VARIABLE, "").strip()
    return value == "1" or (kernel is not None and kernel in {word.strip() for word in value.split(",")})
