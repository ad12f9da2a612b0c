"""Scenario runners for the Bioloid behaviours (tasks/bioloid_step_*.yaml, tasks/bioloid_walk*.yaml),
registered with :mod:`wbik.scenarios` when this module is imported.

Kinds (each report has ``passed`` and a ``behaviours`` list):

- ``bioloid_step``: the thesis's step forward. ``generators: [faithful, wholebody]`` (default both),
  ``first: left|right``, ``margin`` (m), ``rear_lift`` (m), ``gait`` (overrides of
  :class:`~wbik.bioloid.gait.GaitParameters`), ``timing: {speed_rpm, law, mode}``,
  ``export: {servo_csv: PATH, dt: S}``. ``expect``: ``faithful_min_inconsistency_mm`` (the
  double-support mismatch the faithful version must show), ``wholebody: true`` (every sample
  verified).
- ``bioloid_walk``: ``steps`` forward then ``turn_deg`` (0 = none), whole-body; ``bioloid_turn``:
  ``turn_deg`` in place. Same timing/export keys.
- ``bioloid_keyframes``: replay ``behaviours`` of the keyframe file ``keyframes`` (default
  tasks/data/bioloid_keyframes.yaml); passes when every row maps to servo units and back exactly.
- ``bioloid_placo_walk``: PlaCo's walk pattern generator on the same URDF (``steps``, ``step_length``,
  ``margin``); see :mod:`wbik.bioloid.placo_walk`.

Every whole-body behaviour passes only if each sample holds its contacts to 1e-6 m / rad, keeps
the CoM inside the support polygon by the margin, stays inside the joint limits, and the timed
servo trajectory keeps every joint under the speed limit (checked on a 1 ms grid).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from pathlib import Path

import numpy as np

from wbik.scenarios import ScenarioError, register_runner

Progress = Callable[[dict], None] | None
VELOCITY_TOLERANCE = 1e-9


def _robot(spec: dict):
    from wbik.errors import UnknownRobotError
    from wbik.models import load

    try:
        return load(spec.get("robot", "bioloid"))
    except UnknownRobotError as exc:
        raise ScenarioError(str(exc)) from exc


def _gait(spec: dict):
    from wbik.bioloid.gait import GaitParameters

    overrides = spec.get("gait", {}) or {}
    known = {f.name for f in fields(GaitParameters)}
    unknown = set(overrides) - known
    if unknown:
        raise ScenarioError(f"unknown gait parameters {sorted(unknown)}; known: {sorted(known)}")
    return GaitParameters(**overrides)


def _report(spec: dict, robot) -> dict:
    return {"name": spec.get("name", ""), "kind": spec["kind"], "robot": robot.name, "passed": True,
            "behaviours": []}


def _timed_entry(spec: dict, result, name: str) -> dict:
    """Summary, timing and servo export of a whole-body result."""
    from wbik.bioloid.gait import time_scale_motion

    timing = spec.get("timing", {}) or {}
    timed = time_scale_motion(result.motion, timing.get("speed_rpm", 40.0), timing.get("law", "quintic"),
                              timing.get("mode", "segment"))
    ratio = timed.peak_velocity_ratio()
    entry = {"name": name, "generator": "wholebody", **result.summary(), "duration_s": timed.duration,
             "speed_rpm": timing.get("speed_rpm", 40.0), "peak_velocity_over_limit": ratio}
    export = spec.get("export", {}) or {}
    if export.get("servo_csv"):
        path = timed.write_servo_csv(export["servo_csv"], float(export.get("dt", 0.02)))
        entry["servo_csv"] = str(path)
    table = timed.servo_table(float(export.get("dt", 0.02)))
    entry["servo_rows"] = int(len(table["times_s"]))
    entry["servo_clamped"] = {joint: max(abs(r - a) for _, r, a in items)
                              for joint, items in table["clamped"].items()}
    entry["passed"] = bool(result.passed and ratio <= 1.0 + VELOCITY_TOLERANCE)
    return entry


def run_step(spec: dict, on_progress: Progress = None) -> dict:
    from wbik.bioloid.step_faithful import step_forward_faithful
    from wbik.bioloid.step_wholebody import step_forward_wholebody

    robot = _robot(spec)
    gait = _gait(spec)
    first = spec.get("first", "left")
    margin = float(spec.get("margin", 0.005))
    expect = spec.get("expect", {}) or {}
    report = _report(spec, robot)
    generators = spec.get("generators", ["faithful", "wholebody"])
    unknown = set(generators) - {"faithful", "wholebody"}
    if unknown:
        raise ScenarioError(f"unknown generators {sorted(unknown)}; use faithful and/or wholebody")
    if "faithful" in generators:
        rounding = bool(spec.get("round_degrees", False))
        faithful = step_forward_faithful(robot, gait, first, round_degrees=rounding)
        summary = faithful.summary()
        wanted = float(expect.get("faithful_min_inconsistency_mm", 0.0))
        entry = {"name": f"step forward ({first} first), faithful", "generator": "faithful", **summary,
                 "margin_mm": 1e3 * margin,
                 "samples_under_margin": int(sum(s["com_margin_m"] < margin for s in faithful.samples)),
                 "passed": summary["max_inconsistency_mm"] >= wanted}
        report["behaviours"].append(entry)
        report["passed"] = report["passed"] and entry["passed"]
        if on_progress is not None:
            on_progress(report)
    if "wholebody" in generators:
        result = step_forward_wholebody(robot, gait, first, margin,
                                        rear_lift=float(spec.get("rear_lift", 0.0)),
                                        backend=spec.get("backend", "daqp"))
        entry = _timed_entry(spec, result, f"step forward ({first} first), whole-body")
        if "wholebody" in expect:
            entry["passed"] = entry["passed"] == bool(expect["wholebody"])
        report["behaviours"].append(entry)
        report["passed"] = report["passed"] and entry["passed"]
    return report


def run_walk(spec: dict, on_progress: Progress = None) -> dict:
    from wbik.bioloid.behaviours import turn_in_place, walk

    robot = _robot(spec)
    gait = _gait(spec)
    margin = float(spec.get("margin", 0.005))
    report = _report(spec, robot)
    if spec["kind"] == "bioloid_turn":
        angle = float(spec.get("turn_deg", 20.0))
        result = turn_in_place(robot, angle, gait, margin, backend=spec.get("backend", "daqp"))
        name = f"turn in place {angle:g} deg"
    else:
        steps, angle = int(spec.get("steps", 4)), float(spec.get("turn_deg", 0.0))
        result = walk(robot, steps, angle, gait, margin, first=spec.get("first", "left"),
                      rear_lift=float(spec.get("rear_lift", 0.0)), backend=spec.get("backend", "daqp"))
        name = f"walk {steps} steps, turn {angle:g} deg"
    entry = _timed_entry(spec, result, name)
    final = result.motion.q[-1]
    entry["final_soles"] = {sole: robot.frame_placement(final, sole).translation.tolist()
                            for sole in ("r_sole", "l_sole")}
    report["behaviours"].append(entry)
    report["passed"] = entry["passed"]
    return report


def run_keyframes(spec: dict, on_progress: Progress = None) -> dict:
    from wbik.bioloid.behaviours import replay_keyframes
    from wbik.bioloid.servo import to_servo

    robot = _robot(spec)
    report = _report(spec, robot)
    default = ["up_stair", "down_stair", "right_turn_medium", "left_turn_medium"]
    for behaviour in spec.get("behaviours", default):
        replay = replay_keyframes(robot, behaviour, spec.get("keyframes"))
        motion = replay["motion"]
        names = motion.joint_names
        exact, clamped_rows = True, 0
        for units, angles in zip(replay["units"], motion.joint_matrix(), strict=True):
            command = to_servo(dict(zip(names, angles, strict=True)))
            clamped_ids = {motion.robot.info["servo_ids"][joint] for joint in command.clamped}
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
                 "source": replay["source"], "passed": bool(exact)}
        report["behaviours"].append(entry)
        report["passed"] = report["passed"] and entry["passed"]
        if on_progress is not None:
            on_progress(report)
    return report


def run_placo_walk(spec: dict, on_progress: Progress = None) -> dict:
    from wbik.bioloid.placo_walk import placo_walk

    robot = _robot(spec)
    report = _report(spec, robot)
    result = placo_walk(robot, steps=int(spec.get("steps", 4)),
                        step_length=float(spec.get("step_length", 0.03)),
                        margin=float(spec.get("margin", 0.005)))
    entry = {"name": "PlaCo walk pattern generator", **result}
    entry["passed"] = bool(result.get("planned", False)) or not spec.get("expect", {}).get("planned", True)
    report["behaviours"].append(entry)
    report["passed"] = entry["passed"]
    return report


RUNNER_KINDS = {"bioloid_step": run_step, "bioloid_walk": run_walk, "bioloid_turn": run_walk,
                "bioloid_keyframes": run_keyframes, "bioloid_placo_walk": run_placo_walk}


def format_report(report: dict) -> str:
    """One block per behaviour with the figures that matter."""
    lines = [f"{report.get('name', '')} ({report['kind']}, {report.get('robot', '')}): "
             f"{'PASSED' if report['passed'] else 'FAILED'}"]
    for entry in report["behaviours"]:
        keys = [k for k in entry if k not in ("name", "passed", "per_phase", "source", "final_soles")]
        figures = ", ".join(f"{k} {_short(entry[k])}" for k in keys)
        lines.append(f"  [{'ok' if entry['passed'] else 'FAIL'}] {entry['name']}: {figures}")
    return "\n".join(lines)


def _short(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) > 6:
        return f"[{len(value)} values]"
    return str(value)


for _kind, _runner in RUNNER_KINDS.items():
    register_runner(_kind, _runner, format_report)


def scenario_path(name: str) -> Path:
    """tasks/NAME.yaml of the repository."""
    return Path(__file__).resolve().parents[2] / "tasks" / f"{name}.yaml"
