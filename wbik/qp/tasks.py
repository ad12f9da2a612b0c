"""Tasks, the soft objectives of the QP: an error e(q) (m rows, 0 when done) and J = de/dq (m x nv), costing
weight |J dq + gain e|^2 in a step (``weight``: a scalar or one per row). ``priority``: its level in a strict
hierarchy (0 first); ``goal`` tasks decide convergence (|e| under ``tolerance``). An *inequality* task wants
e <= 0 row by row: it costs weight max(0, J dq + gain e)^2, its error is max(0, e). Rotation errors are
e_R = log3(R*^T R), de_R/dq = Jlog3(R*^T R) R^T J_w; ``fill`` writes J and e together (compiled where built).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np
import pinocchio as pin

from wbik.geometry import rotation_error, rotation_error_jacobian
from wbik.kernels.twins import chosen, compiled_twin
from wbik.qp.kinematics import Kinematics

_FRAME_ROWS = compiled_twin("qp_rows", "frame_rows")
"""The compiled twin of FrameTask.fill and OrientationTask.fill (None where it is not built)."""


def axis_rows(axes: str) -> np.ndarray:
    """Row indices of a subset of "xyz" (e.g. "xy" -> [0, 1])."""
    if not axes or not set(axes) <= set("xyz") or len(set(axes)) != len(axes):
        raise ValueError(f"axes must be a non-empty subset of 'xyz', got {axes!r}")
    return np.array(["xyz".index(axis) for axis in axes])


class Task:
    """Base class: subclasses set ``dimension`` and implement ``error`` and ``jacobian``."""

    dimension = 0
    goal = True
    inequality = False
    """True: the task wants e <= 0 on each row (see the module docstring), not e = 0."""
    unit = ""
    """The unit of its error: "m", "rad", "m, rad" (a pose) or "" (another quantity)."""

    def __init__(self, weight: float | Sequence[float] = 1.0, gain: float = 1.0, priority: int = 0,
                 tolerance: float = 1e-7, name: str | None = None, goal: bool | None = None):
        if goal is not None:
            self.goal = bool(goal)
        self.weight = np.broadcast_to(np.asarray(weight, dtype=float), (self.dimension,)).copy()
        if np.any(self.weight < 0):
            raise ValueError(f"task weights must be >= 0, got {weight}")
        self.gain = float(gain)
        self.priority = int(priority)
        self.tolerance = float(tolerance)
        self.name = name or type(self).__name__

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, priority={self.priority})"

    def start(self, kinematics: Kinematics) -> None:
        """Called once when a problem starts from a configuration (resolve frame names here)."""

    def error(self, kinematics: Kinematics) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        raise NotImplementedError

    def fill(self, kinematics: Kinematics, jacobian: np.ndarray, error: np.ndarray) -> None:
        """Write J and e into the given rows (a task may compute them together, sharing terms)."""
        jacobian[:] = self.jacobian(kinematics)
        error[:] = self.error(kinematics)

    def constant_diagonal(self) -> np.ndarray | None:
        """The weights w of a task with rows J = I, e = 0 (added to H's diagonal); None for any other task."""
        return None

    def error_parts(self, error: np.ndarray) -> tuple[float | None, float | None]:
        """(position part m, rotation part rad; None: none) of an error, as the check judges it."""
        return float(np.linalg.norm(error)), None


def _fill_rotation(kinematics: Kinematics, frame_id: int, rotation: np.ndarray, target: np.ndarray,
                   jacobian: np.ndarray, error: np.ndarray) -> None:
    """``rotation_error(R, R*)`` into ``error`` and ``rotation_error_jacobian`` into ``jacobian`` (3
    rows of a C-contiguous buffer), sharing M = R*^T R; R^T J_w is the LOCAL Jacobian's angular part."""
    relative = target.T.dot(rotation)  # (ndarray.dot: less call overhead than @ on 3 x 3)
    error[:] = pin.log3(relative)
    pin.Jlog3(relative).dot(kinematics.local_jacobian(frame_id)[3:], out=jacobian)


class _FrameTaskBase(Task):
    kernel_rows: int | None = None
    """The compiled rows' kind (6: pose, 3: orientation) for a task whose ``fill`` calls them."""

    def __init__(self, frame: str, **options):
        self.frame = frame
        self.frame_id = -1
        self._compiled_rows, self._compiled_for = None, None
        self._kernel = chosen(None, _FRAME_ROWS, "qp_rows") if self.kernel_rows is not None else None
        super().__init__(name=options.pop("name", None) or f"{type(self).__name__}[{frame}]", **options)

    def __getstate__(self) -> dict:
        """Without the views of one Kinematics' data nor the target's (``start`` makes them again)."""
        views = ("_compiled_rows", "_compiled_for", "_target_translation", "_target_rotation")
        return {name: value for name, value in self.__dict__.items() if name not in views}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._compiled_rows, self._compiled_for = None, None
        if "_target" in state:
            self.target = self._target  # (views of the copied target)

    def start(self, kinematics: Kinematics) -> None:
        frame_id = kinematics.frame_id(self.frame)
        if frame_id == self.frame_id and kinematics is self._compiled_for:
            return  # started on these kinematics before: the views still follow them
        self.frame_id = frame_id
        self._compiled_rows, self._compiled_for = None, None
        if self._kernel is not None:
            # the kernel reads the frame's placement and data.J through views that follow every update
            placement = kinematics.placement(self.frame_id)
            self._compiled_rows = partial(self._kernel, self.kernel_rows, kinematics.joint_jacobians,
                                          kinematics.support_columns(self.frame_id), placement.translation,
                                          placement.rotation)
            self._compiled_for = kinematics

    def _point(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.placement(self.frame_id).translation

    def _point_jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.jacobian(self.frame_id)[:3]


class _ComPoint(Task):
    """The centre of mass as a task's point (world, m)."""

    def _point(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.com()

    def _point_jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.com_jacobian()


class _AxesTask(Task):
    """A point (``_point``) toward ``target`` (world, m) on some axes: e = (p - p*)[axes]."""

    unit = "m"

    def __init__(self, target: Sequence[float], axes: str = "xyz", **options):
        self.rows = axis_rows(axes)
        self.dimension = len(self.rows)
        super().__init__(**options)
        self.target = np.asarray(target, dtype=float).reshape(3).copy()

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return (self._point(kinematics) - self.target)[self.rows]

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return self._point_jacobian(kinematics)[self.rows]


class _PoseTask(_FrameTaskBase):
    """A 6-row pose task; ``position_weight`` and ``orientation_weight`` weigh its halves."""

    dimension = 6
    unit = "m, rad"

    def __init__(self, frame: str, target: pin.SE3, position_weight: float = 1.0,
                 orientation_weight: float = 1.0, **options):
        weight = options.pop("weight", 1.0)
        rows = np.r_[np.full(3, position_weight), np.full(3, orientation_weight)] * weight
        super().__init__(frame, weight=rows, **options)
        self.target = target.copy()
        self._error = np.zeros(6)

    def error_parts(self, error: np.ndarray) -> tuple[float, float]:
        return float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:]))


class FrameTask(_PoseTask):
    """Full pose of a frame in the world: e = [p - p*; log3(R*^T R)] (6 rows)."""

    kernel_rows = 6

    @property
    def target(self) -> pin.SE3:
        """The target pose (kept as given, not copied: changing it in place moves the target)."""
        return self._target

    @target.setter
    def target(self, value: pin.SE3) -> None:
        self._target = value
        # views of the pose's own memory, for the compiled rows
        self._target_translation, self._target_rotation = value.translation, value.rotation

    def error(self, kinematics: Kinematics) -> np.ndarray:
        """e (a buffer reused by the next call: copy it to keep it)."""
        placement = kinematics.placement(self.frame_id)
        error = self._error
        np.subtract(placement.translation, self.target.translation, out=error[:3])
        error[3:] = rotation_error(placement.rotation, self.target.rotation)
        return error

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        placement = kinematics.placement(self.frame_id)
        jacobian = kinematics.jacobian(self.frame_id)
        jacobian[3:] = rotation_error_jacobian(placement.rotation, self.target.rotation, jacobian[3:])
        return jacobian

    def fill(self, kinematics: Kinematics, jacobian: np.ndarray, error: np.ndarray) -> None:
        if kinematics is self._compiled_for and self._compiled_rows(
                self._target_translation, self._target_rotation, jacobian, error):
            return  # (False near a half turn: the Python twin below)
        frame_id, target = self.frame_id, self.target
        placement = kinematics.placement(frame_id)
        error[:3] = placement.translation - target.translation
        jacobian[:3] = kinematics.jacobian(frame_id)[:3]
        _fill_rotation(kinematics, frame_id, placement.rotation, target.rotation, jacobian[3:], error[3:])


class PositionTask(_AxesTask, _FrameTaskBase):
    """Position of a frame's origin in the world, optionally on some axes only: e = (p - p*)[axes]."""

    def __init__(self, frame: str, target: Sequence[float], axes: str = "xyz", **options):
        super().__init__(target, axes, frame=frame, **options)


class OrientationTask(_FrameTaskBase):
    """Orientation of a frame in the world: e = log3(R*^T R) (3 rows)."""

    dimension = 3
    kernel_rows = 3
    unit = "rad"

    def __init__(self, frame: str, target: np.ndarray, **options):
        super().__init__(frame, **options)
        self.target = np.asarray(target, dtype=float).reshape(3, 3).copy()

    def error_parts(self, error: np.ndarray) -> tuple[None, float]:
        return None, float(np.linalg.norm(error))

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return rotation_error(kinematics.placement(self.frame_id).rotation, self.target)

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return rotation_error_jacobian(kinematics.placement(self.frame_id).rotation, self.target,
                                       kinematics.jacobian(self.frame_id)[3:])

    def fill(self, kinematics: Kinematics, jacobian: np.ndarray, error: np.ndarray) -> None:
        if kinematics is self._compiled_for and self._compiled_rows(None, self.target, jacobian, error):
            return  # (False near a half turn: the Python twin below)
        frame_id = self.frame_id
        _fill_rotation(kinematics, frame_id, kinematics.placement(frame_id).rotation, self.target, jacobian,
                       error)


class RelativeFrameTask(_PoseTask):
    """Pose of ``frame`` in ``reference_frame``: T_rel = T_ref^-1 T_frame, e = [p_rel - p*; log3(R*^T R_rel)];
    with d = p_frame - p_ref, dp_rel = R_ref^T (J_v,frame - J_v,ref + [d]x J_w,ref) dq."""

    def __init__(self, frame: str, reference_frame: str, target: pin.SE3, position_weight: float = 1.0,
                 orientation_weight: float = 1.0, **options):
        options.setdefault("name", f"RelativeFrameTask[{frame} in {reference_frame}]")
        super().__init__(frame, target, position_weight, orientation_weight, **options)
        self.reference_frame = reference_frame
        self.reference_id = -1

    def start(self, kinematics: Kinematics) -> None:
        super().start(kinematics)
        self.reference_id = kinematics.frame_id(self.reference_frame)

    def error(self, kinematics: Kinematics) -> np.ndarray:
        relative = kinematics.placement(self.reference_id).actInv(kinematics.placement(self.frame_id))
        return np.concatenate((relative.translation - self.target.translation,
                               rotation_error(relative.rotation, self.target.rotation)))

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        frame = kinematics.placement(self.frame_id)
        reference = kinematics.placement(self.reference_id)
        frame_jacobian = kinematics.jacobian(self.frame_id)
        reference_jacobian = kinematics.jacobian(self.reference_id)
        offset = pin.skew(frame.translation - reference.translation)
        linear = reference.rotation.T @ (frame_jacobian[:3] - reference_jacobian[:3]
                                         + offset @ reference_jacobian[3:])
        # R_rel' = R_ref^T exp([w_f - w_ref]) R_frame (to first order), so the rotation part is
        # rotation_error_jacobian of R_rel with the relative angular rows in the reference's axes
        relative_rotation = reference.rotation.T @ frame.rotation
        relative_angular = reference.rotation.T @ (frame_jacobian[3:] - reference_jacobian[3:])
        angular = rotation_error_jacobian(relative_rotation, self.target.rotation, relative_angular)
        return np.vstack((linear, angular))


class ComTask(_AxesTask, _ComPoint):
    """Centre of mass in the world, optionally on some axes only: e = (c - c*)[axes]."""


class PostureTask(Task):
    """Joints toward a reference: e = (q (-) q_ref) on the rows of ``joints`` (default: all, not a base)."""

    goal = False

    def __init__(self, reference: np.ndarray, joints: Sequence[str] | None = None, **options):
        self.reference = np.asarray(reference, dtype=float).copy()
        self.joint_names = None if joints is None else list(joints)
        self.rows = np.zeros(0, dtype=int)
        self.dimension = 0
        self._weight_option = options.pop("weight", 1e-3)
        super().__init__(**options)

    def start(self, kinematics: Kinematics) -> None:
        model = kinematics.model
        if self.reference.shape != (model.nq,):
            raise ValueError(f"posture reference has {self.reference.size} values, the model nq = {model.nq}")
        self.rows = (np.arange(6 if model.njoints > 1 and model.joints[1].nv == 6 else 0, model.nv)
                     if self.joint_names is None  # (all but a floating base: joint 1 with nv = 6)
                     else np.array([model.joints[model.getJointId(name)].idx_v for name in self.joint_names]))
        self.dimension = len(self.rows)
        self.weight = np.broadcast_to(np.asarray(self._weight_option, float), (self.dimension,)).copy()
        self._jacobian = np.zeros((self.dimension, model.nv))
        self._jacobian[np.arange(self.dimension), self.rows] = 1.0

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return pin.difference(kinematics.model, self.reference, kinematics.q)[self.rows]

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return self._jacobian


class RegularizationTask(Task):
    """Small steps: weight * |dq|^2 (e = 0, J = I). Damps the redundant directions without bias."""

    goal = False

    def __init__(self, weight: float = 1e-6, **options):
        self._weight_option = weight
        super().__init__(**options)

    def start(self, kinematics: Kinematics) -> None:
        self.weight = np.full(kinematics.nv, float(self._weight_option))
        if self.dimension != kinematics.nv:  # (rows made once per model size)
            self.dimension = kinematics.nv
            self._jacobian = np.eye(kinematics.nv)
            self._error = np.zeros(kinematics.nv)

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return self._error

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return self._jacobian

    def constant_diagonal(self) -> np.ndarray:
        return self.weight


class _BoxTask(Task):
    """A point inside an axis-aligned box (world, m), as an inequality task: e = [p - upper; lower - p]
    on the box's finite sides (each row <= 0 inside), p its ``_point``."""

    inequality = True

    def __init__(self, lower: Sequence[float] | None = None, upper: Sequence[float] | None = None, **options):
        lower = np.full(3, -np.inf) if lower is None else np.asarray(lower, dtype=float).reshape(3)
        upper = np.full(3, np.inf) if upper is None else np.asarray(upper, dtype=float).reshape(3)
        if np.any(np.isnan(lower)) or np.any(np.isnan(upper)) or np.any(lower > upper):
            raise ValueError(f"a box needs lower <= upper on every axis, got {lower} and {upper}")
        self.lower, self.upper = lower, upper
        self._upper_rows = np.flatnonzero(np.isfinite(upper))
        self._lower_rows = np.flatnonzero(np.isfinite(lower))
        self.dimension = len(self._upper_rows) + len(self._lower_rows)
        if not self.dimension:
            raise ValueError("a box task needs at least one finite side")
        super().__init__(**options)

    def error(self, kinematics: Kinematics) -> np.ndarray:
        point = self._point(kinematics)
        return np.concatenate((point[self._upper_rows] - self.upper[self._upper_rows],
                               self.lower[self._lower_rows] - point[self._lower_rows]))

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        jacobian = self._point_jacobian(kinematics)
        return np.vstack((jacobian[self._upper_rows], -jacobian[self._lower_rows]))


class PositionBoxTask(_BoxTask, _FrameTaskBase):
    """A frame's origin inside the box [lower, upper] (world, m; None or inf: no side), softly."""

    unit = "m"

    def __init__(self, frame: str, lower: Sequence[float] | None = None, upper: Sequence[float] | None = None,
                 **options):
        super().__init__(lower, upper, frame=frame, **options)


class ComBoxTask(_BoxTask, _ComPoint):
    """The centre of mass inside the box [lower, upper] (world, m; None or inf: no side), softly."""
