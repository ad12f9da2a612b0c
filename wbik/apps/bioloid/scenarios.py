"""Scenario kinds of the Bioloid behaviours: schemas, runners and printed reports, each entry judged against
the file's ``expect`` (a whole-body behaviour by default against its generator's guarantees)."""

from __future__ import annotations

import math

import numpy as np

from wbik.apps.bioloid.behaviours import HALF_STEPS, half_step_phases, replay_keyframes, turn_in_place, walk
from wbik.apps.bioloid.gait import GaitParameters, TimedMotion, step_forward_faithful, time_scale_motion
from wbik.apps.bioloid.placo_walk import placo_walk
from wbik.apps.bioloid.sensors import stance_loads
from wbik.apps.bioloid.stairs import Staircase, simulate_stairs
from wbik.apps.bioloid.stairs_physics import stairs_physics
from wbik.apps.bioloid.step_wholebody import current_soles, solve_phases, step_forward_wholebody
from wbik.expectations import ExpectationError, Rule, judge
from wbik.motion.walking.physics import Servos
from wbik.motion.walking.scenario import physics_keys, simulated_animation
from wbik.motion.walking.stabiliser import PhysicsSettings
from wbik.scenarios.kinds import KindRun, Progress, ScenarioKind, ScenarioReport, format_entries, start_of
from wbik.scenarios.schema import (
    START,
    Robot,
    backend_key,
    common_keys,
    expect_block,
    kind_schema,
    margin_key,
    time_laws,
    timing_modes,
)
from wbik.scenarios.wholebody import CONTACT_TOLERANCE
from wbik.schema import Boolean, Key, ListOf, Map, Number, Text, default_of, from_dataclass
from wbik.viz.animation import Animation, Overlays

VELOCITY_TOLERANCE = 1e-9
FAITHFUL_SAMPLE_S = 0.2  # s between two samples of the faithful step's animation (it is not timed)
SIMULATED_SAMPLE_TICKS = 5  # physics ticks between two samples of the simulated stairs' animation, at least
SIMULATED_FRAMES_MAX = 1000  # samples of the simulated stairs' animation, at most (the page's size)

# the faithful step: the mismatch a non-closed chain shows, CoM margin, lifted sole above the floor, limits
FAITHFUL_RULES = {
    "closed_chain_mismatch_min_m": Rule("max_inconsistency_m", ">=", "m"),
    "com_margin_min_m": Rule("min_com_margin_m", ">=", "m"),
    "clearance_min_m": Rule("min_clearance_m", ">=", "m"),
    "limit_excess_max_rad": Rule("max_limit_excess_rad", "<=", "rad"),
    "unreachable_samples_max": Rule("unreachable_samples", "<="),
}
# every sample of a whole-body behaviour by FK (bounded by default: sample_guarantees)
SAMPLE_RULES = {
    "contact_error_max_m": Rule("max_contact_error_m", "<=", "m"),
    "contact_error_max_rad": Rule("max_contact_error_rad", "<=", "rad"),
    "com_margin_min_m": Rule("min_com_margin_m", ">=", "m"),
    "limit_excess_max_rad": Rule("max_limit_excess_rad", "<=", "rad"),
}
WHOLEBODY_RULES = {  # the samples, then the timed servo trajectory
    **SAMPLE_RULES,
    "velocity_ratio_max": Rule("peak_velocity_over_limit", "<="),
    "servo_clamp_max_rad": Rule("max_servo_clamp_rad", "<=", "rad"),
}
KEYFRAME_RULES = {
    "units_round_trip_exact": Rule("units_round_trip_exact", "=="),
    "rows_beyond_urdf_limits_max": Rule("rows_beyond_urdf_limits", "<="),
    "rows_beyond_servo_limits_max": Rule("rows_beyond_servo_limits", "<="),
    "com_margin_single_min_m": Rule("min_com_margin_single_m", ">=", "m"),
}
# PlaCo's walk: CoM and ZMP margins (the plan's pendulum ZMP and the multibody ZMP of PlaCo's IK)
PLACO_WALK_RULES = {
    "planned": Rule("planned", "=="),
    "step_advance_max_m": Rule("max_step_advance_m", "<=", "m"),
    "com_margin_min_m": Rule("min_com_margin_m", ">=", "m"),
    "zmp_margin_min_m": Rule("min_zmp_margin_m", ">=", "m"),
    "multibody_zmp_margin_min_m": Rule("multibody_zmp_margin_min_m", ">=", "m"),
}
STAIR_RULES = {  # the top (and the floor beyond), the samples, the swing sole's distance to the step edges
    "reached_top": Rule("reached_top", "=="),
    "reached_bottom": Rule("reached_bottom", "=="),
    **SAMPLE_RULES,
    "clearance_min_m": Rule("min_clearance_m", ">=", "m"),
    "penetration_max_m": Rule("max_penetration_m", "<=", "m"),
    "physics_fell": Rule("physics_fell", "=="),
    "physics_cop_margin_min_m": Rule("physics_cop_margin_min_m", ">=", "m"),
}
STANCE_RULES = {"cop_error_max_m": Rule("cop_minus_com_m", "<=", "m")}  # statics: the CoP is the CoM's


def sample_guarantees(margin: float) -> dict:
    """What a whole-body generator guarantees at every sample by FK."""
    return {"contact_error_max_m": CONTACT_TOLERANCE, "contact_error_max_rad": CONTACT_TOLERANCE,
            "com_margin_min_m": margin - 1e-9, "limit_excess_max_rad": 1e-9}


class _Behaviours(KindRun):

    def __init__(self, spec: dict, on_progress: Progress = None):
        super().__init__(spec, "behaviours", on_progress)
        self.gait = GaitParameters(**spec["gait"]) if "gait" in spec else None
        self.margin = float(spec["margin"]) if "margin" in spec else None
        self.expect = spec["expect"] or {}


def _timed(spec: dict, motion) -> TimedMotion:
    timing = spec["timing"]
    return time_scale_motion(motion, timing["speed_rpm"], timing["law"], timing["mode"],
                             timing["zmp_shift_max_m"])


def _final_soles(robot, q: np.ndarray) -> dict:
    return {sole: robot.frame_placement(q, sole).translation.tolist() for sole in ("r_sole", "l_sole")}


def _motion_animation(motion, times, name: str, trace_frame: str | None = None):
    times = np.asarray(times, dtype=float)
    keep = np.r_[np.diff(times) > 0, True]  # a sample that did not move has the next one's time
    support = tuple(tuple(feet) for feet, kept in zip(motion.support, keep, strict=True) if kept)
    return Animation(motion.robot, times[keep], motion.q[keep], Overlays(trace_frame, support, support), name)


def _timed_entry(spec: dict, result, name: str, expect: dict | None) -> tuple[dict, object]:
    timed = _timed(spec, result.motion)
    entry = {"name": name, "generator": "wholebody", **result.summary(), "duration_s": timed.duration,
             "speed_rpm": spec["timing"]["speed_rpm"],
             "peak_velocity_over_limit": timed.peak_velocity_ratio()}
    export = spec["export"]
    if export.get("servo_csv"):
        entry["servo_csv"] = str(timed.write_servo_csv(export["servo_csv"], float(export["dt"])))
    table = timed.servo_table(float(export["dt"]))
    entry["servo_rows"] = int(len(table["times_s"]))
    entry["servo_clamped"] = {joint: max(abs(r - a) for _, r, a in items)
                              for joint, items in table["clamped"].items()}
    entry.pop("passed", None)
    figures = {**entry, "min_com_margin_m": entry["min_com_margin_mm"] / 1e3,
               "max_servo_clamp_rad": max(entry["servo_clamped"].values(), default=0.0)}
    wanted = {**sample_guarantees(float(spec["margin"])), "velocity_ratio_max": 1.0 + VELOCITY_TOLERANCE,
              **(expect or {})}
    animation = _motion_animation(result.motion, timed.sample_times, name, trace_frame="pelvis")
    return judge(entry, wanted, figures, WHOLEBODY_RULES, f"{name} expect"), animation


def run_step(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = _Behaviours(spec, on_progress)
    first, margin, generators = spec["first"], run.margin, spec["generators"]
    if "faithful" in generators:
        faithful = step_forward_faithful(run.robot, run.gait, first,
                                         round_degrees=bool(spec["round_degrees"]))
        summary = faithful.summary()
        entry = {"name": f"step forward ({first} first), faithful", "generator": "faithful", **summary,
                 "margin_mm": 1e3 * margin,
                 "samples_under_margin": int(sum(s["com_margin_m"] < margin for s in faithful.samples))}
        clearance = summary["min_clearance_mm"]
        figures = {**summary, "max_inconsistency_m": summary["max_inconsistency_mm"] / 1e3,
                   "min_com_margin_m": summary["min_com_margin_mm"] / 1e3,
                   "min_clearance_m": None if clearance is None else clearance / 1e3,
                   "max_limit_excess_rad": float(np.radians(summary["max_limit_excess_deg"]))}
        times = FAITHFUL_SAMPLE_S * np.arange(len(faithful.motion.q))
        run.add(judge(entry, run.expect.get("faithful"), figures, FAITHFUL_RULES, "expect.faithful"),
                _motion_animation(faithful.motion, times, entry["name"], trace_frame="pelvis"))
    if "wholebody" in generators:
        result = step_forward_wholebody(run.robot, run.gait, first, margin,
                                        rear_lift=float(spec["rear_lift"]), backend=spec["backend"])
        run.add(*_timed_entry(spec, result, f"step forward ({first} first), whole-body",
                              run.expect.get("wholebody")))
    return run.finished()


def run_walk(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = _Behaviours(spec, on_progress)
    angle = float(spec["turn_deg"])  # the kind's own default: 20 deg turning, 0 walking
    if spec["kind"] == "bioloid_turn":
        result = turn_in_place(run.robot, angle, run.gait, run.margin, backend=spec["backend"])
        name = f"turn in place {angle:g} deg"
    else:
        steps = int(spec["steps"])
        result = walk(run.robot, steps, angle, run.gait, run.margin, first=spec["first"],
                      rear_lift=float(spec["rear_lift"]), backend=spec["backend"])
        name = f"walk {steps} steps, turn {angle:g} deg"
    entry, animation = _timed_entry(spec, result, name, run.expect)
    entry["final_soles"] = _final_soles(run.robot, result.motion.q[-1])
    run.add(entry, animation)
    return run.finished()


def run_keyframes(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = _Behaviours(spec, on_progress)
    expect = dict(run.expect)
    own = expect.pop("behaviours", {}) or {}
    chosen = spec["behaviours"]
    if set(own) - set(chosen):
        raise ExpectationError(f"expect.behaviours names {sorted(set(own) - set(chosen))}, which are not "
                               f"replayed; replayed: {chosen}")
    for behaviour in chosen:
        replay = replay_keyframes(run.robot, behaviour, spec["keyframes"])
        rows = replay["rows"]
        single = min(r["com_margin_single_m"] for r in rows)
        entry = {"name": f"keyframes {behaviour}", "rows": len(rows),
                 "duration_s": float(replay["times_s"][-1]),
                 "units_round_trip_exact": all(r["units_round_trip"] for r in rows),
                 "rows_beyond_urdf_limits": sum(bool(r["beyond_limits"]) for r in rows),
                 "rows_beyond_servo_limits": sum(bool(r["servos_clamped"]) for r in rows),
                 "max_other_sole_height_mm": 1e3 * max(r["other_sole_height_m"] for r in rows),
                 "min_com_margin_single_mm": 1e3 * single, "source": replay["source"]}
        wanted = {**expect, **(own.get(behaviour) or {})}
        run.add(judge(entry, wanted, {**entry, "min_com_margin_single_m": single}, KEYFRAME_RULES,
                      f"expect ({behaviour})"),
                _motion_animation(replay["motion"], replay["times_s"], f"keyframes {behaviour}"))
    return run.finished()


def run_placo_walk(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = _Behaviours(spec, on_progress)
    result, animation = placo_walk(run.robot, int(spec["steps"]), float(spec["step_length"]), run.margin)
    scaled = ("max_step_advance", "min_com_margin", "min_zmp_margin", "multibody_zmp_margin_min")
    figures = {**result, **{f"{key}_m": result[f"{key}_mm"] / 1e3 for key in scaled if f"{key}_mm" in result}}
    entry = {"name": "PlaCo walk pattern generator", **result}
    run.add(judge(entry, {"planned": True, **run.expect}, figures, PLACO_WALK_RULES, "expect"), animation)
    return run.finished()


def run_half_steps(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = _Behaviours(spec, on_progress)
    robot = run.robot
    q = robot.nominal.copy()
    for name in spec["sequence"]:
        phases, _ = half_step_phases(robot, current_soles(robot, q), name, run.gait, spec["length"],
                                     float(spec["lift"]))
        result = solve_phases(robot, q, phases, run.margin, spec["backend"], name=name)
        entry, animation = _timed_entry(spec, result, name, run.expect)
        q = result.motion.q[-1].copy()
        entry["final_soles"] = _final_soles(robot, q)
        run.add(entry, animation)
    return run.finished()


def run_stairs(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = _Behaviours(spec, on_progress)
    margin = run.margin
    stairs = Staircase(**spec["stairs"])
    climb = simulate_stairs(run.robot, stairs, run.gait, margin, spec["climbs"], backend=spec["backend"],
                            com_inset=spec["com_inset"])
    summary = climb.summary()
    timed = _timed(spec, climb.motion)
    size = f"{stairs.height * 1e3:g} mm x {stairs.depth * 1e3:g} mm"
    way = ", up and down" if stairs.descend else ""
    entry = {"name": f"stairs: {stairs.steps} steps of {size}{way}",
             **summary, "margin_m": margin, "duration_s": timed.duration,
             "staircase": {"steps": stairs.steps, "height_m": stairs.height, "depth_m": stairs.depth,
                           "start_x_m": stairs.start_x, "top_depth_m": stairs.top_depth,
                           "width_m": stairs.width, "descend": stairs.descend},
             "states": climb.states, "reads": climb.reads, "per_sample": climb.samples}
    wanted = {"reached_top": True, **({"reached_bottom": True} if stairs.descend else {}),
              **sample_guarantees(margin), **run.expect}
    judged, simulated = dict(summary), None
    if spec["physics"] is not None:  # in MuJoCo too: standing, the CoP `margin` inside the soles pressed
        given = spec["physics"]
        settings = PhysicsSettings(Servos(**given["servos"]), timestep=given["timestep"],
                                   friction=given["friction"], settle_s=given["settle_s"],
                                   contact_time_constant=given["contact_time_constant"])
        entry["physics"], simulated = stairs_physics(climb, timed, settings)
        wanted = {"physics_fell": False, "physics_cop_margin_min_m": margin, **wanted}
        judged.update(physics_fell=entry["physics"]["fell"],
                      physics_cop_margin_min_m=entry["physics"]["cop_margin_min_m"])
    animation = _motion_animation(climb.motion, timed.sample_times, "bioloid stairs", trace_frame="pelvis")
    if simulated is not None and simulated.configurations:
        played = simulated_animation(animation, simulated, "simulated, open loop")
        every = max(SIMULATED_SAMPLE_TICKS, math.ceil(played.frames / SIMULATED_FRAMES_MAX))
        animation = animation.then(played.subsampled(every))
    run.add(judge(entry, wanted, judged, STAIR_RULES, "expect"),
            animation.with_environment(climb.scene_boxes()))
    return run.finished()


def run_stance_sensors(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = KindRun(spec, "moves", on_progress)
    robot = run.robot
    q = start_of(spec, robot)
    stance = stance_loads(robot, q)
    gap = float(np.linalg.norm(stance.cop_world - stance.com_xy))
    entry = {"name": "static stance", "cop_minus_com_m": gap, **stance.as_dict()}
    wanted = {"cop_error_max_m": float(spec["tolerance"]), **(spec["expect"] or {})}
    judge(entry, wanted, {"cop_minus_com_m": gap}, STANCE_RULES, f"{spec['name'] or spec['kind']} expect")
    soles = (("r_sole", "l_sole"),)
    run.add(entry, Animation(robot, [0.0], q[None], Overlays(None, soles, soles), "static stance"))
    return run.finished()


def format_report(report: dict) -> str:
    hidden = ("name", "passed", "per_phase", "source", "final_soles", "expectations", "verdict", "physics")

    def describe(entry: dict) -> str:
        line = ", ".join(f"{k} {_short(v)}" for k, v in entry.items() if k not in hidden)
        return line if "physics" not in entry else f"{line}\n      {_physics_line(entry['physics'])}"

    return format_entries(report, "behaviours", describe)


def _physics_line(physics: dict) -> str:
    """Fell or stood, the CoP margin overall and per behaviour run (mm; '-': no sole pressed), the base's
    distance to the plan at each run's end."""
    def mm(value) -> str:
        return "-" if value is None else f"{value * 1e3:.1f}"

    fell = f"FELL at {physics['fell_at_s']:.2f} s" if physics["fell"] else "stood"
    runs = "; ".join(f"{b['behaviour']} {mm(b['cop_margin_min_m'])} ({mm(b['base_error_m'])})"
                     for b in physics["per_behaviour"])
    return (f"physics (open loop, {physics['simulated_s']:.2f} of {physics['planned_s']:.2f} s): {fell}, "
            f"CoP margin min {mm(physics['cop_margin_min_m'])} mm; per behaviour, mm: CoP margin min (the "
            f"base off the plan at its end): {runs}")


def _short(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) > 6:
        return f"[{len(value)} values]"
    return str(value)


def format_stance(report: dict) -> str:
    return format_entries(report, "moves", lambda move: f"CoP - CoM {move['cop_minus_com_m']:.2e} m")


def bioloid_schema(kind: str) -> Map:
    common = common_keys(robot=Key(Robot(only=("bioloid",)), "bioloid"))
    margin = {"margin": margin_key()}
    gait = {"gait": Key(Map(from_dataclass(GaitParameters).keys, nullable=True), {})}
    timed = {"timing": Key(Map({"speed_rpm": Key(Number(gt=0, nullable=True, unit="rpm"),
                                                 default_of(time_scale_motion, "speed_rpm")),
                                "law": Key(Text(time_laws), default_of(time_scale_motion, "law")),
                                "mode": Key(Text(timing_modes), default_of(time_scale_motion, "mode")),
                                "zmp_shift_max_m": Key(Number(gt=0, nullable=True, unit="m"),
                                                       default_of(time_scale_motion, "zmp_shift_max"))},
                               nullable=True), {}),
             "export": Key(Map({"servo_csv": Key(Text(what="a file path", nullable=True)),
                                "dt": Key(Number(gt=0, unit="s"), default_of(TimedMotion.servo_table, "dt"))},
                               nullable=True), {}),
             "backend": backend_key()}
    walking = {"first": Key(Text(("left", "right")), default_of(walk, "first")),
               "rear_lift": Key(Number(ge=0, unit="m"), default_of(walk, "rear_lift"))}
    generators = ("faithful", "wholebody")
    if kind == "bioloid_step":
        keys = {**margin, **gait, **timed, **walking,
                "generators": Key(ListOf(Text(generators), min_items=1), list(generators)),
                "round_degrees": Key(Boolean(), default_of(step_forward_faithful, "round_degrees")),
                "expect": Key(expect_block({}, faithful=Key(expect_block(FAITHFUL_RULES)),
                                           wholebody=Key(expect_block(WHOLEBODY_RULES))), None)}
    elif kind == "bioloid_walk":
        keys = {**margin, **gait, **timed, **walking,
                "steps": Key(Number(ge=1, integer=True), default_of(walk, "steps")),
                "turn_deg": Key(Number(unit="deg"), default_of(walk, "turn_deg")),
                "expect": Key(expect_block(WHOLEBODY_RULES), None)}
    elif kind == "bioloid_turn":
        keys = {**margin, **gait, **timed,
                "turn_deg": Key(Number(unit="deg"), default_of(turn_in_place, "angle_deg")),
                "expect": Key(expect_block(WHOLEBODY_RULES), None)}
    elif kind == "bioloid_keyframes":
        keys = {"behaviours": Key(ListOf(Text(what="a behaviour name"), min_items=1),
                                  ["up_stair", "down_stair", "right_turn_medium", "left_turn_medium"]),
                "keyframes": Key(Text(what="a keyframe file path", nullable=True), None),
                "expect": Key(expect_block(KEYFRAME_RULES, behaviours=Key(
                    Map(values=expect_block(KEYFRAME_RULES), nullable=True))), None)}
    elif kind == "bioloid_half_steps":
        keys = {**margin, **gait, **timed,
                "sequence": Key(ListOf(Text(tuple(HALF_STEPS)), min_items=1),
                                ["WalkSR1", "WalkSR2", "WalkSL1", "WalkSL2", "WalkSR1", "BackSR", "WalkSL1",
                                 "BackSL"]),
                "length": Key(Number(gt=0, nullable=True, unit="m"), default_of(half_step_phases, "length")),
                "lift": Key(Number(ge=0, unit="m"), default_of(half_step_phases, "lift")),
                "expect": Key(expect_block(WHOLEBODY_RULES), None)}
    elif kind == "bioloid_stairs":
        keys = {**margin, **gait, **timed,
                "stairs": Key(Map(from_dataclass(Staircase, {"descend": Boolean()}).keys, nullable=True), {}),
                "climbs": Key(Number(ge=1, integer=True, nullable=True),
                              default_of(simulate_stairs, "climbs")),
                "com_inset": Key(Number(ge=0, unit="m"), default_of(simulate_stairs, "com_inset"),
                                 doc="every step of the run (half steps, UpStair, DownStair) moves the CoM "
                                     "this far into a sole before the other lifts"),
                "physics": Key(Map(physics_keys(), nullable=True), None,
                               doc="the run in MuJoCo on the staircase's boxes, open loop"),
                "expect": Key(expect_block(STAIR_RULES), None)}
    elif kind == "bioloid_placo_walk":
        keys = {**margin, "steps": Key(Number(ge=1, integer=True), default_of(placo_walk, "steps")),
                "step_length": Key(Number(gt=0, unit="m"), default_of(placo_walk, "step_length")),
                "expect": Key(expect_block(PLACO_WALK_RULES), None)}
    elif kind == "bioloid_stance_sensors":
        common = common_keys(robot=Key(Robot(), "bioloid"))  # any robot with sole corners
        keys = {"start": Key(START, "nominal"), "tolerance": Key(Number(gt=0, unit="m"), 1e-9),
                "expect": Key(expect_block(STANCE_RULES), None)}
    else:
        raise ValueError(f"not a Bioloid kind: {kind!r}")
    return kind_schema(common, keys)


def _kind(name: str, run, summary: str, format=format_report) -> ScenarioKind:
    return ScenarioKind(name, run, lambda: bioloid_schema(name), format, summary)


SCENARIO_KINDS = (
    _kind("bioloid_step", run_step, "the thesis's step forward: faithful and/or whole-body"),
    _kind("bioloid_walk", run_walk, "whole-body walk of N steps, then an optional turn"),
    _kind("bioloid_turn", run_walk, "whole-body turn in place"),
    _kind("bioloid_keyframes", run_keyframes, "replay of the seed's keyframe behaviours"),
    _kind("bioloid_placo_walk", run_placo_walk, "PlaCo's walk pattern generator on the same URDF"),
    _kind("bioloid_half_steps", run_half_steps, "a sequence of the seed's half steps, whole-body"),
    _kind("bioloid_stairs", run_stairs, "the sensor-driven stair climb on a simulated staircase"),
    _kind("bioloid_stance_sensors", run_stance_sensors, "FSR loads and centre of pressure of a static stance",
          format_stance),
)
