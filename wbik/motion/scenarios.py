"""Scenario kinds ``motion_joint`` and ``motion_cartesian``, one entry per move, by default expected to
succeed within the joint speed limits, Cartesian knots to ``tolerance``; applications build their own
motion kinds on :class:`MoveRun` and :func:`common_motion_keys`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.expectations import Rule, judge
from wbik.files import json_plain
from wbik.motion.cartesian import waypoint_path
from wbik.motion.joint import joint_path
from wbik.motion.path import JointPath
from wbik.motion.timing import time_scale
from wbik.motion.trajectory import make_trajectory
from wbik.qp.task_entries import VECTOR3
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
    Method,
    Robot,
    common_keys,
    expect_block,
    kind_schema,
    time_laws,
    timing_modes,
)
from wbik.schema import Either, Key, ListOf, Map, Number, Text, Vector, default_of
from wbik.solvers.method_registry import solver
from wbik.validation import finite_vector
from wbik.viz.animation import Animation

MOVE_RULES = {  # the expectations of one move (jumps: joint steps above the jump threshold)
    "success": Rule("success", "=="),
    "knot_error_max_m": Rule("max_knot_position_error", "<=", "m"),
    "knot_error_max_rad": Rule("max_knot_rotation_error", "<=", "rad"),
    "velocity_ratio_max": Rule("max_velocity_over_limit", "<="),
    "jumps_max": Rule("jumps", "<="),
    "waypoints_reached": Rule("waypoints_reached", "=="),
}


def vector_of(value, size: int, what: str) -> np.ndarray:
    """``value`` as ``size`` finite numbers, else a ScenarioError."""
    return finite_vector(value, size, what, ScenarioError)


def pose_of(entry, what: str):
    if isinstance(entry, dict):
        position = vector_of(entry.get("position"), 3, f"{what} position")
        if "rpy" in entry:
            return pin.SE3(pin.rpy.rpyToMatrix(*vector_of(entry["rpy"], 3, f"{what} rpy")), position)
        return position
    return vector_of(entry, 3, what)


def timed_move(spec: dict, path: JointPath, name: str, extra_figures: dict | None = None,
                extra_defaults: dict | None = None, rules: dict = MOVE_RULES) -> tuple[dict, object]:
    """The entry of a timed, sampled and judged path (``extra_*``: the kind's own) and its trajectory."""
    timing = spec["timing"]
    timed = time_scale(path, timing["law"], timing["velocity_limit"], timing["acceleration_limit"],
                       timing["mode"])
    trajectory = make_trajectory(timed, dt=timing["dt"])
    dense = timed.evaluate(np.linspace(0.0, timed.duration, 20001))[1]
    velocity_ratio = float(np.max(np.abs(dense) / timed.velocity_limit))
    tolerance = float(spec["tolerance"])
    summary = path.summary()
    entry = {"name": name, "path": summary, "info": json_plain(path.info),
             "duration_s": timed.duration, "time_law": timed.law.name, "timing_mode": timed.mode,
             "max_velocity_over_limit": velocity_ratio,
             "trajectory_max_position_error": trajectory.max_position_error,
             "q_end": path.q[-1].tolist()}
    figures = {"success": bool(path.success), "max_velocity_over_limit": velocity_ratio,
               "max_knot_position_error": summary["max_knot_position_error"],
               "max_knot_rotation_error": summary["max_knot_rotation_error"],
               "jumps": len(summary["jumps"] or []), **(extra_figures or {})}
    defaults = {"success": True, "velocity_ratio_max": 1.0 + 1e-9}
    if (spec["expect"] or {}).get("success", True) and summary["max_knot_position_error"] is not None:
        defaults.update(knot_error_max_m=tolerance, knot_error_max_rad=tolerance)  # Cartesian knots
    wanted = {**defaults, **(extra_defaults or {}), **(spec["expect"] or {})}
    return judge(entry, wanted, figures, rules, f"{spec['name'] or spec['kind']} expect"), trajectory


class MoveRun(KindRun):
    """A motion run: its ``moves`` (:func:`timed_move`), animated 0.25 s apart; ``export`` the last one."""

    def __init__(self, spec: dict, on_progress: Progress = None, rules: dict = MOVE_RULES):
        super().__init__(spec, "moves", on_progress, pause=0.25)
        self.trajectory = None
        self.rules = rules  # MOVE_RULES, with a kind's own figures added (e.g. an application's)

    def move(self, chain, path: JointPath, name: str, extra_figures: dict | None = None,
             extra_defaults: dict | None = None, spec: dict | None = None) -> dict:
        """Time, judge and add one move of ``chain`` (``spec``: the move's own keys); the entry."""
        entry, self.trajectory = timed_move(spec or self.spec, path, name, extra_figures, extra_defaults,
                                            self.rules)
        times = np.asarray(self.trajectory.times, dtype=float)
        keep = np.r_[True, np.diff(times) > 0]  # a repeated time keeps its first row
        return self.add(entry, Animation.from_chain(self.robot, chain, times[keep],
                                                    np.asarray(self.trajectory.positions)[keep], name=name))

    def finished(self) -> ScenarioReport:
        """The report; the last move's trajectory written where ``export`` says (paths in the figures)."""
        for kind in ("csv", "json"):
            if kind in self.spec["export"]:
                file = Path(self.spec["export"][kind])
                self.report.figures[kind] = str(getattr(self.trajectory, f"write_{kind}")(file))
        return super().finished()


def chain_of(robot, spec: dict):
    """The file's chain: ``chain`` by name, or the joints between ``base`` and ``tip`` frames."""
    base, tip = spec.get("base"), spec.get("tip")
    if (base is None) != (tip is None):
        raise ScenarioValueError(f"{'tip' if tip is None else 'base'}: missing; a chain named by its frames "
                                 "needs both base: and tip:")
    if base is None:
        return robot.chain(spec["chain"])
    if spec.get("chain") is not None:
        raise ScenarioValueError("chain: give either chain: or base: and tip:, not both")
    return robot.chain_between(base, tip)


def chain_keys() -> dict[str, Key]:
    """``chain`` by name, or ``base`` and ``tip`` frames (the joints between them)."""
    return {"chain": Key(Text(what="a chain name", nullable=True), None),
            "base": Key(Text(what="the chain's base frame", nullable=True), None),
            "tip": Key(Text(what="the chain's tip frame", nullable=True), None)}


def run_joint(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = MoveRun(spec, on_progress)
    chain = chain_of(run.robot, spec)
    configurations = [vector_of(q, chain.nq, f"configurations[{index}]")
                      for index, q in enumerate(spec["configurations"])]
    run.move(chain, joint_path(chain, configurations, int(spec["samples"])), "joint interpolation")
    return run.finished()


def run_cartesian(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = MoveRun(spec, on_progress)
    ik = solver(spec["method"], run.robot, chain=chain_of(run.robot, spec).name,
                timeout_s=float(spec["timeout_s"]))
    waypoints = [pose_of(entry, f"waypoints[{i}]") for i, entry in enumerate(spec["waypoints"])]
    path = waypoint_path(ik, start_of(spec, ik.chain), waypoints, int(spec["samples"]),
                         float(spec["jump_threshold"]))
    chain, tolerance = ik.chain, float(spec["tolerance"])
    wanted = [waypoint.translation if isinstance(waypoint, pin.SE3) else waypoint for waypoint in waypoints]
    reached = [bool(np.linalg.norm(chain.fk(path.q[knot]).translation - position) <= tolerance)
               for knot, position in zip(path.waypoint_knots, wanted, strict=True)]
    entry = run.move(chain, path, f"{len(waypoints)} Cartesian segments", {"waypoints_reached": all(reached)},
                     {"waypoints_reached": True})
    entry["waypoints_reached"] = reached
    return run.finished()


def format_report(report: dict) -> str:
    """One line per move (knots, knot error, jumps, duration, peak speed) and its checks."""
    def describe(move: dict) -> str:
        path = move["path"]
        return (f"{path['knots']} knots, max knot error {path['max_knot_position_error']}, "
                f"jumps {path['jumps']}, duration {move['duration_s']:.3f} s "
                f"({move['time_law']}, {move['timing_mode']}), "
                f"peak |v|/limit {move['max_velocity_over_limit']:.6f}")

    return format_entries(report, "moves", describe)


# -- the schemas -----------------------------------------------------------------------------------
def timing_node() -> Map:
    """``timing: {law, mode, velocity_limit, acceleration_limit, dt}`` (defaults of time_scale)."""
    limit = Either(Number(gt=0, nullable=True), Vector(positive=True))
    return Map({"law": Key(Text(time_laws), default_of(time_scale, "law")),
                "mode": Key(Text(timing_modes), default_of(time_scale, "mode")),
                "velocity_limit": Key(limit, None), "acceleration_limit": Key(limit, None),
                "dt": Key(Number(gt=0, nullable=True, unit="s"), None)}, nullable=True)


def common_motion_keys(rules: dict = MOVE_RULES) -> dict[str, Key]:
    """Keys every motion kind has: robot, timing, export, tolerance, expect (the keys of ``rules``)."""
    return {**common_keys(robot=Key(Robot(), required=True)),
            "timing": Key(timing_node(), {}),
            "export": Key(Map({"csv": Key(Text(what="a file path")), "json": Key(Text(what="a file path"))},
                              nullable=True), {}),
            "tolerance": Key(Number(gt=0, unit="m / rad"), 1e-6),
            "expect": Key(expect_block(rules), None)}


def solving_keys() -> dict[str, Key]:
    """Keys of the kinds that solve IK: method, timeout_s, start."""
    return {"method": Key(Method(), "dls"), "timeout_s": Key(Number(gt=0, unit="s", budget=True), 0.05),
            "start": Key(START, "nominal")}


def samples_key(function) -> dict[str, Key]:
    """``samples`` with the default of the path builder it feeds."""
    return {"samples": Key(Number(ge=1, integer=True), default_of(function, "samples"))}


def joint_schema() -> Map:
    """The keys of a ``motion_joint`` file."""
    configurations = Key(ListOf(Vector(), min_items=2, what="joint vectors"), required=True)
    return kind_schema(common_motion_keys(),
                       {**samples_key(joint_path), **chain_keys(), "configurations": configurations})


def cartesian_schema() -> Map:
    """The keys of a ``motion_cartesian`` file."""
    waypoint = Either(VECTOR3, Map({"position": Key(VECTOR3, required=True), "rpy": Key(VECTOR3)}))
    return kind_schema(common_motion_keys(), {
        **solving_keys(), **samples_key(waypoint_path), **chain_keys(),
        "waypoints": Key(ListOf(waypoint, min_items=1, what="[x, y, z] or {position, rpy}"), required=True),
        "jump_threshold": Key(Number(gt=0, unit="rad"), default_of(waypoint_path, "jump_threshold"))})


SCENARIO_KINDS = (
    ScenarioKind("motion_joint", run_joint, joint_schema, format_report,
                 "joint-space interpolation through configurations"),
    ScenarioKind("motion_cartesian", run_cartesian, cartesian_schema, format_report,
                 "straight Cartesian lines through waypoints"),
)
