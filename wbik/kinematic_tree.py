"""The joints between two frames of a Pinocchio model's tree, as KDL, TRAC-IK and MoveIt find a chain:
the ancestors of the tip's joint below the base's joint (the base must lie upstream of the tip)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import pinocchio as pin

from wbik.errors import RobotDescriptionError, UnknownFrameError


@dataclass(frozen=True)
class ChainPath:
    """The 1-DOF joints moving the tip relative to the base (base to tip), the mimic joints between locked."""

    joints: tuple[str, ...]
    locked_mimic: tuple[str, ...] = ()


def frame_index(model: pin.Model, name: str) -> int:
    """The id of the frame called ``name``, or UnknownFrameError listing the model's frames."""
    if not isinstance(name, str) or not model.existFrame(name):
        raise UnknownFrameError(str(name), [frame.name for frame in model.frames])
    return model.getFrameId(name)


def ancestors(model: pin.Model, joint_id: int) -> list[int]:
    """``joint_id`` and the joints above it up to (not including) the universe, tip first."""
    line = []
    while joint_id != 0:
        line.append(joint_id)
        joint_id = model.parents[joint_id]
    return line


def leaf_frames(model: pin.Model) -> list[str]:
    """Body frames of joints that carry no other joint (hands, feet, tools), in model order."""
    parents = set(model.parents[1:])
    return [frame.name for frame in model.frames if frame.type == pin.FrameType.BODY
            and frame.parentJoint not in parents and frame.parentJoint != 0]


def chain_path(model: pin.Model, base: str, tip: str, mimic: Mapping[str, object] = ()) -> ChainPath:
    """The joints moving ``tip`` relative to ``base``, mimic followers locked; RobotDescriptionError when
    the base is not upstream of the tip, no joint lies between them or one is not 1-DOF."""
    base_joint = model.frames[frame_index(model, base)].parentJoint
    tip_joint = model.frames[frame_index(model, tip)].parentJoint
    line = ancestors(model, tip_joint)
    if base_joint != 0 and base_joint not in line:
        upstream = [frame.name for frame in model.frames
                    if frame.type == pin.FrameType.BODY and frame.parentJoint in [0, *line]][:6]
        raise RobotDescriptionError(
            f"frame {base!r} is not upstream of {tip!r}: a chain's base must not move with its joints. "
            f"Frames upstream of {tip!r} include {upstream}")
    below_base = line[:line.index(base_joint)] if base_joint in line else line
    joints, locked = [], []
    for joint_id in reversed(below_base):
        name, joint = model.names[joint_id], model.joints[joint_id]
        if joint.nq != 1 or joint.nv != 1:
            kind = joint.shortname().removeprefix("JointModel")
            raise RobotDescriptionError(
                f"joint {name!r} ({kind}, {joint.nv} DOF) lies between {base!r} and {tip!r}; a chain takes "
                "1-DOF revolute and prismatic joints only. Choose a base frame below it (for a floating "
                "base: a frame on the robot, e.g. its base link)")
        (locked if name in mimic else joints).append(name)
    if not joints:
        raise RobotDescriptionError(f"no movable joint lies between {base!r} and {tip!r}")
    return ChainPath(tuple(joints), tuple(locked))

