"""Golem-III binding (golem3.md, thesis ch. 4.1 and 4.2.1): both arms as the stacked-planar family
(:mod:`wbik.solvers.analytic.stacked_planar`) with one Euler triple, as the thesis (roll range +-pi/2);
the left arm, T_left(m0, q) = M T_right(-m0, q) M, through an
:class:`~wbik.solvers.analytic.aligned.AlignedForm` with G = X = M = diag(1, -1, 1) and -m0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.robot import Chain
from wbik.solvers.analytic.aligned import AlignedForm, FamilyChain
from wbik.solvers.analytic.stacked_planar import (
    StackedPlanarGeometry,
    StackedPlanarPose,
    StackedPlanarPosition,
    held_roll,
)

RIGHT_JOINTS = ("m10", "m11", "m12", "m13", "m14")
LEFT_JOINTS = ("m20", "m21", "m22", "m23", "m24")
_MIRROR_P = np.array([1.0, -1.0, 1.0])
_MIRROR_R = np.outer(_MIRROR_P, _MIRROR_P)  # M R M, entry-wise


@dataclass(frozen=True)
class Golem3Facts:
    """``robot.facts`` of Golem-III: ``arm``, the thesis's right-arm DH numbers (golem3.md) as the
    closed form takes them: l1, l2, l4, l5 (row a's), l6 (row 6 d), h (row 1 d) in m, rho (rad)."""

    arm: StackedPlanarGeometry


def right_arm_coordinates(chain: Chain) -> tuple[bool, np.ndarray, np.ndarray]:
    """(mirrored: ``chain`` is the left arm, its lower and upper limits in right-arm terms (m0 -> -m0))."""
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
    """6-DOF pose IK: up to 4 real branches; at gimbal lock (gripper x vertical) q0's t6 and 7 rolls."""
    return _arm(chain, lambda family_chain, geometry: StackedPlanarPose(family_chain, geometry, triples=1))


def golem3_position(chain: Chain, yaw: float = 0.0) -> AlignedForm:
    """Position-only IK with the wrist roll t6 held at ``yaw`` (rad, inside its limits)."""
    yaw = held_roll(chain, yaw, InvalidConfigurationError)
    return _arm(chain, lambda family_chain, geometry: StackedPlanarPosition(family_chain, geometry, yaw))
