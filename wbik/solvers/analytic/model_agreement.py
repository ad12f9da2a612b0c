"""A closed form's FK held to the model's when built: the batched check and the kernels measure with it."""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import RobotDescriptionError

MODEL_AGREEMENT = 1e-9  # m and rotation entries; the shipped forms differ by 1.24e-11 at most
MODEL_SAMPLES = 16  # seeded joint vectors inside the limits ([-pi, pi] where one is infinite)


def check_fk_against_model(form) -> None:
    """RobotDescriptionError unless ``form.fk`` is the model's within MODEL_AGREEMENT."""
    positions_only = form.target_kind == "position"
    chain = form.chain
    lower = np.where(np.isfinite(chain.lower), chain.lower, -math.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, math.pi)
    joints = np.random.default_rng(0).uniform(lower, upper, (MODEL_SAMPLES, chain.nq))
    positions, rotations = form.fk(joints)
    for q, position, rotation in zip(joints, positions, rotations, strict=True):
        pose = chain.fk(q)
        gap = float(np.abs(pose.translation - position).max())
        if not positions_only:
            gap = max(gap, float(np.abs(pose.rotation - rotation).max()))
        if not gap <= MODEL_AGREEMENT:
            raise RobotDescriptionError(
                f"the closed form {type(form).__name__} of {chain.robot.name}.{chain.name} is not this "
                f"chain: its FK differs from the robot model's by {gap:.3g} (m or rotation entries) at q = "
                f"{np.round(q, 6).tolist()}; give it the model's geometry (e.g. the DH numbers of this arm)")
