"""The ``pincher_motion`` scenario kind: ``moves`` (jog, plane_line, automatic) run one after another from
the previous end, each with its own ``timing``, ``tolerance`` and ``expect`` over the scenario's."""

from __future__ import annotations

import math

import wbik.apps.pincher.teleoperation as teleoperation
from wbik.motion.scenarios import (
    MOVE_RULES,
    MoveRun,
    common_motion_keys,
    format_report,
    samples_key,
    solving_keys,
    timing_node,
    vector_of,
)
from wbik.scenarios.kinds import Progress, ScenarioKind, ScenarioReport, start_of
from wbik.scenarios.schema import expect_block, kind_schema
from wbik.schema import Either, Key, ListOf, Map, Number, Text, Variants, Vector


def run_pincher(spec: dict, on_progress: Progress = None) -> ScenarioReport:
    from wbik.solvers.method_registry import solver
    run = MoveRun(spec, on_progress)
    ik = solver(spec["method"], run.robot, timeout_s=float(spec["timeout_s"]))
    chain = ik.chain
    q = start_of(spec, chain)
    for move in spec["moves"]:  # the schema's variants: jog, plane_line or automatic
        if "jog" in move:
            path = teleoperation.jog(chain, q, move["jog"], math.radians(float(move["delta_deg"])),
                                     int(move["samples"]))
            name = f"jog {move['jog']} by {move['delta_deg']} deg"
        elif "plane_line" in move:
            line = move["plane_line"]
            start = vector_of(line["start_xy_mm"], 2, "start_xy_mm") / 1000.0
            goal = vector_of(line["goal_xy_mm"], 2, "goal_xy_mm") / 1000.0
            path = teleoperation.plane_line(ik, start, goal, int(line["samples"]), q0=q)
            name = f"plane line {line['start_xy_mm']} -> {line['goal_xy_mm']} mm"
        else:
            path = teleoperation.automatic_path(ik, int(move["automatic"]["samples"]))
            name = "automatic cycle"
        run.move(chain, path, name, spec={**spec, **move})
        q = path.q[-1].copy()
    return run.finished()


def pincher_schema() -> Map:
    common = common_motion_keys()
    own = {"timing": Key(timing_node()), "tolerance": Key(common["tolerance"].node),
           "expect": Key(expect_block(MOVE_RULES))}
    moves = {
        "jog": Map({"jog": Key(Either(Text(what="a joint name"), Number(integer=True))),
                    "delta_deg": Key(Number(unit="deg"), 0.0), **samples_key(teleoperation.jog), **own}),
        "plane_line": Map({"plane_line": Key(Map({"start_xy_mm": Key(Vector(2), required=True),
                                                  "goal_xy_mm": Key(Vector(2), required=True),
                                                  **samples_key(teleoperation.plane_line)}), required=True),
                           **own}),
        "automatic": Map({"automatic": Key(Map(samples_key(teleoperation.automatic_path), nullable=True),
                                           required=True), **own}),
    }
    move = Variants(lambda move: "+".join(name for name in moves if name in move) or None, moves,
                    "a move: {jog: JOINT, delta_deg: D}, {plane_line: {...}} or {automatic: {}}", "move")
    keys = {**solving_keys(), "moves": Key(ListOf(move, min_items=1, what="moves"), required=True)}
    return kind_schema(common, keys)


SCENARIO_KINDS = (
    ScenarioKind("pincher_motion", run_pincher, pincher_schema, format_report,
                 "a Pincher teleoperation session (jog, plane line, automatic cycle)"),
)
