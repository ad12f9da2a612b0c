"""The robot in MuJoCo's physics: its links with their masses and inertias (its URDF), a flat floor, a thin
box under each sole (``robot.soles``), a position servo on every 1-DOF joint, torque
clip(kp (target - q) - kv q', +-limit) - damping q' (``damping``: a motor's back-EMF, stall torque /
no-load speed). Each control tick's target, rounded to the servo's resolution, is reached at constant speed
over the tick (a goal position with a moving speed, as Dynamixels take them). The centre of pressure of a
tick: p = sum f_n r / sum f_n over its physics steps and sole contacts (normal force f_n at r). Optional
terrain: solid boxes on the floor (a staircase's steps), the soles' contacts with them counted too."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.mujoco_model import MuJoCoBody, captured_warnings, carrier, compiled_body, import_mink, robot_spec
from wbik.qp.support_polygon import SupportPolygon
from wbik.robot import Robot

SOLE_THICKNESS = 0.004  # m: the sole boxes, their underside on the sole's plane
FALLEN_HEIGHT_RATIO = 0.75  # fallen: the CoM below this fraction of its starting height above the ground


@dataclass(frozen=True)
class Servos:
    """Position servos: gains ``kp`` (N m/rad) and ``kv`` (N m s/rad) inside the ``torque_limit`` (N m; None:
    the URDF's effort limits, where an effort of 0 states none), ``damping`` (N m s/rad) outside it,
    ``armature`` (the rotor's inertia through the gears, kg m^2), ``resolution`` (rad)."""

    kp: float
    kv: float = 0.0
    damping: float = 0.0
    torque_limit: float | None = None
    armature: float = 0.0
    resolution: float = 0.0


@dataclass(frozen=True)
class Push:
    """A horizontal force on the link ``body`` at its CoM along ``direction`` (world x, y), constant over
    [``at_s``, ``at_s`` + ``duration_s``) of the walk's time, its impulse ``impulse_n_s`` (N s)."""

    body: str
    direction: tuple[float, float]
    impulse_n_s: float
    at_s: float
    duration_s: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise InvalidSettingError(f"a push lasts > 0 s, got {self.duration_s}")
        if not (math.isfinite(self.impulse_n_s) and self.impulse_n_s >= 0):
            raise InvalidSettingError(f"a push's impulse is >= 0 N s, got {self.impulse_n_s}")
        if not (len(self.direction) == 2 and np.all(np.isfinite(self.direction))
                and np.hypot(*self.direction) > 0):
            raise InvalidSettingError(f"a push's direction is a nonzero (x, y), got {self.direction}")

    def force(self, start: float, step: float) -> np.ndarray:
        """The mean force (N, world) over the physics step [start, start + step): the impulse exact."""
        overlap = min(start + step, self.at_s + self.duration_s) - max(start, self.at_s)
        unit = np.asarray(self.direction, dtype=float) / np.hypot(*self.direction)
        return np.append(unit, 0.0) * (self.impulse_n_s / self.duration_s) * max(overlap, 0.0) / step


@dataclass
class Measured:
    """What the physics measured over a run: each tick's CoP margin inside the soles pressed during it, the
    worst margin of a single physics step's CoP, and when it fell (the CoM below ``FALLEN_HEIGHT_RATIO``)."""

    times: list = field(default_factory=list)
    margins: list = field(default_factory=list)
    """Each tick's end (s) and the margin of its CoP (m; NaN: no sole pressed)."""
    fell_at_s: float | None = None
    step_margin_min: float = math.inf
    configurations: list = field(default_factory=list)
    cops: list = field(default_factory=list)
    """Each tick's end: the simulated configuration (wbik's q) and the tick's CoP (world, m; NaN: none)."""
    pushes: list = field(default_factory=list)
    """The pushes applied (:class:`wbik.viz.animation.PushArrow`: frame, start, end (s), force (N))."""
    step_moves: list = field(default_factory=list)
    """The controller's step moves: (time (s), x, y (m)) of each move of the steps it applied."""
    touch_downs_sooner: list = field(default_factory=list)
    """The controller's touch-downs brought forward: (time (s), how much sooner (s))."""
    tick_cpu_s: list = field(default_factory=list)
    """The controller's CPU time (s) of each tick (a closed loop's; empty open loop)."""

    def figures(self) -> dict:
        margins = np.asarray(self.margins, dtype=float)
        worst = None if np.all(np.isnan(margins)) else int(np.nanargmin(margins))
        return {"fell": self.fell_at_s is not None, "fell_at_s": self.fell_at_s,
                "cop_margin_min_m": None if worst is None else float(margins[worst]),
                "cop_margin_min_at_s": None if worst is None else float(self.times[worst]),
                "cop_margin_p5_m": None if worst is None else float(np.nanpercentile(margins, 5)),
                "cop_margin_min_per_step_m": (self.step_margin_min if math.isfinite(self.step_margin_min)
                                              else None),
                "ticks_without_contact": int(np.isnan(margins).sum()),
                "step_move_max_m": max((math.hypot(x, y) for _, x, y in self.step_moves), default=0.0),
                "touch_down_sooner_max_s": max((early for _, early in self.touch_downs_sooner), default=0.0),
                "tick_cpu_max_s": max(self.tick_cpu_s, default=None)}


def servo_joints(robot: Robot) -> list[int]:
    """The joints a servo drives: every joint of the model but the universe and a floating base."""
    return list(range(2 if robot.has_floating_base else 1, robot.model.njoints))


class Simulation:
    """``robot`` standing at ``q`` on the floor z = ``ground_z``, its servos holding q; ``boxes``: (lower,
    upper) corners (m) of solid boxes on the floor (the ground under a point: the highest top over it)."""

    def __init__(self, robot: Robot, servos: Servos, q: np.ndarray, ground_z: float = 0.0,
                 timestep: float = 0.001, friction: float = 1.0,
                 boxes: Sequence[tuple[np.ndarray, np.ndarray]] = (),
                 contact_time_constant: float | None = None):
        _, mujoco = import_mink("the walk's physics")
        self.mujoco, self.robot, self.servos, self.ground_z = mujoco, robot, servos, float(ground_z)
        self.boxes = [(np.asarray(low, dtype=float), np.asarray(high, dtype=float)) for low, high in boxes]
        self._box_bounds = [(*low[:2].tolist(), *high.tolist()) for low, high in self.boxes]
        model = robot.model
        self.joints = servo_joints(robot)
        warnings: list[str] = []
        with captured_warnings(mujoco, warnings):
            self.body = self._scene(timestep, friction)
        self.body.warnings = tuple(warnings)
        self.model, self.data = self.body.model, mujoco.MjData(self.body.model)
        if contact_time_constant is not None:  # every contact as stiff (MuJoCo's solref[0], default 0.02 s)
            if not contact_time_constant >= 2.0 * timestep:
                raise InvalidSettingError(
                    f"a contact time constant of {contact_time_constant} s is under two physics timesteps "
                    f"({timestep} s): MuJoCo's contacts would not be stable; raise it or lower the timestep")
            self.model.geom_solref[:, 0] = contact_time_constant
        self.target_index = np.array([model.joints[j].idx_q for j in self.joints], dtype=int)
        named, kinds = mujoco.mj_name2id, mujoco.mjtObj
        self.sole_geoms = {named(self.model, kinds.mjOBJ_GEOM, f"sole:{sole}"): sole for sole in robot.soles}
        self.sole_sites = {sole: named(self.model, kinds.mjOBJ_SITE, self.body.sites[sole])
                           for sole in robot.soles}
        self.mass = float(self.model.body_subtreemass[0])
        self.time, self._force = 0.0, np.zeros(6)
        self.push: Push | None = None
        self.data.qpos[:] = self.body.qpos(q)
        self.data.ctrl[:] = self.target = self._targets(q)
        mujoco.mj_forward(self.model, self.data)
        self.start_height = self.com_height()

    def _scene(self, timestep: float, friction: float) -> MuJoCoBody:
        """The robot, its servos, the floor and the sole boxes, compiled."""
        mujoco, robot, servos, model = self.mujoco, self.robot, self.servos, self.robot.model
        spec, sites = robot_spec(robot, mujoco, masses=True)
        spec.option.timestep = timestep
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], pos=[0, 0, self.ground_z],
                                friction=[friction, 0.005, 0.0001])
        for index, (low, high) in enumerate(self.boxes):
            spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, name=f"terrain:{index}",
                                    size=((high - low) / 2).tolist(), pos=((high + low) / 2).tolist(),
                                    friction=[friction, 0.005, 0.0001])
        for sole, corners in robot.soles.items():
            self._add_sole(spec, sole, np.asarray(corners, dtype=float), friction)
        for j in self.joints:
            name = model.names[j]
            limit = float(model.effortLimit[model.joints[j].idx_v] if servos.torque_limit is None
                          else servos.torque_limit)
            limited = math.isfinite(limit) and limit > 0  # a URDF's effort of 0 (or none) states no limit
            joint = spec.joint(name)
            joint.armature, joint.damping = servos.armature, [servos.damping, 0.0, 0.0]
            if limited:
                joint.actfrcrange, joint.actfrclimited = [-limit, limit], True  # not the URDF's effort
            spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              gaintype=mujoco.mjtGain.mjGAIN_FIXED, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                              gainprm=[servos.kp] + [0] * 9, biasprm=[0, -servos.kp, -servos.kv] + [0] * 7,
                              forcerange=[-limit, limit] if limited else [0.0, 0.0], forcelimited=limited)
        return compiled_body(robot, spec, sites, mujoco)

    def _add_sole(self, spec, sole: str, corners: np.ndarray, friction: float) -> None:
        """A box spanning the sole's corners, its underside on their plane (z = 0 of the sole frame)."""
        link, placement = carrier(self.robot, self.robot.frame_id(sole))
        low, high = corners.min(axis=0), corners.max(axis=0)
        half = np.append((high - low)[:2] / 2, SOLE_THICKNESS / 2)
        centre = placement.act(np.append((high + low)[:2] / 2, low[2] + SOLE_THICKNESS / 2))
        quaternion = pin.Quaternion(placement.rotation)
        body = spec.worldbody if link is None else spec.body(link)
        body.add_geom(type=self.mujoco.mjtGeom.mjGEOM_BOX, name=f"sole:{sole}", size=half.tolist(),
                      pos=centre.tolist(), quat=[quaternion.w, quaternion.x, quaternion.y, quaternion.z],
                      friction=[friction, 0.005, 0.0001])

    def _targets(self, q: np.ndarray, lead: np.ndarray | None = None) -> np.ndarray:
        targets = np.asarray(q, dtype=float)[self.target_index] + (0.0 if lead is None else lead)
        step = self.servos.resolution
        return np.round(targets / step) * step if step > 0 else targets

    def pushed(self, push: Push) -> None:
        """The push's force over the coming physics step on its body (``xfrc_applied``)."""
        body = self.mujoco.mj_name2id(self.model, self.mujoco.mjtObj.mjOBJ_BODY, push.body)
        if body < 0:
            raise InvalidSettingError(f"no body {push.body!r} to push; give a link of "
                                            f"{self.robot.name!r}")
        self.data.xfrc_applied[body, :3] = push.force(self.time, self.model.opt.timestep)

    def com(self) -> np.ndarray:
        """The simulated robot's CoM (world, m)."""
        return self.data.subtree_com[0].copy()

    def com_height(self) -> float:
        """Height (m) of the CoM above the ground under it (the floor or the highest box there)."""
        x, y, z = self.data.subtree_com[0].tolist()
        ground = self.ground_z
        for x_low, y_low, x_high, y_high, top in self._box_bounds:  # Python floats: a few boxes, every step
            if x_low <= x <= x_high and y_low <= y <= y_high and top > ground:
                ground = top
        return z - ground

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) in wbik's conventions (the base's velocity in its own frame, as Pinocchio's)."""
        q = self.body.q(self.data.qpos)
        v = np.zeros(self.robot.model.nv)
        v[self.body.v_index] = self.data.qvel[self.body.dof_index]
        if self.body.base_dof is not None:
            linear = self.data.qvel[self.body.base_dof:self.body.base_dof + 3]
            v[:3] = pin.Quaternion(q[6], *q[3:6]).toRotationMatrix().T @ linear
            v[3:6] = self.data.qvel[self.body.base_dof + 3:self.body.base_dof + 6]
        return q, v

    def contact_forces(self) -> tuple[float, np.ndarray, set[str]]:
        """(sum of the soles' normal forces f_n (N), sum f_n r (x, y), the soles pressed)."""
        mujoco, data = self.mujoco, self.data
        soles: set[str] = set()
        if data.ncon == 0:
            return 0.0, np.zeros(2), soles
        contacts = data.contact  # the fields as arrays: one view each, not one struct per contact
        first, second = contacts.geom1.tolist(), contacts.geom2.tolist()
        points, force, sole_geoms = contacts.pos[:, :2].tolist(), self._force, self.sole_geoms
        total = moment_x = moment_y = 0.0  # (Python floats: the same products and sums as NumPy's)
        for i in range(data.ncon):
            sole = sole_geoms.get(first[i]) or sole_geoms.get(second[i])
            if sole is None:
                continue
            mujoco.mj_contactForce(self.model, data, i, force)
            normal = force.item(0)
            if normal > 0:
                x, y = points[i]
                total += normal
                moment_x += normal * x
                moment_y += normal * y
                soles.add(sole)
        return total, np.array([moment_x, moment_y]), soles

    def support(self, soles: list[str]) -> SupportPolygon:
        """The polygon of the simulated soles ``soles`` projected on the floor."""
        points = []
        for sole in soles:
            site = self.sole_sites[sole]
            rotation = self.data.site_xmat[site].reshape(3, 3)
            points.append(np.asarray(self.robot.soles[sole]) @ rotation.T + self.data.site_xpos[site])
        return SupportPolygon(np.vstack(points)[:, :2])

    def run(self, q_target: np.ndarray, duration: float, measured: Measured,
            lead: np.ndarray | None = None) -> bool:
        """Servo targets of ``q_target`` (``lead`` added, rad, one per servo) reached over ``duration`` s (one
        control tick); into ``measured`` the margin of the tick's CoP inside the soles pressed during it and
        the worst margin of a physics step's CoP inside the soles it pressed (the soles where they are at the
        tick's end); False once fallen."""
        if measured.fell_at_s is not None:
            return False
        start, end = self.target, self._targets(q_target, lead)
        steps = max(1, int(round(duration / self.model.opt.timestep)))
        impulse, moment, pressed = 0.0, np.zeros(2), {}
        for step in range(1, steps + 1):
            self.data.ctrl[:] = start + (end - start) * (step / steps)
            if self.push is not None:
                self.pushed(self.push)
            self.mujoco.mj_step(self.model, self.data)
            self.time += self.model.opt.timestep
            total, step_moment, soles = self.contact_forces()
            if total > 0:
                impulse, moment = impulse + total, moment + step_moment
                pressed.setdefault(tuple(sorted(soles)), []).append(step_moment / total)
            if self.com_height() < FALLEN_HEIGHT_RATIO * self.start_height:
                measured.fell_at_s = self.time
                return False
        self.target = end
        polygons = {soles: self.support(list(soles)) for soles in pressed}  # qhull: each set of soles once
        for soles, cops in pressed.items():
            margins = (polygons[soles].margin_of(point) for point in cops)
            measured.step_margin_min = min(measured.step_margin_min, *margins)
        every = tuple(sorted(set().union(*pressed)))
        polygon = polygons.get(every) or (self.support(list(every)) if every else None)
        measured.times.append(self.time)
        measured.margins.append(polygon.margin_of(moment / impulse) if impulse > 0 else math.nan)
        measured.configurations.append(self.body.q(self.data.qpos))
        sole_z = np.mean([self.data.site_xpos[self.sole_sites[sole]][2] for sole in every]) if every else 0.0
        measured.cops.append(np.append(moment / impulse, sole_z) if impulse > 0 else np.full(3, math.nan))
        return True
