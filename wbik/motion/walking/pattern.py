"""The walk pattern: every reference of a walk on the control grid, the CoM by preview control tick by
tick, until the CoM has settled over its final reference."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.motion.walking.control_loop import without_cyclic_gc
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


def walk_pattern(robot: Robot, q0: np.ndarray, steps: StepCommand | list[Footstep], timing: Timing,
                 dt: float = 0.01, clearance: float = 0.02, feet: Feet | None = None,
                 preview: PreviewSettings | None = None, com_height: float | None = None,
                 zmp_offset: np.ndarray | None = None, zmp_forward: float = 0.0) -> WalkPattern:
    """The pattern of a walk from ``q0``: ``clearance`` swing height, ``com_height`` z_c, ``zmp_forward`` the
    ZMP ahead of each sole's centre (m); ``zmp_offset`` (K, 2) added to the pendulum's reference."""
    if not (math.isfinite(dt) and dt > 0):
        raise InvalidConfigurationError(f"dt must be > 0 s, got {dt}")
    if not (math.isfinite(clearance) and clearance >= 0):
        raise InvalidConfigurationError(f"the swing clearance must be >= 0 m, got {clearance}")
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
    tracked = targets.copy()
    if zmp_offset is not None:
        offset = np.asarray(zmp_offset, dtype=float)
        if offset.ndim != 2 or offset.shape[1] != 2 or len(offset) < planned:
            raise InvalidConfigurationError(f"zmp_offset must have ({planned}, 2) values at least, got "
                                            f"{offset.shape}")
        used = min(len(offset), longest)
        tracked[:used] += offset[:used]
        tracked[used:] += offset[used - 1]
    state = controller.start(com0[:2])
    com, acceleration = np.zeros((longest, 3)), np.zeros((longest, 2))
    feet_poses: dict[str, list[pin.SE3]] = {side: [] for side in SIDES}
    support, swing, count = [], [], longest
    yaw, ticks, cpu = (np.zeros(longest) for _ in range(3))
    with without_cyclic_gc():  # a control loop: no collector pause inside a tick
        for k in range(longest):
            tick, tick_cpu = time.perf_counter(), time.thread_time()
            t = k * dt
            com[k, :2], _, acceleration[k] = state.x
            if k >= planned and np.linalg.norm(state.x[0] - targets[k]) <= SETTLED_M \
                    and np.linalg.norm(state.x[1]) <= SETTLED_M_S:
                count = k + 1
            phase = phase_at(phases, t)
            poses = dict(phase.feet)
            if phase.swing is not None:
                poses[phase.swing.side] = swing_pose(phase.feet[phase.swing.side], phase.swing.placement,
                                                     phase.fraction(t), clearance)
            for side in SIDES:
                feet_poses[side].append(poses[side])
            support.append(tuple(feet.frame(side) for side in phase.stance))
            swing.append(phase.swing.side if phase.swing is not None else None)
            yaw[k] = yaw_of(centre_frame(poses["left"], poses["right"]).rotation)
            state.step(tracked[k + 1:k + 1 + horizon], tracked[k])
            ticks[k], cpu[k] = time.perf_counter() - tick, time.thread_time() - tick_cpu
            if count == k + 1:
                break
    com = com[:count]
    com[:, 2] = ground_z + height
    return WalkPattern(robot, feet, float(dt), dt * np.arange(count), footsteps, phases, height, ground_z,
                       targets[:count], controller.zmp_of(com[:, :2], acceleration[:count]), com, feet_poses,
                       support, swing, np.unwrap(yaw[:count]), ticks[:count], float(clearance),
                       {"omega": controller.omega, "preview_steps": horizon}, cpu[:count])
