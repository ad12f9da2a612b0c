"""PlaCo's walk pattern generator on the Bioloid's URDF: its LIPM/ZMP plan measured on a 10 ms grid and,
``multibody_*``, as PlaCo's IK follows it (docs/measurements.md, Bioloid PlaCo walk)."""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import InvalidConfigurationError, RobotDescriptionError
from wbik.qp.support_polygon import SupportPolygon
from wbik.robot import Robot
from wbik.robot_packages.bioloid.model import BioloidFacts

GROUND_TOLERANCE = 1e-6  # m: a sole this close to the floor (by PlaCo's foot trajectory) is on the ground
SAMPLE_S = 0.05  # s between two samples of the animation (PlaCo's own plan is on a 10 ms grid)
ITERATIONS = 10  # solver iterations per sample of the animation after the first (each from the previous)


def humanoid(robot: Robot):
    """PlaCo's ``HumanoidRobot`` of the Bioloid, at the nominal configuration."""
    from wbik.motion.walking.footsteps import Feet
    from wbik.motion.walking.placo_pattern import humanoid_urdf
    from wbik.solvers.placo import placo_robot

    return placo_robot(robot, humanoid_urdf=humanoid_urdf(robot, Feet("l_sole", "r_sole"), "pelvis"))


def plan_walk(robot: Robot, steps: int, step_length: float, margin: float, single_support_s: float):
    """(humanoid, parameters, footsteps, trajectory) of PlaCo's plan of ``steps`` steps straight ahead."""
    from wbik.solvers.placo import import_placo

    placo = import_placo("the Bioloid's PlaCo walk")
    walker = humanoid(robot)
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
    left, right = walker.get_T_world_left(), walker.get_T_world_right()
    goal_left, goal_right = left.copy(), right.copy()
    goal_left[0, 3] += steps * step_length
    goal_right[0, 3] += steps * step_length
    planner = placo.FootstepsPlannerNaive(parameters)
    planner.configure(goal_left, goal_right)
    footsteps = planner.plan(placo.HumanoidRobot_Side.left, left, right)
    supports = placo.FootstepsPlanner.make_supports(footsteps, 0.0, True, True, True)
    trajectory = placo.WalkPatternGenerator(walker, parameters).plan(supports, walker.com_world(), 0.0)
    return walker, parameters, footsteps, trajectory


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
    omega = math.sqrt(9.80665 / parameters.walk_com_height)  # LIPM: zmp = c - c'' / omega^2
    for t in np.arange(0.0, trajectory.t_end, dt):
        feet = {"left": trajectory.get_T_world_left(t), "right": trajectory.get_T_world_right(t)}
        down = [f for f in feet.values() if abs(f[2, 3]) <= GROUND_TOLERANCE]
        if not down:  # never in a walk plan; fall back on PlaCo's support side
            down = [feet["left" if "left" in str(trajectory.support_side(t)).lower() else "right"]]
        polygon = SupportPolygon(np.vstack([(corners @ f[:3, :3].T + f[:3, 3])[:, :2] for f in down]))
        com_margins.append(polygon.margin_of(trajectory.get_p_world_CoM(t)[:2]))
        zmp_margins.append(polygon.margin_of(trajectory.get_p_world_ZMP(t, omega)[:2]))
        single.append(len(down) == 1)
    com_margins, zmp_margins, single = map(np.asarray, (com_margins, zmp_margins, single))
    return {**_multibody(robot, trajectory, margin, dt),
            "planned": True, "footsteps": len(footsteps), "footstep_x_m": xs,
            "max_step_advance_mm": 1e3 * max(advances, default=0.0),
            "per_foot_advance_mm": {k: [1e3 * v for v in values] for k, values in per_foot.items()},
            "duration_s": float(trajectory.t_end),
            "min_com_margin_mm": 1e3 * float(np.min(com_margins)),
            "min_com_margin_single_support_mm": (1e3 * float(np.min(com_margins[single]))
                                                 if single.any() else None),
            "samples_com_outside": int(np.sum(com_margins < 0)),
            "min_zmp_margin_mm": 1e3 * float(np.min(zmp_margins)),
            "walk_com_height_m": parameters.walk_com_height}


def _multibody(robot: Robot, trajectory, margin: float, dt: float, iterations: int = 3) -> dict:
    """PlaCo's IK on the plan every ``dt`` and the figures of the whole robot's motion (mm, rad/s)."""
    from wbik.motion.walking.figures import walk_figures
    from wbik.motion.walking.footsteps import Feet
    from wbik.motion.walking.placo_pattern import follow_plan

    times = np.arange(0.0, trajectory.t_end + 0.5 * dt, dt)
    rows, support, _ = follow_plan(robot, humanoid(robot), trajectory, times, iterations, "l_sole", "r_sole")
    com = np.array([np.asarray(trajectory.get_p_world_CoM(float(t)), dtype=float) for t in times])
    figures, _ = walk_figures(robot, Feet("l_sole", "r_sole"), times, rows, support, 0.0, margin, com)
    return {"multibody_zmp_margin_min_mm": 1e3 * figures["zmp_margin_min_m"],
            "multibody_zmp_margin_p5_mm": 1e3 * figures["zmp_margin_p5_m"],
            "multibody_com_error_max_mm": 1e3 * figures["com_error_max_m"],
            "multibody_foot_slip_max_mm": 1e3 * figures["foot_slip_max_m"],
            "multibody_joint_velocity_peak_rad_s": figures["joint_velocity_peak_rad_s"],
            "multibody_joint_acceleration_peak_rad_s2": figures["joint_acceleration_peak_rad_s2"]}


def placo_walk_animation(robot, steps: int = 4, step_length: float = 0.03, margin: float = 0.005,
                         single_support_s: float = 0.5, footstep_x: list[float] | None = None):
    """PlaCo's walk as its IK follows it every ``SAMPLE_S``; the re-planned footsteps must equal the
    report's ``footstep_x`` (m)."""
    from wbik.motion.walking.placo_pattern import follow_plan
    from wbik.viz.animation import Animation, Overlays

    walker, _, footsteps, trajectory = plan_walk(robot, steps, step_length, margin, single_support_s)
    planned_x = [float(step.frame[0, 3]) for step in footsteps]
    if footstep_x is not None and (len(planned_x) != len(footstep_x)
                                   or not np.allclose(planned_x, footstep_x, atol=1e-9)):
        raise InvalidConfigurationError(
            f"PlaCo's re-planned footsteps {planned_x} differ from the report's {list(footstep_x)}: "
            "placo_walk_animation no longer mirrors placo_walk")
    times = np.append(np.arange(0.0, trajectory.t_end, SAMPLE_S), trajectory.t_end)
    rows, support, _ = follow_plan(robot, walker, trajectory, times, ITERATIONS, "l_sole", "r_sole")
    return Animation(robot, times, rows, Overlays("pelvis", tuple(support), tuple(support)),
                     "PlaCo walk pattern generator")
