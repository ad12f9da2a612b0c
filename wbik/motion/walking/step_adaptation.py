"""Step adaptation, tick by tick in single support: the footstep being taken and every later one moved by the
error of the measured divergent component of motion (DCM) predicted at touch-down, the CoM re-planned by the
preview control from its planned state (the stabiliser keeps correcting what remains against it).

With the stance sole's ZMP fixed, the linear pendulum's DCM error grows as e(t) = e exp(omega t): measured
``remaining`` s before touch-down, the steps move by ``gain`` e exp(omega remaining) (``gain`` < 1: the
stabiliser's own corrections and the robot's ankles absorb part of it), at most ``offset_max_m``, never across
toward the stance foot."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.motion.walking.footsteps import OTHER, Footstep
from wbik.motion.walking.pattern import WalkPattern, feet_at_ticks
from wbik.motion.walking.preview import PreviewState
from wbik.motion.walking.swing import quintic
from wbik.motion.walking.timeline import phase_at, timeline
from wbik.motion.walking.zmp_reference import ZmpReference
from wbik.robot import Robot


@dataclass(frozen=True)
class StepAdaptation:
    """Steps moved by ``gain`` times the DCM error predicted at touch-down once that move is over
    ``threshold_m`` (m), at most ``offset_max_m``; from ``min_remaining_s`` (s) before touch-down on the
    steps stay; a new move only when it differs from the one applied by over ``change_m``."""

    gain: float = 0.3
    threshold_m: float = 0.02
    offset_max_m: float = 0.15
    min_remaining_s: float = 0.1
    change_m: float = 0.002

    def __post_init__(self) -> None:
        for name in ("gain", "threshold_m", "offset_max_m", "min_remaining_s", "change_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise InvalidSettingError(f"step adaptation: {name} is a number >= 0, got {value!r}")

    def remaining(self, pattern: WalkPattern, k: int) -> float | None:
        """The time (s) from tick k to touch-down when the steps may still move, else None."""
        if not 0 <= k < pattern.ticks or pattern.swing[k] is None:
            return None
        left = phase_at(pattern.phases, k * pattern.dt).end - k * pattern.dt
        return left if left >= self.min_remaining_s else None

    def offset(self, pattern: WalkPattern, k: int, error: np.ndarray, remaining: float) -> np.ndarray:
        """The steps' move (x, y; m) at tick ``k`` of a single support for the DCM error ``error`` (x, y)
        measured ``remaining`` s before touch-down (zero under the threshold)."""
        move = np.asarray(error, dtype=float)[:2] * math.exp(pattern.info["omega"] * remaining)
        if np.linalg.norm(move) <= self.threshold_m:
            return np.zeros(2)
        move = self.gain * move
        stance = pattern.feet_poses[OTHER[pattern.swing[k]]][k]
        outward = pattern.feet_poses[pattern.swing[k]][k].translation[:2] - stance.translation[:2]
        lateral = np.array([-stance.rotation[1, 0], stance.rotation[0, 0]])  # the stance sole's y axis
        lateral *= np.sign(lateral @ outward)
        toward = lateral @ move
        if toward < 0:  # the swing foot would cross toward the stance foot
            move -= toward * lateral
        norm = np.linalg.norm(move)
        return move * min(1.0, self.offset_max_m / norm) if norm > 0 else move


def stance_dcm_error(robot: Robot, data: pin.Data, pattern: WalkPattern, q: np.ndarray, v: np.ndarray,
                     k: int) -> np.ndarray:
    """The DCM error (x, y; m) of the measured state (q, v) against ``pattern``'s at tick k, each relative to
    its stance soles: (c - s) - (c_d - s_d) + (c' - c_d') / omega (c_d, c_d' the preview's state)."""
    com = pin.centerOfMass(robot.model, data, q, v)
    pin.framesForwardKinematics(robot.model, data, q)
    stance = np.mean([data.oMf[robot.frame_id(frame)].translation for frame in pattern.support[k]], axis=0)
    planned_stance = np.mean([p.translation for p in pattern.stance(k).values()], axis=0)
    planned = pattern.info["replan"].states[k]
    return (com[:2] - stance[:2] - (planned[0] - planned_stance[:2])
            + (data.vcom[0][:2] - planned[1]) / pattern.info["omega"])


def adapted(pattern: WalkPattern, k: int, offset: np.ndarray) -> WalkPattern:
    """The pattern from tick ``k`` (in a single support) with the footstep taken and the later ones moved by
    ``offset`` (x, y; m), the swing foot blended onto it by a quintic from tick k to touch-down, the CoM
    re-planned from the preview's planned state at k (a zero offset gives the same pattern, bit for bit);
    the ticks before k kept."""
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
    state = PreviewState(controller, plan.states[k].copy())
    state.error_sum = plan.error_sums[k].copy()
    com, zmp = pattern.com.copy(), pattern.lipm_zmp.copy()
    states, error_sums = plan.states.copy(), plan.error_sums.copy()
    for tick in range(k, count):
        com[tick, :2], states[tick], error_sums[tick] = state.x[0], state.x, state.error_sum
        zmp[tick] = controller.zmp_of(state.x[0], state.x[2])
        state.step(tracked[tick + 1:tick + 1 + controller.steps], tracked[tick])
    info = {**pattern.info, "replan": replace(plan, states=states, error_sums=error_sums)}
    return replace(pattern, footsteps=footsteps, phases=phases, zmp_reference=targets[:count], lipm_zmp=zmp,
                   com=com, feet_poses=feet_poses, info=info)


@dataclass
class Stepper:
    """One run's step adaptation: each tick of a single support the move wanted against the pattern the
    single support started with; the pattern re-planned when it differs from the move applied by over
    ``change_m``. ``moves``: (time (s), x, y (m)) of each move applied."""

    settings: StepAdaptation
    moves: list = field(default_factory=list)
    _started: float | None = None
    _base: WalkPattern | None = None
    _applied: np.ndarray = field(default_factory=lambda: np.zeros(2))

    def __call__(self, robot: Robot, data: pin.Data, pattern: WalkPattern, q: np.ndarray, v: np.ndarray,
                 k: int) -> WalkPattern | None:
        """The pattern re-planned at tick ``k`` from the state (q, v) measured then, or None (no change)."""
        remaining = self.settings.remaining(pattern, k)
        if remaining is None:
            return None
        started = phase_at(pattern.phases, k * pattern.dt).start
        if self._started != started:
            self._started, self._base, self._applied = started, pattern, np.zeros(2)
        base = self._base
        wanted = self.settings.offset(base, k, stance_dcm_error(robot, data, base, q, v, k), remaining)
        change = wanted - self._applied
        if np.linalg.norm(change) <= self.settings.change_m:
            return None
        self._applied = wanted
        self.moves.append((k * pattern.dt, *wanted.tolist()))
        return adapted(pattern, k, change)
