"""A closed form's FK held to the robot model's when ``analytic`` builds the form: the batched check (and
a kernel's) uses the form's FK, the shared one only if that is the model's (e.g. not a UR-type binding
given another arm's DH numbers)."""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import RobotDescriptionError

MODEL_AGREEMENT = 1e-9
"""Largest difference (m, rotation entries) between a form's FK and the model's, three orders below the
check's tolerances; the shipped forms differ by 1.24e-11 at most (the UR5's DH numbers vs its URDF)."""
MODEL_SAMPLES = 16
"""Joint vectors the agreement is checked on (seeded, inside the limits; [-pi, pi] where one is infinite)."""


def check_fk_against_model(form) -> None:
    """RobotDescriptionError unless ``form.fk`` is the chain's model FK within MODEL_AGREEMENT on
    MODEL_SAMPLES seeded joint vectors; positions only for a form of position targets (its check reads
    no rotation)."""
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
