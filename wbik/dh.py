"""Denavit-Hartenberg tables -> URDF text -> Pinocchio model.

Standard (distal): A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i); modified (proximal, Craig):
A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i); theta_i = theta + q (revolute) or d_i = d + q
(prismatic), T = base A_1 ... A_n tool. Each A_i = Pre_i J(q) Post_i with J about/along z, a URDF joint
of origin Post_{i-1} Pre_i: standard Pre = Rz(theta) Tz(d), Post = Tx(a) Rx(alpha); modified
Pre = Rx(alpha) Tx(a) Rz(theta) Tz(d), Post = I.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pinocchio as pin

import wbik.geometry as geometry
from wbik.errors import RobotDescriptionError

Convention = Literal["standard", "modified"]
JointType = Literal["revolute", "prismatic"]


def homogeneous(rotation: np.ndarray | None = None, translation=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The 4x4 homogeneous transform [R p; 0 1] (R the identity when not given)."""
    matrix = np.eye(4)
    if rotation is not None:
        matrix[:3, :3] = rotation
    matrix[:3, 3] = translation
    return matrix


def rot_x(angle: float) -> np.ndarray:
    return homogeneous(geometry.rot_x(angle))


def rot_z(angle: float) -> np.ndarray:
    return homogeneous(geometry.rot_z(angle))


def trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    return homogeneous(translation=(x, y, z))


@dataclass(frozen=True)
class DHJoint:
    """One row of a DH table. Lengths in metres, angles in radians."""

    a: float
    alpha: float
    d: float
    theta: float = 0.0
    type: JointType = "revolute"
    lower: float = -math.pi
    upper: float = math.pi
    velocity: float = 1.0
    effort: float = 10.0
    name: str | None = None

    def pre(self, convention: Convention) -> np.ndarray:
        if convention == "standard":
            return rot_z(self.theta) @ trans(z=self.d)
        return rot_x(self.alpha) @ trans(x=self.a) @ rot_z(self.theta) @ trans(z=self.d)

    def post(self, convention: Convention) -> np.ndarray:
        if convention == "standard":
            return trans(x=self.a) @ rot_x(self.alpha)
        return np.eye(4)


@dataclass
class DHTable:
    """A serial chain as a DH table, with optional fixed base and tool transforms (4x4)."""

    joints: Sequence[DHJoint]
    convention: Convention = "standard"
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        if self.convention not in ("standard", "modified"):
            raise RobotDescriptionError(
                f"DH convention must be 'standard' or 'modified', got {self.convention!r}")
        if not self.joints:
            raise RobotDescriptionError("a DH table needs at least one joint")
        for index, joint in enumerate(self.joints):
            if joint.type not in ("revolute", "prismatic"):
                raise RobotDescriptionError(
                    f"joint {index}: type must be 'revolute' or 'prismatic', got {joint.type!r}")
            if not joint.lower <= joint.upper:
                raise RobotDescriptionError(
                    f"joint {index}: lower limit {joint.lower} is above upper limit {joint.upper}")
        self.base = np.asarray(self.base, dtype=float)
        self.tool = np.asarray(self.tool, dtype=float)

    def urdf(self, name: str = "dh_robot", base_link: str = "base_link", tip_link: str = "tool",
             link_mass: float = 0.1) -> str:
        """A URDF document of this chain: links ``link1..n``, then ``tip_link`` fixed by Post_n tool."""
        parts = [link_xml(base_link, 0.0)]
        carry, parent = self.base, base_link
        for index, joint in enumerate(self.joints):
            child = f"link{index + 1}"
            parts.append(link_xml(child, link_mass))
            parts.append(joint_xml(joint.name or f"joint{index + 1}", joint.type, parent, child,
                                   carry @ joint.pre(self.convention),
                                   limits=(joint.lower, joint.upper, joint.velocity, joint.effort)))
            carry, parent = joint.post(self.convention), child
        parts.append(link_xml(tip_link, 0.0))
        parts.append(joint_xml(f"{tip_link}_fixed", "fixed", parent, tip_link, carry @ self.tool))
        return urdf_document(name, "\n".join(parts))

    def model(self, base_link: str = "base_link", tip_link: str = "tool") -> pin.Model:
        """The Pinocchio model of this chain (from its URDF text)."""
        return pin.buildModelFromXML(self.urdf(base_link=base_link, tip_link=tip_link))


def _fmt(value: float) -> str:
    return repr(float(value))


def link_xml(name: str, mass: float, com: Sequence[float] = (0.0, 0.0, 0.0),
             inertia_diagonal: Sequence[float] | None = None) -> str:
    """A <link>; with mass > 0 it carries an inertial (a small solid by default)."""
    if mass <= 0.0:
        return f'<link name="{name}"/>'
    ixx, iyy, izz = inertia_diagonal or (mass * 1e-4,) * 3
    return (f'<link name="{name}"><inertial><origin xyz="{_fmt(com[0])} {_fmt(com[1])} {_fmt(com[2])}"/>'
            f'<mass value="{_fmt(mass)}"/><inertia ixx="{_fmt(ixx)}" ixy="0" ixz="0" iyy="{_fmt(iyy)}" '
            f'iyz="0" izz="{_fmt(izz)}"/></inertial></link>')


def joint_xml(name: str, kind: str, parent: str, child: str, origin: np.ndarray,
              axis: Sequence[float] = (0.0, 0.0, 1.0),
              limits: tuple[float, float, float, float] | None = None) -> str:
    """A <joint> at the 4x4 ``origin`` (URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll), as pin.rpy); ``limits`` =
    (lower, upper, velocity, effort) for revolute/prismatic joints."""
    xyz, rpy = origin[:3, 3], pin.rpy.matrixToRpy(origin[:3, :3])
    xml = [f'<joint name="{name}" type="{kind}">', f'<parent link="{parent}"/>', f'<child link="{child}"/>',
           f'<origin xyz="{_fmt(xyz[0])} {_fmt(xyz[1])} {_fmt(xyz[2])}" '
           f'rpy="{_fmt(rpy[0])} {_fmt(rpy[1])} {_fmt(rpy[2])}"/>']
    if kind != "fixed":
        xml.append(f'<axis xyz="{_fmt(axis[0])} {_fmt(axis[1])} {_fmt(axis[2])}"/>')
        lower, upper, velocity, effort = limits or (-math.pi, math.pi, 1.0, 10.0)
        xml.append(f'<limit lower="{_fmt(lower)}" upper="{_fmt(upper)}" velocity="{_fmt(velocity)}" '
                   f'effort="{_fmt(effort)}"/>')
    xml.append("</joint>")
    return "".join(xml)


def urdf_document(name: str, body: str) -> str:
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'
