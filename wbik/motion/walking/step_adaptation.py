"""Step adaptation: at a lift-off, the footstep being taken and every later one moved by the measured error of
the divergent component of motion (DCM), and the CoM re-planned by preview control from the measured state."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.motion.walking.footsteps import OTHER, Footstep
from wbik.motion.walking.pattern import WalkPattern, feet_at_ticks
from wbik.motion.walking.preview import PreviewState
from wbik.motion.walking.stabiliser import Adapt, Stabiliser
from wbik.motion.walking.swing import quintic
from wbik.motion.walking.timeline import phase_at, timeline
from wbik.motion.walking.zmp_reference import ZmpReference


@dataclass(frozen=True)
class StepAdaptation:
    """In single support, at least ``min_remaining_s`` (s) before touch-down, a DCM error e (m) predicted
    at touch-down by the pendulum, e exp(omega T), over ``threshold_m`` moves the steps by ``gain`` times it,
    at most ``offset_max_m``, never toward the stance foot."""

    threshold_m: float = 0.05
    gain: float = 1.0
    offset_max_m: float = 0.1
    min_remaining_s: float = 0.1

    def __post_init__(self) -> None:
        for name in ("threshold_m", "gain", "offset_max_m", "min_remaining_s"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise InvalidSettingError(f"step adaptation: {name} must be >= 0, got {getattr(self, name)}")

    def remaining(self, pattern: WalkPattern, k: int) -> float | None:
        """The time (s) from tick k to touch-down when the steps may move then, else None."""
        if not 0 <= k < pattern.ticks or pattern.swing[k] is None:
            return None
        left = phase_at(pattern.phases, k * pattern.dt).end - k * pattern.dt
        return left if left >= self.min_remaining_s else None

    def offset(self, pattern: WalkPattern, k: int, error: np.ndarray, remaining: float) -> np.ndarray | None:
        """The steps' move (x, y; m) at tick ``k`` of a single support for the DCM error ``error`` (x, y)
        measured ``remaining`` s before touch-down; None: under the threshold."""
        move = np.asarray(error, dtype=float)[:2] * math.exp(pattern.info["omega"] * remaining)
        if np.linalg.norm(move) <= self.threshold_m:
            return None
        move = self.gain * move
        stance = pattern.feet_poses[OTHER[pattern.swing[k]]][k]
        outward = pattern.feet_poses[pattern.swing[k]][k].translation[:2] - stance.translation[:2]
        lateral = np.array([-stance.rotation[1, 0], stance.rotation[0, 0]])  # the stance sole's y axis
        lateral *= np.sign(lateral @ outward)
        toward = lateral @ move
        if toward < 0:  # the swing foot would cross toward the stance foot
            move -= toward * lateral
        norm = np.linalg.norm(move)
        return move * min(1.0, self.offset_max_m / norm) if norm > 0 else None


def adapted(pattern: WalkPattern, k: int, offset: np.ndarray, com: np.ndarray,
            velocity: np.ndarray) -> WalkPattern:
    """The pattern from tick ``k`` (in a single support) with the footstep taken and the later ones moved by
    ``offset`` (x, y; m), the swing foot blended onto it by a quintic from tick k to touch-down, the CoM
    re-planned from ``com`` and ``velocity`` (x, y) measured; the ticks before k kept."""
    plan, dt = pattern.info["replan"], pattern.dt
    phase = phase_at(pattern.phases, k * dt)
    taken = next(i for i, step in enumerate(pattern.footsteps) if step is phase.swing)
    move = np.append(np.asarray(offset, dtype=float)[:2], 0.0)
    footsteps = [*pattern.footsteps[:taken],
                 *(Footstep(step.side, step.frame, pin.SE3(step.placement.rotation,
                                                           step.placement.translation + move))
                   for step in pattern.footsteps[taken:])]
    start = {side: poses[0] for side, poses in pattern.feet_poses.items()}
    phases = timeline(start, footsteps, plan.timing)
    count, controller = pattern.ticks, plan.controller
    feet_poses = feet_at_ticks(phases, pattern.feet, dt, count, pattern.clearance)[0]  # same phase times
    feet_poses = {side: [*pattern.feet_poses[side][:k], *poses[k:]] for side, poses in feet_poses.items()}
    landing = min(int(round(phase.end / dt)), count)
    swinging = pattern.feet_poses[phase.swing.side]
    blend = quintic((np.arange(k, landing) - k) / max(landing - k, 1))
    feet_poses[phase.swing.side][k:landing] = [
        pin.SE3(swinging[tick].rotation, swinging[tick].translation + s * move)
        for tick, s in zip(range(k, landing), blend, strict=True)]
    reference = ZmpReference(phases, plan.centre, pattern.com[0, :2])
    targets = reference(dt * np.arange(count + controller.steps + 1))
    tracked = targets + plan.zmp_shift[:len(targets)]
    state = PreviewState(controller, np.array([com[:2], velocity[:2], np.zeros(2)], dtype=float))
    planned, zmp = pattern.com.copy(), pattern.lipm_zmp.copy()
    for tick in range(k, count):
        planned[tick, :2] = state.x[0]
        zmp[tick] = controller.zmp_of(state.x[0], state.x[2])
        state.step(tracked[tick + 1:tick + 1 + controller.steps], tracked[tick])
    return replace(pattern, footsteps=footsteps, phases=phases, zmp_reference=targets[:count], lipm_zmp=zmp,
                   com=planned, feet_poses=feet_poses)


def stepping(adaptation: StepAdaptation) -> Adapt:
    """The closed loop's re-planning: in single support, the steps moved by the error of the measured DCM
    c + c'/omega against the planned one (world: after a re-plan from the measured state, none)."""
    def adapt(stabiliser: Stabiliser, q: np.ndarray, v: np.ndarray, k: int) -> WalkPattern | None:
        pattern = stabiliser.pattern
        remaining = adaptation.remaining(pattern, k)
        if remaining is None:
            return None
        data, omega = stabiliser.data, pattern.info["omega"]
        com = pin.centerOfMass(stabiliser.robot.model, data, q, v)[:2]
        planned_velocity = (pattern.com[k] - pattern.com[max(k - 1, 0)])[:2] / pattern.dt
        error = com + data.vcom[0][:2] / omega - pattern.com[k, :2] - planned_velocity / omega
        offset = adaptation.offset(pattern, k, error, remaining)
        return None if offset is None else adapted(pattern, k, offset, com, data.vcom[0])
    return adapt
