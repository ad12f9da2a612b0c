"""Golem-III binding (golem3.md, thesis ch. 4.1 and 4.2.1): both arms, the stacked-planar family
(:mod:`wbik.solvers.analytic.stacked_planar`) with the thesis's geometry and, as the thesis, one Euler
triple (the roll range is +-pi/2).

The left arm is the mirror image of the right one (see wbik.robot_packages.golem3.model): T_left(m0, q) =
M T_right(-m0, q) M with M = diag(1, -1, 1), the family's form seen through G = X = M and the sign of m0
(:class:`~wbik.solvers.analytic.aligned.AlignedForm`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.robot import Chain
from wbik.solvers.analytic.aligned import AlignedForm
from wbik.solvers.analytic.aligned import FamilyChain
from wbik.solvers.analytic.stacked_planar import StackedPlanarGeometry
from wbik.solvers.analytic.stacked_planar import StackedPlanarPose
from wbik.solvers.analytic.stacked_planar import StackedPlanarPosition
from wbik.solvers.analytic.stacked_planar import held_roll

RIGHT_JOINTS = ("m10", "m11", "m12", "m13", "m14")
LEFT_JOINTS = ("m20", "m21", "m22", "m23", "m24")
_MIRROR_P = np.array([1.0, -1.0, 1.0])
_MIRROR_R = np.outer(_MIRROR_P, _MIRROR_P)  # M R M, entry-wise


@dataclass(frozen=True)
class Golem3Facts:
    """The thesis's right-arm DH numbers (golem3.md), ``robot.facts``; the closed form reads them.

    ASSUMPTIONS documented here and in the model's docstring: the left arm is the mirror image of the
    right one, T_left(m0, q) = M T_right(-m0, q) M with M = diag(1, -1, 1) in torso_link, and its
    joints m2x have the limits of m1x; masses, head and finger geometry are guesses.
    """

    arm: StackedPlanarGeometry
    """The arm as the stacked-planar closed form takes it: l1 = row 1 a (chest yaw axis -> shoulder),
    l2 = row 2 a, l4 = row 4 a (upper arm), l5 = row 5 a (elbow offset), l6 = row 6 d (forearm, wrist
    roll axis to the gripper centre), h = row 1 d (base height of the shoulder plane), all in m, and
    rho the elbow angle offset (rad, 13.43 deg)."""


def right_arm_coordinates(chain: Chain) -> tuple[bool, np.ndarray, np.ndarray]:
    """(mirrored, lower, upper): whether ``chain`` is the left arm, solved as the mirror image of the
    right one, and its limits in right-arm coordinates (m0 -> -m0 on the left)."""
    mirrored = any(name in chain.joint_names for name in LEFT_JOINTS)
    lower, upper = chain.lower.copy(), chain.upper.copy()
    if mirrored:
        lower[0], upper[0] = -chain.upper[0], -chain.lower[0]
    return mirrored, lower, upper


def mirror_positions(positions: np.ndarray) -> np.ndarray:
    """M p with M = diag(1, -1, 1) (positions (..., 3))."""
    return positions * _MIRROR_P


def mirror_rotations(rotations: np.ndarray) -> np.ndarray:
    """M R M with M = diag(1, -1, 1) (rotations (..., 3, 3))."""
    return rotations * _MIRROR_R


def _arm(chain: Chain, form) -> AlignedForm:
    """``form(family_chain, geometry)`` on the arm in right-arm coordinates, seen from ``chain``."""
    if chain.nq != 6 or chain.base_frame != "torso_link":
        raise InvalidConfigurationError(
            f"the Golem-III closed form needs a chain from torso_link over (m0, 5 arm joints); "
            f"{chain.name!r} is {chain.base_frame} -> {chain.tip_frame} with {chain.joint_names}")
    geometry = chain.robot.require_facts(Golem3Facts, "the Golem-III closed form").arm
    mirrored = right_arm_coordinates(chain)[0]
    signs = np.array([-1.0 if mirrored else 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    mirror = np.diag([*(_MIRROR_P if mirrored else np.ones(3)), 1.0])
    inner = form(FamilyChain(chain, signs, np.zeros(6)), geometry)
    return AlignedForm(chain, inner, mirror, mirror, signs, np.zeros(6))


def golem3_pose(chain: Chain) -> AlignedForm:
    """6-DOF pose IK: up to 4 real branches per pose; at gimbal lock (gripper x axis vertical) q0's t6 and
    7 rolls over its range."""
    return _arm(chain, lambda family_chain, geometry: StackedPlanarPose(family_chain, geometry, triples=1))


def golem3_position(chain: Chain, yaw: float = 0.0) -> AlignedForm:
    """Position-only IK with the wrist roll t6 held at ``yaw`` (rad, inside its limits): the family's
    (t1, t2) search."""
    yaw = held_roll(chain, yaw, InvalidConfigurationError)
    return _arm(chain, lambda family_chain, geometry: StackedPlanarPosition(family_chain, geometry, yaw))
