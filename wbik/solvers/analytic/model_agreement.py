"""A closed form's FK held to the robot model's (Pinocchio) when ``analytic`` builds the form.

``solve_many``, and ``solve_all`` through a compiled kernel, check their answers with the closed form's
own FK (the batched rule of :func:`wbik.solvers.analytic.batch.evaluate_batch`). That check is the
shared one (Pinocchio) only if the form's FK is the model's: :func:`check_fk_against_model` refuses a
form whose FK differs, e.g. a UR-type binding given another arm's DH numbers.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import RobotDescriptionError

MODEL_AGREEMENT = 1e-9
"""Largest difference (m, and rotation-matrix entries) allowed between a closed form's FK and the robot
model's. Held to it, the closed form's check is the shared one's to within 1e-9, three orders of
magnitude below the check's tolerances (1e-6). The shipped forms differ by 1.24e-11 at most (the UR5's
DH numbers against its URDF)."""
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
