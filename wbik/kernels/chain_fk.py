"""The compiled chain FK's side in Python (:mod:`wbik.kernels._chain_fk`): a chain's reduced model copied
into the kernel, which then places the tip with Pinocchio's own C++ FK in one call. Its Python twin is the
binding's path of :class:`wbik.robot.Chain` (``forwardKinematics`` and ``updateFramePlacement``)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.kernels.twins import compiled_twin, pure_python

JOINT_KINDS = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2, "JointModelRevoluteUnaligned": 3,
               "JointModelPX": 4, "JointModelPY": 5, "JointModelPZ": 6, "JointModelPrismaticUnaligned": 7}
"""Pinocchio's joint types the kernel copies (its JointKind numbers); a model with another keeps the twin."""
UNALIGNED = {"JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned"}
PROBES = 4
"""Configurations at which the copy must place the tip as the binding does, bit for bit, to be used."""

_build = compiled_twin("chain_fk", "build")
tip_pose = compiled_twin("chain_fk", "tip_pose")
"""tip_pose(chain, q, out): the tip's 4 x 4 pose in the root frame into ``out`` (the kernel's)."""
_ERRORS = not pure_python("pose")  # the errors are the pose kernel's: WBIK_PURE_PYTHON=pose runs their twin
tip_errors = compiled_twin("chain_fk", "tip_errors") if _ERRORS else None
"""tip_errors(chain, q, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, |e_R|,
exact): :func:`wbik.geometry.pose_errors` of the tip pose of q, in one call (the kernel's), or None."""
checked_result = compiled_twin("chain_fk", "checked_result") if _ERRORS else None
"""checked_result(chain, q, position, rotation, position_tolerance, rotation_tolerance, time_s, iterations,
method, extra) -> the shared check's answer of joints inside the limits that pass, whole, else None (the
kernel's; its twin: :func:`wbik.solvers.check.evaluate`'s Python path), or None where not built."""
result_type = compiled_twin("chain_fk", "result_type")
"""result_type(cls, fields): registers the answer type ``checked_result`` fills (its slot fields in order)."""


def compiled_chain(model: pin.Model, tip_id: int, lower: np.ndarray, upper: np.ndarray,
                   base_inverse: np.ndarray | None):
    """The kernel's copy of ``model`` with frame ``tip_id`` as its tip, or None where the kernel is not built,
    ``WBIK_PURE_PYTHON`` asks for the twin, a joint is none of :data:`JOINT_KINDS`, or the copy does not
    place the tip as the binding does at :data:`PROBES` seeded configurations (it then never runs)."""
    if _build is None or pure_python("chain_fk"):
        return None
    names = [model.joints[j].shortname() for j in range(1, model.njoints)]
    if any(name not in JOINT_KINDS for name in names):
        return None
    axes = np.zeros((len(names), 3))
    for row, name in enumerate(names):
        if name in UNALIGNED:
            axes[row] = model.joints[row + 1].extract().axis
    placements = np.array([model.jointPlacements[j].homogeneous.ravel() for j in range(1, model.njoints)]
                          ).reshape(len(names), 16)
    frame = model.frames[tip_id]
    chain = _build([JOINT_KINDS[name] for name in names], list(model.parents)[1:], axes, placements,
                   frame.parentJoint, frame.placement.homogeneous, lower, upper, base_inverse)
    return chain if _agrees(chain, model, tip_id) else None


def _agrees(chain, model: pin.Model, tip_id: int) -> bool:
    """Whether the copy places the tip as Pinocchio's binding does, bit for bit, at seeded configurations
    inside the limits and within +-pi (of a limit that excludes it, the nearest value: FK does not read the
    limits, and a model built in code has limits of +-1.8e308)."""
    lower = np.clip(-np.pi, model.lowerPositionLimit, model.upperPositionLimit)
    upper = np.clip(np.pi, model.lowerPositionLimit, model.upperPositionLimit)
    data, pose = model.createData(), np.empty((4, 4))
    for q in np.random.default_rng(0).uniform(lower, upper, (PROBES, model.nq)):
        pin.forwardKinematics(model, data, q)
        tip_pose(chain, q, pose)
        if pose.tobytes() != pin.updateFramePlacement(model, data, tip_id).homogeneous.tobytes():
            return False
    return True
