"""Chatter near a joint limit in a control loop: velocity limits alone against acceleration limits.

A planar two-link arm (links 0.3 m; the elbow's range [0, 2.5] rad: 0 is the straight arm, it cannot
bend backwards) tracks a target that moves on a circle-like path whose radius swings between 0.25 and
0.65 m, so that for part of every period the target is out of reach and the arm reaches for it
straight, its elbow on its limit. One QP step per period, ``IKProblem.step(q, dt)`` with dt = 10 ms:
a position task (gain 1), joint position limits, velocity limits (3 rad/s), and, in the second
configuration, acceleration limits (``JointAccelerationLimits``, with room to brake before the limits).

With velocity limits alone the elbow bounces off its limit at full velocity from one period to the
next while the target is out of reach (the linearised step at the straight, singular arm overshoots
the other way); bounding the change of velocity removes that. Chatter is counted as sign changes of
each joint's velocity per second (velocities under 1e-3 rad/s ignored); also printed: the largest
change of velocity per period (as an acceleration), the tracking error while the target is within
reach, and the elbow's lowest angle (it must stay >= 0).

Run: .venv/bin/python benchmarks/chatter.py [--seconds 4]
"""

from __future__ import annotations

import argparse

import numpy as np

from wbik.qp import IKProblem, JointPositionLimits, JointVelocityLimits, PositionTask, PostureTask
from wbik.qp.limits import JointAccelerationLimits
from wbik.robot import robot_from_urdf_text

LINK = 0.3
DT = 0.01
ELBOW = (0.0, 2.5)


def planar_arm():
    """Two revolute joints about z, 0.3 m links, 3 rad/s; the elbow limited to [0, 2.5] rad."""
    inertia = '<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>'
    parts = ['<robot name="planar_arm">', '<link name="base"/>']
    parent = "base"
    for index, (lower, upper) in enumerate(((-2.5, 2.5), ELBOW)):
        parts.append(f'<link name="link{index}"><inertial><mass value="1"/>{inertia}</inertial></link>')
        parts.append(f'<joint name="joint{index}" type="revolute"><parent link="{parent}"/>'
                     f'<child link="link{index}"/><origin xyz="{0.0 if index == 0 else LINK} 0 0"/>'
                     f'<axis xyz="0 0 1"/><limit lower="{lower}" upper="{upper}" effort="1" velocity="3"/>'
                     "</joint>")
        parent = f"link{index}"
    parts.append(f'<link name="tip"/><joint name="tip_fixed" type="fixed"><parent link="{parent}"/>'
                 f'<child link="tip"/><origin xyz="{LINK} 0 0"/></joint></robot>')
    return robot_from_urdf_text("planar_arm", "\n".join(parts), [], floating_base=False)


def target(t: float) -> np.ndarray:
    """The moving target at time t (s): radius 0.45 +- 0.2 m at 0.5 Hz, angle +-0.6 rad at 0.25 Hz."""
    radius = 0.45 + 0.2 * np.sin(2 * np.pi * 0.5 * t)
    angle = 0.6 * np.sin(2 * np.pi * 0.25 * t)
    return np.array([radius * np.cos(angle), radius * np.sin(angle), 0.0])


def track(robot, acceleration_limit: float | None, seconds: float = 4.0) -> dict:
    """The control loop (see the module docstring); its figures."""
    model = robot.model
    task = PositionTask("tip", np.zeros(3), axes="xy")
    constraints = [JointPositionLimits(), JointVelocityLimits()]
    if acceleration_limit is not None:
        constraints.append(JointAccelerationLimits(acceleration_limit))
    posture = PostureTask(np.array([0.0, 1.2]), weight=1e-4, priority=1)  # (a bent elbow, in the null space)
    problem = IKProblem(model, [task, posture], constraints)
    q = np.array([0.0, 0.3])
    velocities, angles, errors = [], [], []
    for period in range(int(round(seconds / DT))):
        task.target = target(period * DT)
        dq = problem.step(q, dt=DT)
        q = q + dq
        velocities.append(dq / DT)
        angles.append(q.copy())
        reached = LINK * np.array([np.cos(q[0]) + np.cos(q[0] + q[1]), np.sin(q[0]) + np.sin(q[0] + q[1])])
        if np.linalg.norm(task.target[:2]) < 2 * LINK - 0.01:  # within reach
            errors.append(float(np.linalg.norm(reached - task.target[:2])))
    velocity = np.array(velocities)
    moving = np.abs(velocity) > 1e-3
    flips = (velocity[1:] * velocity[:-1] < 0) & moving[1:] & moving[:-1]
    return {"sign_changes_per_s": flips.sum(axis=0) / seconds,
            "max_acceleration": np.abs(np.diff(velocity, axis=0)).max(axis=0) / DT,
            "tracking_rms_m": float(np.sqrt(np.mean(np.square(errors)))) if errors else float("nan"),
            "elbow_min_rad": float(np.array(angles)[:, 1].min())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0)
    args = parser.parse_args()
    robot = planar_arm()
    print(f"planar two-link arm, dt = {DT * 1e3:g} ms, {args.seconds:g} s, target out of reach part of every "
          "period (the elbow on its limit); velocity limit 3 rad/s")
    header = (f"{'limits':32s} {'sign changes/s':>16s} {'(shoulder, elbow)':>18s} {'max accel rad/s^2':>18s} "
              f"{'track rms mm':>13s} {'elbow min rad':>14s}")
    print(header)
    print("-" * len(header))
    for limit in (None, 50.0, 20.0, 10.0):
        figures = track(robot, limit, args.seconds)
        label = "velocity only" if limit is None else f"velocity + acceleration {limit:g} rad/s^2"
        flips, acceleration = figures["sign_changes_per_s"], figures["max_acceleration"]
        per_joint = f"({flips[0]:.2f}, {flips[1]:.2f})"
        largest = f"({acceleration[0]:.0f}, {acceleration[1]:.0f})"
        print(f"{label:32s} {flips.sum():16.2f} {per_joint:>18s} {largest:>18s} "
              f"{figures['tracking_rms_m'] * 1e3:13.2f} {figures['elbow_min_rad']:14.2e}")


if __name__ == "__main__":
    main()
