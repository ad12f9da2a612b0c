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


@dataclass(frozen=True)
class StepResponses:
    """The preview's answer, from rest, to a unit move of the ZMP reference that it first sees m ticks before
    the move starts (m = 0 to a single support's ticks): per m and tick after the first sight, (c, c', c'',
    the integral of the ZMP error). ``double``: a quintic over a double support; ``end``: over the walk's
    end (a last step moves the final reference, between the soles, by half)."""

    double: np.ndarray
    end: np.ndarray
    double_ticks: int
    end_ticks: int


def ramp(ticks: np.ndarray, length: int) -> np.ndarray:
    """The ZMP reference's move (0 to 1) ``ticks`` after its start, a quintic over ``length`` ticks."""
    return quintic(np.clip(ticks / length, 0.0, 1.0)) if length > 0 else (ticks >= 0).astype(float)


def step_responses(pattern: WalkPattern) -> StepResponses:
    """The responses of ``pattern``'s preview control (a linear system: a re-plan is the planned state plus
    the move times a response), every m at once: one pass over the walk's ticks, before its first."""
    plan, dt, count = pattern.info["replan"], pattern.dt, pattern.ticks
    controller, timing = plan.controller, plan.timing
    ahead = np.arange(int(round(timing.single_support_s / dt)) + 1)

    def run(length: int) -> np.ndarray:
        reference = ramp(np.arange(count + controller.steps + 1)[:, None] - ahead[None, :], length)
        state = PreviewState(controller, np.zeros((3, len(ahead))))
        state.error_sum = np.zeros(len(ahead))
        found = np.zeros((len(ahead), count, 4))
        for tick in range(count):
            found[:, tick, :3], found[:, tick, 3] = state.x.T, state.error_sum
            state.step(reference[tick + 1:tick + 1 + controller.steps], reference[tick])
        return found

    double, end = int(round(timing.double_support_s / dt)), int(round(timing.end_s / dt))
    return StepResponses(run(double), run(end), double, end)


def _shifted(pose: pin.SE3, move: np.ndarray) -> pin.SE3:
    return pin.SE3(pose.rotation, pose.translation + move)


def adapted(pattern: WalkPattern, k: int, offset: np.ndarray, responses: StepResponses) -> WalkPattern:
    """The pattern from tick ``k`` (in a single support) with the footstep taken and the later ones moved by
    ``offset`` (x, y; m): the swing foot blended onto it by a quintic from tick k to touch-down, the feet of
    the next single support from the new footsteps and later ones shifted; the CoM, its pendulum's ZMP and
    the preview's state re-planned from the planned state at k, as the planned state plus the move times
    the preview's response (``step_responses``: the same as running the preview again, to rounding); the
    ticks before k kept."""
    plan, dt, count = pattern.info["replan"], pattern.dt, pattern.ticks
    phase = phase_at(pattern.phases, k * dt)
    taken = next(i for i, step in enumerate(pattern.footsteps) if step is phase.swing)
    move = np.append(np.asarray(offset, dtype=float)[:2], 0.0)
    footsteps = [*pattern.footsteps[:taken], *(Footstep(step.side, step.frame, _shifted(step.placement, move))
                                               for step in pattern.footsteps[taken:])]
    start = {side: poses[0] for side, poses in pattern.feet_poses.items()}
    phases = timeline(start, footsteps, plan.timing)
    landing = min(int(round(phase.end / dt)), count)
    last = taken == len(footsteps) - 1
    scale, length = (0.5, responses.end_ticks) if last else (1.0, responses.double_ticks)
    response = (responses.end if last else responses.double)[landing - k, :count - k]
    change = scale * response[:, :, None] * move[None, None, :2]  # (ticks, c c' c'' integral, x y)
    states, error_sums = plan.states.copy(), plan.error_sums.copy()
    states[k:] += change[:, :3]
    error_sums[k:] += change[:, 3]
    com, zmp = pattern.com.copy(), pattern.lipm_zmp.copy()
    com[k:, :2] = states[k:, 0]
    zmp[k:] = plan.controller.zmp_of(states[k:, 0], states[k:, 2])
    reference = pattern.zmp_reference.copy()
    reference[k:] += scale * ramp(np.arange(k, count) - landing, length)[:, None] * move[:2]
    later = next((p for p in phases if p.swing is not None and p.start >= phase.end - 1e-9), None)
    window = count if later is None else min(int(round(later.end / dt)), count)
    fresh = feet_at_ticks(phases, pattern.feet, dt, window, pattern.clearance, first=landing)[0]
    blend = quintic((np.arange(k, landing) - k) / max(landing - k, 1))
    feet_poses = {}
    for side, poses in pattern.feet_poses.items():
        now = poses[k:landing] if side != phase.swing.side else [
            _shifted(pose, s * move) for pose, s in zip(poses[k:landing], blend, strict=True)]
        shifted: dict[int, pin.SE3] = {}  # a planted foot's ticks share one pose: shifted once
        feet_poses[side] = [*poses[:k], *now, *fresh[side],
                            *(shifted.get(id(pose)) or shifted.setdefault(id(pose), _shifted(pose, move))
                              for pose in poses[window:])]
    info = {**pattern.info, "replan": replace(plan, states=states, error_sums=error_sums)}
    return replace(pattern, footsteps=footsteps, phases=phases, zmp_reference=reference, lipm_zmp=zmp,
                   com=com, feet_poses=feet_poses, info=info)


@dataclass
class Stepper:
    """One run's step adaptation: each tick of a single support the move wanted against the pattern the
    single support started with; the pattern re-planned when it differs from the move applied by over
    ``change_m``. ``responses``: :func:`step_responses` of the walk's pattern; ``moves``: (time (s), x, y
    (m)) of each move applied."""

    settings: StepAdaptation
    responses: StepResponses
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
        return adapted(pattern, k, change, self.responses)
