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
from wbik.motion.walking.swing import quintic, swing_pose
from wbik.motion.walking.timeline import Phase, phase_at, timeline
from wbik.motion.walking.zmp_reference import ZmpReference
from wbik.robot import Robot
from wbik.schema import Number

NON_NEGATIVE = Number(ge=0)


@dataclass(frozen=True)
class StepAdaptation:
    """Steps moved by ``gain`` times the DCM error predicted at touch-down once that move is over
    ``threshold_m`` (m), at most ``offset_max_m``; from ``min_remaining_s`` (s) before touch-down on the
    steps stay; a new move only when it differs from the one applied by over ``change_m``. Timing: where the
    move wanted is over ``offset_max_m``, the touch-down comes up to ``sooner_max_s`` (s) sooner, once per
    single support, as much as makes gain |e| exp(omega T) = ``offset_max_m`` (the error grows for less
    time), never later than ``min_remaining_s`` from now."""

    gain: float = 0.3
    threshold_m: float = 0.02
    offset_max_m: float = 0.15
    min_remaining_s: float = 0.1
    change_m: float = 0.002
    sooner_max_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("gain", "threshold_m", "offset_max_m", "min_remaining_s", "change_m", "sooner_max_s"):
            NON_NEGATIVE.checked(getattr(self, name), name, "StepAdaptation", InvalidSettingError)

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

    def sooner(self, omega: float, error: np.ndarray, remaining: float) -> float:
        """How much sooner (s, >= 0) the touch-down ``remaining`` s away comes for the DCM error ``error``."""
        size = self.gain * float(np.hypot(*np.asarray(error, dtype=float)[:2]))
        if self.sooner_max_s <= 0 or size * math.exp(omega * remaining) <= self.offset_max_m or size <= 0:
            return 0.0
        wanted = math.log(self.offset_max_m / size) / omega if self.offset_max_m > 0 else 0.0
        return max(remaining - max(wanted, self.min_remaining_s, remaining - self.sooner_max_s), 0.0)


def measure(robot: Robot, data: pin.Data, q: np.ndarray, v: np.ndarray) -> None:
    """Into ``data``: the measured state's CoM and its velocity, and every frame's placement (once a tick)."""
    pin.centerOfMass(robot.model, data, q, v)
    pin.framesForwardKinematics(robot.model, data, q)


def stance_dcm_error(robot: Robot, data: pin.Data, pattern: WalkPattern, k: int,
                     planned_velocity: np.ndarray) -> np.ndarray:
    """The DCM error (x, y; m) of the state :func:`measure` put into ``data`` against ``pattern``'s at tick k
    (its CoM velocity ``planned_velocity``), each relative to its stance soles:
    (c - s) - (c_d - s_d) + (c' - c_d') / omega."""
    stance = np.mean([data.oMf[robot.frame_id(frame)].translation for frame in pattern.support[k]], axis=0)
    planned_stance = np.mean([p.translation for p in pattern.stance(k).values()], axis=0)
    return (data.com[0][:2] - stance[:2] - (pattern.com[k, :2] - planned_stance[:2])
            + (data.vcom[0][:2] - np.asarray(planned_velocity)[:2]) / pattern.info["omega"])


@dataclass(frozen=True)
class StepResponses:
    """The preview's answer, from rest, to a unit ramp of the ZMP reference that it first sees m ticks before
    the ramp starts, per ramp length (ticks): ``by_length[length]`` (N + 1, ticks, 4) for m = 0 to the
    preview's N steps, per tick after the first sight (c, c', c'', the integral of the ZMP error). A ramp
    seen earlier is the same answer later: the controller rests until the ramp enters its window."""

    by_length: dict[int, np.ndarray]
    steps: int

    def answer(self, m: int, length: int, ticks: int) -> np.ndarray:
        """(ticks, 4): the answer to a unit ramp of ``length`` starting m >= 0 ticks ahead."""
        table = self.by_length[length]
        later = max(m - self.steps, 0)
        found = np.zeros((ticks, 4))
        if later < ticks:
            found[later:] = table[min(m, self.steps), :ticks - later]
        return found


def ramp(ticks: np.ndarray, length: int) -> np.ndarray:
    """The ZMP reference's move (0 to 1) ``ticks`` after its start, a quintic over ``length`` ticks."""
    return quintic(np.clip(ticks / length, 0.0, 1.0)) if length > 0 else (ticks >= 0).astype(float)


def step_responses(pattern: WalkPattern) -> StepResponses:
    """The responses of ``pattern``'s preview control (a linear system: a re-plan is the planned state plus
    each moved ramp's answer), for the lengths of its reference's ramps: one pass over the walk's ticks per
    length, before the walk's first tick."""
    plan, dt, count = pattern.info["replan"], pattern.dt, pattern.ticks
    controller = plan.controller
    ahead = np.arange(controller.steps + 1)
    knots = np.rint(np.asarray(_reference(pattern).knot_times) / dt).astype(int)
    lengths = sorted({int(length) for length in np.diff(knots)})

    def run(length: int) -> np.ndarray:
        reference = ramp(np.arange(count + controller.steps + 1)[:, None] - ahead[None, :], length)
        state = PreviewState(controller, np.zeros((3, len(ahead))))
        state.error_sum = np.zeros(len(ahead))
        found = np.zeros((len(ahead), count, 4))
        for tick in range(count):
            found[:, tick, :3], found[:, tick, 3] = state.x.T, state.error_sum
            state.step(reference[tick + 1:tick + 1 + controller.steps], reference[tick])
        return found

    return StepResponses({length: run(length) for length in lengths}, controller.steps)


def _reference(pattern: WalkPattern) -> ZmpReference:
    return ZmpReference(pattern.phases, pattern.info["replan"].centre, pattern.com[0, :2])


def _ramps(reference: ZmpReference, dt: float, after: int) -> list[tuple[int, int, np.ndarray]]:
    """(start tick, length in ticks, jump (x, y)) of each ramp of ``reference`` starting at or after
    ``after``."""
    ticks = np.rint(np.asarray(reference.knot_times) / dt).astype(int)
    points = reference.knot_points
    return [(int(ticks[i]), int(ticks[i + 1] - ticks[i]), points[i + 1] - points[i])
            for i in range(len(ticks) - 1) if ticks[i] >= after and np.any(points[i + 1] != points[i])]


def _shifted(pose: pin.SE3, move: np.ndarray) -> pin.SE3:
    return pin.SE3(pose.rotation, pose.translation + move)


def _retimed(phases: list, current: Phase, earlier: float) -> list:
    """``phases`` with ``current`` (a single support) ending ``earlier`` s sooner and the later ones moved
    (the walk ends sooner: its last ticks hold the end)."""
    found = []
    for phase in phases:
        if phase.end <= current.start + 1e-9:
            found.append(phase)
        elif phase is current:
            found.append(replace(phase, end=phase.end - earlier))
        else:
            found.append(replace(phase, start=phase.start - earlier, end=phase.end - earlier))
    return found


def adapted(pattern: WalkPattern, k: int, offset: np.ndarray, responses: StepResponses,
            sooner: int = 0) -> WalkPattern:
    """The pattern from tick ``k`` (in a single support) with the footstep taken and the later ones moved by
    ``offset`` (x, y; m) and the touch-down ``sooner`` ticks earlier (the later phases with it; the walk's
    last ticks hold its end): the swing foot blended onto the moved footstep and re-timed to touch down then,
    the feet of the next single support from the new phases and the later ones shifted; the CoM, its
    pendulum's ZMP and the preview's state re-planned from the planned state at k, as the planned state plus
    each changed ramp's answer (``step_responses``: the same as running the preview again, to rounding);
    the ticks before k kept."""
    plan, dt, count = pattern.info["replan"], pattern.dt, pattern.ticks
    phase = phase_at(pattern.phases, k * dt)
    landing = min(int(round(phase.end / dt)), count)
    sooner = min(max(int(sooner), 0), landing - k - 1)
    taken = next(i for i, step in enumerate(pattern.footsteps) if step is phase.swing)
    move = np.append(np.asarray(offset, dtype=float)[:2], 0.0)
    footsteps = [*pattern.footsteps[:taken],
                 *(Footstep(step.side, step.frame, _shifted(step.placement, move))
                   for step in pattern.footsteps[taken:])]
    start = {side: poses[0] for side, poses in pattern.feet_poses.items()}
    placed = [replace(new, start=was.start, end=was.end)  # the new footsteps at the phases' own times
              for new, was in zip(timeline(start, footsteps, plan.timing), pattern.phases, strict=True)]
    phases = _retimed(placed, placed[pattern.phases.index(phase)], sooner * dt)
    current = phases[pattern.phases.index(phase)]
    old, new = _reference(pattern), ZmpReference(phases, plan.centre, pattern.com[0, :2])
    before, after = _ramps(old, dt, landing), _ramps(new, dt, landing - sooner)
    change = np.zeros((count - k, 4, 2))
    for sign, ramps, others in ((-1.0, before, after), (1.0, after, before)):
        for start, length, jump in ramps:
            if any(start == s and length == n and np.array_equal(jump, j) for s, n, j in others):
                continue  # the same ramp in both: no change
            change += sign * responses.answer(start - k, length, count - k)[:, :, None] * jump[None, None, :]
    states, error_sums = plan.states.copy(), plan.error_sums.copy()
    states[k:] += change[:, :3]
    error_sums[k:] += change[:, 3]
    com, zmp = pattern.com.copy(), pattern.lipm_zmp.copy()
    com[k:, :2] = states[k:, 0]
    zmp[k:] = plan.controller.zmp_of(states[k:, 0], states[k:, 2])
    reference = pattern.zmp_reference.copy()
    reference[k:] = new(dt * np.arange(k, count))
    touch = landing - sooner
    later = next((p for p in phases if p.swing is not None and p.start >= current.end - 1e-9), None)
    window = count if later is None else min(int(round(later.end / dt)), count)
    fresh, support, swing, _ = feet_at_ticks(phases, pattern.feet, dt, window, pattern.clearance,
                                             first=touch)
    later_ticks = np.minimum(np.arange(window, count) + sooner, count - 1).tolist()  # the old pattern's
    lift, side = phase.feet[phase.swing.side], phase.swing.side
    start_fraction = phase.fraction(k * dt)
    feet_poses = {}
    for foot, poses in pattern.feet_poses.items():
        if foot == side:  # the old swing re-timed to touch down sooner, blended onto the moved footstep
            now = [_shifted(swing_pose(lift, phase.swing.placement,
                                       start_fraction + (1.0 - start_fraction) * (tick - k) / (touch - k),
                                       pattern.clearance), quintic((tick - k) / (touch - k)) * move)
                   for tick in range(k, touch)]
        else:
            now = poses[k:touch]
        shifted: dict[int, pin.SE3] = {}  # a planted foot's ticks share one pose: shifted once
        for t in later_ticks:
            if id(poses[t]) not in shifted:
                shifted[id(poses[t])] = _shifted(poses[t], move)
        feet_poses[foot] = [*poses[:k], *now, *fresh[foot], *(shifted[id(poses[t])] for t in later_ticks)]
    info = {**pattern.info, "replan": replace(plan, states=states, error_sums=error_sums),
            "ticks_sooner": pattern.info.get("ticks_sooner", 0) + sooner}
    return replace(pattern, footsteps=footsteps, phases=phases, zmp_reference=reference, lipm_zmp=zmp,
                   com=com, feet_poses=feet_poses, info=info,
                   support=[*pattern.support[:touch], *support, *(pattern.support[t] for t in later_ticks)],
                   swing=[*pattern.swing[:touch], *swing, *(pattern.swing[t] for t in later_ticks)],
                   trunk_yaw=pattern.trunk_yaw[
                       np.r_[np.arange(touch), np.minimum(np.arange(touch, count) + sooner, count - 1)]])


@dataclass
class Stepper:
    """One run's step adaptation: each tick of a single support the move wanted against the pattern the
    single support started with; the pattern re-planned when it differs from the move applied by over
    ``change_m``. ``responses``: :func:`step_responses` of the walk's pattern; ``moves``: (time (s), x, y
    (m)) of each move applied."""

    settings: StepAdaptation
    responses: StepResponses
    moves: list = field(default_factory=list)
    soonest: list = field(default_factory=list)
    """(time (s), how much sooner (s)) of each touch-down brought forward."""
    _started: float | None = None
    _base: WalkPattern | None = None
    _applied: np.ndarray = field(default_factory=lambda: np.zeros(2))
    _retimed: bool = False

    def __call__(self, robot: Robot, data: pin.Data, pattern: WalkPattern, k: int) -> WalkPattern | None:
        """The pattern re-planned at tick ``k`` from the state :func:`measure` put into ``data``, or None (no
        change)."""
        remaining = self.settings.remaining(pattern, k)
        if remaining is None:
            return None
        started = phase_at(pattern.phases, k * pattern.dt).start
        if self._started != started:
            self._started, self._base, self._applied, self._retimed = started, pattern, np.zeros(2), False
        base = self._base
        error = stance_dcm_error(robot, data, base, k, base.info["replan"].states[k][1])
        sooner = 0
        if not self._retimed:
            sooner = int(self.settings.sooner(pattern.info["omega"], error, remaining) / pattern.dt + 1e-9)
        wanted = self.settings.offset(base, k, error, remaining - sooner * pattern.dt)
        change = wanted - self._applied
        if np.linalg.norm(change) <= self.settings.change_m and not sooner:
            return None
        if sooner:
            self._retimed = True
            self.soonest.append((k * pattern.dt, sooner * pattern.dt))
        self._applied = wanted
        self.moves.append((k * pattern.dt, *wanted.tolist()))
        return adapted(pattern, k, change, self.responses, sooner)
