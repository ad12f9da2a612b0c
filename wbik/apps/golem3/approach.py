"""Golem-III approach (golem3.md): a straight line to a grasp pose, each sample solved with the 6-DOF
``right_arm`` (the slow torso lift ``mb`` held) and, only when that fails or jumps, with the 7-DOF
``right_arm_lift``; ``info['lift_samples']`` and ``info['lift_travel_m']`` tell what the lift did."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.motion.cartesian import DEFAULT_JUMP_THRESHOLD, PolylineReference
from wbik.motion.path import JointPath
from wbik.robot import Robot
from wbik.solvers.method_registry import solver as make_solver
from wbik.targets import Target, as_target

ARM, ARM_WITH_LIFT = "right_arm", "right_arm_lift"


def approach(robot: Robot, q0: Sequence[float], grasp, samples: int = 20, method: str = "dls",
             jump_threshold: float = DEFAULT_JUMP_THRESHOLD, lift_method: str | None = None,
             **solver_options) -> JointPath:
    """Straight line from the gripper at q0 (mb, m0, m10..m14) to ``grasp`` (base_link); ``lift_method``
    (default ``method``, 'dls' for 'analytic') solves the 7-DOF chain."""
    if samples < 1:
        raise InvalidConfigurationError(f"samples must be at least 1, got {samples}")
    arm_solver = make_solver(method, robot, chain=ARM, **solver_options)
    lift_method = lift_method or ("dls" if method == "analytic" else method)
    lift_solver = make_solver(lift_method, robot, chain=ARM_WITH_LIFT, **solver_options)
    lift_chain = lift_solver.chain
    q = lift_chain.check_q(q0)
    start = lift_chain.fk(q)
    reference = PolylineReference([Target(start.translation.copy(), start.rotation.copy()), as_target(grasp)])
    rows, solved, reasons, jumps, lift_samples = [q.copy()], [True], {}, [], []
    for k in range(1, samples + 1):
        target = reference.target(k / samples)
        full = lift_chain.full_configuration(q)
        base = robot.frame_placement(full, lift_chain.base_frame)
        torso = base.actInv(robot.frame_placement(full, "torso_link"))  # torso_link in base_link
        in_torso = Target(torso.actInv(target.se3()).translation,
                          None if target.rotation is None else torso.rotation.T @ target.rotation)
        arm = arm_solver.solve(in_torso, q[1:])
        if arm.success and np.max(np.abs(arm.q - q[1:])) <= jump_threshold:
            new_q, ok, note = np.concatenate(([q[0]], arm.q)), True, ""
        else:
            lifted = lift_solver.solve(target, q)
            lift_samples.append(k)
            new_q, ok = (lifted.q if lifted.q is not None else q), lifted.success
            note = "" if ok else f"arm alone: {arm.reason or 'jump'}; with the lift: {lifted.reason}"
        step = float(np.max(np.abs(new_q - q)))
        if step > jump_threshold:
            jumps.append(k)
            note = f"branch jump: a joint moved {step:.3g}" + (f"; {note}" if note else "")
        if note:
            reasons[k] = note
        rows.append(new_q.copy())
        solved.append(ok)
        q = new_q
    rows = np.array(rows)
    return JointPath(lift_chain, np.arange(samples + 1) / samples, rows, reference, np.array(solved),
                     reasons, jumps, [samples],
                     info={"kind": "golem3_approach", "method": method, "lift_method": lift_method,
                           "lift_samples": lift_samples,
                           "lift_travel_m": float(np.sum(np.abs(np.diff(rows[:, 0])))),
                           "arm_only": not lift_samples})
