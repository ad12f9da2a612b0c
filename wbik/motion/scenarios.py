"""Scenario kinds of robot motions (tasks/motion_*.yaml): their schemas, runners and printed report,
registered in ``SCENARIO_KINDS`` (see :mod:`wbik.scenarios.kinds`); every runner reads the spec
checked against its kind's schema.

Kinds (each report's figures have one entry per move in ``moves``):

- ``motion_joint``: joint-space interpolation through ``configurations`` (rad / m).
- ``motion_cartesian``: straight lines from ``start`` (joints or "nominal") through ``waypoints``
  (each [x, y, z] or {position, rpy}) with ``method``; ``samples`` per segment.
- ``pincher_motion``: a teleoperation session, ``moves`` run one after another from the previous
  end: {jog: JOINT, delta_deg: D}, {plane_line: {start_xy_mm: [x, y], goal_xy_mm: [x, y]}},
  {automatic: {}}.
- ``golem3_approach``: straight approach from ``start`` (mb, m0, m10..m14) to ``grasp``
  ({position, rpy} in base_link, or {from_joints: [7 values]}); ``expect: {lift: bool}``.

Common keys: ``timing: {law, mode, velocity_limit, acceleration_limit, dt}`` (defaults those of
:func:`wbik.motion.timing.time_scale`: quintic, global; URDF limits, knot times), ``export: {csv:
PATH, json: PATH}`` (the trajectory of the last move, JointTrajectory shape), ``tolerance`` (knot
tracking, default 1e-6 m / rad) and ``expect`` with the keys of ``MOVE_RULES`` (thresholds SI,
judged by :mod:`wbik.expectations` for every move and printed as figure / threshold / ok). Unless
``expect`` sets them, a move expects success, the peak joint speed within the limit (1e-9) and,
when it has Cartesian knots, each knot tracked to ``tolerance``. ``samples`` defaults are those of
the path builders (:func:`wbik.motion.joint.joint_path`, ...).

Each runner's report carries a :class:`wbik.viz.animation.Animation` (what ``wbik view`` plays):
every move's timed trajectory (the chain's joints in the full configuration, the tip traced), the
moves one after the other.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.expectations import Rule, evaluate, format_checks, verdict
from wbik.motion.path import JointPath
from wbik.motion.timing import time_scale
from wbik.motion.trajectory import make_trajectory
from wbik.scenario_schema import (
    START,
    VECTOR3,
    Either,
    Key,
    ListOf,
    Map,
    Method,
    Number,
    Robot,
    ScenarioError,
    Text,
    Variants,
    Vector,
    check_robot_params,
    common_keys,
    default_of,
    expect_block,
    time_laws,
    timing_modes,
)
from wbik.scenarios.kinds import Progress, ScenarioKind, ScenarioReport, report_header

MOVE_RULES = {
    "success": Rule("success", "=="),
    "knot_error_max_m": Rule("max_knot_position_error", "<=", "m"),
    "knot_error_max_rad": Rule("max_knot_rotation_error", "<=", "rad"),
    "velocity_ratio_max": Rule("max_velocity_over_limit", "<="),
    "jumps_max": Rule("jumps", "<="),
    "waypoints_reached": Rule("waypoints_reached", "=="),
    "lift": Rule("lift", "=="),
}
"""Expectations of one move (``jumps``: joint steps above the jump threshold; ``lift``: the Golem-III
torso lift moved)."""


def judge_move(spec: dict, entry: dict, figures: dict, defaults: dict, rules: dict = MOVE_RULES) -> dict:
    """The move's expectations (``defaults`` under the task file's ``expect``) into the entry:
    ``expectations``, ``verdict``, ``passed``."""
    wanted = {**defaults, **(spec["expect"] or {})}
    where = f"{spec['name'] or spec['kind']} expect"
    entry["expectations"] = evaluate(wanted, figures, rules, where)
    entry["verdict"] = verdict(entry["expectations"])
    entry["passed"] = entry["verdict"] != "FAILED"
    return entry


def _robot(spec: dict):
    from wbik.models import load

    return load(spec["robot"], **spec["robot_params"])


def _vector(value, size: int | None, what: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ScenarioError(f"{what} must be numbers, got {value!r}") from exc
    if (size is not None and array.shape != (size,)) or not np.all(np.isfinite(array)):
        raise ScenarioError(f"{what} must be {size} finite numbers, got {value!r}")
    return array


def _start(spec: dict, chain) -> np.ndarray:
    start = spec["start"]
    return chain.nominal.copy() if start == "nominal" else _vector(start, chain.nq, "start")


def _pose(entry, what: str):
    if isinstance(entry, dict):
        position = _vector(entry.get("position"), 3, f"{what} position")
        if "rpy" in entry:
            return pin.SE3(pin.rpy.rpyToMatrix(*_vector(entry["rpy"], 3, f"{what} rpy")), position)
        return position
    return _vector(entry, 3, what)


def _timed_move(spec: dict, path: JointPath, name: str, extra_figures: dict | None = None,
                extra_defaults: dict | None = None) -> tuple[dict, object]:
    """Time the path, sample it, judge it (with the kind's own figures); the entry and the trajectory."""
    timing = spec["timing"]
    timed = time_scale(path, timing["law"], timing["velocity_limit"], timing["acceleration_limit"],
                       timing["mode"])
    trajectory = make_trajectory(timed, dt=timing["dt"])
    dense = timed.evaluate(np.linspace(0.0, timed.duration, 20001))[1]
    velocity_ratio = float(np.max(np.abs(dense) / timed.velocity_limit))
    tolerance = float(spec["tolerance"])
    summary = path.summary()
    entry = {"name": name, "path": summary, "info": _plain(path.info),
             "duration_s": timed.duration, "time_law": timed.law.name, "timing_mode": timed.mode,
             "max_velocity_over_limit": velocity_ratio,
             "trajectory_max_position_error": trajectory.max_position_error,
             "q_end": path.q[-1].tolist()}
    figures = {"success": bool(path.success), "max_velocity_over_limit": velocity_ratio,
               "max_knot_position_error": summary["max_knot_position_error"],
               "max_knot_rotation_error": summary["max_knot_rotation_error"],
               "jumps": len(summary["jumps"] or [])}
    defaults = {"success": True, "velocity_ratio_max": 1.0 + 1e-9}
    if bool((spec["expect"] or {}).get("success", True)):
        for key, figure in (("knot_error_max_m", "max_knot_position_error"),
                            ("knot_error_max_rad", "max_knot_rotation_error")):
            if figures[figure] is not None:
                defaults[key] = tolerance
    figures.update(extra_figures or {})
    defaults.update(extra_defaults or {})
    return judge_move(spec, entry, figures, defaults), trajectory


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _export(spec: dict, report: ScenarioReport, trajectory, animation) -> ScenarioReport:
    """The last move's trajectory written where ``export`` says (paths in the figures); the animation."""
    export = spec["export"]
    if "csv" in export:
        report.figures["csv"] = str(trajectory.write_csv(Path(export["csv"])))
    if "json" in export:
        report.figures["json"] = str(trajectory.write_json(Path(export["json"])))
    report.animation = animation
    return report


def _animation(robot, chain, trajectory, name: str, reference: np.ndarray | None = None):
    """A move's trajectory (chain joint rows at their times; a repeated time keeps its first row)."""
    from wbik.viz.animation import Animation

    times = np.asarray(trajectory.times, dtype=float)
    keep = np.r_[True, np.diff(times) > 0]
    return Animation.from_chain(robot, chain, times[keep], np.asarray(trajectory.positions)[keep],
                                reference=reference, name=name)


def _report(spec: dict, robot) -> ScenarioReport:
    return ScenarioReport(spec["name"], spec["kind"], robot.name, {"moves": []})


def run_joint(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.motion.joint import joint_path

    robot = _robot(spec)
    chain = robot.chain(spec["chain"])
    configurations = [_vector(q, chain.nq, f"configurations[{index}]")
                      for index, q in enumerate(spec["configurations"])]
    path = joint_path(chain, configurations, int(spec["samples"]))
    report = _report(spec, robot)
    entry, trajectory = _timed_move(spec, path, "joint interpolation")
    report.add_entry("moves", entry)
    return _export(spec, report, trajectory, _animation(robot, chain, trajectory, entry["name"]))


def run_cartesian(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.motion.cartesian import waypoint_path
    from wbik.solvers.base import solver

    robot = _robot(spec)
    ik = solver(spec["method"], robot, chain=spec["chain"], timeout_s=float(spec["timeout_s"]))
    waypoints = [_pose(entry, f"waypoints[{i}]") for i, entry in enumerate(spec["waypoints"])]
    path = waypoint_path(ik, _start(spec, ik.chain), waypoints, int(spec["samples"]),
                         float(spec["jump_threshold"]))
    report = _report(spec, robot)
    chain = ik.chain
    tolerance = float(spec["tolerance"])
    reached = []
    for knot, waypoint in zip(path.waypoint_knots, waypoints, strict=True):
        wanted = waypoint.translation if isinstance(waypoint, pin.SE3) else waypoint
        reached.append(bool(np.linalg.norm(chain.fk(path.q[knot]).translation - wanted) <= tolerance))
    entry, trajectory = _timed_move(spec, path, f"{len(waypoints)} Cartesian segments",
                                    {"waypoints_reached": all(reached)}, {"waypoints_reached": True})
    entry["waypoints_reached"] = reached
    report.add_entry("moves", entry)
    return _export(spec, report, trajectory, _animation(robot, chain, trajectory, entry["name"]))


def run_pincher(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.motion import pincher
    from wbik.solvers.base import solver

    robot = _robot(spec)
    ik = solver(spec["method"], robot, timeout_s=float(spec["timeout_s"]))
    chain = ik.chain
    q = _start(spec, chain)
    report, trajectory, animation = _report(spec, robot), None, None
    for index, move in enumerate(spec["moves"]):
        if "jog" in move:
            path = pincher.jog(chain, q, move["jog"], math.radians(float(move["delta_deg"])),
                               int(move["samples"]))
            name = f"jog {move['jog']} by {move['delta_deg']} deg"
        elif "plane_line" in move:
            line = move["plane_line"]
            start = _vector(line["start_xy_mm"], 2, "start_xy_mm") / 1000.0
            goal = _vector(line["goal_xy_mm"], 2, "goal_xy_mm") / 1000.0
            path = pincher.plane_line(ik, start, goal, int(line["samples"]), q0=q)
            name = f"plane line {line['start_xy_mm']} -> {line['goal_xy_mm']} mm"
        elif "automatic" in move:
            path = pincher.automatic_path(ik, int(move["automatic"]["samples"]))
            name = "automatic cycle"
        else:
            raise ScenarioError(f"pincher move {index + 1} must be jog, plane_line or automatic: {move!r}")
        entry, trajectory = _timed_move({**spec, **move}, path, name)
        report.add_entry("moves", entry)
        move_animation = _animation(robot, chain, trajectory, name)
        animation = move_animation if animation is None else animation.then(move_animation, pause=0.25)
        q = path.q[-1].copy()
        if on_progress is not None:
            on_progress(report)
    return _export(spec, report, trajectory, animation)


def run_golem3(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.motion.golem3 import ARM_WITH_LIFT, approach

    robot = _robot(spec)
    chain = robot.chain(ARM_WITH_LIFT)
    grasp = spec["grasp"]
    if "from_joints" in grasp:
        goal = chain.fk(_vector(grasp["from_joints"], chain.nq, "grasp from_joints"))
    else:
        goal = _pose(grasp, "grasp")
    path = approach(robot, _start(spec, chain), goal, int(spec["samples"]), spec["method"],
                    timeout_s=float(spec["timeout_s"]))
    report = _report(spec, robot)
    entry, trajectory = _timed_move(spec, path, "approach", {"lift": bool(path.info["lift_samples"])})
    report.add_entry("moves", entry)
    return _export(spec, report, trajectory, _animation(robot, chain, trajectory, "approach"))


def format_report(report: dict) -> str:
    """One line per move (knots, knot error, jumps, duration, peak speed) and its checks."""
    lines = [report_header(report)]
    for move in report["moves"]:
        path = move["path"]
        lines.append(f"  [{'ok' if move['passed'] else 'FAIL'}] {move['name']}: {path['knots']} knots, "
                     f"max knot error {path['max_knot_position_error']}, jumps {path['jumps']}, "
                     f"duration {move['duration_s']:.3f} s ({move['time_law']}, {move['timing_mode']}), "
                     f"peak |v|/limit {move['max_velocity_over_limit']:.6f}")
        lines.extend(format_checks(move.get("expectations", []), indent="      "))
    return "\n".join(lines)



# -- the schemas -----------------------------------------------------------------------------------
def motion_schema(kind: str) -> Map:
    """The keys of a motion kind's file (see the module docstring); defaults of ``samples``,
    ``timing`` and ``jump_threshold`` are those of the functions they feed."""
    from wbik.motion import golem3, pincher
    from wbik.motion.cartesian import waypoint_path
    from wbik.motion.joint import joint_path

    limit = Either(Number(gt=0, nullable=True), Vector(positive=True))
    timing = Map({"law": Key(Text(time_laws), default_of(time_scale, "law")),
                  "mode": Key(Text(timing_modes), default_of(time_scale, "mode")),
                  "velocity_limit": Key(limit, None), "acceleration_limit": Key(limit, None),
                  "dt": Key(Number(gt=0, nullable=True, unit="s"), None)}, nullable=True)
    common = {**common_keys(robot=Key(Robot(), required=True)),
              "timing": Key(timing, {}),
              "export": Key(Map({"csv": Key(Text(what="a file path")), "json": Key(Text(what="a file path"))},
                                nullable=True), {}),
              "tolerance": Key(Number(gt=0, unit="m / rad"), 1e-6),
              "expect": Key(expect_block(MOVE_RULES), None)}
    solving = {"method": Key(Method(), "dls"), "timeout_s": Key(Number(gt=0, unit="s", budget=True), 0.05),
               "start": Key(START, "nominal")}

    def samples(function) -> dict[str, Key]:
        return {"samples": Key(Number(ge=1, integer=True), default_of(function, "samples"))}

    if kind == "motion_joint":
        keys = {**samples(joint_path), "chain": Key(Text(what="a chain name", nullable=True), None),
                "configurations": Key(ListOf(Vector(), min_items=2, what="joint vectors"), required=True)}
    elif kind == "motion_cartesian":
        waypoint = Either(VECTOR3, Map({"position": Key(VECTOR3, required=True), "rpy": Key(VECTOR3)}))
        keys = {**solving, **samples(waypoint_path),
                "chain": Key(Text(what="a chain name", nullable=True), None),
                "waypoints": Key(ListOf(waypoint, min_items=1, what="[x, y, z] or {position, rpy}"),
                                 required=True),
                "jump_threshold": Key(Number(gt=0, unit="rad"), default_of(waypoint_path, "jump_threshold"))}
    elif kind == "pincher_motion":
        # a move's own timing / tolerance / expect override the scenario's (no defaults here)
        own = {"timing": Key(timing), "tolerance": Key(common["tolerance"].node),
               "expect": Key(expect_block(MOVE_RULES))}
        moves = {
            "jog": Map({"jog": Key(Either(Text(what="a joint name"), Number(integer=True))),
                        "delta_deg": Key(Number(unit="deg"), 0.0), **samples(pincher.jog), **own}),
            "plane_line": Map({"plane_line": Key(Map({"start_xy_mm": Key(Vector(2), required=True),
                                                      "goal_xy_mm": Key(Vector(2), required=True),
                                                      **samples(pincher.plane_line)}), required=True),
                               **own}),
            "automatic": Map({"automatic": Key(Map(samples(pincher.automatic_path), nullable=True),
                                               required=True), **own}),
        }

        def move_kind(move: Mapping) -> str | None:
            found = [name for name in moves if name in move]
            return found[0] if len(found) == 1 else (None if not found else "+".join(found))

        move = Variants(move_kind, moves, "a move: {jog: JOINT, delta_deg: D}, {plane_line: {...}} or "
                                          "{automatic: {}}", "move")
        keys = {**solving, "moves": Key(ListOf(move, min_items=1, what="moves"), required=True)}
    elif kind == "golem3_approach":
        grasp = Either(Map({"from_joints": Key(Vector(), required=True)}),
                       Map({"position": Key(VECTOR3, required=True), "rpy": Key(VECTOR3)}))
        keys = {**solving, **samples(golem3.approach), "grasp": Key(grasp, required=True)}
    else:
        raise ValueError(f"not a motion kind: {kind!r}")
    return Map({**common, **keys}, post=check_robot_params)


SCENARIO_KINDS = (
    ScenarioKind("motion_joint", run_joint, lambda: motion_schema("motion_joint"), format_report,
                 "joint-space interpolation through configurations"),
    ScenarioKind("motion_cartesian", run_cartesian, lambda: motion_schema("motion_cartesian"), format_report,
                 "straight Cartesian lines through waypoints"),
    ScenarioKind("pincher_motion", run_pincher, lambda: motion_schema("pincher_motion"), format_report,
                 "a Pincher teleoperation session (jog, plane line, automatic cycle)"),
    ScenarioKind("golem3_approach", run_golem3, lambda: motion_schema("golem3_approach"), format_report,
                 "Golem-III straight grasp approach, torso lift when needed"),
)
