"""Bioloid behaviours on the whole-body engine: turning in place, walking then turning, the thesis's half
steps (bioloid.md 5.3; generated, their Roboplus matrices are not in our sources) and the keyframe replay."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import (
    OTHER,
    SIDE_NAME,
    SIDES,
    SOLE,
    GaitParameters,
    flatten_on_ground,
    start_q,
)
from wbik.apps.bioloid.servo import SERVOS, from_servo_units, to_servo
from wbik.apps.bioloid.step_wholebody import (
    RAMP_INSET,
    com_over_phase,
    current_soles,
    pelvis_rotation,
    recentre_goal,
    sole_path,
    solve_phases,
    step_phases,
)
from wbik.data import data_dir
from wbik.errors import InvalidConfigurationError
from wbik.files import read_data_file
from wbik.motion.walking.footsteps import placed_on, sole_polygon, yaw_of
from wbik.motion.walking.static_gait import BodyPhase, ComRamp, SampledMotion, WholeBodyMotion
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.robot import Robot

KEYFRAMES_PATH = data_dir("tasks") / "data" / "bioloid_keyframes.yaml"
HALF_STEP_LIFT = 0.015  # m, swing height (ours; the thesis says only "much less" than 40 mm)
ALONG_TOLERANCE = 1e-4  # m, a foot counts as beside the other one within this along the heading
HALF_STEPS: dict[str, tuple[str, str]] = {
    # name -> (foot moved, where it ends: "ahead" of the other foot or "beside" it)
    "WalkSR1": ("r", "ahead"), "WalkSR2": ("l", "beside"), "BackSR": ("r", "beside"),
    "WalkSL1": ("l", "ahead"), "WalkSL2": ("r", "beside"), "BackSL": ("l", "beside"),
}


def recentre_phase(robot: Robot, soles: dict[str, pin.SE3], gait: GaitParameters,
                   name: str = "re-centre the CoM between the feet", rotation=None) -> BodyPhase:
    """Both feet down, the CoM back between the feet, the pelvis at ``rotation`` (s -> R; default: the
    feet's mean heading)."""
    heading = 0.5 * (yaw_of(soles["r"].rotation) + yaw_of(soles["l"].rotation))
    return BodyPhase(name, {SOLE[s]: soles[s] for s in SIDES},
                     pelvis_rotation=rotation or (lambda s: pelvis_rotation(heading, gait.pitch)),
                     com=ComRamp(goal=recentre_goal(robot, soles)), divisions=gait.divisions)


def both_feet_phases(robot: Robot, soles: dict[str, pin.SE3], after: dict[str, pin.SE3], first: str,
                     gait: GaitParameters, names: list[str], paths: list, rotations: list,
                     swing_divisions: int, shift_divisions: int, inset: float = RAMP_INSET
                     ) -> list[BodyPhase]:
    """Five phases moving both feet from ``soles`` to ``after``, ``first`` first: the CoM ``inset`` into
    the other foot, ``first`` on ``paths[0]`` with the CoM held, the CoM ``inset`` into it, the other on
    ``paths[1]`` with the CoM held, the CoM between the feet; ``rotations``: the pelvis's per phase,
    divisions in units of ``gait.divisions``."""
    second, n = OTHER[first], gait.divisions
    return [
        com_over_phase(robot, names[0], {SOLE[s]: soles[s] for s in SIDES}, second, soles[second], inset,
                       pelvis_rotation=rotations[0], divisions=n),
        BodyPhase(names[1], {SOLE[second]: soles[second]}, swing={SOLE[first]: paths[0]},
                  pelvis_rotation=rotations[1], com=ComRamp(), divisions=swing_divisions * n),
        com_over_phase(robot, names[2], {SOLE[second]: soles[second], SOLE[first]: after[first]}, first,
                       after[first], inset, pelvis_rotation=rotations[2], divisions=shift_divisions * n),
        BodyPhase(names[3], {SOLE[first]: after[first]}, swing={SOLE[second]: paths[1]},
                  pelvis_rotation=rotations[3], com=ComRamp(), divisions=swing_divisions * n),
        recentre_phase(robot, after, gait, names[4], rotations[4]),
    ]


def turn_phases(robot: Robot, soles: dict[str, pin.SE3], angle: float, gait: GaitParameters | None = None,
                lift: float | None = None) -> tuple[list[BodyPhase], dict[str, pin.SE3]]:
    """Phases turning in place by ``angle`` (rad, positive = left) from the planted ``soles``."""
    gait = gait or GaitParameters()
    lift = gait.lift_height if lift is None else float(lift)
    if abs(angle) > math.radians(60):
        raise InvalidConfigurationError(f"turn by at most 60 deg at a time, got {math.degrees(angle):.1f}")
    centre = 0.5 * (soles["r"].translation + soles["l"].translation)
    centre[2] = 0.0
    heading = 0.5 * (yaw_of(soles["r"].rotation) + yaw_of(soles["l"].rotation))
    first = "l" if angle >= 0 else "r"
    second = OTHER[first]
    turn = pin.utils.rotate("z", angle)
    turned = {side: pin.SE3(turn @ soles[side].rotation, centre + turn @ (soles[side].translation - centre))
              for side in SIDES}
    half = heading + 0.5 * angle
    ramps = [(heading, heading), (heading, half), (half, half), (half, heading + angle)]
    phases = both_feet_phases(
        robot, soles, turned, first, gait,
        [f"shift the CoM over the {SIDE_NAME[second]} foot", f"turn the {SIDE_NAME[first]} foot",
         f"shift the CoM over the {SIDE_NAME[first]} foot", f"turn the {SIDE_NAME[second]} foot",
         "re-centre the CoM between the feet"],
        [sole_path(soles[side], turned[side], lift=lift) for side in (first, second)],
        [lambda s, a=a, b=b: pelvis_rotation(a + s * (b - a), gait.pitch) for a, b in ramps] + [None], 2, 1)
    return phases, turned


def turn_in_place(robot: Robot, angle_deg: float = 20.0, gait: GaitParameters | None = None,
                  margin: float = 0.005, q0: np.ndarray | None = None,
                  backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """Turn in place by ``angle_deg`` (positive = left) with the whole-body QP."""
    q = start_q(robot, q0)
    phases, _ = turn_phases(robot, current_soles(robot, q), math.radians(angle_deg), gait)
    return solve_phases(robot, q, phases, margin, backend, name=f"turn_{angle_deg:g}deg")


def walk(robot: Robot, steps: int = 4, turn_deg: float = 0.0, gait: GaitParameters | None = None,
         margin: float = 0.005, q0: np.ndarray | None = None, first: str = "left", rear_lift: float = 0.0,
         backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """``steps`` steps forward, ``first`` foot first, then a turn by ``turn_deg`` (+ left) or re-centring."""
    gait = gait or GaitParameters()
    if steps < 0:
        raise InvalidConfigurationError(f"steps must be >= 0, got {steps}")
    q = start_q(robot, q0)
    soles = current_soles(robot, q)
    phases: list[BodyPhase] = []
    side = "left" if str(first).lower() in ("left", "l") else "right"
    for _ in range(steps):
        step, soles = step_phases(robot, soles, gait, side, rear_lift)
        phases += step
        side = "right" if side == "left" else "left"
    if turn_deg:
        phases += turn_phases(robot, soles, math.radians(turn_deg), gait)[0]
    else:
        phases.append(recentre_phase(robot, soles, gait))
    return solve_phases(robot, q, phases, margin, backend, name=f"walk_{steps}_turn_{turn_deg:g}")


def along(soles: dict[str, pin.SE3], side: str) -> float:
    """How far the ``side`` foot is ahead of the other one along the other foot's heading (m)."""
    reference = soles[OTHER[side]]
    return float(reference.rotation[:, 0] @ (soles[side].translation - reference.translation))


def half_step_phases(robot: Robot, soles: dict[str, pin.SE3], name: str, gait: GaitParameters | None = None,
                     length: float | None = None, lift: float = HALF_STEP_LIFT, inset: float = RAMP_INSET
                     ) -> tuple[list[BodyPhase], dict[str, pin.SE3]]:
    """Phases of the half step ``name`` (a key of ``HALF_STEPS``) and the soles after it, the CoM ``inset``
    into the standing sole and held there while the other swings; InvalidConfigurationError when the moved
    foot is not where the half step starts from."""
    if name not in HALF_STEPS:
        raise InvalidConfigurationError(f"unknown half step {name!r}; known: {', '.join(HALF_STEPS)}")
    gait = gait or GaitParameters()
    length = gait.step_length if length is None else float(length)
    if not 0.0 < length <= 0.06:
        raise InvalidConfigurationError(f"half step length must be in (0, 0.06] m, got {length}")
    if not 0.0 <= lift <= 0.05:
        raise InvalidConfigurationError(f"half step lift must be in [0, 0.05] m, got {lift}")
    moved, ends = HALF_STEPS[name]
    stays = OTHER[moved]
    ahead = along(soles, moved)
    foot = f"{name} brings the {SIDE_NAME[moved]} foot"
    if name.startswith("Back") and ahead <= ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{foot} back from in front, but it is {ahead * 1e3:.1f} mm ahead of "
                                        "the other one")
    if name.endswith("2") and ahead >= -ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{foot} from behind, but it is {ahead * 1e3:.1f} mm ahead of the "
                                        "other one")
    if name.endswith("1") and ahead > ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{name} puts the {SIDE_NAME[moved]} foot forward from beside the "
                                        f"other one, but it is already {ahead * 1e3:.1f} mm ahead")
    start, other = soles[moved], soles[stays]
    end = pin.SE3(start.rotation.copy(),
                  start.translation + other.rotation[:, 0] * ((length if ends == "ahead" else 0.0) - ahead))
    heading = yaw_of(other.rotation)
    rotation = lambda s: pelvis_rotation(heading, gait.pitch)  # noqa: E731
    after = {moved: end, stays: other}
    n = gait.divisions
    phases = [
        com_over_phase(robot, f"{name}: CoM over the {SIDE_NAME[stays]} foot",
                       {SOLE[moved]: start, SOLE[stays]: other}, stays, other, inset,
                       pelvis_rotation=rotation, divisions=n),
        BodyPhase(f"{name}: {SIDE_NAME[moved]} foot {'back' if name.startswith('Back') else 'forward'}",
                  {SOLE[stays]: other}, swing={SOLE[moved]: sole_path(start, end, lift=lift)},
                  pelvis_rotation=rotation, com=ComRamp(), divisions=2 * n),
        BodyPhase(f"{name}: CoM between the feet", {SOLE[moved]: end, SOLE[stays]: other},
                  pelvis_rotation=rotation, com=ComRamp(goal=recentre_goal(robot, after)), divisions=n),
    ]
    return phases, after


def half_step_sequence(robot: Robot, names: list[str], q0: np.ndarray | None = None,
                       gait: GaitParameters | None = None, margin: float = 0.005,
                       length: float | None = None, lift: float = HALF_STEP_LIFT,
                       backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """Half steps one after the other from ``q0`` (default the nominal)."""
    q = start_q(robot, q0)
    soles = current_soles(robot, q)
    phases: list[BodyPhase] = []
    for name in names:
        more, soles = half_step_phases(robot, soles, name, gait, length, lift)
        phases += more
    return solve_phases(robot, q, phases, margin, backend, name="+".join(names))


def load_keyframes(path: str | Path | None = None) -> dict:
    """The keyframe file (see tasks/data/bioloid_keyframes.yaml for the format and provenance)."""
    path = Path(path) if path is not None else KEYFRAMES_PATH
    data = read_data_file(path, InvalidConfigurationError, "keyframe", "it holds pages and behaviours")
    for name, rows in data.get("pages", {}).items():
        array = np.asarray(rows)
        if array.ndim != 2 or array.shape[1] != 18 or np.any(array < 0) or np.any(array > 1023):
            raise InvalidConfigurationError(f"keyframe page {name!r}: rows of 18 units in 0..1023 expected")
    return data


def keyframe_rows(data: dict, behaviour: str) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(units (K, 18), time per row (K,), page name per row) of one behaviour of the file."""
    behaviours = data.get("behaviours", {})
    if behaviour not in behaviours:
        raise InvalidConfigurationError(
            f"unknown keyframe behaviour {behaviour!r}; known: {', '.join(behaviours)}")
    spec = behaviours[behaviour]
    rows = [(row, float(dt), page) for page, dt in zip(spec["pages"], spec["row_time_s"], strict=True)
            for row in data["pages"][page]]
    return np.asarray([r[0] for r in rows], dtype=int), np.asarray([r[1] for r in rows]), [r[2] for r in rows]


def replay_keyframes(robot: Robot, behaviour: str, path: str | Path | None = None) -> dict:
    """A keyframe behaviour's configurations, its lower sole flat on the ground, and per row the other
    sole's height (m) and tilt (deg), CoM margins (m), joints beyond the URDF limits, servos clamped."""
    data = load_keyframes(path)
    units, row_times, pages = keyframe_rows(data, behaviour)
    model = robot.model
    configurations, rows = [], []
    for index, row in enumerate(units):
        q = robot.nominal.copy()
        angles = from_servo_units(row)
        for joint, value in angles.items():
            q[model.joints[model.getJointId(joint)].idx_q] = value
        command = to_servo(angles)
        clamped = {SERVOS[joint].servo_id for joint in command.clamped}
        q[:7] = pin.SE3ToXYZQUAT(pin.SE3.Identity())
        placed = {}
        for side in SIDES:  # each sole flat on the ground in turn; keep the one with the other above
            ground_side = flatten_on_ground(robot.frame_placement(q, SOLE[side]))
            q_side = placed_on(robot, q, SOLE[side], ground_side)
            placed[side] = (q_side, ground_side, robot.frame_placement(q_side, SOLE[OTHER[side]]))
        lower = max(SIDES, key=lambda side: placed[side][2].translation[2])
        q, ground, other = placed[lower]
        tilt = math.degrees(math.acos(float(np.clip(other.rotation[2, 2], -1.0, 1.0))))
        com = robot.center_of_mass(q)
        single = sole_polygon(robot, {SOLE[lower]: ground}).margin_of(com[:2])
        both = None
        if abs(other.translation[2]) <= 0.005:
            both = sole_polygon(robot, {SOLE[lower]: ground, SOLE[OTHER[lower]]: flatten_on_ground(other)}
                                ).margin_of(com[:2])
        index_q = [model.joints[j].idx_q for j in range(2, model.njoints)]
        beyond = [model.names[j] for j, i in zip(range(2, model.njoints), index_q, strict=True)
                  if not model.lowerPositionLimit[i] - 1e-9 <= q[i] <= model.upperPositionLimit[i] + 1e-9]
        rows.append({"row": index, "page": pages[index], "lower_sole": SOLE[lower],
                     "other_sole_height_m": float(other.translation[2]), "other_sole_tilt_deg": tilt,
                     "com_margin_single_m": single, "com_margin_both_m": both, "beyond_limits": beyond,
                     "servos_clamped": sorted(clamped), "units_round_trip": all(
                         command.units[i] == int(u) for i, u in enumerate(row, start=1) if i not in clamped)})
        configurations.append(q)
    times = np.cumsum(row_times)
    motion = SampledMotion(f"keyframes_{behaviour}", robot, np.array(configurations), np.arange(len(units)),
                           [f"{p} row" for p in pages], [(r["lower_sole"],) for r in rows])
    return {"behaviour": behaviour, "rows": rows, "units": units, "times_s": times, "motion": motion,
            "source": data.get("source")}
