"""Scenario kind ``wholebody_ik``: phases solved by the QP layer, each from the previous phase's answer
(keys: docs/formats/task-files.md). By default a phase expects success, contacts held to 1e-6 m / rad, the
CoM ``margin`` inside the support polygon, no joint beyond its limit and, with ``collisions``, every pair
at least the safety distance apart; ``methods`` are compared on every phase (reported, not judged)."""

from __future__ import annotations

import numpy as np

from wbik.collision import Obstacle, robot_collision_model
from wbik.errors import SoleError
from wbik.expectations import Rule, judge
from wbik.options import UnknownOptionError, option_schema
from wbik.qp.contacts import HeldFrame
from wbik.qp.diagnosis import report_lines
from wbik.qp.distances import CollisionAvoidance
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import LockedJoints
from wbik.qp.support_polygon import DegenerateSupportPolygonError
from wbik.qp.task_entries import (
    FRAME,
    NON_NEGATIVE,
    POSITIVE,
    REGULARIZATION_WEIGHT,
    TASK_ENTRY,
    VECTOR3,
    TaskEntryError,
    build_task,
)
from wbik.scenarios.kinds import (
    KindRun,
    Progress,
    ScenarioError,
    ScenarioKind,
    ScenarioReport,
    ScenarioValueError,
    format_entries,
    start_of,
)
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
from wbik.schema import Anything, Boolean, Context, Either, Key, ListOf, Map, Number, Text, Vector
from wbik.solvers.method_registry import method_factory, methods, solver
from wbik.wholebody.problem import FRAMES, WholeBody

CONTACT_TOLERANCE = 1e-6  # m for a contact's position error, rad for its rotation error
PHASE_SECONDS = 1.0  # s of playback per phase
SAMPLES_PER_PHASE = 30

PHASE_RULES = {
    "success": Rule("success", "=="),
    "contact_error_max_m": Rule("contact_error_m", "<=", "m"),
    "contact_error_max_rad": Rule("contact_error_rad", "<=", "rad"),
    "com_margin_min_m": Rule("com_margin_m", ">=", "m"),
    "limit_excess_max_rad": Rule("limit_excess_rad", "<=", "rad"),
    "collision_distance_min_m": Rule("collision_distance_m", ">=", "m"),
}  # (the limit excess of a prismatic joint is in m)


def wholebody_schema() -> Map:
    phase = Map({
        "name": Key(Text()),
        "contacts": Key(FRAMES, []),
        "support": Key(FRAMES),                      # default: the contacts
        "margin": Key(Number(unit="m")),             # default: the scenario's margin
        "lock": Key(ListOf(Text(what="a joint name"), what="joint names"), []),
        "tasks": Key(ListOf(TASK_ENTRY, min_items=1, what="task mappings"), required=True),
        "regularization": Key(POSITIVE, REGULARIZATION_WEIGHT),
        "min_distance": Key(ListOf(Map({"frames": Key(ListOf(FRAME, min_items=2), required=True),
                                        "distance": Key(NON_NEGATIVE, required=True)})), []),
        "max_step": Key(POSITIVE, 0.2),
        "acceleration_limit": Key(Number(gt=0, unit="rad/s^2")),
        "dt": Key(Number(gt=0, unit="s"), 1.0),
        "max_iterations": Key(Number(gt=0, integer=True, budget=True), 300),
        "expect": Key(expect_block(PHASE_RULES), None),
        "continue_from": Key(Text(("result", "start")), "result"),
    })
    collisions = Map({
        "self_collision": Key(Boolean(), True),
        "robot_obstacles": Key(Boolean(), True),
        "boxes": Key(ListOf(Map({"name": Key(Text(), required=True),
                                 "size": Key(Vector(3, positive=True, unit="m"), required=True),
                                 "xyz": Key(VECTOR3, [0.0, 0.0, 0.0]),
                                 "rpy": Key(VECTOR3, [0.0, 0.0, 0.0])}), what="box mappings"), []),
        "safety_distance": Key(Number(ge=0, unit="m"), 0.01),
        "influence_distance": Key(Number(gt=0, unit="m"), 0.1),
    })
    method = Map({"method": Key(Text(_method_names), required=True), "label": Key(Text()),
                  "options": Key(Map(values=Anything()), {}),
                  "max_iterations": Key(Number(gt=0, integer=True, budget=True, nullable=True))})

    def post(spec: dict, path: str, ctx: Context) -> None:
        check_robot_params(spec, path, ctx)
        apply_soles(spec, path, ctx)
        spec["methods"] = _checked_methods(spec, ctx)
        block = spec["collisions"]
        if block is not None and not block["influence_distance"] > block["safety_distance"]:
            ctx.fail("collisions.influence_distance", f"must exceed safety_distance "
                                                      f"({block['safety_distance']:g} m)")
        for index, entry in enumerate(spec["phases"]):
            if block is None and "collision_distance_min_m" in (entry["expect"] or {}):
                ctx.fail(f"phases[{index}].expect.collision_distance_min_m",
                         "needs a top-level 'collisions' block (the pairs whose distance it judges)")
            entry.setdefault("name", f"phase {index + 1}")
            entry.setdefault("support", list(entry["contacts"]))
            entry.setdefault("margin", spec["margin"])
            for item_index, item in enumerate(entry["min_distance"]):
                if len(item["frames"]) != 2:
                    ctx.fail(f"phases[{index}].min_distance[{item_index}].frames",
                             "must name exactly 2 frames")

    return Map({**common_keys(robot=Key(Robot(), required=True)),
                "backend": backend_key(),
                "start": Key(START, "nominal"),
                "margin": margin_key(),
                "collisions": Key(collisions, None),
                "soles": soles_key(),
                "methods": Key(ListOf(Either(Text(_method_names, what="a whole-body method name"), method),
                                      what="whole-body method names or {method, label, options, "
                                           "max_iterations}"), []),
                "phases": Key(ListOf(phase, min_items=1, what="phase mappings"), required=True)}, post=post)


def _method_names() -> tuple[str, ...]:
    return tuple(sorted(methods()))


def _checked_methods(spec: dict, ctx: Context) -> list[dict]:
    """The ``methods`` entries as {method, label, options, max_iterations}, options checked, labels unique."""
    entries = []
    for index, item in enumerate(spec["methods"]):
        entry = {"method": item, "options": {}} if isinstance(item, str) else dict(item)
        entry = {"label": entry["method"], "max_iterations": None, **entry}
        options = option_schema(method_factory(entry["method"]), 2, skip=("max_iterations",),
                                owner=f"method {entry['method']!r}", unknown_error=UnknownOptionError)
        entry["options"] = options.check(entry["options"], f"methods[{index}].options", ctx)
        if entry["label"] in (e["label"] for e in entries):
            ctx.fail(f"methods[{index}]", f"label {entry['label']!r} is used twice; give each a label")
        entries.append(entry)
    return entries


def phase_checks(problem, q0: np.ndarray, solution, collisions=None) -> dict:
    """A phase's checks: contact drifts (m, rad), CoM, limits and, with ``collisions``, the closest pair."""
    robot, q = problem.robot, solution.q
    kinematics = Kinematics(robot.model, q)
    contact_errors = {c.frame: dict(zip(("position", "rotation"), c.drift(kinematics), strict=True))
                      for c in problem.start(q0, strict=False).constraints if isinstance(c, HeldFrame)}
    margin = solution.com_margin
    checks = {"contact_errors": contact_errors,
              "contacts_ok": all(max(e.values()) <= CONTACT_TOLERANCE for e in contact_errors.values()),
              "com": robot.center_of_mass(q).tolist(), "com_margin": None if np.isnan(margin) else margin,
              "balance_ok": all(m.holds for m in solution.measures.values() if m.quantity == "CoM margin"),
              "limit_excess": solution.limit_excess, "limits_ok": solution.limit_excess <= 1e-9}
    if collisions is not None:
        model = collisions.collision_model
        closest = model.minimum(q)
        checks["collision"] = ({"min_distance": None, "pair": None, "pairs": 0} if closest is None else
                               {"min_distance": closest.distance, "pair": [closest.a, closest.b],
                                "pairs": len(model.pairs)})
    return checks


def collision_avoidance(robot, collisions: dict | None):
    """The QP constraint of a checked ``collisions`` block (None without one)."""
    if collisions is None:
        return None
    boxes = [Obstacle(box["name"], tuple(box["size"]), tuple(box["xyz"]), tuple(box["rpy"]))
             for box in collisions["boxes"]]
    model = robot_collision_model(robot, self_collision=collisions["self_collision"],
                                  robot_obstacles=collisions["robot_obstacles"], obstacles=boxes,
                                  contact_distance=collisions["safety_distance"])
    return CollisionAvoidance(model, collisions["safety_distance"], collisions["influence_distance"])


def phase_problem(robot, q: np.ndarray, phase: dict, index: int, extra: list, regularization: bool = True):
    """The phase as a WholeBody from q (contacts held there), with the constraints ``extra``."""
    tasks = []
    for number, entry in enumerate(phase["tasks"]):
        try:
            tasks.append(build_task(robot, q, entry))
        except TaskEntryError as exc:
            raise ScenarioValueError(f"phases[{index}].tasks[{number}]: {exc}") from exc
    if not any(task.goal for task in tasks):
        raise ScenarioError(f"phase {phase['name']!r} has no goal task")
    if regularization:  # on the lowest level (see lowest_priority)
        tasks.append(build_task(robot, q, {"type": "regularization", "weight": phase["regularization"]}))
        tasks[-1].priority = max(task.priority for task in tasks[:-1])
    return WholeBody(robot, tasks,
                     contacts={frame: robot.frame_placement(q, frame) for frame in phase["contacts"]},
                     support=list(phase["support"]), margin=float(phase["margin"]), limits="position",
                     collisions=[(*item["frames"], item["distance"]) for item in phase["min_distance"]],
                     constraints=extra, step_dt=float(phase["dt"]),
                     acceleration_limit=phase.get("acceleration_limit"), name=phase["name"])


def compare_methods(robot, q: np.ndarray, phase: dict, index: int, methods: list[dict],
                    solvers: dict, extra: list) -> dict[str, dict]:
    """{label: figures} of ``methods`` on the phase from q; ``solvers`` keeps one per (label, budget)."""
    problem = phase_problem(robot, q, phase, index, extra)
    compared = {}
    for entry in methods:
        label = entry["label"]
        budget = entry["max_iterations"] or int(phase["max_iterations"])
        if (label, budget) not in solvers:
            solvers[label, budget] = solver(entry["method"], robot, max_iterations=budget, **entry["options"])
        result = solvers[label, budget].solve(problem, q)
        compared[label] = {**result.as_dict(), "task_error": result.task_error, "max_iterations": budget}
    return compared


def run_wholebody_ik(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Solve the phases of a checked spec with ``wbik.solver("qp", robot)``."""
    backend = spec["backend"]
    try:
        run = KindRun(spec, "phases", on_progress, figures={"backend": backend})
    except SoleError as exc:  # named by its soles entry
        index = next((i for i, entry in enumerate(spec["soles"]) if entry["frame"] == exc.sole), None)
        raise ScenarioValueError(f"{'robot_params.soles' if index is None else f'soles[{index}].frame'}: "
                                 f"{exc}") from None
    robot = run.robot
    q = start_of(spec, robot)
    start = q.copy()
    collision_constraint = collision_avoidance(robot, spec["collisions"])
    solvers: dict = {}
    for index, phase in enumerate(spec["phases"]):
        margin, support = float(phase["margin"]), list(phase["support"])
        extra = ([LockedJoints(list(phase["lock"]))] if phase["lock"] else []) + (
            [collision_constraint] if collision_constraint is not None else [])
        problem = phase_problem(robot, q, phase, index, extra, regularization=False)
        settings = (float(phase["max_step"]), int(phase["max_iterations"]), phase["regularization"])
        if settings not in solvers:  # (compare_methods keeps its solvers by (label, budget))
            solvers[settings] = solver("qp", robot, backend=backend, max_step=settings[0],
                                       max_iterations=settings[1], regularization=settings[2])
        try:
            solution = solvers[settings].solve(problem, q)
        except DegenerateSupportPolygonError as exc:
            raise ScenarioValueError(f"phases[{index}].support: {exc}") from None
        checks = phase_checks(problem, q, solution, collision_constraint)
        errors = checks["contact_errors"].values()
        figures = {"success": bool(solution.success),
                   "contact_error_m": max((e["position"] for e in errors), default=0.0),
                   "contact_error_rad": max((e["rotation"] for e in errors), default=0.0),
                   "com_margin_m": checks["com_margin"], "limit_excess_rad": checks["limit_excess"],
                   "collision_distance_m": (checks.get("collision") or {}).get("min_distance")}
        expect = {"success": True, "contact_error_max_m": CONTACT_TOLERANCE,
                  "contact_error_max_rad": CONTACT_TOLERANCE, "limit_excess_max_rad": 1e-9}
        if support:
            expect["com_margin_min_m"] = margin - 1e-9
        if collision_constraint is not None:
            expect["collision_distance_min_m"] = collision_constraint.safety - 1e-9
        expect.update(phase["expect"] or {})
        entry = judge({
            "name": phase["name"], "success": solution.success, "reason": solution.reason,
            "iterations": solution.iterations, "time_s": solution.time_s, "task_errors": solution.task_errors,
            "checks": checks, "expect": expect, "contacts": list(phase["contacts"]), "support": support,
            "margin": margin, "q": solution.q.tolist(),
            "diagnosis": None if solution.diagnosis is None else solution.diagnosis.as_dict(),
        }, expect, figures, PHASE_RULES, f"phase {phase['name']!r} expect")
        if spec["methods"]:
            entry["methods"] = compare_methods(robot, q, phase, index, spec["methods"], solvers, extra)
        run.add(entry)
        if phase["continue_from"] == "result":
            q = solution.q.copy()
    report = run.finished()  # one animation through every phase's answer, not one per phase
    report.animation = wholebody_animation(robot, spec, start, report.figures["phases"])
    return report


def moved_frame(spec: dict) -> str | None:
    """The first frame a phase's frame or position task moves."""
    return next((task["frame"] for phase in spec.get("phases", []) for task in phase.get("tasks", [])
                 if task.get("type") in ("frame", "position") and task.get("frame")
                 and task["frame"] not in phase.get("contacts", []) and not task.get("keep")), None)


def wholebody_animation(robot, spec: dict, start: np.ndarray, phases: list[dict]):
    """From the start through each phase's answer, with its support and contacts (and back to the start
    of a ``continue_from: start`` phase)."""
    from wbik.viz.animation import Animation

    stops = []  # (configuration, support, contacts) of each keyframe
    origin = shown = np.asarray(start, dtype=float)  # where the next phase starts, where the robot is
    for phase, entry in zip(spec["phases"], phases, strict=False):
        if stops and not np.array_equal(origin, shown):
            stops.append((origin, *stops[-1][1:]))
        shown = np.asarray(entry["q"], dtype=float)
        stops.append((shown, tuple(entry["support"]), tuple(entry["contacts"])))
        if phase["continue_from"] == "result":
            origin = shown
    keyframes, support, contacts = zip(*stops, strict=True)
    return Animation.from_keyframes(
        robot, start, keyframes, PHASE_SECONDS, SAMPLES_PER_PHASE, support=support, contacts=contacts,
        trace_frame=moved_frame(spec), name=spec["name"])


def format_method(label: str, figures: dict) -> str:
    """A compared method's verdict and figures, why it failed, what it could not express."""
    margin = figures["com_margin"]
    margin_text = "no support" if margin is None or margin != margin else f"CoM margin {margin * 1e3:.1f} mm"
    lines = [f"      {label}: {'solved' if figures['success'] else 'not solved'}; {margin_text}, worst task "
             f"error {figures['task_error']:.2e}, contact drift {figures['contact_drift']:.1e}, "
             f"{figures['time_s'] * 1e3:.1f} ms, {figures['iterations']} it"]
    reason, diagnosis = split_diagnosis(figures["reason"], figures.get("diagnosis"))
    if not figures["success"]:
        lines.append(f"        why: {reason}")
    lines += [f"        {text}" for text in diagnosis]
    # a peer's "unsupported by PEER: ...", or another method's words
    lines += [f"        {item if item.startswith('unsupported by ') else f'cannot express: {item}'}"
              for item in figures["unsupported"]]
    return "\n".join(lines)


def split_diagnosis(reason: str, diagnosis: dict | None) -> tuple[str, list[str]]:
    """``reason`` without the QP diagnosis summary at its end, and the diagnosis (JSON form) as lines."""
    if not diagnosis:
        return reason, []
    summary = diagnosis.get("summary") or ""
    return (reason.removesuffix(summary).rstrip("; ") if summary and reason.endswith(summary) else reason,
            report_lines(diagnosis))


def format_report(report: dict) -> str:
    def describe(phase: dict) -> str:
        goal_errors = ", ".join(f"{k} {v:.2e}" for k, v in phase["task_errors"].items()
                                if not k.startswith("Regularization"))
        reason, diagnosis = split_diagnosis(phase["reason"], phase.get("diagnosis"))
        text = (f"{'solved' if phase['success'] else 'best effort: ' + reason}; "
                f"{phase['iterations']} it, {phase['time_s'] * 1e3:.1f} ms\n      task errors: {goal_errors}")
        text += "".join(f"\n      {line}" for line in diagnosis)
        if phase.get("methods"):
            text += "\n    compared (wbik.wholebody, the shared check):\n" + "\n".join(
                format_method(label, figures) for label, figures in phase["methods"].items())
        return text

    return format_entries(report, "phases", describe)


SCENARIO_KINDS = (
    ScenarioKind("wholebody_ik", run_wholebody_ik, wholebody_schema, format_report,
                 "phases of whole-body IK (QP), each checked by FK"),
)
