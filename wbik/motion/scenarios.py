"""Scenario runners for motion files (tasks/motion_*.yaml), registered by name in
:data:`wbik.scenarios.KINDS`; their keys, types and defaults are declared in
:mod:`wbik.scenario_schema`, and every runner reads the checked spec.

Kinds (each report has ``passed`` and one entry per move in ``moves``):

- ``motion_joint``: joint-space interpolation through ``configurations`` (rad / m).
- ``motion_cartesian``: straight lines from ``start`` (joints or "nominal") through ``waypoints``
  (each [x, y, z] or {position, rpy}) with ``method``; ``samples`` per segment.
- ``pincher_motion``: a teleoperation session, ``moves`` run one after another from the previous
  end: {jog: JOINT, delta_deg: D}, {plane_line: {start_xy_mm: [x, y], goal_xy_mm: [x, y]}},
  {automatic: {}}.
- ``golem3_approach``: straight approach from ``start`` (mb, m0, m10..m14) to ``grasp``
  ({position, rpy} in base_link, or {from_joints: [7 values]}); ``expect: {lift: bool}``.
- ``bioloid_stance_sensors``: expected FSR loads and CoP of the static stance at ``start``.

Common keys: ``timing: {law, mode, velocity_limit, acceleration_limit, dt}`` (defaults quintic,
global, URDF limits, knot times), ``export: {csv: PATH, json: PATH}`` (the trajectory of the last
move, JointTrajectory shape), ``tolerance`` (knot tracking, default 1e-6 m / rad) and ``expect``
with the keys of ``MOVE_RULES`` (thresholds SI, judged by :mod:`wbik.expectations` for every move
and printed as figure / threshold / ok). Unless ``expect`` sets them, a move expects success, the
peak joint speed within the limit (1e-9) and, when it has Cartesian knots, each knot tracked to
``tolerance``.

Each runner returns its report and a :class:`wbik.viz.animation.Animation` (what ``wbik view``
plays): every move's timed trajectory (the chain's joints in the full configuration, the tip traced),
the moves one after the other; the foot-sensor stance is one still sample on both soles.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.expectations import Rule, evaluate, format_checks, verdict
from wbik.motion.path import JointPath
from wbik.motion.timing import time_scale
from wbik.motion.trajectory import make_trajectory
from wbik.scenarios import ScenarioError

Progress = Callable[[dict], None] | None

MOVE_RULES = {
    "success": Rule("success", "=="),
    "knot_error_max_m": Rule("max_knot_position_error", "<=", "m"),
    "knot_error_max_rad": Rule("max_knot_rotation_error", "<=", "rad"),
    "velocity_ratio_max": Rule("max_velocity_over_limit", "<="),
    "jumps_max": Rule("jumps", "<="),
    "waypoints_reached": Rule("waypoints_reached", "=="),
    "lift": Rule("lift", "=="),
    "cop_error_max_m": Rule("cop_minus_com_m", "<=", "m"),
}
"""Expectations of one move (``jumps``: joint steps above the jump threshold; ``lift``: the Golem-III
torso lift moved; ``cop_error_max_m``: the stance's centre of pressure off the CoM projection)."""


def _judge(spec: dict, entry: dict, figures: dict, defaults: dict) -> dict:
    """The move's expectations (defaults under the task file's ``expect``) into the entry."""
    wanted = {**defaults, **(spec["expect"] or {})}
    where = f"{spec['name'] or spec['kind']} expect"
    entry["expectations"] = evaluate(wanted, figures, MOVE_RULES, where)
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
    return _judge(spec, entry, figures, defaults), trajectory


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


def _finish(spec: dict, report: dict, trajectory) -> dict:
    export = spec.get("export") or {}
    if trajectory is not None:
        if "csv" in export:
            report["csv"] = str(trajectory.write_csv(Path(export["csv"])))
        if "json" in export:
            report["json"] = str(trajectory.write_json(Path(export["json"])))
    report["passed"] = all(move["passed"] for move in report["moves"])
    report["verdict"] = verdict(c for move in report["moves"] for c in move["expectations"])
    return report


def _animation(robot, chain, trajectory, name: str, reference: np.ndarray | None = None):
    """A move's trajectory (chain joint rows at their times; a repeated time keeps its first row)."""
    from wbik.viz.animation import Animation

    times = np.asarray(trajectory.times, dtype=float)
    keep = np.r_[True, np.diff(times) > 0]
    return Animation.from_chain(robot, chain, times[keep], np.asarray(trajectory.positions)[keep],
                                reference=reference, name=name)


def _report(spec: dict, robot) -> dict:
    return {"name": spec["name"], "kind": spec["kind"], "robot": robot.name, "moves": [],
            "passed": True, "verdict": "informational"}


def run_joint(spec: dict, on_progress: Progress = None) -> tuple[dict, object]:
    from wbik.motion.joint import joint_path

    robot = _robot(spec)
    chain = robot.chain(spec["chain"])
    configurations = [_vector(q, chain.nq, f"configurations[{index}]")
                      for index, q in enumerate(spec["configurations"])]
    path = joint_path(chain, configurations, int(spec["samples"]))
    report = _report(spec, robot)
    entry, trajectory = _timed_move(spec, path, "joint interpolation")
    report["moves"].append(entry)
    return _finish(spec, report, trajectory), _animation(robot, chain, trajectory, entry["name"])


def run_cartesian(spec: dict, on_progress: Progress = None) -> tuple[dict, object]:
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
    report["moves"].append(entry)
    return _finish(spec, report, trajectory), _animation(robot, chain, trajectory, entry["name"])


def run_pincher(spec: dict, on_progress: Progress = None) -> tuple[dict, object]:
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
            name = f"jog {move['jog']} by {move.get('delta_deg')} deg"
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
        report["moves"].append(entry)
        move_animation = _animation(robot, chain, trajectory, name)
        animation = move_animation if animation is None else animation.then(move_animation, pause=0.25)
        q = path.q[-1].copy()
        if on_progress is not None:
            on_progress(report)
    return _finish(spec, report, trajectory), animation


def run_golem3(spec: dict, on_progress: Progress = None) -> tuple[dict, object]:
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
    report["moves"].append(entry)
    return _finish(spec, report, trajectory), _animation(robot, chain, trajectory, "approach")


def run_bioloid_stance(spec: dict, on_progress: Progress = None) -> tuple[dict, object]:
    from wbik.bioloid.sensors import stance_loads

    robot = _robot(spec)
    q = robot.nominal.copy() if spec["start"] == "nominal" else _vector(
        spec["start"], robot.model.nq, "start")
    stance = stance_loads(robot, q)
    gap = float(np.linalg.norm(stance.cop_world - stance.com_xy))
    entry = {"name": "static stance", "cop_minus_com_m": gap, **stance.as_dict()}
    _judge(spec, entry, {"cop_minus_com_m": gap}, {"cop_error_max_m": float(spec["tolerance"])})
    report = _report(spec, robot)
    report["moves"].append(entry)
    from wbik.viz.animation import Animation, Overlays

    soles = (("r_sole", "l_sole"),)
    return _finish(spec, report, None), Animation(robot, [0.0], q[None], Overlays(None, soles, soles),
                                                  "static stance")


RUNNER_KINDS = {"motion_joint": run_joint, "motion_cartesian": run_cartesian, "pincher_motion": run_pincher,
                "golem3_approach": run_golem3, "bioloid_stance_sensors": run_bioloid_stance}
"""The kinds of this module (registered by name in wbik.scenarios.KINDS)."""


def format_report(report: dict) -> str:
    """One line per move."""
    from wbik.scenarios import report_verdict

    lines = [f"{report.get('name', '')} ({report['kind']}, {report.get('robot', '')}): "
             f"{report_verdict(report)}"]
    for move in report["moves"]:
        if "path" in move:
            path = move["path"]
            lines.append(f"  [{'ok' if move['passed'] else 'FAIL'}] {move['name']}: {path['knots']} knots, "
                         f"max knot error {path['max_knot_position_error']}, jumps {path['jumps']}, "
                         f"duration {move['duration_s']:.3f} s ({move['time_law']}, {move['timing_mode']}), "
                         f"peak |v|/limit {move['max_velocity_over_limit']:.6f}")
        else:
            lines.append(f"  [{'ok' if move['passed'] else 'FAIL'}] {move['name']}: "
                         f"CoP - CoM {move['cop_minus_com_m']:.2e} m")
        lines.extend(format_checks(move.get("expectations", []), indent="      "))
    return "\n".join(lines)

