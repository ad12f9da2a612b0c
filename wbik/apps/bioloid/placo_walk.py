"""PlaCo's walk pattern generator on the same Bioloid URDF, for comparison with the whole-body step.

PlaCo's ``HumanoidRobot`` looks for frames called ``left_foot``, ``right_foot`` and ``trunk``; the
mesh-free copy of our URDF gets three fixed frames with those names at ``l_sole``, ``r_sole`` and
``pelvis`` (nothing else changes). The footsteps come from PlaCo's naive planner (steps of at most
``step_length`` toward a target ``steps * step_length`` ahead), the CoM from its LIPM/ZMP walk
pattern generator at the robot's standing CoM height with the trunk pitched 20 deg and 40 mm foot
rise, the 100 x 60 mm soles and a ZMP margin of ``margin``.

Reported: the planned step lengths (between consecutive footsteps of opposite feet, and per foot), the
duration, and on a 10 ms grid the margin of the CoM ground projection and of the plan's ZMP (the
pendulum's, c - c'' / omega^2) in the support polygon of the feet on the ground at that time: a foot is
down when PlaCo's own foot trajectory has its sole within ``GROUND_TOLERANCE`` of the floor. (PlaCo's
``support_is_both(t)`` already answers "single support" at the switch instant, while the leaving foot is
still flat on the floor and the ZMP is still between the feet: judged against the single sole, that
instant shows the ZMP outside; docs/measurements.md, Bioloid PlaCo walk.) PlaCo hands no polygon of
ours to PlaCo: the footsteps and the ZMP bounds are PlaCo's own, from ``foot_length``, ``foot_width``
and ``zmp_margin``. PlaCo's generator is dynamic: it keeps the ZMP, not the CoM, inside the support (at
its planning time steps), so the CoM may leave the polygon in single support, unlike the quasi-static
whole-body step.

The robot's own ZMP is reported too (``multibody_*``): PlaCo's IK (``WalkTasks``, 3 iterations per
10 ms tick, as :mod:`wbik.apps.bioloid.placo_view` does at 50 ms) follows the plan, and the motion is
judged by :func:`wbik.motion.walking.figures.walk_figures` (the multibody ZMP of its centroidal
dynamics in the support, CoM tracking, slip, joint velocity and acceleration peaks).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from wbik.errors import RobotDescriptionError
from wbik.qp.support_polygon import SupportPolygon
from wbik.robot import Robot
from wbik.robot import write_cached_urdf
from wbik.robot_packages.bioloid.model import BioloidFacts

FRAMES = (("left_foot", "l_sole"), ("right_foot", "r_sole"), ("trunk", "pelvis"))
GROUND_TOLERANCE = 1e-6
"""m: a sole this close to the floor (by PlaCo's foot trajectory) is on the ground."""


def placo_humanoid_urdf(robot: Robot) -> Path:
    """Mesh-free URDF with PlaCo's humanoid frame names added as fixed frames."""
    from wbik.solvers.placo import kinematic_urdf_path

    text = kinematic_urdf_path(robot).read_text()
    extra = "".join(
        f'  <link name="{name}"/>\n  <joint name="{name}_frame" type="fixed"><parent link="{parent}"/>'
        f'<child link="{name}"/><origin xyz="0 0 0" rpy="0 0 0"/></joint>\n' for name, parent in FRAMES)
    return write_cached_urdf(f"{robot.name}-placo-humanoid", text.replace("</robot>", extra + "</robot>"))


def _foot_polygon(transform: np.ndarray, corners: np.ndarray) -> np.ndarray:
    return (corners @ transform[:3, :3].T + transform[:3, 3])[:, :2]


def plan_walk(robot: Robot, steps: int, step_length: float, margin: float, single_support_s: float):
    """PlaCo's humanoid standing at the nominal configuration, PlaCo's walk parameters for the
    Bioloid, its naive footstep plan of ``steps`` steps straight ahead and the walk pattern
    generator's trajectory: (humanoid, parameters, footsteps, trajectory). Shared by the walk's
    report and its animation (wbik.apps.bioloid.placo_view), so both see the same plan; a
    RobotDescriptionError when PlaCo cannot load the humanoid."""
    from wbik.solvers.placo import import_placo
    from wbik.solvers.placo import placo_robot

    placo = import_placo()
    humanoid = placo_robot(robot, humanoid_urdf=placo_humanoid_urdf(robot))
    facts = robot.require_facts(BioloidFacts, "PlaCo's Bioloid walk")
    parameters = placo.HumanoidParameters()
    parameters.single_support_duration = single_support_s
    parameters.single_support_timesteps = 10
    parameters.double_support_ratio = 0.2
    parameters.startend_double_support_ratio = 1.5
    parameters.planned_timesteps = 48
    parameters.walk_com_height = float(robot.center_of_mass(robot.nominal)[2])
    parameters.walk_foot_height = 0.04
    parameters.walk_trunk_pitch = math.radians(20.0)
    parameters.walk_foot_rise_ratio = 0.2
    parameters.foot_length, parameters.foot_width = facts.sole_size
    parameters.feet_spacing = 2 * facts.hip_lateral
    parameters.zmp_margin = margin
    parameters.walk_max_dx_forward = step_length
    left, right = humanoid.get_T_world_left(), humanoid.get_T_world_right()
    goal_left, goal_right = left.copy(), right.copy()
    goal_left[0, 3] += steps * step_length
    goal_right[0, 3] += steps * step_length
    planner = placo.FootstepsPlannerNaive(parameters)
    planner.configure(goal_left, goal_right)
    footsteps = planner.plan(placo.HumanoidRobot_Side.left, left, right)
    supports = placo.FootstepsPlanner.make_supports(footsteps, 0.0, True, True, True)
    trajectory = placo.WalkPatternGenerator(humanoid, parameters).plan(supports, humanoid.com_world(), 0.0)
    return humanoid, parameters, footsteps, trajectory


def placo_walk(robot: Robot, steps: int = 4, step_length: float = 0.03, margin: float = 0.005,
               single_support_s: float = 0.5, dt: float = 0.01) -> dict:
    """Plan a straight walk with PlaCo and measure it (see the module docstring)."""
    try:
        _, parameters, footsteps, trajectory = plan_walk(robot, steps, step_length, margin, single_support_s)
    except RobotDescriptionError as exc:
        return {"planned": False, "reason": f"PlaCo cannot load the humanoid: {exc}"}

    xs = [float(step.frame[0, 3]) for step in footsteps]
    sides = [str(step.side) for step in footsteps]
    advances = [b - a for a, b in zip(xs[:-1], xs[1:], strict=True) if b - a > 1e-9]
    per_foot = {}
    for side in set(sides):
        positions = [x for x, s in zip(xs, sides, strict=True) if s == side]
        per_foot[side] = [b - a for a, b in zip(positions[:-1], positions[1:], strict=True) if b - a > 1e-9]
    corners = np.asarray(robot.soles["l_sole"], dtype=float)
    com_margins, zmp_margins, single = [], [], []
    times = np.arange(0.0, trajectory.t_end, dt)
    omega = math.sqrt(9.80665 / parameters.walk_com_height)  # LIPM: zmp = c - c'' / omega^2
    for t in times:
        feet = {"left": trajectory.get_T_world_left(t), "right": trajectory.get_T_world_right(t)}
        down = [f for f in feet.values() if abs(f[2, 3]) <= GROUND_TOLERANCE]
        if not down:  # never in a walk plan; fall back on PlaCo's support side
            side = "left" if "left" in str(trajectory.support_side(t)).lower() else "right"
            down = [feet[side]]
        polygon = SupportPolygon(np.vstack([_foot_polygon(f, corners) for f in down]))
        com_margins.append(polygon.margin_of(trajectory.get_p_world_CoM(t)[:2]))
        zmp_margins.append(polygon.margin_of(trajectory.get_p_world_ZMP(t, omega)[:2]))
        single.append(len(down) == 1)
    com_margins, zmp_margins, single = map(np.asarray, (com_margins, zmp_margins, single))
    body = _multibody(robot, trajectory, parameters, margin, dt)
    return {**body,
        "planned": True, "footsteps": len(footsteps), "footstep_x_m": xs,
        "max_step_advance_mm": 1e3 * max(advances, default=0.0),
        "per_foot_advance_mm": {k: [1e3 * v for v in values] for k, values in per_foot.items()},
        "duration_s": float(trajectory.t_end),
        "min_com_margin_mm": 1e3 * float(np.min(com_margins)),
        "min_com_margin_single_support_mm": (1e3 * float(np.min(com_margins[single]))
                                             if single.any() else None),
        "samples_com_outside": int(np.sum(com_margins < 0)),
        "min_zmp_margin_mm": 1e3 * float(np.min(zmp_margins)),
        "walk_com_height_m": parameters.walk_com_height,
    }


def _multibody(robot: Robot, trajectory, parameters, margin: float, dt: float,
               iterations: int = 3) -> dict:
    """PlaCo's IK on the plan every ``dt`` and the figures of the whole robot's motion (mm, rad/s)."""
    from wbik.motion.walking.figures import walk_figures
    from wbik.motion.walking.footsteps import Feet
    from wbik.motion.walking.placo_pattern import WalkIK
    from wbik.motion.walking.placo_pattern import soles_on_ground
    from wbik.solvers.placo import placo_configuration
    from wbik.solvers.placo import placo_robot

    humanoid = placo_robot(robot, humanoid_urdf=placo_humanoid_urdf(robot))
    ik = WalkIK(humanoid)
    times = np.arange(0.0, trajectory.t_end + 0.5 * dt, dt)
    rows, support, com = [], [], []
    for index, t in enumerate(times):
        ik.follow(trajectory, float(t), 50 if index == 0 else iterations)
        rows.append(placo_configuration(robot, humanoid))
        support.append(soles_on_ground(trajectory, float(t), "l_sole", "r_sole", tolerance=GROUND_TOLERANCE))
        com.append(np.asarray(trajectory.get_p_world_CoM(float(t)), dtype=float))
    figures, _ = walk_figures(robot, Feet("l_sole", "r_sole"), times, np.array(rows), support, 0.0, margin,
                              np.array(com))
    return {"multibody_zmp_margin_min_mm": 1e3 * figures["zmp_margin_min_m"],
            "multibody_zmp_margin_p5_mm": 1e3 * figures["zmp_margin_p5_m"],
            "multibody_com_error_max_mm": 1e3 * figures["com_error_max_m"],
            "multibody_foot_slip_max_mm": 1e3 * figures["foot_slip_max_m"],
            "multibody_joint_velocity_peak_rad_s": figures["joint_velocity_peak_rad_s"],
            "multibody_joint_acceleration_peak_rad_s2": figures["joint_acceleration_peak_rad_s2"]}
