"""Strict priority levels against one weighted QP: time per step, and what each task achieves.

Two whole bodies, each with a goal, a soft orientation of the trunk (weight 0.1, not a goal) and a
posture toward a reference away from the start (weight 1e-3), under hard contacts, the CoM in the
shrunk support polygon and joint limits:

- Bioloid (nv 24): standing on the right foot, the left sole 40 mm up (a frame task); the pelvis keeps
  its orientation; the posture pulls the knees 0.3 rad straighter;
- Talos (nv 38): both feet flat, CoM margin 20 mm, the right gripper 0.15 m forward (a position
  task); the base keeps its orientation; the posture is the half-sitting one with the right arm
  0.4 rad away.

Each is solved three ways: ``weighted`` (one level: every task traded off by weight, as PlaCo and Pink
do), ``posture below`` (goal and orientation on level 0, posture on level 1) and ``3 levels`` (goal,
orientation, posture). The regularisation (1e-6) is on the lowest level in every variant.

Printed per variant: the time of one QP step at the start (median of ``repeats``, best of ``rounds``
interleaved rounds) and of the converged IK, its iterations, and each task's error at the answer:
the goal (m), the orientation (rad), the posture (rad, |q - q_ref| on the joints).

Run: .venv/bin/python benchmarks/priorities.py [--repeats 200] [--rounds 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pinocchio as pin

import wbik
from wbik.qp import (
    ComTask,
    FrameTask,
    IKProblem,
    OrientationTask,
    PositionTask,
    PostureTask,
    RegularizationTask,
)
from wbik.qp.humanoid import stance_constraints
from wbik.qp.support_polygon import sole_rectangle

VARIANTS = {"weighted": (0, 0, 0), "posture below": (0, 0, 1), "3 levels": (0, 1, 2)}
"""Priority of (goal, orientation, posture) in each variant."""


def bioloid_case():
    """(robot, start, goal task maker, constraints, trunk frame, posture reference)."""
    robot = wbik.load("bioloid")
    q0 = robot.nominal
    right = robot.frame_placement(q0, "r_sole").translation
    shift = IKProblem(robot.model, [ComTask([right[0], right[1], 0.0], axes="xy"),
                                    OrientationTask("pelvis", robot.frame_placement(q0, "pelvis").rotation,
                                                    weight=0.1, goal=False), RegularizationTask(1e-6)],
                      stance_constraints(robot, q0, ["r_sole", "l_sole"], margin=0.005))
    start = shift.solve(q0).q
    target = robot.frame_placement(start, "l_sole")
    target.translation = target.translation + np.array([0.0, 0.0, 0.04])
    reference = start.copy()
    for name in ("r_knee", "l_knee"):
        joint = robot.model.joints[robot.model.getJointId(name)] if robot.model.existJointName(name) else None
        if joint is not None:
            reference[joint.idx_q] -= 0.3 * np.sign(reference[joint.idx_q] or 1.0)
    constraints = stance_constraints(robot, start, ["r_sole"], margin=0.005)
    return robot, start, lambda priority: FrameTask("l_sole", target, priority=priority), constraints, \
        "pelvis", reference


def talos_case():
    soles = {frame: sole_rectangle(0.20, 0.12, (-0.005, 0.0, 0.0)) for frame in ("left_sole_link",
                                                                                  "right_sole_link")}
    robot = wbik.load("example-robot-data:talos", soles=soles)
    start = robot.nominal.copy()
    target = robot.frame_placement(start, "gripper_right_base_link").translation + np.array([0.15, 0.0, 0.0])
    reference = start.copy()
    for name in ("arm_right_1_joint", "arm_right_2_joint", "arm_right_4_joint"):
        reference[robot.model.joints[robot.model.getJointId(name)].idx_q] += 0.4
    reference = np.clip(reference, robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
    constraints = stance_constraints(robot, start, ["left_sole_link", "right_sole_link"], margin=0.02)
    def goal(priority: int) -> PositionTask:
        return PositionTask("gripper_right_base_link", target, priority=priority)

    return robot, start, goal, constraints, "base_link", reference


def problem(case, priorities: tuple[int, int, int]) -> tuple[IKProblem, list]:
    robot, start, goal, constraints, trunk, reference = case
    goal_priority, trunk_priority, posture_priority = priorities
    tasks = [goal(goal_priority),
             OrientationTask(trunk, robot.frame_placement(start, trunk).rotation, weight=0.1, goal=False,
                             priority=trunk_priority),
             PostureTask(reference, weight=1e-3, priority=posture_priority),
             RegularizationTask(1e-6, priority=max(priorities))]
    return IKProblem(robot.model, tasks, constraints), tasks


def median_time(function, repeats: int) -> float:
    times = np.empty(repeats)
    for index in range(repeats):
        tick = time.perf_counter()
        function()
        times[index] = time.perf_counter() - tick
    return float(np.median(times))


def measure(name: str, case, repeats: int, rounds: int) -> list[dict]:
    robot, start = case[0], case[1]
    built = {variant: problem(case, priorities) for variant, priorities in VARIANTS.items()}
    best = {variant: (np.inf, np.inf) for variant in VARIANTS}
    for _ in range(rounds):  # the variants take turns (the machine is shared)
        for variant, (ik, _) in built.items():
            step = median_time(lambda ik=ik: ik.step(start), repeats)
            solve = median_time(lambda ik=ik: ik.solve(start, max_iterations=300, diagnose=False),
                                max(repeats // 10, 3))
            best[variant] = (min(best[variant][0], step), min(best[variant][1], solve))
    rows = []
    for variant, (ik, tasks) in built.items():
        solution = ik.solve(start, max_iterations=300, diagnose=False)
        goal, trunk, posture = tasks[:3]
        posture_error = float(np.linalg.norm(pin.difference(robot.model, posture.reference, solution.q)[6:]))
        rows.append({"robot": name, "variant": variant, "levels": len(set(VARIANTS[variant])),
                     "step_us": best[variant][0] * 1e6, "ik_ms": best[variant][1] * 1e3,
                     "iterations": solution.iterations, "success": solution.success,
                     "goal": solution.task_errors[goal.name], "trunk": solution.task_errors[trunk.name],
                     "posture": posture_error})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rows = measure("Bioloid", bioloid_case(), args.repeats, args.rounds)
    rows += measure("Talos", talos_case(), args.repeats, args.rounds)
    header = (f"{'robot':8s} {'variant':14s} {'levels':>6s} {'us/step':>8s} {'ms/IK':>7s} {'iters':>6s} "
              f"{'ok':>4s} {'goal err m':>11s} {'trunk rad':>10s} {'posture rad':>12s}")
    print(f"Best of {args.rounds} interleaved rounds of the median of {args.repeats} steps "
          f"/ {max(args.repeats // 10, 3)} IK solves (DAQP).")
    print(header)
    print("-" * len(header))
    for row in rows:
        print(f"{row['robot']:8s} {row['variant']:14s} {row['levels']:6d} {row['step_us']:8.1f} "
              f"{row['ik_ms']:7.2f} {row['iterations']:6d} {'yes' if row['success'] else 'no':>4s} "
              f"{row['goal']:11.2e} {row['trunk']:10.2e} {row['posture']:12.3e}")
    print("goal err: the goal task's error at the answer (the IK converges at 1e-7); trunk: the orientation "
          "task's; posture: |q - q_ref| over the joints.")


if __name__ == "__main__":
    main()
