"""Scenario kinds of the Bioloid behaviours (tasks/bioloid_*.yaml, tasks/motion_bioloid_foot_sensors.yaml):
their schemas, runners and printed report, registered in ``SCENARIO_KINDS`` (see
:mod:`wbik.scenarios.kinds`); every runner reads the spec checked against its kind's schema.

Kinds (each report's figures have a ``behaviours`` list; the stance's a ``moves`` list):

- ``bioloid_step``: the thesis's step forward. ``generators: [faithful, wholebody]`` (default both),
  ``first: left|right``, ``margin`` (m), ``rear_lift`` (m), ``gait`` (overrides of
  :class:`~wbik.apps.bioloid.gait.GaitParameters`), ``timing: {speed_rpm, law, mode}``,
  ``export: {servo_csv: PATH, dt: S}``. ``expect: {faithful: {...}, wholebody: {...}}`` with the
  keys of ``FAITHFUL_RULES`` and ``WHOLEBODY_RULES``.
- ``bioloid_walk``: ``steps`` forward then ``turn_deg`` (0 = none), whole-body; ``bioloid_turn``:
  ``turn_deg`` in place. Same timing/export keys; ``expect`` has the keys of ``WHOLEBODY_RULES``.
- ``bioloid_keyframes``: replay ``behaviours`` of the keyframe file ``keyframes`` (default
  tasks/data/bioloid_keyframes.yaml); ``expect`` has the keys of ``KEYFRAME_RULES`` for every
  behaviour, and ``behaviours: {NAME: {...}}`` for one behaviour's own thresholds.
- ``bioloid_placo_walk``: PlaCo's walk pattern generator on the same URDF (``steps``, ``step_length``,
  ``margin``); see :mod:`wbik.apps.bioloid.placo_walk`; ``expect`` has the keys of ``PLACO_WALK_RULES``.
- ``bioloid_half_steps``: the half steps of ``sequence``; ``bioloid_stairs``: the sensor-driven
  stair climb (``stairs``: the fields of :class:`~wbik.apps.bioloid.stairs.Staircase`).
- ``bioloid_stance_sensors``: expected FSR loads and centre of pressure of the static stance at
  ``start``; ``expect`` has the key of ``STANCE_RULES`` (default: CoP on the CoM projection to
  ``tolerance``).

Defaults are the ones of the functions the keys feed (:func:`wbik.scenario_schema.default_of`):
``timing`` those of :func:`~wbik.apps.bioloid.gait.time_scale_motion` (40 rpm, quintic, "segment": rest
at every sample like the seed code), ``steps``/``turn_deg``/``first``/``rear_lift`` those of
:func:`~wbik.apps.bioloid.behaviours.walk` and :func:`~wbik.apps.bioloid.behaviours.turn_in_place`, and so on;
``margin`` and ``backend`` are the scenario-wide ones (:func:`wbik.scenario_schema.margin_key`,
:func:`~wbik.scenario_schema.backend_key`).

Each runner's report carries a :class:`wbik.viz.animation.Animation` (what ``wbik view`` plays):
the whole-body samples at their timed knot times (40 rpm), the faithful step's samples
``FAITHFUL_SAMPLE_S`` apart, the keyframe rows at their own times, PlaCo's walk on its 50 ms grid,
the stance as one still sample; the soles on the ground at each sample are its support and contacts.

Each figure with a meaning of good or bad is judged by :mod:`wbik.expectations` against the task
file's threshold (SI: m, rad), and printed as figure / threshold / ok. A whole-body behaviour
without an ``expect`` block still expects what its generator guarantees: contacts held to 1e-6 m /
rad, the CoM ``margin`` inside the support polygon, no joint beyond its limit, and the timed servo
trajectory under the speed limit (checked on a 1 ms grid). A behaviour with nothing to judge is
reported as informational.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wbik.data import data_dir
from wbik.expectations import ExpectationError
from wbik.expectations import Rule
from wbik.expectations import judge
from wbik.scenario_schema import START
from wbik.scenario_schema import Robot
from wbik.scenario_schema import backend_key
from wbik.scenario_schema import common_keys
from wbik.scenario_schema import expect_block
from wbik.scenario_schema import kind_schema
from wbik.scenario_schema import margin_key
from wbik.scenario_schema import time_laws
from wbik.scenario_schema import timing_modes
from wbik.scenarios.kinds import KindRun
from wbik.scenarios.kinds import Progress
from wbik.scenarios.kinds import ScenarioKind
from wbik.scenarios.kinds import ScenarioReport
from wbik.scenarios.kinds import format_entries
from wbik.scenarios.kinds import start_of
from wbik.scenarios.wholebody import CONTACT_TOLERANCE
from wbik.schema import Boolean
from wbik.schema import Key
from wbik.schema import ListOf
from wbik.schema import Map
from wbik.schema import Number
from wbik.schema import Text
from wbik.schema import default_of
from wbik.schema import from_dataclass

VELOCITY_TOLERANCE = 1e-9
FAITHFUL_SAMPLE_S = 0.2
"""s between two samples of the faithful step's animation (the faithful generator is not timed)."""

FAITHFUL_RULES = {
    "closed_chain_mismatch_min_m": Rule("max_inconsistency_m", ">=", "m"),
    "com_margin_min_m": Rule("min_com_margin_m", ">=", "m"),
    "clearance_min_m": Rule("min_clearance_m", ">=", "m"),
    "limit_excess_max_rad": Rule("max_limit_excess_rad", "<=", "rad"),
    "unreachable_samples_max": Rule("unreachable_samples", "<="),
}
"""The faithful step: the double-support mismatch it must show (a closed chain would have none),
the CoM margin in the planted soles, the lifted sole's lowest corner above the floor, joint limits."""

SAMPLE_RULES = {
    "contact_error_max_m": Rule("max_contact_error_m", "<=", "m"),
    "contact_error_max_rad": Rule("max_contact_error_rad", "<=", "rad"),
    "com_margin_min_m": Rule("min_com_margin_m", ">=", "m"),
    "limit_excess_max_rad": Rule("max_limit_excess_rad", "<=", "rad"),
}
"""Every sample of a whole-body behaviour by FK: contacts held, the CoM margin, joint limits (the
figures :func:`sample_guarantees` bounds by default)."""

WHOLEBODY_RULES = {
    **SAMPLE_RULES,
    "velocity_ratio_max": Rule("peak_velocity_over_limit", "<="),
    "servo_clamp_max_rad": Rule("max_servo_clamp_rad", "<=", "rad"),
}
"""A whole-body behaviour: every sample by FK, then the timed servo trajectory."""

KEYFRAME_RULES = {
    "units_round_trip_exact": Rule("units_round_trip_exact", "=="),
    "rows_beyond_urdf_limits_max": Rule("rows_beyond_urdf_limits", "<="),
    "rows_beyond_servo_limits_max": Rule("rows_beyond_servo_limits", "<="),
    "com_margin_single_min_m": Rule("min_com_margin_single_m", ">=", "m"),
}
"""A keyframe replay: servo units map back exactly, rows inside the limits, the static CoM margin
in the lower sole."""

PLACO_WALK_RULES = {
    "planned": Rule("planned", "=="),
    "step_advance_max_m": Rule("max_step_advance_m", "<=", "m"),
    "com_margin_min_m": Rule("min_com_margin_m", ">=", "m"),
    "zmp_margin_min_m": Rule("min_zmp_margin_m", ">=", "m"),
    "multibody_zmp_margin_min_m": Rule("multibody_zmp_margin_min_m", ">=", "m"),
}
"""PlaCo's walk: planned, steps no longer than asked, CoM and ZMP margins in the feet on the ground (the
plan's pendulum ZMP, and the multibody ZMP of PlaCo's IK following it)."""


def sample_guarantees(margin: float) -> dict:
    """What a whole-body generator guarantees at every sample by FK: contacts held to
    ``CONTACT_TOLERANCE`` (m, rad), the CoM ``margin`` inside the support (less 1e-9 m), no joint
    beyond its limit (1e-9 rad)."""
    return {"contact_error_max_m": CONTACT_TOLERANCE, "contact_error_max_rad": CONTACT_TOLERANCE,
            "com_margin_min_m": margin - 1e-9, "limit_excess_max_rad": 1e-9}


def wholebody_defaults(margin: float) -> dict:
    """What the whole-body generators guarantee (used under the task file's own thresholds): every
    sample's guarantees, and the timed servo trajectory under the speed limit."""
    return {**sample_guarantees(margin), "velocity_ratio_max": 1.0 + VELOCITY_TOLERANCE}


class _Behaviours(KindRun):
    """A Bioloid run in progress: the report's ``behaviours``, and the spec's gait, margin and
    ``expect`` block."""

    def __init__(self, spec: dict, on_progress: Progress = None):
        super().__init__(spec, "behaviours", on_progress)

    @property
    def gait(self):
        """The spec's :class:`~wbik.apps.bioloid.gait.GaitParameters` (every field checked by the schema)."""
        from wbik.apps.bioloid.gait import GaitParameters

        return GaitParameters(**self.spec["gait"])

    @property
    def margin(self) -> float:
        return float(self.spec["margin"])

    @property
    def expect(self) -> dict:
        """The ``expect`` block (its keys were checked by wbik.scenario_schema), {} when absent."""
        return self.spec["expect"] or {}


def _timed(spec: dict, motion):
    """The sampled motion timed by the spec's ``timing``
    (:func:`wbik.apps.bioloid.gait.time_scale_motion`)."""
    from wbik.apps.bioloid.gait import time_scale_motion

    timing = spec["timing"]
    return time_scale_motion(motion, timing["speed_rpm"], timing["law"], timing["mode"])


def _final_soles(robot, q: np.ndarray) -> dict:
    """Where the two soles are at ``q`` (world, m)."""
    return {sole: robot.frame_placement(q, sole).translation.tolist() for sole in ("r_sole", "l_sole")}


def _motion_animation(motion, times, name: str, trace_frame: str | None = None):
    """A sampled motion (wbik.apps.bioloid.gait.SampledMotion) at ``times``: its soles on the ground are
    the support and the contacts of every sample."""
    from wbik.viz.animation import Animation
    from wbik.viz.animation import Overlays

    times = np.asarray(times, dtype=float)
    keep = np.r_[np.diff(times) > 0, True]  # a sample that did not move has the next one's time
    support = tuple(tuple(feet) for feet, kept in zip(motion.support, keep, strict=True) if kept)
    return Animation(motion.robot, times[keep], motion.q[keep], Overlays(trace_frame, support, support), name)


def _timed_entry(spec: dict, result, name: str, expect: dict | None) -> tuple[dict, object]:
    """Summary, timing, servo export and expectations of a whole-body result; the entry and the
    animation of its samples at their knot times."""
    timed = _timed(spec, result.motion)
    ratio = timed.peak_velocity_ratio()
    entry = {"name": name, "generator": "wholebody", **result.summary(), "duration_s": timed.duration,
             "speed_rpm": spec["timing"]["speed_rpm"], "peak_velocity_over_limit": ratio}
    export = spec["export"]
    if export.get("servo_csv"):
        path = timed.write_servo_csv(export["servo_csv"], float(export["dt"]))
        entry["servo_csv"] = str(path)
    table = timed.servo_table(float(export["dt"]))
    entry["servo_rows"] = int(len(table["times_s"]))
    entry["servo_clamped"] = {joint: max(abs(r - a) for _, r, a in items)
                              for joint, items in table["clamped"].items()}
    entry.pop("passed", None)
    figures = {**entry, "min_com_margin_m": entry["min_com_margin_mm"] / 1e3,
               "max_servo_clamp_rad": max(entry["servo_clamped"].values(), default=0.0)}
    wanted = {**wholebody_defaults(float(spec["margin"])), **(expect or {})}
    animation = _motion_animation(result.motion, timed.sample_times, name, trace_frame="pelvis")
    return judge(entry, wanted, figures, WHOLEBODY_RULES, f"{name} expect"), animation


def run_step(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.apps.bioloid.step_faithful import step_forward_faithful
    from wbik.apps.bioloid.step_wholebody import step_forward_wholebody

    run = _Behaviours(spec, on_progress)
    first, margin, generators = spec["first"], run.margin, spec["generators"]
    if "faithful" in generators:
        rounding = bool(spec["round_degrees"])
        faithful = step_forward_faithful(run.robot, run.gait, first, round_degrees=rounding)
        summary = faithful.summary()
        entry = {"name": f"step forward ({first} first), faithful", "generator": "faithful", **summary,
                 "margin_mm": 1e3 * margin,
                 "samples_under_margin": int(sum(s["com_margin_m"] < margin for s in faithful.samples))}
        clearance = summary["min_clearance_mm"]
        figures = {**summary, "max_inconsistency_m": summary["max_inconsistency_mm"] / 1e3,
                   "min_com_margin_m": summary["min_com_margin_mm"] / 1e3,
                   "min_clearance_m": None if clearance is None else clearance / 1e3,
                   "max_limit_excess_rad": float(np.radians(summary["max_limit_excess_deg"]))}
        samples = len(faithful.motion.q)
        run.add(judge(entry, run.expect.get("faithful"), figures, FAITHFUL_RULES, "expect.faithful"),
                _motion_animation(faithful.motion, FAITHFUL_SAMPLE_S * np.arange(samples), entry["name"],
                                  trace_frame="pelvis"))
    if "wholebody" in generators:
        result = step_forward_wholebody(run.robot, run.gait, first, margin,
                                        rear_lift=float(spec["rear_lift"]), backend=spec["backend"])
        run.add(*_timed_entry(spec, result, f"step forward ({first} first), whole-body",
                              run.expect.get("wholebody")))
    return run.finished()


def run_walk(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.apps.bioloid.behaviours import turn_in_place
    from wbik.apps.bioloid.behaviours import walk

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
    from wbik.apps.bioloid.behaviours import replay_keyframes
    from wbik.apps.bioloid.servo import to_servo
    from wbik.robot_packages.bioloid.model import BioloidFacts

    run = _Behaviours(spec, on_progress)
    expect = dict(run.expect)
    own = expect.pop("behaviours", {}) or {}
    chosen = spec["behaviours"]
    if set(own) - set(chosen):
        raise ExpectationError(f"expect.behaviours names {sorted(set(own) - set(chosen))}, which are not "
                               f"replayed; replayed: {chosen}")
    for behaviour in chosen:
        replay = replay_keyframes(run.robot, behaviour, spec["keyframes"])
        motion = replay["motion"]
        names = motion.joint_names
        servo_ids = motion.robot.require_facts(BioloidFacts, "the keyframe replay").servo_ids
        exact, clamped_rows = True, 0
        for units, angles in zip(replay["units"], motion.joint_matrix(), strict=True):
            command = to_servo(dict(zip(names, angles, strict=True)))
            clamped_ids = {servo_ids[joint] for joint in command.clamped}
            clamped_rows += bool(clamped_ids)
            exact = exact and all(command.units[i] == int(u) for i, u in zip(range(1, 19), units, strict=True)
                                  if i not in clamped_ids)
        rows = replay["rows"]
        entry = {"name": f"keyframes {behaviour}", "rows": len(rows),
                 "duration_s": float(replay["times_s"][-1]),
                 "units_round_trip_exact": bool(exact),
                 "rows_beyond_urdf_limits": sum(bool(r["beyond_limits"]) for r in rows),
                 "rows_beyond_servo_limits": clamped_rows,
                 "max_other_sole_height_mm": 1e3 * max(r["other_sole_height_m"] for r in rows),
                 "min_com_margin_single_mm": 1e3 * min(r["com_margin_single_m"] for r in rows),
                 "source": replay["source"]}
        figures = {**entry, "min_com_margin_single_m": min(r["com_margin_single_m"] for r in rows)}
        wanted = {**expect, **(own.get(behaviour) or {})}
        run.add(judge(entry, wanted, figures, KEYFRAME_RULES, f"expect ({behaviour})"),
                _motion_animation(motion, replay["times_s"], f"keyframes {behaviour}"))
    return run.finished()


def run_placo_walk(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.apps.bioloid.placo_view import placo_walk_animation
    from wbik.apps.bioloid.placo_walk import placo_walk

    run = _Behaviours(spec, on_progress)
    result = placo_walk(run.robot, steps=int(spec["steps"]), step_length=float(spec["step_length"]),
                        margin=run.margin)
    entry = {"name": "PlaCo walk pattern generator", **result}
    figures = {**result}
    for key in ("max_step_advance", "min_com_margin", "min_zmp_margin", "multibody_zmp_margin_min"):
        if f"{key}_mm" in result:
            figures[f"{key}_m"] = result[f"{key}_mm"] / 1e3
    wanted = {"planned": True, **run.expect}
    animation = None
    if result.get("planned"):
        animation = placo_walk_animation(
            run.robot, steps=int(spec["steps"]), step_length=float(spec["step_length"]),
            margin=run.margin, footstep_x=result["footstep_x_m"])
    run.add(judge(entry, wanted, figures, PLACO_WALK_RULES, "expect"), animation)
    return run.finished()


def format_report(report: dict) -> str:
    """One line per behaviour with the figures that matter, and its checks."""
    hidden = ("name", "passed", "per_phase", "source", "final_soles", "expectations", "verdict")
    return format_entries(report, "behaviours", lambda entry: ", ".join(
        f"{k} {_short(v)}" for k, v in entry.items() if k not in hidden))


def _short(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) > 6:
        return f"[{len(value)} values]"
    return str(value)


def scenario_path(name: str) -> Path:
    """tasks/NAME.yaml shipped with wbik (the repository's, or the installed package's copy)."""
    return data_dir("tasks") / f"{name}.yaml"


# -- half steps and stairs (wbik.apps.bioloid.half_steps, wbik.apps.bioloid.stairs) ------------------

STAIR_RULES = {
    "reached_top": Rule("reached_top", "=="),
    "reached_bottom": Rule("reached_bottom", "=="),
    **SAMPLE_RULES,
    "clearance_min_m": Rule("min_clearance_m", ">=", "m"),
    "penetration_max_m": Rule("max_penetration_m", "<=", "m"),
}
"""The stair run: the top reached (and the floor beyond, down again, for a staircase that
``descend``s), and at every sample by FK contacts held, the CoM margin, joint limits, the swing
sole's distance to the step edges, no sole corner below the surface under it."""


def run_half_steps(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Kind ``bioloid_half_steps``: the half steps of ``sequence`` one after the other, each judged
    like a whole-body behaviour (``expect`` with the keys of ``WHOLEBODY_RULES``, for each)."""
    from wbik.apps.bioloid.half_steps import half_step_phases
    from wbik.apps.bioloid.step_wholebody import current_soles
    from wbik.apps.bioloid.step_wholebody import solve_phases

    run = _Behaviours(spec, on_progress)
    robot, gait = run.robot, run.gait
    q = robot.nominal.copy()
    for name in spec["sequence"]:
        phases, _ = half_step_phases(robot, current_soles(robot, q), name, gait, spec["length"],
                                     float(spec["lift"]))
        result = solve_phases(robot, q, phases, run.margin, spec["backend"], name=name)
        entry, animation = _timed_entry(spec, result, name, run.expect)
        q = result.motion.q[-1].copy()
        entry["final_soles"] = _final_soles(robot, q)
        run.add(entry, animation)
    return run.finished()


def run_stairs(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Kind ``bioloid_stairs``: the sensor-driven stair behaviour on a simulated staircase
    (``stairs``: the fields of :class:`wbik.apps.bioloid.stairs.Staircase`), see
    :func:`wbik.apps.bioloid.stairs.simulate_stairs`. The entry has the states visited, the reads the
    state machine decided on, and one record per sample (state, Sharp and filtered FSR readings,
    CoM margin, swing-sole clearance to the step edges); ``expect`` has the keys of ``STAIR_RULES``.
    The animation has the samples at their timed knot times and the staircase's steps."""
    from wbik.apps.bioloid.stairs import Staircase
    from wbik.apps.bioloid.stairs import simulate_stairs

    run = _Behaviours(spec, on_progress)
    margin = run.margin
    stairs = Staircase(**spec["stairs"])
    climb = simulate_stairs(run.robot, stairs, run.gait, margin, spec["climbs"], backend=spec["backend"])
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
    animation = _motion_animation(climb.motion, timed.sample_times, "bioloid stairs", trace_frame="pelvis")
    run.add(judge(entry, wanted, dict(summary), STAIR_RULES, "expect"),
            animation.with_environment(climb.scene_boxes()))
    return run.finished()


# -- the static stance's foot sensors (wbik.apps.bioloid.sensors) ------------------------------------------
STANCE_RULES = {"cop_error_max_m": Rule("cop_minus_com_m", "<=", "m")}
"""The stance: its centre of pressure on the CoM's ground projection (statics: exact)."""


def run_stance_sensors(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Kind ``bioloid_stance_sensors``: the FSR loads and CoP of the static stance at ``start`` (one
    entry in ``moves``); the animation is that stance, one still sample on both soles."""
    from wbik.apps.bioloid.sensors import stance_loads
    from wbik.viz.animation import Animation
    from wbik.viz.animation import Overlays

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


def format_stance(report: dict) -> str:
    """The stance's CoP - CoM gap and its check."""
    return format_entries(report, "moves", lambda move: f"CoP - CoM {move['cop_minus_com_m']:.2e} m")


# -- the schemas -----------------------------------------------------------------------------------
def bioloid_schema(kind: str) -> Map:
    """The keys of a Bioloid kind's file (see the module docstring)."""
    from wbik.apps.bioloid.behaviours import turn_in_place
    from wbik.apps.bioloid.behaviours import walk
    from wbik.apps.bioloid.gait import GaitParameters
    from wbik.apps.bioloid.gait import TimedMotion
    from wbik.apps.bioloid.gait import time_scale_motion
    from wbik.apps.bioloid.half_steps import HALF_STEPS
    from wbik.apps.bioloid.half_steps import half_step_phases
    from wbik.apps.bioloid.placo_walk import placo_walk
    from wbik.apps.bioloid.stairs import Staircase
    from wbik.apps.bioloid.stairs import simulate_stairs
    from wbik.apps.bioloid.step_faithful import step_forward_faithful

    common = common_keys(robot=Key(Robot(only=("bioloid",)), "bioloid"))
    margin = {"margin": margin_key()}
    gait = {"gait": Key(Map(from_dataclass(GaitParameters).keys, nullable=True), {})}
    timed = {"timing": Key(Map({"speed_rpm": Key(Number(gt=0, nullable=True, unit="rpm"),
                                                 default_of(time_scale_motion, "speed_rpm")),
                                "law": Key(Text(time_laws), default_of(time_scale_motion, "law")),
                                "mode": Key(Text(timing_modes), default_of(time_scale_motion, "mode"))},
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
