"""The ``golem3_approach`` scenario kind: from ``start`` to ``grasp`` ({position, rpy} in base_link, or
{from_joints}) along a straight line, judged like any motion and by ``expect: {lift: bool}``."""

from __future__ import annotations

from wbik.apps.golem3.approach import ARM_WITH_LIFT, approach
from wbik.expectations import Rule
from wbik.motion.scenarios import (
    MOVE_RULES,
    MoveRun,
    common_motion_keys,
    format_report,
    pose_of,
    samples_key,
    solving_keys,
    vector_of,
)
from wbik.qp.task_entries import VECTOR3
from wbik.scenarios.kinds import Progress, ScenarioKind, ScenarioReport, start_of
from wbik.scenarios.schema import kind_schema
from wbik.schema import Either, Key, Map, Vector

APPROACH_RULES = {**MOVE_RULES, "lift": Rule("lift", "==")}  # lift: whether the torso lift moved


def run_golem3(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    run = MoveRun(spec, on_progress, APPROACH_RULES)
    chain = run.robot.chain(ARM_WITH_LIFT)
    grasp = spec["grasp"]
    goal = (chain.fk(vector_of(grasp["from_joints"], chain.nq, "grasp from_joints")) if "from_joints" in grasp
            else pose_of(grasp, "grasp"))
    path = approach(run.robot, start_of(spec, chain), goal, int(spec["samples"]), spec["method"],
                    timeout_s=float(spec["timeout_s"]))
    run.move(chain, path, "approach", {"lift": bool(path.info["lift_samples"])})
    return run.finished()


def approach_schema() -> Map:
    grasp = Either(Map({"from_joints": Key(Vector(), required=True)}),
                   Map({"position": Key(VECTOR3, required=True), "rpy": Key(VECTOR3)}))
    keys = {**solving_keys(), **samples_key(approach), "grasp": Key(grasp, required=True)}
    return kind_schema(common_motion_keys(APPROACH_RULES), keys)


SCENARIO_KINDS = (
    ScenarioKind("golem3_approach", run_golem3, approach_schema, format_report,
                 "Golem-III straight grasp approach, torso lift when needed"),
)
