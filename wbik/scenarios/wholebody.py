"""Scenario kind ``wholebody_ik``: a sequence of phases solved by the QP layer, each from the
previous phase's answer (its schema, runner and printed report)::

    kind: wholebody_ik
    robot: bioloid                 # a built-in name, example-robot-data:NAME or a .urdf path
    robot_params: {floating_base: true}   # for a URDF path: wbik.load's parameters (typed)
    soles:                         # feet of a URDF / example-robot-data robot (m, in the sole frame)
      - {frame: left_sole_link, size: [0.2, 0.12], centre: [-0.005, 0, 0]}   # a flat sole rectangle
      - {frame: FL_FOOT, point: [0, 0, 0]}                                   # a point foot
      - {frame: edge_link, corners: [[0.1, 0, 0], [-0.1, 0, 0]]}            # any contact points
    backend: daqp                  # osqp, daqp, quadprog, proxqp, "fastest" or "default"
                                   # (default: wbik.qp.backends.DEFAULT, DAQP, the fastest measured)
    margin: 0.005                  # m, default CoM margin of the phases (default COM_MARGIN, 0.005)
    methods: [qp, placo, pink, mink]   # optional: whole-body methods compared on every phase (below)
    collisions:                    # optional: hard collision avoidance in every phase (wbik.collision)
      self_collision: true         # pairs of the robot's own primitives (default true)
      robot_obstacles: true        # the fixed obstacles its model lists, e.g. the UR5's table (default true)
      boxes: [{name: shelf, size: [0.4, 0.3, 0.02], xyz: [0.6, 0.0, 0.8], rpy: [0, 0, 0]}]   # m, rad
      safety_distance: 0.02        # m, every pair at least this far apart (default 0.01); pairs
                                   # closer than this at the nominal pose are left out (close by design)
      influence_distance: 0.1      # m, pairs closer than this get a QP row (default 0.1)
    phases:
      - name: shift the CoM over the right foot
        contacts: [r_sole, l_sole]  # frames held fixed (hard equality; a point foot: its position only)
        support: [r_sole, l_sole]   # soles of the support polygon (default: the contacts)
        margin: 0.005               # m, CoM at least this far inside the polygon (default: the file's)
        lock: [mb]                  # joints held at their value (optional)
        acceleration_limit: 20      # rad/s^2, optional: each IK step a period of dt (s, default 1):
        dt: 0.01                    # joint velocities change by at most a dt from step to step
        tasks:
          - {type: com, over: r_sole, axes: xy}
          - {type: orientation, frame: pelvis, keep: true, weight: 0.1, goal: false}
        expect: {success: true}     # or {success: false}: a balanced best effort; see PHASE_RULES

Task entries are those of :mod:`wbik.qp.task_entries` (``type`` frame | position | orientation |
relative | com | posture | regularization, or any type registered there; ``target``, ``rpy``, ``keep``,
``offset``, ``over``; options weight, position_weight, orientation_weight, axes, goal, priority,
tolerance): each type's keys are those its :class:`~wbik.qp.task_entries.TaskEntry` declares. Every phase's
answer is checked independently by FK: contacts, CoM margin in the support polygon, joint limits.
The phase's ``expect`` block judges these figures (keys in ``PHASE_RULES``, thresholds SI); unless
the block sets them, the phase expects success, contacts held to 1e-6 m / rad, the CoM ``margin``
inside the support polygon (when there is one) and no joint beyond its limit (1e-9), and with
``collisions`` the minimum pair distance (coal, by FK) at least the safety distance
(``collision_distance_min_m``). An ``expect`` value may be ``{threshold, expected_to_fail, why}``
(see :mod:`wbik.expectations`).

Contacts on a point foot (a sole with a single contact point) hold its position only: a point
contact transmits no moment, so its rotation is free (:func:`wbik.qp.humanoid.contact_constraint`).
The support polygon is the convex hull of the contact points of the support soles; a support that
spans no area (two point feet) is refused as input of a phase (``phases[i].support``), and reported
as a degenerate polygon (margin: minus the distance to it, failed) where an answer is checked.

``methods`` (entries: a whole-body method name, or ``{method, label, options, max_iterations}``)
compares methods of :mod:`wbik.wholebody` on every phase: each phase becomes a
:class:`wbik.wholebody.WholeBody` (the same tasks, contacts held where they are at the phase's
start, support, margin, ``min_distance`` pairs, joint position limits) solved from the same start
by each method within the phase's ``max_iterations`` (unless the entry gives its own), and judged
by the one shared check (:func:`wbik.solvers.check.check_problem`). Each phase's ``methods`` figure
holds per label: success, reason, CoM margin, contact drift, task errors and the worst of them,
time, iterations, and what the method could not express (``unsupported``: Pink and mink have no
hard support polygon). These comparisons are reported, not judged: the phase's verdict is the kind's
own QP's. ``lock`` and ``collisions`` are not part of a WholeBody problem, so a file with
``methods`` may not use them.

The report's figures: ``backend`` and one entry per phase in ``phases``; the animation goes from
the start through every phase's answer.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.expectations import Rule
from wbik.expectations import evaluate
from wbik.expectations import verdict
from wbik.options import UnknownOptionError
from wbik.options import option_schema
from wbik.qp.diagnosis import report_lines
from wbik.qp.task_entries import FRAME
from wbik.qp.task_entries import NON_NEGATIVE
from wbik.qp.task_entries import POSITIVE
from wbik.qp.task_entries import REGULARIZATION_WEIGHT
from wbik.qp.task_entries import TASK_ENTRY
from wbik.qp.task_entries import VECTOR3
from wbik.qp.task_entries import TaskEntryError
from wbik.qp.task_entries import build_task
from wbik.scenario_schema import FRAMES
from wbik.scenario_schema import START
from wbik.scenario_schema import Robot
from wbik.scenario_schema import apply_soles
from wbik.scenario_schema import backend_key
from wbik.scenario_schema import check_robot_params
from wbik.scenario_schema import common_keys
from wbik.scenario_schema import expect_block
from wbik.scenario_schema import margin_key
from wbik.scenario_schema import soles_key
from wbik.scenarios.kinds import KindRun
from wbik.scenarios.kinds import Progress
from wbik.scenarios.kinds import ScenarioError
from wbik.scenarios.kinds import ScenarioKind
from wbik.scenarios.kinds import ScenarioReport
from wbik.scenarios.kinds import ScenarioValueError
from wbik.scenarios.kinds import format_entries
from wbik.scenarios.kinds import start_of
from wbik.schema import Anything
from wbik.schema import Boolean
from wbik.schema import Context
from wbik.schema import Either
from wbik.schema import Key
from wbik.schema import ListOf
from wbik.schema import Map
from wbik.schema import Number
from wbik.schema import Text
from wbik.schema import Vector

__all__ = ["CONTACT_TOLERANCE", "PHASE_RULES", "SCENARIO_KINDS", "check_configuration", "compare_methods",
           "format_method", "format_report", "run_wholebody_ik", "wholebody_schema"]

CONTACT_TOLERANCE = 1e-6
"""Contacts must hold to this (m for the position error, rad for the rotation error)."""

PHASE_RULES = {
    "success": Rule("success", "=="),
    "contact_error_max_m": Rule("contact_error_m", "<=", "m"),
    "contact_error_max_rad": Rule("contact_error_rad", "<=", "rad"),
    "com_margin_min_m": Rule("com_margin_m", ">=", "m"),
    "limit_excess_max_rad": Rule("limit_excess_rad", "<=", "rad"),
    "collision_distance_min_m": Rule("collision_distance_m", ">=", "m"),
}
"""Expectations of a wholebody_ik phase (limit excess is in m for a prismatic joint)."""


# -- the schema ------------------------------------------------------------------------------------
def wholebody_schema() -> Map:
    """The keys of a wholebody_ik file (see the module docstring)."""
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
    collisions = Map({  # collision_setup; absent: no collision constraint
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
            if entry.get("margin") is None:
                entry["margin"] = spec["margin"]
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
    from wbik.solvers.method_registry import methods
    return tuple(sorted(methods()))


def _checked_methods(spec: dict, ctx: Context) -> list[dict]:
    """The ``methods`` entries as {method, label, options, max_iterations or None}: options checked by the
    method's option schema (:func:`wbik.options.option_schema`), labels unique."""
    from wbik.solvers.method_registry import method_factory
    entries = []
    for index, item in enumerate(spec["methods"]):
        entry = {"method": item, "options": {}} if isinstance(item, str) else dict(item)
        entry.setdefault("label", entry["method"])
        entry.setdefault("max_iterations", None)
        options = option_schema(method_factory(entry["method"]), 2, skip=("max_iterations",),
                                owner=f"method {entry['method']!r}", unknown_error=UnknownOptionError)
        entry["options"] = options.check(entry["options"], f"methods[{index}].options", ctx)
        if entry["label"] in (e["label"] for e in entries):
            ctx.fail(f"methods[{index}]", f"label {entry['label']!r} is used twice; give each a label")
        entries.append(entry)
    return entries


# -- the checks of one phase -----------------------------------------------------------------------
def check_configuration(robot, q: np.ndarray, contact_placements: dict[str, pin.SE3],
                        support: list[str], margin: float) -> dict:
    """Independent FK checks of one solved configuration: contacts (a point foot: its position only),
    CoM margin (a degenerate support: minus the distance to it, and not balanced), joint limits."""
    from wbik.qp.constraint import bounded_joint_indices
    from wbik.qp.humanoid import is_point_foot
    from wbik.qp.humanoid import sole_corners
    from wbik.qp.kinematics import Kinematics
    from wbik.qp.support_polygon import DegenerateSupport
    from wbik.qp.support_polygon import feet_support_region

    contact_errors = {}
    for frame, fixed in contact_placements.items():
        reached = robot.frame_placement(q, frame)
        contact_errors[frame] = {
            "position": float(np.linalg.norm(reached.translation - fixed.translation)),
            "rotation": 0.0 if is_point_foot(robot, frame) else
            float(np.linalg.norm(pin.log3(fixed.rotation.T @ reached.rotation)))}
    contacts_ok = all(e["position"] <= CONTACT_TOLERANCE and e["rotation"] <= CONTACT_TOLERANCE
                      for e in contact_errors.values())
    com = robot.center_of_mass(q)
    com_margin, degenerate = None, False
    if support:
        region = feet_support_region(Kinematics(robot.model, q), sole_corners(robot), support)
        com_margin, degenerate = region.margin_of(com[:2]), isinstance(region, DegenerateSupport)
    balance_ok = com_margin is None or (not degenerate and com_margin >= margin - 1e-9)
    q_index, _ = bounded_joint_indices(robot.model)
    lower, upper = robot.model.lowerPositionLimit[q_index], robot.model.upperPositionLimit[q_index]
    joints = q[q_index]
    limit_excess = float(max(np.max(lower - joints, initial=0.0), np.max(joints - upper, initial=0.0)))
    return {"contact_errors": contact_errors, "contacts_ok": contacts_ok, "com": com.tolist(),
            "com_margin": com_margin, "support_degenerate": degenerate, "balance_ok": balance_ok,
            "limit_excess": limit_excess, "limits_ok": limit_excess <= 1e-9}


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
    from wbik.collision import Obstacle
    from wbik.collision import robot_collision_model
    from wbik.qp.distances import CollisionAvoidance
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
    """The judged figures of a phase (the ``figure`` names of PHASE_RULES)."""
    errors = checks["contact_errors"].values()
    return {"success": bool(success),
            "contact_error_m": max((e["position"] for e in errors), default=0.0),
            "contact_error_rad": max((e["rotation"] for e in errors), default=0.0),
            "com_margin_m": checks["com_margin"], "limit_excess_rad": checks["limit_excess"],
            "collision_distance_m": (checks.get("collision") or {}).get("min_distance")}


# -- the runner ------------------------------------------------------------------------------------
def _phase_tasks(robot, q: np.ndarray, phase: dict, index: int, regularization: bool = True) -> list:
    """The phase's tasks (targets at q) and, with ``regularization``, its regularisation; a bad entry
    names the phase."""
    tasks = []
    for number, entry in enumerate(phase["tasks"]):
        try:
            tasks.append(build_task(robot, q, entry))
        except TaskEntryError as exc:
            raise ScenarioValueError(f"phases[{index}].tasks[{number}]: {exc}") from exc
    if not any(task.goal for task in tasks):
        raise ScenarioError(f"phase {phase['name']!r} has no goal task")
    if not regularization:
        return tasks
    regularization = build_task(robot, q, {"type": "regularization", "weight": phase["regularization"]})
    regularization.priority = max(task.priority for task in tasks)  # the lowest level (see lowest_priority)
    tasks.append(regularization)
    return tasks


def _kind_run(spec: dict, on_progress: Progress) -> KindRun:
    """The run of a checked spec; a sole the robot refuses (an unknown frame, bad points) is a
    ScenarioValueError naming the ``soles`` entry."""
    from wbik.errors import SoleError

    try:
        return KindRun(spec, "phases", on_progress, figures={"backend": spec["backend"]})
    except SoleError as exc:
        index = next((i for i, entry in enumerate(spec["soles"]) if entry["frame"] == exc.sole), None)
        where = f"soles[{index}].frame" if index is not None else "robot_params.soles"
        raise ScenarioValueError(f"{where}: {exc}") from None


def phase_problem(robot, q: np.ndarray, phase: dict, index: int, extra: list, regularization: bool = True):
    """The phase as a :class:`wbik.wholebody.problem.WholeBody` from q: its tasks, contacts held where they
    are at q, support and margin, joint position limits, minimum distances, acceleration limits (IK steps:
    periods of ``dt``) and ``extra`` (locked joints, collision avoidance)."""
    from wbik.wholebody.problem import WholeBody

    return WholeBody(robot, _phase_tasks(robot, q, phase, index, regularization),
                     contacts={frame: robot.frame_placement(q, frame) for frame in phase["contacts"]},
                     support=list(phase["support"]), margin=float(phase["margin"]), limits="position",
                     collisions=[(*item["frames"], item["distance"]) for item in phase["min_distance"]],
                     constraints=extra, step_dt=float(phase["dt"]),
                     acceleration_limit=phase.get("acceleration_limit"), name=phase["name"])


def compare_methods(robot, q: np.ndarray, phase: dict, index: int, methods: list[dict],
                    solvers: dict, extra: list) -> dict[str, dict]:
    """Each of ``methods`` on the phase as a :class:`wbik.wholebody.problem.WholeBody` from q (see the
    module docstring; ``extra``: the phase's locked joints and collision avoidance), judged by the shared
    check: {label: figures}. ``solvers`` keeps one solver per (label, budget) for the run (a PlaCo robot
    costs milliseconds to load)."""
    from wbik.solvers.method_registry import solver

    problem = phase_problem(robot, q, phase, index, extra)
    compared = {}
    for entry in methods:
        label = entry["label"]
        budget = entry["max_iterations"] or int(phase["max_iterations"])
        if (label, budget) not in solvers:
            solvers[label, budget] = solver(entry["method"], robot, max_iterations=budget, **entry["options"])
        result = solvers[label, budget].solve(problem, q)
        compared[label] = {**result.as_dict(), "task_error": result.task_error,
                           "max_iterations": budget}
    return compared


def run_wholebody_ik(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Solve the phases of a checked spec (:func:`wbik.scenario_schema.validate` filled the defaults) with
    ``wbik.solver("qp", robot)``; the report and the animation from the start through every phase's
    answer."""
    from wbik.qp.limits import LockedJoints
    from wbik.qp.support_polygon import DegenerateSupportPolygonError
    from wbik.solvers.method_registry import solver

    backend = spec["backend"]
    run = _kind_run(spec, on_progress)
    robot = run.robot
    q = start_of(spec, robot)
    start = q.copy()
    collision_model, collision_constraint = collision_setup(robot, spec["collisions"])
    solvers: dict = {}
    for index, phase in enumerate(spec["phases"]):
        name = phase["name"]
        contacts = list(phase["contacts"])
        support = list(phase["support"])
        margin = float(phase["margin"])
        extra = ([LockedJoints(list(phase["lock"]))] if phase["lock"] else []) + (
            [collision_constraint] if collision_constraint is not None else [])
        contact_placements = {frame: robot.frame_placement(q, frame) for frame in contacts}
        problem = phase_problem(robot, q, phase, index, extra, regularization=False)
        settings = ("qp", backend, float(phase["max_step"]), int(phase["max_iterations"]),
                    phase["regularization"])
        if settings not in solvers:
            solvers[settings] = solver("qp", robot, backend=backend, max_step=settings[2],
                                       max_iterations=settings[3], regularization=settings[4])
        try:
            solution = solvers[settings].solve(problem, q)
        except DegenerateSupportPolygonError as exc:
            raise ScenarioValueError(f"phases[{index}].support: {exc}") from None
        checks = check_configuration(robot, solution.q, contact_placements, support, margin)
        if collision_model is not None:
            checks["collision"] = collision_check(collision_model, solution.q)
        expect = phase_expectations(phase["expect"], margin, bool(support),
                                    collision_constraint and collision_constraint.safety)
        expectations = evaluate(expect, phase_figures(solution.success, checks), PHASE_RULES,
                                f"phase {name!r} expect")
        entry = {
            "name": name, "passed": verdict(expectations) != "FAILED", "success": solution.success,
            "reason": solution.reason, "iterations": solution.iterations, "time_s": solution.time_s,
            "task_errors": solution.task_errors, "checks": checks, "expect": expect,
            "expectations": expectations,
            "contacts": contacts, "support": support, "margin": margin, "q": solution.q.tolist(),
            "diagnosis": None if solution.diagnosis is None else solution.diagnosis.as_dict()}
        if spec["methods"]:
            entry["methods"] = compare_methods(robot, q, phase, index, spec["methods"], solvers, extra)
        run.add(entry)
        if phase["continue_from"] == "result":
            q = solution.q.copy()
    report = run.finished()  # one animation through every phase's answer, not one per phase
    report.animation = wholebody_animation(robot, spec, start, report.figures["phases"])
    return report


def moved_frame(spec: dict) -> str | None:
    """The first frame a phase task moves (frame/position tasks that do not keep their pose)."""
    for phase in spec.get("phases", []):
        contacts = set(phase.get("contacts", []))
        for task in phase.get("tasks", []):
            frame = task.get("frame")
            if task.get("type") in ("frame", "position") and frame and frame not in contacts \
                    and not task.get("keep"):
                return frame
    return None


def wholebody_animation(robot, spec: dict, start: np.ndarray, phases: list[dict]):
    """From the start through each phase's answer, ``PHASE_SECONDS`` each (wbik.viz.scenario), with
    each phase's support soles and contacts; a phase that started from elsewhere than the previous
    answer (``continue_from: start``) is preceded by the way back there, on the previous stance. The
    first frame a phase task moves is traced."""
    from wbik.viz.animation import Animation
    from wbik.viz.scenario import PHASE_SECONDS
    from wbik.viz.scenario import SAMPLES_PER_PHASE

    keyframes: list[np.ndarray] = []
    support: list[tuple] = []
    contacts: list[tuple] = []
    origin = shown = np.asarray(start, dtype=float)  # where the next phase starts, where the robot is
    for phase, entry in zip(spec["phases"], phases, strict=False):
        if keyframes and not np.array_equal(origin, shown):
            keyframes.append(origin)
            support.append(support[-1])
            contacts.append(contacts[-1])
        shown = np.asarray(entry["q"], dtype=float)
        keyframes.append(shown)
        support.append(tuple(entry["support"]))
        contacts.append(tuple(entry["contacts"]))
        if phase["continue_from"] == "result":
            origin = shown
    return Animation.from_keyframes(
        robot, start, keyframes, PHASE_SECONDS, SAMPLES_PER_PHASE, support=support, contacts=contacts,
        trace_frame=moved_frame(spec), name=spec["name"])


def format_method(label: str, figures: dict) -> str:
    """One compared method's line: verdict of the shared check, CoM margin, worst goal task error,
    contact drift, time and iterations, and what it could not express."""
    margin = figures["com_margin"]
    margin_text = "no support" if margin is None or margin != margin else f"CoM margin {margin * 1e3:.1f} mm"
    line = (f"      {label}: {'solved' if figures['success'] else 'not solved'}; {margin_text}, worst task "
            f"error {figures['task_error']:.2e}, contact drift {figures['contact_drift']:.1e}, "
            f"{figures['time_s'] * 1e3:.1f} ms, {figures['iterations']} it")
    diagnosis = figures.get("diagnosis")
    if not figures["success"]:
        line += f"\n        why: {_without_summary(figures['reason'], diagnosis)}"
    for text in report_lines(diagnosis) if diagnosis else ():
        line += f"\n        {text}"
    for item in figures["unsupported"]:  # a peer's "unsupported by PEER: ...", or another method's words
        said = item if item.startswith("unsupported by ") else f"cannot express: {item}"
        line += f"\n        {said}"
    return line


def _without_summary(reason: str, diagnosis: dict | None) -> str:
    """The reason without the diagnosis's summary at its end (printed line by line instead)."""
    summary = (diagnosis or {}).get("summary") or ""
    return reason.removesuffix(summary).rstrip("; ") if summary and reason.endswith(summary) else reason


def format_report(report: dict) -> str:
    """The phase summary: solved or best effort, iterations, time, goal task errors, the compared
    methods (with ``methods``), the checks."""
    def describe(phase: dict) -> str:
        goal_errors = ", ".join(f"{k} {v:.2e}" for k, v in phase["task_errors"].items()
                                if not k.startswith("Regularization"))
        diagnosis = phase.get("diagnosis")
        reason = _without_summary(phase["reason"], diagnosis)
        text = (f"{'solved' if phase['success'] else 'best effort: ' + reason}; "
                f"{phase['iterations']} it, {phase['time_s'] * 1e3:.1f} ms\n      task errors: {goal_errors}")
        for line in report_lines(diagnosis) if diagnosis else ():
            text += f"\n      {line}"
        if phase.get("methods"):
            text += "\n    compared (wbik.wholebody, the shared check):\n" + "\n".join(
                format_method(label, figures) for label, figures in phase["methods"].items())
        return text

    return format_entries(report, "phases", describe)


SCENARIO_KINDS = (
    ScenarioKind("wholebody_ik", run_wholebody_ik, wholebody_schema, format_report,
                 "phases of whole-body IK (QP), each checked by FK"),
)
