"""The walk pattern: every reference of a walk on the control grid, the CoM by preview control tick by
tick, until the CoM has settled over its final reference."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.motion.walking.control_loop import without_cyclic_gc
from wbik.motion.walking.feedforward import SwingMomentum, rest_start
from wbik.motion.walking.footsteps import (
    SIDES,
    Feet,
    Footstep,
    StepCommand,
    centre_frame,
    plan_footsteps,
    yaw_of,
)
from wbik.motion.walking.preview import PreviewController
from wbik.motion.walking.swing import swing_pose
from wbik.motion.walking.timeline import Phase, Timing, phase_at, timeline
from wbik.motion.walking.zmp_reference import ZmpReference, sole_centres
from wbik.robot import Robot

SETTLED_M, SETTLED_M_S = 0.002, 0.01  # m, m/s: the CoM this close to its last reference and this slow
SETTLE_MAX_S = 1.0  # s: the longest the pattern waits for it after the last phase


@dataclass(frozen=True)
class PreviewSettings:
    """The preview controller's horizon (s) and weights (see :mod:`wbik.motion.walking.preview`)."""

    horizon_s: float = 1.0
    q: float = 1.0
    r: float = 1e-6


@dataclass(frozen=True)
class Replan:
    """What re-planning a walk from one of its ticks needs: its ``timing``, the soles' ZMP ``centre``, the
    preview ``controller``, the feedforward's ``zmp_shift`` (reference tracked minus the footsteps')."""

    timing: Timing
    centre: Callable
    controller: PreviewController
    zmp_shift: np.ndarray
    states: np.ndarray
    """The preview's state x (K, 3, 2) and its integral of the ZMP error (K, 2) at each tick."""
    error_sums: np.ndarray


@dataclass
class WalkPattern:
    """References at the ticks ``times`` (K,) (``support[k]``: soles down, ``swing[k]``: the swinging side)
    and each tick's computing time (wall clock, CPU)."""

    robot: Robot
    feet: Feet
    dt: float
    times: np.ndarray
    footsteps: list[Footstep]
    phases: list[Phase]
    com_height: float
    ground_z: float
    zmp_reference: np.ndarray
    lipm_zmp: np.ndarray
    com: np.ndarray
    feet_poses: dict[str, list[pin.SE3]]
    support: list[tuple[str, ...]]
    swing: list[str | None]
    trunk_yaw: np.ndarray
    tick_time_s: np.ndarray
    clearance: float
    info: dict = field(default_factory=dict)
    tick_cpu_s: np.ndarray | None = None

    @property
    def ticks(self) -> int:
        return len(self.times)

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def stance(self, k: int) -> dict[str, pin.SE3]:
        """The sole frames on the ground at tick k and where they stand."""
        return {frame: self.feet_poses[self.feet.side(frame)][k] for frame in self.support[k]}


def feet_at_ticks(phases: list[Phase], feet: Feet, dt: float, count: int, clearance: float, first: int = 0):
    """(each side's sole pose, the soles down, the swinging side, the feet's yaw) at the ticks ``first`` to
    ``count`` - 1."""
    feet_poses: dict[str, list[pin.SE3]] = {side: [] for side in SIDES}
    support, swing, yaw = [], [], np.zeros(count - first)
    for k in range(first, count):
        t = k * dt
        phase = phase_at(phases, t)
        poses = dict(phase.feet)
        if phase.swing is not None:
            poses[phase.swing.side] = swing_pose(phase.feet[phase.swing.side], phase.swing.placement,
                                                 phase.fraction(t), clearance)
        for side in SIDES:
            feet_poses[side].append(poses[side])
        support.append(tuple(feet.frame(side) for side in phase.stance))
        swing.append(phase.swing.side if phase.swing is not None else None)
        yaw[k - first] = yaw_of(centre_frame(poses["left"], poses["right"]).rotation)
    return feet_poses, support, swing, yaw


def walk_pattern(robot: Robot, q0: np.ndarray, steps: StepCommand | list[Footstep], timing: Timing,
                 dt: float = 0.01, clearance: float = 0.02, feet: Feet | None = None,
                 preview: PreviewSettings | None = None, com_height: float | None = None,
                 zmp_forward: float = 0.0, rest: bool = False, momentum: SwingMomentum | None = None
                 ) -> WalkPattern:
    """The pattern of a walk from ``q0``: ``clearance`` swing height, ``com_height`` z_c, ``zmp_forward`` the
    ZMP ahead of each sole's centre (m); the pendulum's reference started from ``rest`` and shifted by the
    swing leg's ``momentum`` (:mod:`wbik.motion.walking.feedforward`). ``info["plan_cpu_s"]``: the CPU
    time of the plan made before the first tick (feet, reference, feedforward)."""
    if not (math.isfinite(dt) and dt > 0):
        raise InvalidConfigurationError(f"dt must be > 0 s, got {dt}")
    if not (math.isfinite(clearance) and clearance >= 0):
        raise InvalidConfigurationError(f"the swing clearance must be >= 0 m, got {clearance}")
    planning = time.thread_time()
    feet = feet or Feet.of(robot)
    preview = preview or PreviewSettings()
    start = {side: robot.frame_placement(q0, feet.frame(side)) for side in SIDES}
    footsteps = plan_footsteps(start, steps, feet) if isinstance(steps, StepCommand) else list(steps)
    phases = timeline(start, footsteps, timing)
    com0 = robot.center_of_mass(q0)
    ground_z = float(np.mean([start[side].translation[2] for side in SIDES]))
    height = com0[2] - ground_z if com_height is None else float(com_height)
    reference = ZmpReference(phases, sole_centres(robot, feet, zmp_forward), com0[:2])
    planned = int(round(reference.end / dt)) + 1
    controller = PreviewController(dt, height, preview.horizon_s, preview.q, preview.r)
    horizon = controller.steps
    longest = planned + int(round(SETTLE_MAX_S / dt))
    targets = reference(dt * np.arange(longest + horizon + 1))
    feet_poses, support, swing, yaw = feet_at_ticks(phases, feet, dt, longest, clearance)
    tracked = rest_start(targets, com0, int(round(phases[0].end / dt)), controller.omega, dt) if rest \
        else targets.copy()
    if momentum is not None:
        swinging = [None if side is None else feet_poses[side][k] for k, side in enumerate(swing)]
        tracked[:longest] += momentum.zmp_shift(swing, swinging, np.unwrap(yaw) - yaw[0], dt)
    planning = time.thread_time() - planning
    state = controller.start(com0[:2])
    com, acceleration = np.zeros((longest, 3)), np.zeros((longest, 2))
    states, error_sums = np.zeros((longest, 3, 2)), np.zeros((longest, 2))
    ticks, cpu, count = np.zeros(longest), np.zeros(longest), longest
    with without_cyclic_gc():  # a control loop: no collector pause inside a tick
        for k in range(longest):
            tick, tick_cpu = time.perf_counter(), time.thread_time()
            com[k, :2], _, acceleration[k] = state.x
            states[k], error_sums[k] = state.x, state.error_sum
            if k >= planned and np.linalg.norm(state.x[0] - targets[k]) <= SETTLED_M \
                    and np.linalg.norm(state.x[1]) <= SETTLED_M_S:
                count = k + 1
            state.step(tracked[k + 1:k + 1 + horizon], tracked[k])
            ticks[k], cpu[k] = time.perf_counter() - tick, time.thread_time() - tick_cpu
            if count == k + 1:
                break
    com = com[:count]
    com[:, 2] = ground_z + height
    info = {"omega": controller.omega, "preview_steps": horizon, "plan_cpu_s": planning,
            "replan": Replan(timing, reference.centre, controller, tracked - targets, states[:count],
                             error_sums[:count])}
    feet_poses = {side: poses[:count] for side, poses in feet_poses.items()}
    return WalkPattern(robot, feet, float(dt), dt * np.arange(count), footsteps, phases, height, ground_z,
                       targets[:count], controller.zmp_of(com[:, :2], acceleration[:count]), com, feet_poses,
                       support[:count], swing[:count], np.unwrap(yaw[:count]), ticks[:count],
                       float(clearance), info, cpu[:count])
