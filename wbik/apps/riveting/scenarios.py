"""Scenario kind ``ur5_riveting``: schema, runner and printed report. The animation is the first planner's
first ``ANIMATION_SECONDS`` every ``ANIMATION_SAMPLE_S`` (all runs would add some 12 MB)."""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from wbik.apps.riveting.cycle import NoiseModel, RunConfig
from wbik.apps.riveting.plan import Insertion
from wbik.apps.riveting.report import DEFAULT_PLANNERS, RIVETING_RULES, format_text, run_task, write_report
from wbik.apps.riveting.scene import build_scene
from wbik.errors import WbikError, did_you_mean
from wbik.models import load
from wbik.qp.task_entries import NON_NEGATIVE, POSITIVE, VECTOR3
from wbik.scenarios.kinds import (
    Progress,
    ScenarioError,
    ScenarioKind,
    ScenarioReport,
    UnknownExpectationKeyError,
)
from wbik.scenarios.schema import Robot, backend_key, common_keys, expect_block, time_laws
from wbik.schema import (
    Context,
    Either,
    Key,
    ListOf,
    Map,
    Number,
    Refused,
    Text,
    Variants,
    Vector,
    from_dataclass,
)

ANIMATION_SECONDS = 40.0
ANIMATION_SAMPLE_S = 0.1


def run_riveting(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    """Every planner of a checked spec; the report with the animation of the first planner's first cycle."""
    kept = {}

    def progress(partial: dict) -> None:
        if on_progress is not None:
            on_progress(ScenarioReport.from_dict(partial))

    try:
        result = run_task(spec, progress, keep=kept)
    except WbikError:
        raise
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"ur5_riveting: {exc}") from exc
    if spec["report_folder"]:
        write_report(result, spec["report_folder"])
    report = ScenarioReport.from_dict(result)
    if kept:
        robot = load(spec["robot"])  # the robot of wbik.apps.riveting.report.Cell, arm chain "arm"
        animation = riveting_animation(robot.chain("arm"), next(iter(kept.values())))
        report.animation = animation.with_environment(scene_boxes(build_scene(spec.get("scene"))))
    return report


def scene_boxes(scene) -> tuple:
    """The cell's table and workpiece (a wbik.apps.riveting.scene.Scene) as the viewer's boxes."""
    from wbik.viz.environment import PART_COLOR, TABLE_COLOR, SceneBox

    return (SceneBox("table", scene.table_size, scene.table_box_center, color=TABLE_COLOR),
            SceneBox("workpiece", scene.workpiece_size, scene.workpiece_center, color=PART_COLOR))


def riveting_animation(chain, result, seconds: float = ANIMATION_SECONDS,
                       sample_s: float = ANIMATION_SAMPLE_S):
    """The first ``seconds`` of a planner's RunResult every ``sample_s``."""
    from wbik.viz.animation import Animation

    timeline = result.timeline
    end = min(seconds, timeline[-1][0] + timeline[-1][1].duration)
    times = np.append(np.arange(0.0, end, sample_s), end)
    times = times[np.r_[True, np.diff(times) > 1e-9]]
    indices = np.searchsorted([start for start, _ in timeline], times, side="right") - 1
    rows = [move.evaluate(min(t - start, move.duration))[0]
            for t, (start, move) in zip(times, [timeline[i] for i in indices], strict=True)]
    return Animation.from_chain(chain.robot, chain, times, np.array(rows), name=f"riveting, {result.planner}")


def riveting_schema() -> Map:
    run = {item.name: item.default for item in fields(RunConfig)}
    position = Map({"position": Key(VECTOR3), "rpy": Key(VECTOR3)})
    rows = ListOf(Map({"x": Key(Vector(), required=True), "y": Key(Number(unit="m")),
                       "z": Key(Number(unit="m"))}), min_items=1)
    face = Map({"rows": Key(rows, required=True)})
    scene = Map({  # missing keys take wbik.apps.riveting.scene.DEFAULT_SCENE
        "table": Key(Map({"top_z": Key(Number(unit="m")), "center": Key(Vector(2)),
                          "size": Key(Vector(3, positive=True))})),
        "workpiece": Key(Map({"center": Key(Vector(2)), "size": Key(Vector(3, positive=True))})),
        "hole_diameter": Key(Number(gt=0, unit="m")), "hole_depth": Key(Number(gt=0, unit="m")),
        "faces": Key(Map({"top": Key(face), "right": Key(face), "left": Key(face)})),
        "rivet_home": Key(position)}, nullable=True)
    named = {"name": Key(Text())}
    noise = {"position_sigma": NON_NEGATIVE, "position_max": POSITIVE, "angle_sigma_deg": NON_NEGATIVE}
    planners = {  # options and their defaults are the planner classes' (wbik.apps.riveting.thesis / .ours)
        "thesis": Map({**named, "planner": Key(Text()), "timing": Key(Text(("thesis", "optimal"))),
                       "intermediate_distance": Key(Number(gt=0, unit="m")),
                       "intermediate_time": Key(Number(gt=0, unit="s")), "sleep": Key(Number(ge=0, unit="s")),
                       "move_time": Key(Number(gt=0, unit="s")),
                       "return_via": Key(Text(("direct", "intermediate")))}),
        "ours": Map({**named, "planner": Key(Text()), "minimum_clearance": Key(Number(ge=0, unit="m")),
                     "line_clearance": Key(Number(ge=0, unit="m")),
                     "knot_spacing": Key(Number(gt=0, unit="m")),
                     "max_step": Key(Number(gt=0, unit="rad")), "backend": backend_key()}),
    }
    planner = Variants(lambda entry: entry.get("planner", "ours"), planners,
                       "a planner mapping {name, planner: thesis | ours, options...}", "planner")

    def post(spec: dict, path: str, ctx: Context) -> None:
        names = [entry.get("name", entry.get("planner", "ours")) for entry in spec["planners"]]
        for name in spec.get("expect") or {}:
            if name not in names:
                raise UnknownExpectationKeyError(
                    f"{ctx.source}: unknown key 'expect.{name}'{did_you_mean(name, names)}: expect names the "
                    f"planners of 'planners', which are {', '.join(names)}", f"expect.{name}", names)

    return Map({
        **common_keys(robot=Key(Robot(only=("ur5",)), "ur5")),
        "robot_params": Key(Refused("ur5_riveting does not take robot_params: its cell is built for the "
                                    "built-in UR5 with the rivet tool; remove the key")),
        "duration_s": Key(Number(gt=0, unit="s", budget=True), run["duration"]),
        "seed": Key(Number(ge=0, integer=True), run["seed"]),
        "max_cycles": Key(Number(ge=1, integer=True, nullable=True), run["max_cycles"]),
        "report_folder": Key(Text(what="a folder path", nullable=True), None),
        "limits": Key(Map({"velocity": Key(Either(POSITIVE, Vector(6, positive=True))),
                           "acceleration": Key(Number(gt=0, unit="rad/s^2"), 5.0),
                           "law": Key(Text(time_laws), "quintic")}, nullable=True), {}),
        "insertion": Key(Map(from_dataclass(Insertion, {"depth": POSITIVE}).keys, nullable=True), {}),
        "noise": Key(Map(from_dataclass(NoiseModel, noise).keys, nullable=True), {}),
        "scene": Key(scene),
        "planners": Key(ListOf(planner, min_items=1, what="planner mappings"), DEFAULT_PLANNERS),
        "expect": Key(Map(values=expect_block(RIVETING_RULES), nullable=True), None),
    }, post=post)


SCENARIO_KINDS = (
    ScenarioKind("ur5_riveting", run_riveting, riveting_schema, format_text,
                 "the UR5 riveting cell: every planner for the task's simulated time, Table 5 score"),
)
