"""Scenario files: declarative YAML (or JSON) that a user runs with ``wbik run FILE``.

Every file has a ``kind`` that selects a runner (``KINDS``: kind -> "module:function", imported on
first use; ``register_runner`` adds one) and usually a ``robot``. Before anything runs, the file is
checked against its kind's schema (:mod:`wbik.scenario_schema`: allowed keys, types, ranges and the
one set of defaults), and the runner reads the checked copy. The runner returns a report (a
JSON-friendly dict with ``passed``); ``run_scenario`` can write it after every phase, so an
interruption loses nothing.

Kind ``wholebody_ik``: a sequence of phases solved by the QP layer, each from the previous
phase's answer::

    kind: wholebody_ik
    robot: bioloid
    backend: daqp                  # osqp, daqp, quadprog, proxqp, "fastest" or "default"
                                   # (default: wbik.qp.backends.DEFAULT, DAQP, the fastest measured)
    margin: 0.005                  # m, default CoM margin of the phases (default 0.005)
    collisions:                    # optional: hard collision avoidance in every phase (wbik.collision)
      self_collision: true         # pairs of the robot's own primitives (default true)
      robot_obstacles: true        # the fixed obstacles its model lists, e.g. the UR5's table (default true)
      boxes: [{name: shelf, size: [0.4, 0.3, 0.02], xyz: [0.6, 0.0, 0.8], rpy: [0, 0, 0]}]   # m, rad
      safety_distance: 0.02        # m, every pair at least this far apart (default 0.01); pairs
                                   # closer than this at the nominal pose are left out (close by design)
      influence_distance: 0.1      # m, pairs closer than this get a QP row (default 0.1)
    phases:
      - name: shift the CoM over the right foot
        contacts: [r_sole, l_sole]  # soles held fixed (hard equality)
        support: [r_sole, l_sole]   # soles of the support polygon (default: the contacts)
        margin: 0.005               # m, CoM at least this far inside the polygon (default: the file's)
        lock: [mb]                  # joints held at their value (optional)
        tasks:
          - {type: com, over: r_sole, axes: xy}
          - {type: orientation, frame: pelvis, keep: true, weight: 0.1, goal: false}
        expect: {success: true}     # or {success: false}: a balanced best effort; see PHASE_RULES

Task entries: ``type`` in frame | position | orientation | relative | com | posture |
regularization; the target is ``target`` (position [x, y, z] m; for frame/orientation also
``rpy`` [r, p, y] rad), or ``keep: true`` (the pose at the start of the phase), or ``offset``
([dx, dy, dz] m added to the start pose, world axes), or for com ``over: FRAME`` (above that
frame's origin). Options: weight, position_weight, orientation_weight, axes, goal, priority,
tolerance. Every phase's answer is checked independently by FK: contacts, CoM margin in the
support polygon, joint limits. The phase's ``expect`` block judges these figures (keys in
``PHASE_RULES``, thresholds SI); unless the block sets them, the phase expects success, contacts held
to 1e-6 m / rad, the CoM ``margin`` inside the support polygon (when there is one) and no joint
beyond its limit (1e-9), and with ``collisions`` the minimum pair distance (coal, by FK) at least the
safety distance (``collision_distance_min_m``). An ``expect`` value may be
``{threshold, expected_to_fail, why}`` (see :mod:`wbik.expectations`).
"""

from __future__ import annotations

import importlib
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.errors import MissingDependencyError
from wbik.expectations import Rule, evaluate, format_checks, verdict
from wbik.files import atomic_write_text
from wbik.scenario_schema import ScenarioError, ScenarioFileError, kind_names, register_schema, validate

__all__ = ["KINDS", "ScenarioError", "format_report", "load_scenario", "register_runner", "run_scenario",
           "run_scenario_animated"]

CONTACT_TOLERANCE = 1e-6
"""Contacts must hold to this (m for the position error, rad for the rotation error)."""

Runner = Callable[[dict, Callable[[dict], None] | None], "dict | tuple[dict, object]"]

KINDS: dict[str, str | Runner] = {
    # kind -> "module:function" (imported on first use; a failed import is an error, never skipped)
    "wholebody_ik": "wbik.scenarios:run_wholebody_ik",
    "bioloid_step": "wbik.bioloid.scenarios:run_step",
    "bioloid_walk": "wbik.bioloid.scenarios:run_walk",
    "bioloid_turn": "wbik.bioloid.scenarios:run_walk",
    "bioloid_keyframes": "wbik.bioloid.scenarios:run_keyframes",
    "bioloid_placo_walk": "wbik.bioloid.scenarios:run_placo_walk",
    "bioloid_half_steps": "wbik.bioloid.scenarios:run_half_steps",
    "bioloid_stairs": "wbik.bioloid.scenarios:run_stairs",
    "motion_joint": "wbik.motion.scenarios:run_joint",
    "motion_cartesian": "wbik.motion.scenarios:run_cartesian",
    "pincher_motion": "wbik.motion.scenarios:run_pincher",
    "golem3_approach": "wbik.motion.scenarios:run_golem3",
    "bioloid_stance_sensors": "wbik.motion.scenarios:run_bioloid_stance",
    "ur5_riveting": "wbik.riveting.scenarios:run_riveting",
}
FORMATTERS: dict[str, str | Callable[[dict], str]] = {
    # kind -> "module:function" printing its report (default: the phase summary of format_report)
    **{kind: "wbik.bioloid.scenarios:format_report" for kind in KINDS if kind.startswith("bioloid_")
       and kind != "bioloid_stance_sensors"},
    **{kind: "wbik.motion.scenarios:format_report" for kind in
       ("motion_joint", "motion_cartesian", "pincher_motion", "golem3_approach", "bioloid_stance_sensors")},
    "ur5_riveting": "wbik.riveting.report:format_text",
}
RUNNERS = KINDS  # the former name


def register_runner(kind: str, runner: str | Runner, formatter: str | Callable[[dict], str] | None = None,
                    schema: Callable | None = None) -> None:
    """``runner(spec, on_progress) -> (report, animation)`` or ``-> report`` (or "module:function");
    on_progress(report so far) may be None; the animation (:class:`wbik.viz.animation.Animation`)
    is what ``wbik view`` plays. ``schema()`` builds the kind's :class:`wbik.scenario_schema.Map`
    (needed by a new kind).

    ``formatter(report) -> str`` prints the report for ``wbik run`` (default: the phase summary).
    """
    KINDS[kind] = runner
    if formatter is not None:
        FORMATTERS[kind] = formatter
    if schema is not None:
        register_schema(kind, schema)


def _registered(table: dict, kind: str, what: str):
    """The callable registered for ``kind`` in ``table``, importing its module on first use."""
    entry = table[kind]
    if not isinstance(entry, str):
        return entry
    module_name, function = entry.split(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise MissingDependencyError(
            f"scenario kind {kind!r} is registered with the {what} {entry!r}, but importing {module_name} "
            f"failed: {exc}. Install what it names (pip install -e . installs wbik's own dependencies)"
        ) from exc
    return getattr(module, function)


def _read(path: Path):
    """The parsed content of a scenario file, or a ScenarioFileError saying what is wrong with it."""
    kinds = ", ".join(kind_names())
    if path.is_dir():
        raise ScenarioFileError(f"scenario file {str(path)!r} is a directory; pass a YAML/JSON/TOML "
                                "scenario file, e.g. tasks/bioloid_balance.yaml")
    if not path.is_file():
        raise ScenarioFileError(f"scenario file {str(path)!r} does not exist")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioFileError(f"{path}: not UTF-8 text (byte {exc.start}: {exc.reason}); a scenario is "
                                "a YAML/JSON/TOML text file") from None
    except OSError as exc:
        raise ScenarioFileError(f"cannot read scenario file {str(path)!r}: {exc.strerror}") from None
    if not text.strip():
        raise ScenarioFileError(f"{path}: the file is empty; a scenario is a mapping with a 'kind' "
                                f"(one of {kinds})")
    suffix = path.suffix.lower()
    try:
        if suffix == ".json":
            return json.loads(text)
        if suffix == ".toml":
            import tomllib

            return tomllib.loads(text)
        import yaml

        return yaml.safe_load(text)
    except Exception as exc:  # yaml, json and tomllib raise several types
        raise ScenarioFileError(f"{path}: not valid {suffix.lstrip('.').upper() or 'YAML'}: {exc}") from None


def load_scenario(path: str | Path) -> dict:
    """Read a YAML/JSON/TOML scenario file, checked against its kind's schema (errors name the file
    and the key); the file's own mapping is returned (``name`` defaults to the file's stem)."""
    path = Path(path)
    spec = _read(path)
    if spec is None:
        raise ScenarioFileError(f"{path}: the file is empty (only comments or null); a scenario is "
                                f"a mapping with a 'kind' (one of {', '.join(kind_names())})")
    if not isinstance(spec, dict):
        raise ScenarioFileError(f"{path}: a scenario is a mapping with a 'kind' (one of "
                                f"{', '.join(kind_names())}), got a {type(spec).__name__}")
    spec.setdefault("name", path.stem)
    validate(spec, str(path))
    return spec


def run_scenario(scenario: str | Path | dict, output: str | Path | None = None,
                 source: str | None = None) -> dict:
    """Run a scenario (file or dict); with ``output``, write the JSON report after every phase.

    The scenario is checked against its kind's schema first (``source`` names it in errors; default
    the file, or the dict's name); the runner gets the checked copy with the defaults filled in.
    """
    return run_scenario_animated(scenario, output, source)[0]


def run_scenario_animated(scenario: str | Path | dict, output: str | Path | None = None,
                          source: str | None = None) -> tuple[dict, object | None]:
    """:func:`run_scenario`, and the runner's animation (:class:`wbik.viz.animation.Animation`, what
    ``wbik view TASKFILE`` plays; None from a runner that returns a report only). The report names
    the animation's sample count in ``animation_frames``."""
    if isinstance(scenario, dict):
        spec = scenario
        source = source or f"scenario {spec.get('name') or spec.get('kind')!r}"
    else:
        spec = load_scenario(scenario)
        source = source or str(scenario)
    checked = validate(spec, source)
    runner = _registered(KINDS, checked["kind"], "runner")

    def write(report: dict) -> None:
        if output is not None:
            atomic_write_text(Path(output), json.dumps(report, indent=2, default=_json_default))

    result = runner(checked, write)  # (report, animation), or a report alone (register_runner)
    report, animation = result if isinstance(result, tuple) else (result, None)
    if animation is not None:
        report["animation_frames"] = animation.frames
    write(report)
    return report, animation


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value)}")


# -- kind: wholebody_ik --------------------------------------------------------------------------
def _vector(value, size: int, what: str) -> np.ndarray:
    array = np.asarray(value, dtype=float).reshape(-1)
    if array.shape != (size,) or not np.all(np.isfinite(array)):
        raise ScenarioError(f"{what} must be {size} finite numbers, got {value!r}")
    return array


def _start_placement(robot, q: np.ndarray, frame: str) -> pin.SE3:
    from wbik.errors import UnknownFrameError

    try:
        return robot.frame_placement(q, frame)
    except UnknownFrameError as exc:
        raise ScenarioError(str(exc)) from exc


def _target_placement(robot, q: np.ndarray, entry: dict, frame: str) -> pin.SE3:
    """World target of a frame-like task entry (keep / offset / target [+ rpy])."""
    start = _start_placement(robot, q, frame)
    if "target" in entry:
        rotation = (pin.rpy.rpyToMatrix(*_vector(entry["rpy"], 3, "rpy")) if "rpy" in entry
                    else start.rotation)
        return pin.SE3(rotation, _vector(entry["target"], 3, "target"))
    placement = start.copy()
    if "offset" in entry:
        placement.translation = start.translation + _vector(entry["offset"], 3, "offset")
    if "rpy" in entry:
        placement.rotation = pin.rpy.rpyToMatrix(*_vector(entry["rpy"], 3, "rpy"))
    return placement


_TASK_OPTIONS = ("weight", "goal", "priority", "tolerance", "gain", "name")


def build_task(robot, q: np.ndarray, entry: dict):
    """A wbik.qp task from a scenario entry, targets resolved at configuration q."""
    from wbik.qp import tasks as T

    if not isinstance(entry, dict) or "type" not in entry:
        raise ScenarioError(f"a task entry needs a 'type', got {entry!r}")
    kind = entry["type"]
    options = {key: entry[key] for key in _TASK_OPTIONS if key in entry}
    frame = entry.get("frame")
    if kind in ("frame", "position", "orientation", "relative") and not frame:
        raise ScenarioError(f"task type {kind!r} needs a 'frame'")
    if kind == "frame":
        for key in ("position_weight", "orientation_weight"):
            if key in entry:
                options[key] = float(entry[key])
        return T.FrameTask(frame, _target_placement(robot, q, entry, frame), **options)
    if kind == "position":
        return T.PositionTask(frame, _target_placement(robot, q, entry, frame).translation,
                              axes=entry.get("axes", "xyz"), **options)
    if kind == "orientation":
        return T.OrientationTask(frame, _target_placement(robot, q, entry, frame).rotation, **options)
    if kind == "relative":
        reference = entry.get("reference")
        if not reference:
            raise ScenarioError("task type 'relative' needs a 'reference' frame")
        relative = _start_placement(robot, q, reference).actInv(_start_placement(robot, q, frame))
        if "target" in entry:
            rotation = (pin.rpy.rpyToMatrix(*_vector(entry["rpy"], 3, "rpy")) if "rpy" in entry
                        else relative.rotation)
            relative = pin.SE3(rotation, _vector(entry["target"], 3, "target"))
        elif "offset" in entry:
            relative.translation = relative.translation + _vector(entry["offset"], 3, "offset")
        return T.RelativeFrameTask(frame, reference, relative, **options)
    if kind == "com":
        com = robot.center_of_mass(q)
        if "target" in entry:
            target = _vector(entry["target"], 3, "com target")
        elif "over" in entry:
            above = _start_placement(robot, q, entry["over"]).translation
            target = np.array([above[0], above[1], com[2]])
        else:
            target = com + _vector(entry.get("offset", [0, 0, 0]), 3, "offset")
        return T.ComTask(target, axes=entry.get("axes", "xyz"), **options)
    if kind == "posture":
        reference = robot.nominal if entry.get("reference", "nominal") == "nominal" else q
        return T.PostureTask(reference, joints=entry.get("joints"), **options)
    if kind == "regularization":
        return T.RegularizationTask(float(entry.get("weight", 1e-6)))
    raise ScenarioError(f"unknown task type {kind!r}; use frame, position, orientation, relative, com, "
                        "posture or regularization")


def check_configuration(robot, q: np.ndarray, contact_placements: dict[str, pin.SE3],
                        support: list[str], margin: float) -> dict:
    """Independent FK checks of one solved configuration: contacts, CoM margin, joint limits."""
    from wbik.qp.constraints import bounded_joint_indices
    from wbik.qp.humanoid import support_polygon

    contact_errors = {}
    for frame, fixed in contact_placements.items():
        reached = robot.frame_placement(q, frame)
        contact_errors[frame] = {
            "position": float(np.linalg.norm(reached.translation - fixed.translation)),
            "rotation": float(np.linalg.norm(pin.log3(fixed.rotation.T @ reached.rotation)))}
    contacts_ok = all(e["position"] <= CONTACT_TOLERANCE and e["rotation"] <= CONTACT_TOLERANCE
                      for e in contact_errors.values())
    com = robot.center_of_mass(q)
    com_margin = None
    if support:
        com_margin = support_polygon(robot, q, support).margin_of(com[:2])
    balance_ok = com_margin is None or com_margin >= margin - 1e-9
    q_index, _ = bounded_joint_indices(robot.model)
    lower, upper = robot.model.lowerPositionLimit[q_index], robot.model.upperPositionLimit[q_index]
    joints = q[q_index]
    limit_excess = float(max(np.max(lower - joints, initial=0.0), np.max(joints - upper, initial=0.0)))
    return {"contact_errors": contact_errors, "contacts_ok": contacts_ok, "com": com.tolist(),
            "com_margin": com_margin, "balance_ok": balance_ok, "limit_excess": limit_excess,
            "limits_ok": limit_excess <= 1e-9}


PHASE_RULES = {
    "success": Rule("success", "=="),
    "contact_error_max_m": Rule("contact_error_m", "<=", "m"),
    "contact_error_max_rad": Rule("contact_error_rad", "<=", "rad"),
    "com_margin_min_m": Rule("com_margin_m", ">=", "m"),
    "limit_excess_max_rad": Rule("limit_excess_rad", "<=", "rad"),
    "collision_distance_min_m": Rule("collision_distance_m", ">=", "m"),
}
"""Expectations of a wholebody_ik phase (limit excess is in m for a prismatic joint)."""


def phase_expectations(phase_expect: dict | None, margin: float, has_support: bool,
                       safety: float | None = None) -> dict:
    """The phase's expect block over the defaults (see the module docstring); with a ``collisions``
    block (``safety``, m) the minimum pair distance must also stay >= safety (less 1e-9 m)."""
    expect = {"success": True, "contact_error_max_m": CONTACT_TOLERANCE,
              "contact_error_max_rad": CONTACT_TOLERANCE, "limit_excess_max_rad": 1e-9}
    if has_support:
        expect["com_margin_min_m"] = margin - 1e-9
    if safety is not None:
        expect["collision_distance_min_m"] = safety - 1e-9
    expect.update(phase_expect or {})
    return expect


def collision_setup(robot, collisions: dict | None):
    """(model for the FK check, the QP constraint) of a checked ``collisions`` block, or (None, None).

    Two CollisionModels of the same table: the check measures every pair by its own FK and coal
    query, independent of the distances the constraint linearised."""
    if collisions is None:
        return None, None
    from wbik.collision import Obstacle, robot_collision_model
    from wbik.qp.constraints import CollisionAvoidance

    def build():
        boxes = [Obstacle(b["name"], tuple(b["size"]), tuple(b["xyz"]), tuple(b["rpy"]))
                 for b in collisions["boxes"]]
        # a pair under the safety distance at the nominal pose is close by design: left out
        return robot_collision_model(robot, self_collision=collisions["self_collision"],
                                     robot_obstacles=collisions["robot_obstacles"], obstacles=boxes,
                                     contact_distance=collisions["safety_distance"])

    return build(), CollisionAvoidance(build(), collisions["safety_distance"],
                                       collisions["influence_distance"])


def collision_check(model, q: np.ndarray) -> dict:
    """Minimum signed distance over the checked pairs at q (m, coal by FK) and that pair."""
    closest = model.minimum(q)
    if closest is None:
        return {"min_distance": None, "pair": None, "pairs": 0}
    return {"min_distance": closest.distance, "pair": [closest.a, closest.b], "pairs": len(model.pairs)}


def phase_figures(success: bool, checks: dict) -> dict:
    errors = checks["contact_errors"].values()
    return {"success": bool(success),
            "contact_error_m": max((e["position"] for e in errors), default=0.0),
            "contact_error_rad": max((e["rotation"] for e in errors), default=0.0),
            "com_margin_m": checks["com_margin"], "limit_excess_rad": checks["limit_excess"],
            "collision_distance_m": (checks.get("collision") or {}).get("min_distance")}


def run_wholebody_ik(spec: dict, on_progress: Callable[[dict], None] | None = None) -> tuple[dict, object]:
    """Solve the phases of a checked spec (:func:`wbik.scenario_schema.validate` filled the defaults);
    the report and the animation from the start through every phase's answer."""
    from wbik.models import load
    from wbik.qp.constraints import LockedJoints, MinimumDistance
    from wbik.qp.humanoid import stance_constraints
    from wbik.qp.problem import IKProblem

    robot = load(spec["robot"], **spec["robot_params"])
    backend = spec["backend"]
    q = robot.nominal.copy() if spec["start"] == "nominal" else _vector(
        spec["start"], robot.model.nq, "start configuration")
    start = q.copy()
    phases = spec["phases"]
    collision_model, collision_constraint = collision_setup(robot, spec["collisions"])
    report = {"name": spec["name"], "kind": "wholebody_ik", "robot": robot.name,
              "backend": backend, "phases": [], "passed": True}
    for phase in phases:
        name = phase["name"]
        contacts = list(phase["contacts"])
        support = list(phase["support"])
        margin = float(phase["margin"])
        tasks = [build_task(robot, q, entry) for entry in phase["tasks"]]
        if not any(task.goal for task in tasks):
            raise ScenarioError(f"phase {name!r} has no goal task")
        tasks.append(build_task(robot, q, {"type": "regularization", "weight": phase["regularization"]}))
        constraints = stance_constraints(robot, q, contacts, support, margin)
        if phase["lock"]:
            constraints.append(LockedJoints(robot.model, list(phase["lock"])))
        for item in phase["min_distance"]:
            constraints.append(MinimumDistance(item["frames"][0], item["frames"][1], float(item["distance"])))
        if collision_constraint is not None:
            constraints.append(collision_constraint)
        contact_placements = {frame: robot.frame_placement(q, frame) for frame in contacts}
        problem = IKProblem(robot.model, tasks, constraints, backend=backend,
                            max_step=float(phase["max_step"]))
        solution = problem.solve(q, max_iterations=int(phase["max_iterations"]))
        checks = check_configuration(robot, solution.q, contact_placements, support, margin)
        if collision_model is not None:
            checks["collision"] = collision_check(collision_model, solution.q)
        expect = phase_expectations(phase["expect"], margin, bool(support),
                                    collision_constraint and collision_constraint.safety)
        expectations = evaluate(expect, phase_figures(solution.success, checks), PHASE_RULES,
                                f"phase {name!r} expect")
        passed = verdict(expectations) != "FAILED"
        report["phases"].append({
            "name": name, "passed": passed, "success": solution.success, "reason": solution.reason,
            "iterations": solution.iterations, "time_s": solution.time_s,
            "task_errors": solution.task_errors, "checks": checks, "expect": expect,
            "expectations": expectations,
            "contacts": contacts, "support": support, "margin": margin, "q": solution.q.tolist()})
        report["passed"] = report["passed"] and passed
        report["verdict"] = verdict(c for p in report["phases"] for c in p["expectations"])
        if on_progress is not None:
            on_progress(report)
        if phase["continue_from"] == "result":
            q = solution.q.copy()
    return report, wholebody_animation(robot, spec, start, report["phases"])


def wholebody_animation(robot, spec: dict, start: np.ndarray, phases: list[dict]):
    """From the start through each phase's answer, ``PHASE_SECONDS`` each (wbik.viz.scenario), with
    each phase's support soles and contacts; the first frame a phase task moves is traced."""
    from wbik.viz.animation import Animation
    from wbik.viz.scenario import PHASE_SECONDS, SAMPLES_PER_PHASE, moved_frame

    return Animation.from_keyframes(
        robot, start, [np.asarray(p["q"], dtype=float) for p in phases], PHASE_SECONDS, SAMPLES_PER_PHASE,
        support=[tuple(p["support"]) for p in phases], contacts=[tuple(p["contacts"]) for p in phases],
        trace_frame=moved_frame(spec), name=spec["name"])


def format_report(report: dict) -> str:
    """A short human-readable summary of a report (the kind's own formatter when it has one)."""
    if report.get("kind") in FORMATTERS:
        return _registered(FORMATTERS, report["kind"], "formatter")(report)
    lines = [f"{report.get('name', '')} ({report.get('kind')}, {report.get('robot', '')}): "
             f"{report_verdict(report)}"]
    for phase in report.get("phases", []):
        goal_errors = ", ".join(f"{k} {v:.2e}" for k, v in phase["task_errors"].items()
                                if not k.startswith("Regularization"))
        lines.append(
            f"  [{'ok' if phase['passed'] else 'FAIL'}] {phase['name']}: "
            f"{'solved' if phase['success'] else 'best effort: ' + phase['reason']}; "
            f"{phase['iterations']} it, {phase['time_s'] * 1e3:.1f} ms")
        lines.append(f"      task errors: {goal_errors}")
        lines.extend(format_checks(phase.get("expectations", [])))
    return "\n".join(lines)


def report_verdict(report: dict) -> str:
    """PASSED / FAILED / informational of a report (``passed`` False is FAILED whatever the checks)."""
    if not report.get("passed"):
        return "FAILED"
    return report.get("verdict", "PASSED")
