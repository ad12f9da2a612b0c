"""A walk played in physics (:mod:`wbik.motion.walking.physics`), open loop (the planned joints as the servos'
targets) or closed loop: every tick the controller reads the simulated present state (q, v) and steps the
whole-body QP toward the plan with two corrections of Kajita's stabiliser, CoM and body inclination:
the CoM target moved by -K_dcm e (low-passed, at most ``com_offset_max``), e = (c - s) - (c_d - s_d) +
(c' - c_d') / omega the error of the divergent component of motion relative to the stance soles (s measured,
s_d planned); the trunk's target turned by -K_att times the trunk's measured roll and pitch error. With
``torque_feedforward`` every servo's target is led by the plan's torque of its joint over its stiffness,
tau / kp (:mod:`wbik.motion.walking.planned_torques`): a compliant servo loaded as planned holds the plan."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import NoQPSolutionError
from wbik.motion.walking.control_loop import without_cyclic_gc
from wbik.motion.walking.pattern import WalkPattern
from wbik.motion.walking.physics import Measured, Servos, Simulation, servo_joints
from wbik.motion.walking.planned_torques import planned_torques
from wbik.motion.walking.step_adaptation import (
    StepAdaptation,
    Stepper,
    measure,
    stance_dcm_error,
    step_responses,
)
from wbik.motion.walking.tracking import Tracker, WalkMotion


@dataclass(frozen=True)
class StabiliserGains:
    """``dcm``: CoM offset per m of divergent-component error, low-passed with ``time_constant_s``, at most
    ``com_offset_max`` (m); ``attitude``: trunk correction per rad of roll or pitch error."""

    dcm: float = 0.1
    attitude: float = 0.5
    time_constant_s: float = 0.05
    com_offset_max: float = 0.02


@dataclass(frozen=True)
class PhysicsSettings:
    """The walk in physics: ``servos``, the stabiliser's ``gains``, the physics ``timestep`` (s), the floor's
    ``friction``, ``settle_s`` (s) the last command held after the walk, ``torque_feedforward``: the servos'
    targets led by the planned joint torques over kp, ``step_adaptation``: the closed loop moves the steps
    (:mod:`wbik.motion.walking.step_adaptation`; None: the steps as planned), ``contact_time_constant``
    (s): how stiff every contact is (MuJoCo's solref time constant; None: MuJoCo's 0.02 s)."""

    servos: Servos
    gains: StabiliserGains = StabiliserGains()
    timestep: float = 0.001
    friction: float = 1.0
    settle_s: float = 1.0
    torque_feedforward: bool = True
    step_adaptation: StepAdaptation | None = None
    contact_time_constant: float | None = None

    def simulation(self, robot, q: np.ndarray, ground_z: float = 0.0, boxes=()) -> Simulation:
        """``robot`` standing at ``q`` in the scene these settings describe (``boxes``: solid terrain)."""
        return Simulation(robot, self.servos, q, ground_z, self.timestep, self.friction, boxes,
                          self.contact_time_constant)


class Stabiliser:
    """The corrections of one walk's tracking from the measured state, tick by tick."""

    def __init__(self, tracker: Tracker, pattern: WalkPattern, gains: StabiliserGains):
        self.tracker, self.pattern, self.gains = tracker, pattern, gains
        self.robot = tracker.robot
        self.data = self.robot.model.createData()
        self.trunk = self.robot.frame_id(tracker.trunk)
        self.offset = np.zeros(3)

    def corrections(self, q: np.ndarray, v: np.ndarray, now: int) -> tuple[np.ndarray, np.ndarray]:
        """(CoM offset (m), trunk correction (rotation)) from the state (q, v) measured at tick ``now``."""
        measure(self.robot, self.data, q, v)
        return self.measured_corrections(now)

    def measured_corrections(self, now: int) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`corrections` from the state :func:`measure` put into ``data`` at tick ``now``."""
        data, pattern, gains = self.data, self.pattern, self.gains
        velocity = (pattern.com[now] - pattern.com[max(now - 1, 0)]) / pattern.dt
        error = stance_dcm_error(self.robot, data, pattern, now, velocity)
        wanted = np.zeros(3)
        wanted[:2] = np.clip(-gains.dcm * error, -gains.com_offset_max, gains.com_offset_max)
        self.offset += (wanted - self.offset) * min(1.0, pattern.dt / max(gains.time_constant_s, 1e-9))
        trunk = self.tracker.trunk_rotation(pattern.trunk_yaw[now] - pattern.trunk_yaw[0])
        tilt = pin.log3(data.oMf[self.trunk].rotation @ trunk.T)
        tilt[2] = 0.0
        return self.offset.copy(), pin.exp3(-gains.attitude * tilt)


def play_open_loop(sim: Simulation, dt: float, planned: np.ndarray, settle_s: float,
                   lead: np.ndarray | None = None) -> Measured:
    """The planned configurations as the servos' targets, one per ``dt`` (s) (``lead``: (K, servos) rad
    added), the last held ``settle_s``."""
    measured = Measured()
    for k in range(1, len(planned) + int(round(settle_s / dt))):
        tick = min(k, len(planned) - 1)
        if not sim.run(planned[tick], dt, measured, None if lead is None else lead[tick]):
            break
    return measured


def play_closed_loop(sim: Simulation, tracker: Tracker, pattern: WalkPattern, q0: np.ndarray,
                     gains: StabiliserGains, settle_s: float, lead: np.ndarray | None = None,
                     steps: StepAdaptation | None = None) -> tuple[Measured, np.ndarray]:
    """(what the physics measured, its ``step_moves`` with ``steps``; each tick's controller CPU time (s):
    state read, step adaptation, corrections, QP); ``lead``: (K, servos) rad added to the targets of the
    plan's tick; ``steps``: the pattern re-planned with the steps moved (the ticks are the plan's)."""
    stabiliser = Stabiliser(tracker, pattern, gains)
    stepper = None if steps is None else Stepper(steps, step_responses(pattern))  # before the first tick
    measured, command, last = Measured(), np.asarray(q0, dtype=float).copy(), pattern.ticks - 1
    cpu = []
    with without_cyclic_gc():
        for k in range(1, pattern.ticks + int(round(settle_s / pattern.dt))):
            started = time.thread_time()
            measure(stabiliser.robot, stabiliser.data, *sim.state())  # once: the stepper and the stabiliser
            if stepper is not None and k - 1 <= last:
                moved = stepper(stabiliser.robot, stabiliser.data, pattern, k - 1)
                if moved is not None:
                    pattern = stabiliser.pattern = moved
            offset, rotation = stabiliser.measured_corrections(min(k - 1, last))
            try:
                command = tracker.step(command, pattern, min(k, last), offset, rotation)
            except NoQPSolutionError:
                pass  # the servos keep the last command
            cpu.append(time.thread_time() - started)
            ahead = min(k + pattern.info.get("ticks_sooner", 0), last)  # the plan's tick (touch-downs sooner)
            if not sim.run(command, pattern.dt, measured, None if lead is None else lead[ahead]):
                break
    if stepper is not None:
        measured.step_moves, measured.touch_downs_sooner = stepper.moves, stepper.soonest
    measured.tick_cpu_s = cpu
    return measured, np.array(cpu)


def servo_lead(motion: WalkMotion, settings: PhysicsSettings) -> np.ndarray | None:
    """Each tick's planned joint torques over kp (rad, (K, servos)) with ``torque_feedforward``, else None."""
    if not settings.torque_feedforward:
        return None
    torques = planned_torques(motion.pattern, motion.q, servo_joints(motion.pattern.robot),
                              settings.servos.armature)
    return torques / settings.servos.kp


def physics_figures(motion: WalkMotion, tracker: Tracker, q0: np.ndarray,
                    settings: PhysicsSettings, lead: np.ndarray | None = None) -> tuple[dict, Measured]:
    """The walk in physics, closed loop (its figures) and open loop (``open_loop``), no push; and what the
    closed loop measured (its simulated configurations, CoP points and pushes)."""
    pattern = motion.pattern

    def scene() -> Simulation:
        return settings.simulation(pattern.robot, motion.q[0], pattern.ground_z)

    def figures(sim: Simulation, measured: Measured) -> dict:
        travel = sim.state()[0][:2] - motion.q[0][:2]
        return {**measured.figures(), "base_travel_m": float(np.linalg.norm(travel)),
                "planned_travel_m": float(np.linalg.norm(motion.q[-1][:2] - motion.q[0][:2]))}

    sim = scene()
    lead = servo_lead(motion, settings) if lead is None else lead  # (given: computed once for every run)
    closed, cpu = play_closed_loop(sim, tracker, pattern, q0, settings.gains, settings.settle_s, lead,
                                   settings.step_adaptation)
    closed_figures = figures(sim, closed)
    sim = scene()
    open_figures = figures(sim, play_open_loop(sim, pattern.dt, motion.q, settings.settle_s, lead))
    ticks = {"median_s": float(np.median(cpu)), "p95_s": float(np.percentile(cpu, 95)),
             "max_s": float(np.max(cpu))}
    return {**closed_figures, "push_impulse_n_s": 0.0, "tick_cpu": ticks, "open_loop": open_figures,
            "servos": asdict(settings.servos), "stabiliser": asdict(settings.gains),
            "timestep_s": settings.timestep, "friction": settings.friction, "mass_kg": sim.mass,
            "torque_feedforward": settings.torque_feedforward,
            "step_adaptation": None if settings.step_adaptation is None else asdict(settings.step_adaptation),
            "steps_moved": len(closed.step_moves)}, closed
