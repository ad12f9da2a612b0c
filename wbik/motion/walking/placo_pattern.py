"""PlaCo's walk pattern generator and IK (``WalkTasks``) on our footsteps, at PlaCo's settings or ours."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from wbik.errors import RobotDescriptionError
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


class WalkIK:
    """PlaCo's kinematics solver of a ``placo.HumanoidRobot`` with its ``WalkTasks``."""

    def __init__(self, humanoid):
        self.humanoid = humanoid
        self.solver = humanoid.make_solver()
        self.tasks = import_placo().WalkTasks()
        self.tasks.initialize_tasks(self.solver, humanoid)

    def follow(self, trajectory, t: float, iterations: int) -> None:
        """``iterations`` solver steps toward time ``t`` of PlaCo's ``trajectory``."""
        self.tasks.update_tasks_from_trajectory(trajectory, t)
        for _ in range(iterations):
            self.humanoid.update_kinematics()
            self.solver.solve(True)
        self.humanoid.update_kinematics()


def soles_on_ground(trajectory, t: float, left: str, right: str, ground: float = 0.0,
                    tolerance: float = GROUND_TOLERANCE) -> tuple[str, ...]:
    """The soles that PlaCo's foot trajectories keep within ``tolerance`` (m) of the ground at ``t``."""
    poses = ((left, trajectory.get_T_world_left(t)), (right, trajectory.get_T_world_right(t)))
    return tuple(sole for sole, pose in poses if abs(pose[2, 3] - ground) <= tolerance)


def follow_plan(robot: Robot, humanoid, trajectory, times: np.ndarray, iterations: int, left: str, right: str,
                ground: float = 0.0) -> tuple[np.ndarray, list[tuple[str, ...]], np.ndarray]:
    """PlaCo's IK on ``trajectory`` at ``times`` (SETTLE_ITERATIONS first, then ``iterations`` each): the
    configurations, the soles ``left`` and ``right`` on the ground and each tick's IK time (s)."""
    ik = WalkIK(humanoid)
    rows, support, ticks = [], [], []
    for index, t in enumerate(times):
        tick = time.perf_counter()
        ik.follow(trajectory, float(t), SETTLE_ITERATIONS if index == 0 else iterations)
        ticks.append(time.perf_counter() - tick)
        rows.append(placo_configuration(robot, humanoid))
        support.append(soles_on_ground(trajectory, float(t), left, right, ground))
    return np.array(rows), support, np.array(ticks)


def placo_walk(robot: Robot, q0: np.ndarray, footsteps: list[Footstep], feet: Feet, trunk: str,
               setting: str = "ours", timing: Timing | None = None, clearance: float = 0.02,
               zmp_margin: float = 0.005, horizon_s: float = 1.0, dt: float = 0.01,
               iterations: int = 3) -> PlacoWalk:
    """Plan the walk through ``footsteps`` with PlaCo's generator and follow it with its IK every ``dt``."""
    placo = import_placo("PlaCo's walk pattern generator")
    if setting not in SETTINGS:
        raise ValueError(f"setting must be one of {SETTINGS}, got {setting!r}")
    timing = timing or Timing()
    humanoid = placo_robot(robot, q0, humanoid_urdf=humanoid_urdf(robot, feet, trunk))
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
    if setting == "ours":
        steps = max(1, int(round(timing.single_support_s / dt)))
        parameters.single_support_duration = timing.single_support_s
        parameters.single_support_timesteps = steps
        parameters.double_support_ratio = timing.double_support_s / timing.single_support_s
        parameters.startend_double_support_ratio = timing.start_s / timing.single_support_s
        parameters.planned_timesteps = max(steps, int(round(horizon_s / dt)))
        parameters.zmp_margin = float(zmp_margin)
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
    plan_time = time.perf_counter() - tick
    times = np.arange(0.0, trajectory.t_end + 0.5 * dt, dt)
    rows, support, ticks = follow_plan(robot, humanoid, trajectory, times, iterations, feet.left, feet.right,
                                       ground)
    com = [np.asarray(trajectory.get_p_world_CoM(float(t)), dtype=float) for t in times]
    used = {"setting": setting, "single_support_s": parameters.single_support_duration,
            "double_support_s": parameters.double_support_duration(),
            "start_end_s": parameters.startend_double_support_duration(), "dt": parameters.dt(),
            "planned_timesteps": parameters.planned_timesteps, "zmp_margin_m": parameters.zmp_margin,
            "walk_foot_height_m": parameters.walk_foot_height,
            "walk_com_height_m": parameters.walk_com_height,
            "ik_iterations_per_tick": iterations}
    return PlacoWalk(times, rows, support, np.array(com), ticks, plan_time, used)
