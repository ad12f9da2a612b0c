"""PlaCo's walk pattern generator and IK (``WalkTasks``): its plan through our footsteps (at PlaCo's settings
or ours) or through its own straight-ahead footsteps, and its IK following the plan."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wbik.errors import InvalidSettingError, RobotDescriptionError
from wbik.motion.walking.footsteps import OTHER, SIDES, Feet, Footstep
from wbik.motion.walking.timeline import Timing
from wbik.robot import Robot, write_cached_urdf
from wbik.solvers.placo import import_placo, kinematic_urdf_path, placo_configuration, placo_robot

GROUND_TOLERANCE = 1e-6  # m: a sole this close to the ground is on it
SETTINGS = ("placo", "ours")
SETTLE_ITERATIONS = 50  # PlaCo IK iterations at t = 0, into PlaCo's walking posture


@dataclass
class PlacoWalk:
    """PlaCo's walk at ``times``, the time of each tick's IK and of the plan, and the parameters used."""

    times: np.ndarray
    q: np.ndarray
    support: list[tuple[str, ...]]
    com: np.ndarray
    tick_time_s: np.ndarray
    plan_time_s: float
    parameters: dict = field(default_factory=dict)


def humanoid_urdf(robot: Robot, feet: Feet, trunk: str) -> str:
    """The robot's kinematic URDF with PlaCo's humanoid frames (left_foot, right_foot, trunk); its path."""
    text = kinematic_urdf_path(robot).read_text()
    extra = []
    for name, link in (("left_foot", feet.left), ("right_foot", feet.right), ("trunk", trunk)):
        if f'<link name="{link}"' not in text:
            raise RobotDescriptionError(f"PlaCo's humanoid needs {link!r} to be a link of "
                                        f"{robot.name!r}'s URDF")
        extra.append(f'  <link name="{name}"/>\n  <joint name="{name}_frame" type="fixed">'
                     f'<parent link="{link}"/><child link="{name}"/>'
                     f'<origin xyz="0 0 0" rpy="0 0 0"/></joint>\n')
    return str(write_cached_urdf(f"{robot.name}-placo-walk-humanoid",
                                 text.replace("</robot>", "".join(extra) + "</robot>")))


def soles_on_ground(trajectory, t: float, feet: Feet, ground: float = 0.0,
                    tolerance: float = GROUND_TOLERANCE) -> dict[str, np.ndarray]:
    """PlaCo's planned pose (4x4) of each sole within ``tolerance`` (m) of the ground at ``t``, by frame."""
    poses = {feet.left: trajectory.get_T_world_left(t), feet.right: trajectory.get_T_world_right(t)}
    return {sole: pose for sole, pose in poses.items() if abs(pose[2, 3] - ground) <= tolerance}


@dataclass
class PlacoPlan:
    """PlaCo's walk plan from ``q0``: its ``HumanoidParameters``, ``placo.Footsteps`` and trajectory, the
    humanoid URDF, the ground height (m) and the planning time (s)."""

    robot: Robot
    q0: np.ndarray
    feet: Feet
    urdf: str
    parameters: Any
    footsteps: Any
    trajectory: Any
    ground: float
    plan_time_s: float

    def follow(self, times: np.ndarray, iterations: int) -> PlacoWalk:
        """PlaCo's IK from ``q0`` along the plan at ``times`` (SETTLE_ITERATIONS first, then ``iterations``
        each), with the soles on the ground and the planned CoM."""
        humanoid = placo_robot(self.robot, self.q0, humanoid_urdf=self.urdf)
        solver = humanoid.make_solver()
        tasks = import_placo().WalkTasks()
        tasks.initialize_tasks(solver, humanoid)
        rows, support, com, ticks = [], [], [], []
        for index, t in enumerate(map(float, times)):
            tick = time.perf_counter()
            tasks.update_tasks_from_trajectory(self.trajectory, t)
            for _ in range(SETTLE_ITERATIONS if index == 0 else iterations):
                humanoid.update_kinematics()
                solver.solve(True)
            humanoid.update_kinematics()
            ticks.append(time.perf_counter() - tick)
            rows.append(placo_configuration(self.robot, humanoid))
            support.append(tuple(soles_on_ground(self.trajectory, t, self.feet, self.ground)))
            com.append(np.asarray(self.trajectory.get_p_world_CoM(t), dtype=float))
        return PlacoWalk(times, np.array(rows), support, np.array(com), np.array(ticks), self.plan_time_s)


def placo_plan(robot: Robot, q0: np.ndarray, footsteps: list[Footstep] | float, feet: Feet, trunk: str,
               clearance: float, **settings) -> PlacoPlan:
    """PlaCo's plan from ``q0`` through ``footsteps``, or ``footsteps`` (m) straight ahead by PlaCo's naive
    footstep planner. Its ``HumanoidParameters``: the sole size, feet spacing, CoM height above the ground
    and trunk pitch at ``q0``, ``clearance`` (m) as the foot height, then ``settings`` (attributes)."""
    placo = import_placo("PlaCo's walk pattern generator")
    urdf = humanoid_urdf(robot, feet, trunk)
    humanoid = placo_robot(robot, q0, humanoid_urdf=urdf)
    start = {side: robot.frame_placement(q0, feet.frame(side)) for side in SIDES}
    parameters = placo.HumanoidParameters()
    sole = np.asarray(robot.soles[feet.left], dtype=float)
    parameters.foot_length, parameters.foot_width = float(np.ptp(sole[:, 0])), float(np.ptp(sole[:, 1]))
    parameters.feet_spacing = float(np.linalg.norm(start["left"].translation - start["right"].translation))
    com0 = robot.center_of_mass(q0)
    ground = float(np.mean([start[s].translation[2] for s in SIDES]))
    parameters.walk_com_height = float(com0[2] - ground)
    parameters.walk_foot_height = float(clearance)
    trunk_rotation = robot.frame_placement(q0, trunk).rotation
    parameters.walk_trunk_pitch = float(math.atan2(-trunk_rotation[2, 0], trunk_rotation[2, 2]))
    for name, value in settings.items():
        setattr(parameters, name, value)
    if isinstance(footsteps, (int, float)):
        goal = {side: start[side].homogeneous for side in SIDES}
        for pose in goal.values():
            pose[0, 3] += footsteps
        planner = placo.FootstepsPlannerNaive(parameters)
        planner.configure(goal["left"], goal["right"])
        placo_steps = planner.plan(placo.HumanoidRobot_Side.left, start["left"].homogeneous,
                                   start["right"].homogeneous)
    else:
        placo_steps = placo.Footsteps()
        first = footsteps[0].side if footsteps else "left"
        for side, placement in ((first, start[first]), (OTHER[first], start[OTHER[first]]),
                                *((step.side, step.placement) for step in footsteps)):
            item = placo.Footstep(parameters.foot_width, parameters.foot_length)
            item.side = placo.HumanoidRobot_Side.left if side == "left" else placo.HumanoidRobot_Side.right
            item.frame = placement.homogeneous
            placo_steps.append(item)
    tick = time.perf_counter()
    supports = placo.FootstepsPlanner.make_supports(placo_steps, 0.0, True, True, True)
    trajectory = placo.WalkPatternGenerator(humanoid, parameters).plan(supports, com0, 0.0)
    return PlacoPlan(robot, q0, feet, urdf, parameters, placo_steps, trajectory, ground,
                     time.perf_counter() - tick)


def placo_walk(robot: Robot, q0: np.ndarray, footsteps: list[Footstep], feet: Feet, trunk: str,
               setting: str = "ours", timing: Timing | None = None, clearance: float = 0.02,
               zmp_margin: float = 0.005, horizon_s: float = 1.0, dt: float = 0.01,
               iterations: int = 3) -> PlacoWalk:
    """Plan the walk through ``footsteps`` with PlaCo's generator (``setting`` "placo": its own timing and ZMP
    margin; "ours": ``timing``, ``horizon_s`` and ``zmp_margin``) and follow it with its IK every ``dt``."""
    if setting not in SETTINGS:
        raise InvalidSettingError(f"setting must be one of {SETTINGS}, got {setting!r}")
    timing = timing or Timing()
    steps = max(1, int(round(timing.single_support_s / dt)))
    ours = {"single_support_duration": timing.single_support_s, "single_support_timesteps": steps,
            "double_support_ratio": timing.double_support_s / timing.single_support_s,
            "startend_double_support_ratio": timing.start_s / timing.single_support_s,
            "planned_timesteps": max(steps, int(round(horizon_s / dt))), "zmp_margin": float(zmp_margin)}
    plan = placo_plan(robot, q0, footsteps, feet, trunk, clearance, **(ours if setting == "ours" else {}))
    walk = plan.follow(np.arange(0.0, plan.trajectory.t_end + 0.5 * dt, dt), iterations)
    used = plan.parameters
    walk.parameters = {"setting": setting, "single_support_s": used.single_support_duration,
                       "double_support_s": used.double_support_duration(),
                       "start_end_s": used.startend_double_support_duration(), "dt": used.dt(),
                       "planned_timesteps": used.planned_timesteps, "zmp_margin_m": used.zmp_margin,
                       "walk_foot_height_m": used.walk_foot_height, "walk_com_height_m": used.walk_com_height,
                       "ik_iterations_per_tick": iterations}
    return walk
