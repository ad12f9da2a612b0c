"""The ``walk`` scenario kind: dynamic walks judged on the full model (by default: the multibody ZMP
``margin`` inside the support, no QP failure), compared with the static gait and PlaCo's generator."""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np

from wbik.collision import capsule
from wbik.expectations import Rule, judge
from wbik.motion.walking.figures import walk_figures
from wbik.motion.walking.footsteps import Feet, StepCommand, sole_polygon, yaw_of
from wbik.motion.walking.pattern import PreviewSettings
from wbik.motion.walking.physics import Measured, Servos
from wbik.motion.walking.placo_pattern import placo_walk
from wbik.motion.walking.pushes import DIRECTIONS, PushSettings, physics_compared, players, push_description
from wbik.motion.walking.stabiliser import PhysicsSettings, StabiliserGains, physics_figures, servo_lead
from wbik.motion.walking.static_gait import retimed, static_gait
from wbik.motion.walking.step_adaptation import StepAdaptation
from wbik.motion.walking.timeline import Timing
from wbik.motion.walking.tracking import Tracker, TrackingSettings, leg_collision_model, trunk_frame, walk
from wbik.mujoco_model import carrier
from wbik.qp.task_entries import FRAME, VECTOR3
from wbik.scenarios.kinds import KindRun, Progress, ScenarioKind, ScenarioReport, format_entries, start_of
from wbik.scenarios.schema import (
    START,
    Robot,
    apply_soles,
    backend_key,
    check_robot_params,
    common_keys,
    expect_block,
    margin_key,
    soles_key,
)
from wbik.schema import Boolean, Context, Either, Key, ListOf, Map, Number, Text, default_of, from_dataclass
from wbik.viz.animation import Animation, Overlays

__all__ = ["COMPARED", "SCENARIO_KINDS", "WALK_RULES", "format_report", "run_walk", "physics_keys",
           "walk_schema"]

WALK_RULES = {  # a walk on the full model, and its speed against the static gait on the same footsteps
    "zmp_margin_min_m": Rule("zmp_margin_min_m", ">=", "m"),
    "zmp_margin_p5_min_m": Rule("zmp_margin_p5_m", ">=", "m"),
    "com_error_max_m": Rule("com_error_max_m", "<=", "m"),
    "foot_slip_max_m": Rule("foot_slip_max_m", "<=", "m"),
    "swing_clearance_min_m": Rule("swing_clearance_min_m", ">=", "m"),
    "swing_height_min_m": Rule("swing_height_min_m", ">=", "m"),
    "velocity_ratio_max": Rule("joint_velocity_over_limit", "<="),
    "limit_excess_max_rad": Rule("joint_limit_excess_max_rad", "<=", "rad"),
    "leg_distance_min_m": Rule("leg_distance_min_m", ">=", "m"),
    "qp_failures_max": Rule("qp_failures", "<="),
    "speed_ratio_min": Rule("speed_ratio_vs_static", ">="),
    "physics_fell": Rule("physics_fell", "=="),
    "physics_cop_margin_min_m": Rule("physics_cop_margin_min_m", ">=", "m"),
    "physics_pushed_fell": Rule("physics_pushed_fell", "=="),
}

COMPARED = ("static", "static_balanced", "placo", "placo_ours")
ANIMATION_SAMPLE_S = 0.02  # s between two samples of the animation (the viewer interpolates)
STATIC_SPEEDS = tuple(40.0 / math.sqrt(2.0) ** n for n in range(12))  # rpm tried by static_balanced


def _spec_objects(spec: dict, robot):
    """(feet, timing, preview settings, tracking settings) of a checked spec."""
    feet_spec = spec["feet"] or {}
    feet = Feet.of(robot, feet_spec.get("left"), feet_spec.get("right"))
    capsules = tuple(capsule(f"leg_capsule_{index}", item["frame"], item["start"], item["end"],
                             item["radius"]) for index, item in enumerate(spec["leg_capsules"]))
    settings = TrackingSettings(trunk=spec["trunk"], locked=tuple(spec["locked"]), leg_capsules=capsules,
                                **spec["tracking"])
    return feet, Timing(**spec["timing"]), PreviewSettings(**spec["preview"]), settings


def _ticks(times: np.ndarray) -> dict:
    return {"median_s": float(np.median(times)), "p95_s": float(np.percentile(times, 95)),
            "max_s": float(np.max(times))}


def run_walk(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Every walk of a checked spec."""
    run = KindRun(spec, "walks", on_progress, figures={"backend": spec["backend"]})
    robot, q0 = run.robot, start_of(spec, run.robot)
    feet, _, preview, settings = _spec_objects(spec, robot)
    collisions = leg_collision_model(robot, feet, settings.leg_capsules) if settings.self_collision else None
    margin = float(spec["margin"])
    for item in spec["walks"]:
        command = StepCommand(item["steps"], item["length"], item["lateral"], item["turn_deg"], item["first"])
        timing = Timing(**{**spec["timing"], **(item["timing"] or {})})
        motion = walk(robot, q0, command, timing, spec["dt"], spec["clearance"], feet, preview,
                      spec["com_height"], settings, spec["zmp_forward"], spec["backend"], spec["feedforward"])
        pattern = motion.pattern
        figures, series = walk_figures(robot, feet, pattern.times, motion.q, pattern.support,
                                       pattern.ground_z, margin, pattern.com, collisions)
        figures["qp_failures"] = len(motion.failed)
        lipm = min(sole_polygon(robot, pattern.stance(k)).margin_of(pattern.lipm_zmp[k])
                   for k in range(pattern.ticks))  # the pendulum's ZMP in the planned support
        entry = {"name": item["name"] or f"{command.kind}: {command.steps} steps", "kind": command.kind,
                 "footsteps": len(pattern.footsteps), **figures, "lipm_zmp_margin_min_m": lipm,
                 "tick_time": {"pattern": _ticks(pattern.tick_time_s[1:]),
                               "wholebody_step": _ticks(motion.step_time_s[1:]),
                               "both": _ticks(motion.tick_time_s[1:])},
                 "plan_cpu_s": pattern.info["plan_cpu_s"],
                 "collision_pairs": motion.collision_pairs,
                 "settings": {**asdict(timing), "dt": spec["dt"], "clearance_m": spec["clearance"],
                              "com_height_m": pattern.com_height,
                              "feedforward": spec["feedforward"]}}
        solved: dict = {}  # what this walk's comparisons share
        compared = {label: _compare(label, spec, robot, q0, pattern, feet, timing, settings, margin, solved)
                    for label in item["compare"]}
        if compared:
            entry["compared"] = compared
        for label in ("static", "static_balanced"):
            if compared.get(label, {}).get("duration_s"):
                entry[f"speed_ratio_vs_{label}"] = compared[label]["duration_s"] / entry["duration_s"]
        default = {"zmp_margin_min_m": margin, "qp_failures_max": 0}
        wanted = {**(default if spec["expect"] is None else spec["expect"]), **(item["expect"] or {})}
        judged = dict(entry)
        simulated = None
        if spec["physics"] is not None:  # in physics too: standing, the CoP as far inside as the ZMP
            entry["physics"], simulated = _in_physics(spec, motion, q0, feet, settings, solved)
            wanted = {"physics_fell": False, "physics_cop_margin_min_m": margin, **wanted}
            judged.update(physics_fell=entry["physics"]["fell"],
                          physics_cop_margin_min_m=entry["physics"]["cop_margin_min_m"])
            if "pushed" in entry["physics"]:
                wanted = {"physics_pushed_fell": False, **wanted}
                judged["physics_pushed_fell"] = any(f["fell"] for f in entry["physics"]["pushed"].values())
        judge(entry, wanted, judged, WALK_RULES, f"walks[{entry['name']!r}] expect")
        support = tuple(tuple(s) for s in pattern.support)
        animation = Animation(robot, pattern.times, motion.q, Overlays(settings.trunk, support, support,
                                                                       series["zmp"]), entry["name"])
        if simulated is not None and simulated.configurations:  # the simulated robot instead of the plan
            animation = simulated_animation(animation, simulated, f"{entry['name']} (simulated, closed loop)")
        run.add(entry, animation.subsampled(max(1, round(ANIMATION_SAMPLE_S / pattern.dt))))
    return run.finished()


def simulated_animation(planned: Animation, simulated: Measured, name: str) -> Animation:
    """The simulated robot tick by tick up to the plan's end (the settling after it is in the figures only)
    with the measured CoP and the pushes, the plan's support and ZMP at the same times."""
    kept = int(np.searchsorted(simulated.times, planned.times[-1] + 1e-9))
    times = np.asarray(simulated.times[:kept])
    index = np.minimum(np.searchsorted(planned.times, times - 1e-9), planned.frames - 1)
    support = None if planned.overlays.support is None else tuple(planned.overlays.support[k] for k in index)
    zmp = None if planned.overlays.zmp is None else planned.overlays.zmp[index]
    overlays = Overlays(planned.overlays.trace_frame, support, support, zmp, np.array(simulated.cops[:kept]),
                        tuple(simulated.pushes))
    return Animation(planned.robot, times, np.array(simulated.configurations[:kept]), overlays, name)


def _physics_settings(given: dict) -> PhysicsSettings:
    steps = given["step_adaptation"]
    return PhysicsSettings(Servos(**given["servos"]), StabiliserGains(**given["stabiliser"]),
                           given["timestep"], given["friction"], given["settle_s"],
                           given["torque_feedforward"],
                           None if steps is None else StepAdaptation(**steps), given["contact_time_constant"])


def _in_physics(spec: dict, motion, q0, feet: Feet, settings: TrackingSettings, solved: dict
                ) -> tuple[dict, Measured]:
    """The walk in physics, closed and open loop, PlaCo's compared walks open loop, each pushed if asked: the
    figures and the closed loop's run to play (with the first stated push where there is one)."""
    robot, pattern, physics = motion.pattern.robot, motion.pattern, _physics_settings(spec["physics"])
    given = spec["physics"]["push"]
    push = None if given is None else PushSettings(**{**given, "directions": tuple(given["directions"])})
    tracker = Tracker(robot, feet, q0, settings, spec["backend"])
    lead = servo_lead(motion, physics)  # the plan's torques over kp: our runs only, not PlaCo's
    figures, simulated = physics_figures(motion, tracker, q0, physics, lead)
    placo = {label: solved[label] for label in ("placo", "placo_ours") if label in solved}
    plays = players(motion, lambda: Tracker(robot, feet, q0, settings, spec["backend"]), q0, physics, placo,
                    lead)
    walks = {"closed_loop": (pattern.support, pattern.dt, motion.q), "open_loop": (pattern.support,
             pattern.dt, motion.q), **{label: (walk.support, float(walk.times[1] - walk.times[0]), walk.q)
                                       for label, walk in placo.items()}}
    body = carrier(robot, robot.frame_id(tracker.trunk))[0]
    pushed = physics_compared(figures, plays, walks, push, body,
                              yaw_of(robot.frame_placement(q0, feet.left).rotation))
    if push is not None:
        figures["push"] = push_description(push, body)
    return figures, simulated if pushed is None else pushed


def _compare(label: str, spec: dict, robot, q0, pattern, feet, timing, settings, margin,
             solved: dict) -> dict:
    """The figures of one compared generator on the pattern's footsteps (``solved``: the static gait)."""
    dt = spec["dt"]
    trunk = trunk_frame(robot, settings)
    if label in ("static", "static_balanced"):
        if "static" not in solved:
            static = spec["static"]
            solved["static"] = static_gait(robot, q0, pattern.footsteps, feet, trunk, spec["clearance"],
                                           margin, static["inset"], static["divisions"], static["speed_rpm"],
                                           settings.locked, spec["backend"])
        gait = solved["static"]
        figures: dict = {"generator": "quasi-static gait (CoM over the stance sole, "
                                      f"{margin * 1e3:g} mm margin, one IK per division)"}
        if label == "static":
            found, _ = walk_figures(robot, feet, *gait.resample(dt), pattern.ground_z, margin)
            return {**figures, "timing": f"servo speed {gait.info['speed_rpm']:g} rpm, rest at every sample",
                    "samples_solved": len(gait.q) - 1,
                    "com_margin_min_m": float(np.nanmin(gait.com_margin_m)), **found}
        return {**figures, **_balanced(gait, robot, feet, pattern, margin, dt)}
    if label not in solved:  # kept for the walk in physics
        solved[label] = placo_walk(robot, q0, pattern.footsteps, feet, trunk,
                                   "placo" if label == "placo" else "ours", timing, spec["clearance"], margin,
                                   spec["preview"]["horizon_s"], dt, spec["placo"]["iterations"])
    placo = solved[label]
    found, _ = walk_figures(robot, feet, placo.times, placo.q, placo.support, pattern.ground_z, margin,
                            placo.com)
    setting = "defaults" if label == "placo" else "ours"
    return {"generator": f"PlaCo's walk pattern generator and IK ({setting})",
            "parameters": placo.parameters, "plan_time_s": placo.plan_time_s,
            "tick_time": _ticks(placo.tick_time_s[1:]), **found}


def _balanced(gait, robot, feet, pattern, margin, dt) -> dict:
    """The static gait at the fastest of ``STATIC_SPEEDS`` (stops at phase ends) that keeps the margin."""
    base = retimed(gait, STATIC_SPEEDS[0], "waypoint")
    for rpm in STATIC_SPEEDS:
        found, _ = walk_figures(robot, feet, *retimed(base, rpm, "waypoint").resample(dt), pattern.ground_z,
                                margin)
        if found["zmp_margin_min_m"] >= margin:
            return {"timing": f"servo speed {rpm:.3g} rpm, stops at phase ends only", "speed_rpm": rpm,
                    **found}
    return {"timing": f"no speed down to {STATIC_SPEEDS[-1]:.3g} rpm keeps the margin", "duration_s": None}


def format_report(report: dict) -> str:
    """Per walk: its figures, the compared generators' and the checks."""
    def describe(entry: dict) -> str:
        ticks = entry["tick_time"]["both"]
        lines = [f"{entry['footsteps']} footsteps, {entry['distance_m'] * 1e3:.0f} mm, "
                 f"turn {entry['turn_deg']:.1f} deg in {entry['duration_s']:.2f} s "
                 f"({entry['speed_m_s'] * 1e3:.0f} mm/s)", _line("ours", entry),
                 f"per 10 ms tick (pattern + whole-body step): median {ticks['median_s'] * 1e3:.3f} ms, "
                 f"p95 {ticks['p95_s'] * 1e3:.3f} ms, max {ticks['max_s'] * 1e3:.3f} ms",
                 *(_line(label, figures) for label, figures in entry.get("compared", {}).items())]
        if "physics" in entry:
            lines.append(_physics_line(entry["physics"]))
        if "speed_ratio_vs_static" in entry:
            slowed = entry.get("speed_ratio_vs_static_balanced")
            lines.append(f"speed vs static gait: {entry['speed_ratio_vs_static']:.2f}x" + (
                "" if slowed is None else f" (vs the static gait slowed until balanced: {slowed:.1f}x)"))
        return "\n      ".join(lines)

    return format_entries(report, "walks", describe)


def _physics_line(physics: dict) -> str:
    def run(figures: dict) -> str:
        fell = f"FELL at {figures['fell_at_s']:.2f} s" if figures["fell"] else "stood"
        margin = figures["cop_margin_min_m"]
        travel = (f", {figures['base_travel_m'] * 1e3:.0f} of {figures['planned_travel_m'] * 1e3:.0f} mm"
                  if "base_travel_m" in figures else "")
        sooner = (f", a touch-down up to {figures['touch_down_sooner_max_s']:.2f} s sooner"
                  if figures.get("touch_down_sooner_max_s") else "")
        cpu = f"controller CPU per tick max {(figures.get('tick_cpu_max_s') or 0.0) * 1e3:.2f} ms"
        moved = (f", steps moved up to {figures['step_move_max_m'] * 1e3:.0f} mm{sooner} ({cpu})"
                 if figures.get("step_move_max_m") else "")
        return f"{fell}, CoP margin min {'-' if margin is None else f'{margin * 1e3:.1f}'} mm{travel}{moved}"

    ticks = physics["tick_cpu"]
    line = (f"physics: closed loop {run(physics)} (controller CPU per tick median "
            f"{ticks['median_s'] * 1e3:.2f} ms, p95 {ticks['p95_s'] * 1e3:.2f} ms); open loop "
            f"{run(physics['open_loop'])}; "
            f"push {physics['push_impulse_n_s']:g} N s"
            + ("; the planned joint torques fed forward" if physics.get("torque_feedforward") else ""))
    line += "".join(f"\n      physics, {label} open loop: {run(figures)}"
                    for label, figures in physics.get("compared", {}).items())
    if "push" in physics:
        push = physics["push"]
        line += "".join(f"\n      pushed {direction} {figures['push_impulse_n_s']:g} N s over "
                        f"{push['duration_s']:g} s at {push['body']} ({figures['at_s']:.2f} s), closed loop: "
                        f"{run(figures)}"
                        for direction, figures in physics["pushed"].items())
        runs = {"closed loop": physics, "open loop": physics["open_loop"], **physics.get("compared", {})}
        largest = [f"{label} " + " / ".join(f"{value:.3g}" for value in found.values())
                   for label, found in ((label, figures.get("largest_push_recovered_n_s"))
                                        for label, figures in runs.items()) if found]
        if largest:
            line += (f"\n      largest push recovered ({' / '.join(push['directions'])}, N s): "
                     + ", ".join(largest))
    return line


def _line(label: str, figures: dict) -> str:
    if figures.get("duration_s") is None:
        return f"{label}: {figures.get('timing', 'not run')}"
    down = len(figures["zmp_margin_min_support"])
    parts = [f"{label}: {figures['duration_s']:.2f} s",
             f"ZMP margin min {figures['zmp_margin_min_m'] * 1e3:.1f} mm "
             f"(at {figures['zmp_margin_min_at_s']:.2f} s, {down} {'foot' if down == 1 else 'feet'} down) "
             f"p5 {figures['zmp_margin_p5_m'] * 1e3:.1f} mm"]
    if figures["samples_without_zmp"]:
        parts.append(f"{figures['samples_without_zmp']} samples with no ZMP (the feet would have to pull)")
    if "com_error_max_m" in figures:
        parts.append(f"CoM error {figures['com_error_max_m'] * 1e3:.2f} mm")
    parts.append(f"slip {figures['foot_slip_max_m'] * 1e3:.3f} mm")
    if figures.get("swing_clearance_min_m") is not None:
        parts.append(f"clearance {figures['swing_clearance_min_m'] * 1e3:.1f} mm")
    parts.append(f"peaks {figures['joint_velocity_peak_rad_s']:.2f} rad/s, "
                 f"{figures['joint_acceleration_peak_rad_s2']:.0f} rad/s^2")
    return ", ".join(parts)


# -- the schema ------------------------------------------------------------------------------------
def physics_keys() -> dict[str, Key]:
    """The keys of a ``physics`` block every scene shares: ``servos`` (:class:`Servos`), ``timestep``,
    ``friction``, ``settle_s``, ``contact_time_constant`` (:class:`PhysicsSettings`)."""
    servos = from_dataclass(Servos, {
        "kp": Number(gt=0, unit="N m/rad"), "kv": Number(ge=0, unit="N m s/rad"),
        "damping": Number(ge=0, unit="N m s/rad"), "torque_limit": Number(gt=0, nullable=True, unit="N m"),
        "armature": Number(ge=0, unit="kg m^2"), "resolution": Number(ge=0, unit="rad")})
    return {"servos": Key(servos, required=True),
            **{name: Key(node, getattr(PhysicsSettings(Servos(1.0)), name)) for name, node in (
                ("timestep", Number(gt=0, le=0.01, unit="s")), ("friction", Number(gt=0)),
                ("settle_s", Number(ge=0, unit="s")),
                ("contact_time_constant", Number(gt=0, nullable=True, unit="s")))}}


def walk_schema() -> Map:
    """The keys of a ``walk`` file."""
    defaults = TrackingSettings()
    tracking = Map({name: Key(Number(gt=0), getattr(defaults, name))
                    for name in ("com_weight", "foot_weight", "trunk_weight", "posture_weight",
                                 "regularization")}
                   | {"self_collision": Key(Boolean(), defaults.self_collision),
                      "safety_distance": Key(Number(ge=0, unit="m"), defaults.safety_distance),
                      "velocity_limits": Key(Boolean(), defaults.velocity_limits)}, nullable=True)
    command = StepCommand()
    one = Map({"name": Key(Text(), ""),
               "steps": Key(Number(ge=0, integer=True), command.steps),
               "length": Key(Number(unit="m"), command.length),
               "lateral": Key(Number(unit="m"), command.lateral),
               "turn_deg": Key(Number(ge=-45, le=45, unit="deg"), command.turn_deg),
               "first": Key(Text(("left", "right"), nullable=True), None),
               "timing": Key(Map({name: Key(Number(ge=0, unit="s")) for name in from_dataclass(Timing).keys},
                                 nullable=True), None),
               "compare": Key(ListOf(Text(COMPARED)), []),
               "expect": Key(expect_block(WALK_RULES), None)})
    point = Key(Either(FRAME, VECTOR3), required=True)
    capsules = ListOf(Map({"frame": Key(FRAME, required=True), "start": point, "end": point,
                           "radius": Key(Number(gt=0, unit="m"), required=True)}),
                      what="capsules {frame, start, end, radius} on the legs")
    static = Map({"divisions": Key(Number(ge=1, integer=True), default_of(static_gait, "divisions")),
                  "speed_rpm": Key(Number(gt=0, unit="rpm"), default_of(static_gait, "speed_rpm")),
                  "inset": Key(Number(ge=0, unit="m", nullable=True), None)}, nullable=True)
    placo = Map({"iterations": Key(Number(ge=1, integer=True), default_of(placo_walk, "iterations"))},
                nullable=True)
    physics = Map({**physics_keys(),
                   "stabiliser": Key(from_dataclass(StabiliserGains, {
                       "dcm": Number(ge=0), "attitude": Number(ge=0),
                       "time_constant_s": Number(ge=0, unit="s"),
                       "com_offset_max": Number(ge=0, unit="m")}), {}),
                   "push": Key(from_dataclass(PushSettings, {
                       "impulse_n_s": Number(ge=0, unit="N s"), "step": Number(ge=1, integer=True),
                       "phase": Number(ge=0, le=1), "duration_s": Number(gt=0, unit="s"),
                       "directions": ListOf(Text(tuple(DIRECTIONS))),
                       "search_up_to_n_s": Number(ge=0, unit="N s"),
                       "resolution_n_s": Number(ge=0, unit="N s")}), None,
                               doc="pushes on the trunk, and the search for the largest recovered"),
                   "torque_feedforward": Key(Boolean(), PhysicsSettings(Servos(1.0)).torque_feedforward,
                                             doc="the planned joint torques over kp added to the targets"),
                   "step_adaptation": Key(from_dataclass(StepAdaptation, {
                       "gain": Number(ge=0), "threshold_m": Number(ge=0, unit="m"),
                       "offset_max_m": Number(ge=0, unit="m"), "min_remaining_s": Number(ge=0, unit="s"),
                       "change_m": Number(ge=0, unit="m"), "sooner_max_s": Number(ge=0, unit="s")}), None,
                                          doc="the closed loop moves the steps by the predicted DCM error")},
                  nullable=True)
    walks = ListOf(one, min_items=1, what="walk mappings {name, steps, length, lateral, turn_deg, first, "
                                          "timing, compare, expect}")

    def post(spec: dict, path: str, ctx: Context) -> None:
        check_robot_params(spec, path, ctx)
        apply_soles(spec, path, ctx)
        for index, item in enumerate(spec["walks"]):
            if "speed_ratio_min" in (item["expect"] or {}) and "static" not in item["compare"]:
                ctx.fail(f"walks[{index}].expect.speed_ratio_min",
                         "needs 'static' in this walk's compare list")

    return Map({**common_keys(robot=Key(Robot(), required=True)),
                "soles": soles_key(), "start": Key(START, "nominal"),
                "feet": Key(Map({"left": Key(FRAME, required=True), "right": Key(FRAME, required=True)},
                                nullable=True), None),
                "trunk": Key(Text(what="a frame name", nullable=True), None),
                "locked": Key(ListOf(Text(what="a joint name")), []),
                "leg_capsules": Key(capsules, []),
                "dt": Key(Number(gt=0, le=0.1, unit="s"), default_of(walk, "dt")),
                "timing": Key(Map(from_dataclass(Timing).keys, nullable=True), {}),
                "clearance": Key(Number(ge=0, unit="m"), default_of(walk, "clearance")),
                "zmp_forward": Key(Number(unit="m"), default_of(walk, "zmp_forward")),
                "com_height": Key(Number(gt=0, nullable=True, unit="m"), None),
                "preview": Key(Map(from_dataclass(PreviewSettings).keys, nullable=True), {}),
                "feedforward": Key(Boolean(), default_of(walk, "feedforward"),
                                   doc="the reference from rest and with the swing leg's angular momentum"),
                "tracking": Key(tracking, {}),
                "margin": margin_key(),
                "backend": backend_key(),
                "static": Key(static, {}), "placo": Key(placo, {}), "walks": Key(walks, required=True),
                "physics": Key(physics, None, doc="the walk in MuJoCo, closed and open loop"),
                "expect": Key(expect_block(WALK_RULES), None)}, post=post)


SCENARIO_KINDS = (
    ScenarioKind("walk", run_walk, walk_schema, format_report,
                 "dynamic walk (preview control + whole-body QP), judged by the multibody ZMP"),
)
