"""TRAC-IK through pytracik on the robot's URDF: KDL's NR_JL with random restarts and an SQP run concurrently,
from an unseedable C++ random state (answers vary with the run and the load). Full poses only.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbik.dependencies import TRAC_IK_LIBRARY, import_optional
from wbik.errors import InvalidSettingError, RobotDescriptionError
from wbik.peer_output import captured_output
from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.targets import Target
from wbik.urdf import with_massless_root

SOLVE_TYPES = ("Speed", "Distance", "Manip1", "Manip2")


class TracIKSolver(Solver):
    """TRAC-IK (pytracik): ``solve_type`` one of Speed (default), Distance, Manip1, Manip2; ``epsilon``: its
    per-component twist tolerance (default the shared tolerance / sqrt(3))."""

    name = "trac_ik"
    supports_position_only = False
    pose_only_because = ("TRAC-IK's position-only mode (its bounds argument) is not exposed by pytracik "
                         "0.0.3; use bounded_lm, dls or newton")

    def __init__(self, robot, chain=None, *, epsilon: float | None = None, solve_type: str = "Speed",
                 **options):
        super().__init__(robot, chain, **options)
        if solve_type not in SOLVE_TYPES:
            raise InvalidSettingError(f"solve_type must be one of {SOLVE_TYPES}, got {solve_type!r}")
        self.pytracik = import_optional(TRAC_IK_LIBRARY, "method 'trac_ik'", "pytracik")
        tolerance = min(self.tolerances.position, self.tolerances.rotation)
        self.epsilon = float(epsilon) if epsilon is not None else tolerance / math.sqrt(3.0)
        self.solve_type = solve_type
        self._urdf_text = with_massless_root(
            robot.urdf_text if robot.urdf_path is None else robot.urdf_path.read_text())
        self._thread_state()  # build (and check) this thread's TRAC-IK object now

    def _new_thread_state(self):
        """This thread's TRAC-IK object (one is not safe to call from two threads)."""
        chain_ = self.chain
        with captured_output("TRAC-IK") as printed:
            solver = self.pytracik.TRAC_IK(chain_.base_frame, chain_.tip_frame, self._urdf_text,
                                           self.timeout_s, self.epsilon,
                                           getattr(self.pytracik.SolveType, self.solve_type))
            joints = self.pytracik.get_num_joints(solver)
        if joints != chain_.nq:
            urdf = self.robot.urdf_path or f"the URDF of {self.robot.name!r}"
            raise RobotDescriptionError(
                f"TRAC-IK finds {joints} movable joints between {chain_.base_frame!r} and "
                f"{chain_.tip_frame!r} in {urdf}, the chain {chain_.name!r} has {chain_.nq} "
                f"{chain_.joint_names}; TRAC-IK needs URDF links as base/tip and every joint between "
                f"them in the chain{printed.reason()}")
        # a revolute joint whose bounds reach float's extremes is continuous to TRAC-IK
        extreme = float(np.finfo(np.float32).max)
        lower = np.where(chain_.continuous, -extreme, chain_.lower)
        upper = np.where(chain_.continuous, extreme, chain_.upper)
        self.pytracik.set_joint_limits(solver, lower.tolist(), upper.tolist())
        return solver

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        quaternion = pin.Quaternion(target.rotation)
        x, y, z = target.position
        answer = self.pytracik.ik(self._thread_state(), self.chain.clip(q0), x, y, z,
                                  quaternion.x, quaternion.y, quaternion.z, quaternion.w)
        if answer[0] < 0:
            return Candidate(None, 1, f"TRAC-IK found no solution within {self.timeout_s:g} s")
        return Candidate(np.asarray(answer[1:], dtype=float), 1)


IK_METHODS = (
    IKMethod("trac_ik", TracIKSolver,
             "TRAC-IK (pytracik): KDL NR_JL and SQP run concurrently",
             needs=TRAC_IK_LIBRARY),
)
