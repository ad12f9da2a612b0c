"""Kinematics: one Pinocchio model/data pair at one configuration, shared by every task: ``update(q)``
runs FK and the joint Jacobians once, placements, frame Jacobians (LOCAL_WORLD_ALIGNED: dp = J[:3] dq)
and the CoM are read from them."""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin

from wbik.kinematic_tree import frame_index

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
LOCAL = pin.ReferenceFrame.LOCAL
_VERSIONS = itertools.count()


class Kinematics:
    """Model, data and the configuration ``q`` (nq); ``version``, unique, changes with every ``update``."""

    def __init__(self, model: pin.Model, q: np.ndarray | None = None):
        self.model = model
        self.data = model.createData()
        self._views()
        self.nq = model.nq
        self.nv = model.nv
        self.q = pin.neutral(model) if q is None else np.array(q, dtype=float)
        self._com_ready = False
        self._frame_ids: dict[str, int] = {}
        self._support_columns: dict[int, np.ndarray] = {}
        self.update(self.q)

    def _views(self) -> None:
        """Views into ``data`` (made again by ``__setstate__``: a copy has a new data)."""
        self._placements = self.data.oMf  # the vector itself: indexing it is cheaper than data.oMf[i]
        self.joint_jacobians = self.data.J
        """(6, nv) view of data.J: every joint's Jacobian in world axes at the world origin."""

    def __getstate__(self) -> dict:
        return {name: value for name, value in self.__dict__.items()
                if name not in ("_placements", "joint_jacobians")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views()

    def frame_id(self, name: str) -> int:
        if (frame_id := self._frame_ids.get(name)) is None:
            frame_id = self._frame_ids[name] = frame_index(self.model, name)
        return frame_id

    def update(self, q: np.ndarray) -> None:
        """Forward kinematics and joint Jacobians at q (the CoM waits until it is asked for)."""
        if q is not self.q:
            np.copyto(self.q, q)
        pin.computeJointJacobians(self.model, self.data, self.q)
        pin.updateFramePlacements(self.model, self.data)
        self._com_ready = False
        self.version = next(_VERSIONS)

    def placement(self, frame_id: int) -> pin.SE3:
        """World placement of a frame (a view into data: copy it to keep it)."""
        return self._placements[frame_id]

    def support_columns(self, frame_id: int) -> np.ndarray:
        """Tangent indices (int64) of the joints that move a frame (its Jacobian's other columns are 0)."""
        if (columns := self._support_columns.get(frame_id)) is None:
            model = self.model
            joints = [model.joints[joint] for joint in model.supports[model.frames[frame_id].parentJoint][1:]]
            indices = (index for joint in joints for index in range(joint.idx_v, joint.idx_v + joint.nv))
            columns = np.array(sorted(indices), dtype=np.int64)
            columns.flags.writeable = False
            self._support_columns[frame_id] = columns
        return columns

    def jacobian(self, frame_id: int) -> np.ndarray:
        """6 x nv frame Jacobian [v; w] in world axes (LOCAL_WORLD_ALIGNED)."""
        return pin.getFrameJacobian(self.model, self.data, frame_id, LWA)

    def local_jacobian(self, frame_id: int) -> np.ndarray:
        """6 x nv frame Jacobian in the frame's own axes (LOCAL): rows [R^T v; R^T w]."""
        return pin.getFrameJacobian(self.model, self.data, frame_id, LOCAL)

    def _update_com(self) -> None:
        # (data's joint Jacobians: no second pass; the binding's copies kept until the next update)
        self._com_jacobian = pin.jacobianCenterOfMass(self.model, self.data, False)
        self._com = self.data.com[0]
        self._com_ready = True

    def com(self) -> np.ndarray:
        """Centre of mass in world coordinates (3,; the same array until the next update: read it only)."""
        if not self._com_ready:
            self._update_com()
        return self._com

    def com_jacobian(self) -> np.ndarray:
        """3 x nv Jacobian of the centre of mass (the same array until the next update: read it only)."""
        if not self._com_ready:
            self._update_com()
        return self._com_jacobian

    def com_and_jacobian(self) -> tuple[np.ndarray, np.ndarray]:
        """(``com()``, ``com_jacobian()``) in one call."""
        if not self._com_ready:
            self._update_com()
        return self._com, self._com_jacobian

    def integrate(self, dq: np.ndarray) -> np.ndarray:
        """q (+) dq on the configuration manifold (a new array)."""
        return pin.integrate(self.model, self.q, dq)
