"""orocos KDL's ChainIkSolverPos_NR_JL through PyKDL on the chain's serial structure (its FK held to
Pinocchio's to 1e-12): pseudo-inverse steps clamped into the limits until every twist component is below
``epsilon``. ``kdl``: one attempt from the seed; ``kdl_restarts``: MoveIt's KDL plugin, random restarts
until the time budget is used up. Full poses only (KDL's weighted solvers crash PyKDL 1.5.1 under numpy 2).
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from wbik.dependencies import PYKDL_LIBRARY, import_optional
from wbik.errors import RobotDescriptionError
from wbik.robot import Chain
from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.solvers.task_error import serial_structure
from wbik.targets import Target, pose_error

FK_AGREEMENT = 1e-12  # largest difference of KDL's and Pinocchio's tip pose (m, rotation entries)


def import_pykdl():
    """The PyKDL module, or MissingDependencyError saying how to install it."""
    return import_optional(PYKDL_LIBRARY, "method 'kdl'", "PyKDL")


def kdl_frame(kdl, matrix: np.ndarray):
    """A KDL Frame from a 4x4 homogeneous matrix."""
    rotation = kdl.Rotation(*(float(v) for v in matrix[:3, :3].reshape(-1)))
    return kdl.Frame(rotation, kdl.Vector(*(float(v) for v in matrix[:3, 3])))


def kdl_chain(chain: Chain):
    """The chain as a PyKDL.Chain (base frame to tip frame, one movable segment per chain joint)."""
    kdl = import_pykdl()
    structure = serial_structure(chain)
    result = kdl.Chain()
    result.addSegment(kdl.Segment("base_to_" + chain.joint_names[0], kdl.Joint(kdl.Joint.Fixed),
                                  kdl_frame(kdl, structure.placements[0])))
    for k, name in enumerate(chain.joint_names):
        kind = kdl.Joint.TransAxis if structure.prismatic[k] else kdl.Joint.RotAxis
        joint = kdl.Joint(name, kdl.Vector(0.0, 0.0, 0.0), kdl.Vector(*structure.axes[k]), kind)
        result.addSegment(kdl.Segment(name, joint, kdl_frame(kdl, structure.placements[k + 1])))
    return result


def joint_array(kdl, values: np.ndarray):
    array = kdl.JntArray(len(values))
    for index, value in enumerate(values):
        array[index] = float(value)
    return array


def check_fk_agreement(chain: Chain, kdl_chain_, samples: int = 5, seed: int = 0) -> None:
    """RobotDescriptionError where KDL's and Pinocchio's tip poses at random joints differ by > 1e-12."""
    kdl = import_pykdl()
    fk_solver = kdl.ChainFkSolverPos_recursive(kdl_chain_)
    worst = 0.0
    frame = kdl.Frame()
    for q in chain.random(np.random.default_rng(seed), samples):
        fk_solver.JntToCart(joint_array(kdl, q), frame)
        expected = chain.fk(q)
        position = np.array([frame.p[i] for i in range(3)])
        rotation = np.array([[frame.M[i, j] for j in range(3)] for i in range(3)])
        worst = max(worst, float(np.abs(position - expected.translation).max()),
                    float(np.abs(rotation - expected.rotation).max()))
    if worst > FK_AGREEMENT:
        raise RobotDescriptionError(
            f"KDL chain built from {chain!r} disagrees with Pinocchio's FK by {worst:.3g}")


class KDLSolver(Solver):
    """KDL NR_JL, one attempt from the seed; ``epsilon`` default: the shared tolerance / sqrt(3)."""

    name = "kdl"
    supports_position_only = False
    pose_only_because = ("KDL NR_JL has no position-only mode (and PyKDL's weighted solvers crash under "
                         "numpy 2); use bounded_lm, dls or newton")

    def __init__(self, robot, chain=None, *, max_iterations: int = 100, epsilon: float | None = None,
                 **options):
        super().__init__(robot, chain, **options)
        self.kdl = import_pykdl()
        self.max_iterations = int(max_iterations)
        tolerance = min(self.tolerances.position, self.tolerances.rotation)
        self.epsilon = float(epsilon) if epsilon is not None else tolerance / math.sqrt(3.0)
        self.kdl_chain = kdl_chain(self.chain)
        check_fk_agreement(self.chain, self.kdl_chain)

    def _new_thread_state(self) -> SimpleNamespace:
        """This thread's KDL solvers and output array (KDL's solvers keep working state)."""
        kdl = self.kdl
        fk_solver = kdl.ChainFkSolverPos_recursive(self.kdl_chain)
        velocity_solver = kdl.ChainIkSolverVel_pinv(self.kdl_chain)
        pose_solver = kdl.ChainIkSolverPos_NR_JL(self.kdl_chain, joint_array(kdl, self.chain.unbounded_lower),
                                                 joint_array(kdl, self.chain.unbounded_upper), fk_solver,
                                                 velocity_solver, self.max_iterations, self.epsilon)
        return SimpleNamespace(fk=fk_solver, velocity=velocity_solver, pose=pose_solver,
                               q_out=kdl.JntArray(self.chain.nq))

    def attempt(self, frame, q_seed: np.ndarray) -> tuple[np.ndarray, int]:
        """One NR_JL run: (joints, KDL return code; 0 = converged)."""
        state = self._thread_state()
        code = state.pose.CartToJnt(joint_array(self.kdl, q_seed), frame, state.q_out)
        return np.array([state.q_out[i] for i in range(self.chain.nq)]), int(code)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        q, code = self.attempt(kdl_frame(self.kdl, target.se3().homogeneous), self.chain.clip(q0))
        reason = f"KDL NR_JL returned {code} ({self._thread_state().pose.strError(code)})" if code < 0 else ""
        return Candidate(q, 1, reason, {"kdl_code": code})


class KDLRestartsSolver(KDLSolver):
    """KDL NR_JL from the seed, then random seeds while the time left holds one more mean attempt."""

    name = "kdl_restarts"

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        frame = kdl_frame(self.kdl, target.se3().homogeneous)
        q_seed = self.chain.clip(q0)
        attempts = 0
        best_q, best_error = None, math.inf
        rng = None
        first = time.perf_counter()
        while True:
            q, _ = self.attempt(frame, q_seed)
            now = time.perf_counter()
            attempts += 1
            position, rotation = pose_error(self.chain.fk(q), target)  # as the shared check measures them
            position_error, rotation_error = float(np.linalg.norm(position)), float(np.linalg.norm(rotation))
            if position_error <= self.tolerances.position and rotation_error <= self.tolerances.rotation:
                return Candidate(q, attempts, "", {"attempts": attempts})
            error = position_error + rotation_error
            if error < best_error:
                best_q, best_error = q, error
            if now + (now - first) / attempts >= deadline:
                return Candidate(best_q, attempts, f"time budget of {self.timeout_s:g} s used up after "
                                 f"{attempts} KDL attempts", {"attempts": attempts})
            if rng is None:
                rng = self._call_rng(target, q0)
            q_seed = self.chain.random(rng)


IK_METHODS = (
    IKMethod("kdl", KDLSolver,
             "orocos KDL ChainIkSolverPos_NR_JL through PyKDL, one attempt from the seed",
             needs=PYKDL_LIBRARY),
    IKMethod("kdl_restarts", KDLRestartsSolver,
             "orocos KDL NR_JL with random restarts until the timeout (MoveIt's way)",
             needs=PYKDL_LIBRARY),
)
