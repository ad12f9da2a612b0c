"""The stair run in MuJoCo (:mod:`wbik.motion.walking.physics`): the staircase's steps as solid boxes, the
planned motion timed as the stairs report times it (:func:`time_scale_motion`) played open loop, one servo
target per ``TICK_S`` led by the planned joint torques over kp (``torque_feedforward``); the CoP margin per
behaviour run (a half step, UpStair 2, DownStair 1, ...)."""

from __future__ import annotations

import math
from dataclasses import asdict
from itertools import groupby

import numpy as np

from wbik.apps.bioloid.gait import TimedMotion
from wbik.apps.bioloid.stairs import StairRun
from wbik.motion.walking.multibody_zmp import actuated_joints
from wbik.motion.walking.physics import Measured, servo_joints
from wbik.motion.walking.planned_torques import support_torques
from wbik.motion.walking.stabiliser import PhysicsSettings
from wbik.motion.walking.zmp_timing import stance_placed, stance_sole, stance_support

TICK_S = 0.01  # s between two servo targets
HELD = "held at the end"  # the label of the ticks after the motion (``settle_s``)


def behaviour_of(sample: dict) -> str:
    """A sample's behaviour: its phase name up to the colon ("UpStair 2", "WalkSR1"), or its state."""
    return (sample["phase"] or sample["state"]).split(":")[0]


def stairs_physics(run: StairRun, timed: TimedMotion, settings: PhysicsSettings) -> tuple[dict, Measured]:
    """The run's figures in physics (fell, the CoP margin overall and per behaviour run with the base's
    horizontal distance to the planned one at its end, the base's distance at the end) and what it measured
    tick by tick."""
    robot, motion = run.robot, timed.motion
    sim = settings.simulation(robot, motion.q[0], 0.0, run.stairs.boxes())
    columns = [robot.model.joints[j].idx_q for j in actuated_joints(robot.model)]
    ticks = TICK_S * np.arange(1, int(math.ceil((timed.duration + settings.settle_s) / TICK_S)) + 1)
    angles, _ = timed.evaluate(np.minimum(ticks, timed.duration))
    knots = timed.sample_times
    lead = (_lead(robot, motion, knots, ticks, angles, columns, settings) if settings.torque_feedforward
            else None)
    measured, q = Measured(), motion.q[0].copy()
    for k, row in enumerate(angles):
        q[columns] = row
        if not sim.run(q, TICK_S, measured, None if lead is None else lead[k]):
            break
    labels = [behaviour_of(sample) for sample in run.samples]
    margins = np.asarray(measured.margins, dtype=float)
    sample_of = np.searchsorted(knots, np.asarray(measured.times) - 1e-9)  # a tick ending in (t_k-1, t_k]
    tick_labels = [labels[k] if k < len(labels) else HELD for k in sample_of]
    per_behaviour, start = [], 0
    for label, group in groupby(tick_labels):
        count = len(list(group))
        span = margins[start:start + count]
        last = start + count - 1
        planned = motion.q[min(sample_of[last], len(motion.q) - 1)]
        per_behaviour.append({
            "behaviour": label, "from_s": float(measured.times[start] - TICK_S),
            "to_s": float(measured.times[last]),
            "cop_margin_min_m": None if np.all(np.isnan(span)) else float(np.nanmin(span)),
            "base_error_m": float(np.linalg.norm(measured.configurations[last][:2] - planned[:2]))})
        start += count
    final, _ = sim.state()
    return {**measured.figures(), "push_impulse_n_s": 0.0, "per_behaviour": per_behaviour,
            "final_base_error_m": float(np.linalg.norm(final[:3] - motion.q[-1][:3])),
            "simulated_s": float(sim.time), "planned_s": timed.duration, "tick_s": TICK_S,
            "servos": asdict(settings.servos), "timestep_s": settings.timestep, "friction": settings.friction,
            "contact_time_constant_s": settings.contact_time_constant,
            "mass_kg": sim.mass}, measured


def _lead(robot, motion, knots: np.ndarray, ticks: np.ndarray, angles: np.ndarray, columns: list[int],
          settings: PhysicsSettings) -> np.ndarray:
    """The servos' targets' lead tau / kp at each tick: the planned motion's joint torques, the body carried
    by the sole(s) the tick's samples stand on (the load shared by where the CoM is over them)."""
    sample = np.clip(np.searchsorted(knots, np.minimum(ticks, knots[-1]) - 1e-9), 1, len(motion.q) - 1)
    first = np.flatnonzero(np.r_[True, sample[1:] != sample[:-1]])  # the ticks of one sample run together
    qs = np.vstack([stance_placed(robot, motion.q[sample[start]], stance_sole(motion.support, sample[start]),
                                  angles[start:end], columns)
                    for start, end in zip(first, np.r_[first[1:], len(sample)], strict=True)])
    support = [stance_support(motion.support, i) for i in sample]
    load = [robot.center_of_mass(q)[:2] for q in qs]
    torques = support_torques(robot.model, qs, TICK_S, support, load, servo_joints(robot),
                              settings.servos.armature)
    return torques / settings.servos.kp
