"""PlaCo's walk pattern generator on the Bioloid's URDF: its LIPM/ZMP plan measured on a 10 ms grid and,
``multibody_*``, as PlaCo's IK follows it (docs/measurements.md, Bioloid PlaCo walk)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.motion.walking.figures import walk_figures
from wbik.motion.walking.footsteps import Feet, sole_polygon
from wbik.motion.walking.placo_pattern import placo_plan, soles_on_ground
from wbik.robot import Robot
from wbik.viz.animation import Animation, Overlays

PARAMETERS = {"single_support_timesteps": 10, "double_support_ratio": 0.2, "planned_timesteps": 48,
              "startend_double_support_ratio": 1.5, "walk_trunk_pitch": math.radians(20.0),
              "walk_foot_rise_ratio": 0.2}
"""PlaCo's ``HumanoidParameters`` for the Bioloid, besides those of the robot (sole size, feet spacing, CoM
height) and of the walk asked for."""
SAMPLE_S = 0.05  # s between two samples of the animation (PlaCo's own plan is on a 10 ms grid)
ITERATIONS = 10  # solver iterations per sample of the animation after the first (each from the previous)


def _advances(xs: list[float]) -> list[float]:
    """The forward moves (m) between successive footsteps at ``xs`` (m), those of more than 1 nm."""
    return [b - a for a, b in itertools.pairwise(xs) if b - a > 1e-9]


def placo_walk(robot: Robot, steps: int = 4, step_length: float = 0.03, margin: float = 0.005,
               single_support_s: float = 0.5, dt: float = 0.01) -> tuple[dict, Animation | None]:
    """Plan a straight walk with PlaCo and measure it (see the module docstring): the figures, and the
    animation of PlaCo's IK following the plan every ``SAMPLE_S`` (None if PlaCo cannot load the robot)."""
    try:
        plan = placo_plan(robot, robot.nominal, steps * step_length, Feet("l_sole", "r_sole"), "pelvis", 0.04,
                          single_support_duration=single_support_s, zmp_margin=margin,
                          walk_max_dx_forward=step_length, **PARAMETERS)
    except RobotDescriptionError as exc:
        return {"planned": False, "reason": f"PlaCo cannot load the humanoid: {exc}"}, None
    trajectory = plan.trajectory
    xs = [float(step.frame[0, 3]) for step in plan.footsteps]
    sides = [str(step.side) for step in plan.footsteps]
    per_foot = {side: _advances([x for x, s in zip(xs, sides, strict=True) if s == side])
                for side in set(sides)}
    com_margins, zmp_margins, single = [], [], []
    omega = math.sqrt(9.80665 / plan.parameters.walk_com_height)  # LIPM: zmp = c - c'' / omega^2
    for t in np.arange(0.0, trajectory.t_end, dt):
        down = soles_on_ground(trajectory, t, plan.feet)
        if not down:  # never in a walk plan; fall back on PlaCo's support side
            sole = plan.feet.frame("left" if "left" in str(trajectory.support_side(t)).lower() else "right")
            down = {sole: soles_on_ground(trajectory, t, plan.feet, tolerance=math.inf)[sole]}
        polygon = sole_polygon(robot, {sole: pin.SE3(pose) for sole, pose in down.items()})
        com_margins.append(polygon.margin_of(trajectory.get_p_world_CoM(t)[:2]))
        zmp_margins.append(polygon.margin_of(trajectory.get_p_world_ZMP(t, omega)[:2]))
        single.append(len(down) == 1)
    com_margins, zmp_margins, single = map(np.asarray, (com_margins, zmp_margins, single))
    walk = plan.follow(np.arange(0.0, trajectory.t_end + 0.5 * dt, dt), 3)
    figures, _ = walk_figures(robot, plan.feet, walk.times, walk.q, walk.support, plan.ground, margin,
                              walk.com)
    report = {**{f"multibody_{name[:-2]}_mm": 1e3 * figures[name]
                 for name in ("zmp_margin_min_m", "zmp_margin_p5_m", "com_error_max_m", "foot_slip_max_m")},
              **{f"multibody_{name}": figures[name]
                 for name in ("joint_velocity_peak_rad_s", "joint_acceleration_peak_rad_s2")},
              "planned": True, "footsteps": len(xs), "footstep_x_m": xs,
              "max_step_advance_mm": 1e3 * max(_advances(xs), default=0.0),
              "per_foot_advance_mm": {k: [1e3 * v for v in values] for k, values in per_foot.items()},
              "duration_s": float(trajectory.t_end),
              "min_com_margin_mm": 1e3 * float(np.min(com_margins)),
              "min_com_margin_single_support_mm": (1e3 * float(np.min(com_margins[single]))
                                                   if single.any() else None),
              "samples_com_outside": int(np.sum(com_margins < 0)),
              "min_zmp_margin_mm": 1e3 * float(np.min(zmp_margins)),
              "walk_com_height_m": plan.parameters.walk_com_height}
    times = np.append(np.arange(0.0, trajectory.t_end, SAMPLE_S), trajectory.t_end)
    shown = plan.follow(times, ITERATIONS)
    support = tuple(shown.support)
    return report, Animation(robot, times, shown.q, Overlays("pelvis", support, support),
                             "PlaCo walk pattern generator")
