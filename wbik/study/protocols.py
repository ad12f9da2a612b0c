"""The case kind ``protocol`` (a case with ``success:``): a ``pose`` case whose answers a benchmark's success
rule judges (:mod:`wbik.study.success_rules`; ``check_success`` keeps the shared check's verdict), beside
the ``peers:``' published figures."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.schema import Context, Key, ListOf, Map, Text, dataclass_default, join
from wbik.study.blocks import Block, fmt, write_table
from wbik.study.chain_targets import ChainChunkTask, ChainTargets
from wbik.study.reference import REFERENCE_METRICS, our_figures
from wbik.study.spec import CaseSpec, Study
from wbik.study.success_rules import (
    FRAMES,
    PERCENTILES,
    RULES,
    SuccessRule,
    error_percentiles,
    failure_reason,
    judge,
)
from wbik.study.target_parameters import number

PROTOCOL = "protocol"
_BOUND = number(0.0, 1.0e3, low_open=True)


def success_schema() -> Map:
    """A case's ``success:`` {position, rotation, per, frame (per-axis rules only)}."""

    def frame_for_axis_rules(rule: dict, path: str, ctx: Context) -> None:
        if rule["per"] == "axis":
            rule.setdefault("frame", dataclass_default(SuccessRule, "frame"))
        elif "frame" in rule:
            ctx.says(join(path, "frame"), "applies to per: axis only (norms do not depend on the frame)")

    keys = {key: Key(_BOUND.described(f"a positive bound in {unit} (at most 1000)"), required=True,
                     doc=f"the bound on the {key} error ({unit})")
            for key, unit in (("position", "m"), ("rotation", "rad"))}
    keys["per"] = Key(Text(RULES), dataclass_default(SuccessRule, "per"),
                      doc="norm: the error norms; axis: each of the six components")
    keys["frame"] = Key(Text(FRAMES).described("'target' (TRAC-IK's) or 'base'"),
                        doc="the frame of a per-axis rule")
    return Map(keys, post=frame_for_axis_rules,
               what="a mapping {position: m, rotation: rad, per: norm|axis, frame: target|base}, e.g. "
                    "{per: axis, position: 1.0e-5, rotation: 1.0e-5, frame: target}")


def peers_schema() -> ListOf:
    """A case's ``peers:``: a list of {solver, source, figures: {metric: number}, note}."""
    figures = Map({metric: Key(number(-math.inf, math.inf)) for metric in REFERENCE_METRICS},
                  nullable=True, what=f"a mapping of metrics ({', '.join(REFERENCE_METRICS)}) to numbers")
    peer = Map({"solver": Key(Text(non_empty=True, what="the name of the peer's solver"), required=True),
                "source": Key(Text(), ""), "figures": Key(figures, {}), "note": Key(Text(), "")},
               what="a mapping {solver, source, figures, note}")
    return ListOf(peer, what="{solver, source, figures, note} mappings")


@dataclass(frozen=True)
class ProtocolChunkTask(ChainChunkTask):
    """A chunk of chain targets and the case's success rule (position, rotation, per, frame)."""

    rule: tuple = ()


class ProtocolTargets(ChainTargets):
    """Chain targets judged by a benchmark's success rule."""

    entry_keys = ("success", "peers")

    def __init__(self, name: str = PROTOCOL):
        super().__init__(name, target="pose")

    def entry_schema(self) -> dict[str, Key]:
        return {"success": Key(success_schema(), required=True, doc="the case's success rule"),
                "peers": Key(peers_schema(), [], doc="peers' published figures (report only)")}

    def entry(self, item: dict, path: str, ctx: Context) -> dict:
        peers = [{**peer, "solver": peer["solver"].strip()} for peer in item["peers"]]
        return {**item, "target": self.name, "peers": peers}

    @staticmethod
    def rule_of(case: CaseSpec) -> SuccessRule:
        return SuccessRule(**case.success)

    task_type = ProtocolChunkTask

    def task_fields(self, study: Study, case: CaseSpec) -> dict:
        rule = self.rule_of(case)
        return {"rule": (rule.position, rule.rotation, rule.per, rule.frame)}

    def solve(self, task: ProtocolChunkTask) -> dict[str, np.ndarray]:
        """The chain rows, ``success`` judged by the case's rule, ``check_success`` the shared check's."""
        columns = super().solve(task)
        rule = SuccessRule(*task.rule)
        position = np.stack([columns[f"err_{axis}"] for axis in "xyz"], axis=1)
        rotation = np.stack([columns[f"err_rot_{axis}"] for axis in "xyz"], axis=1)
        passed, worst, component = judge(rule, position, rotation, task.rotations)
        checked = columns["success"].astype(bool)
        reasons = columns["reason"].astype(object)
        for index in np.flatnonzero(checked & ~passed & np.isfinite(worst)):
            reasons[index] = failure_reason(rule, float(worst[index]), int(component[index]))
        reasons[passed] = ""
        columns.update(check_success=checked, success=passed, reason=reasons.astype(str))
        return columns

    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        analysis = super().analyse(study, case, output)
        protocol = {label: protocol_figures(rows) for label, rows in analysis["rows"].items()}
        _write_csv(store.case_dir(output, case.name) / "protocol.csv", protocol)
        analysis.update(protocol=protocol, rule=self.rule_of(case), peers=list(case.peers or []))
        return analysis

    def blocks(self, study: Study, analysis: dict) -> list[Block]:
        blocks = super().blocks(study, analysis)
        if not analysis["summaries"]:
            return blocks
        rule: SuccessRule = analysis["rule"]
        tolerances = study.tolerances
        blocks[2:2] = [Block("h3", "Success rule"),
                   Block("p", f"Solved here means: {rule.describe()}, judged on every answer with joints, "
                              "converged or not. The methods ran under the shared check of "
                              f"{tolerances['position']:g} m / {tolerances['rotation']:g} rad (norms): what "
                              "they aim at and where they stop. "
                              + ("A per-axis bound b implies the norm bound sqrt(3) b, so an answer can pass "
                                 "the shared check and fail the rule; one that passes the rule passes a "
                                 "shared check of sqrt(3) b. " if rule.per == "axis" else "")
                              + "The tables and figures of this case count the rule's verdict."),
                   Block("table", header=["method", "% solved (rule)", "% shared check", "check only",
                                          "rule only"],
                         rows=[[label, fmt(figures["percent_rule"]), fmt(figures["percent_check"]),
                                str(figures["check_only"]), str(figures["rule_only"])]
                               for label, figures in analysis["protocol"].items()])]
        names = ", ".join(f"p{p:g}" if p < 100 else "max" for p in PERCENTILES)
        blocks.append(Block("h3", f"Errors at percentiles ({names})"))
        blocks.append(Block("p", "Position error |p - p*| (mm) and rotation error |log3(R*^T R)| (rad) of "
                                 "the answers the rule counts as solved, then of every answer with joints."))
        header = ["method", *(f"position {n} mm" for n in names.split(", ")),
                  *(f"rotation {n} rad" for n in names.split(", "))]
        for which, title in (("solved", "solved"), ("all", "all answers")):
            blocks.append(Block("table", header=[f"{header[0]} ({title})", *header[1:]], rows=[
                [label, *(fmt(v * 1e3) for v in figures[f"position_{which}"]),
                 *(fmt(v) for v in figures[f"rotation_{which}"])]
                for label, figures in analysis["protocol"].items()]))
        blocks.extend(peer_blocks(analysis["peers"], analysis["summaries"]))
        return blocks


def protocol_figures(rows: dict[str, np.ndarray]) -> dict:
    """One method's % solved by the rule and by the shared check, answers passing one only, and the error
    percentiles (solved, all answers with joints)."""
    rule = rows["success"].astype(bool)
    check = rows["check_success"].astype(bool) if "check_success" in rows else rule
    count = max(int(rule.size), 1)
    figures = {"poses": int(rule.size), "percent_rule": 100.0 * float(rule.sum()) / count,
               "percent_check": 100.0 * float(check.sum()) / count,
               "check_only": int(np.sum(check & ~rule)), "rule_only": int(np.sum(rule & ~check))}
    for which, mask in (("solved", rule), ("all", np.ones(rule.size, dtype=bool))):
        figures[f"position_{which}"] = error_percentiles(rows["position_error"][mask])
        figures[f"rotation_{which}"] = error_percentiles(rows["rotation_error"][mask])
    return figures


def peer_blocks(peers: list[dict], summaries: dict[str, dict]) -> list[Block]:
    """The peers' published figures, each beside the best of ours (highest share, lowest time)."""
    if not peers:
        return []
    ours = {label: our_figures(summary) for label, summary in summaries.items()}
    rows = []
    for peer in peers:
        if not peer["figures"]:
            rows.append([peer["solver"], "-", "-", "-", peer["source"], peer["note"]])
        for metric, value in peer["figures"].items():
            described = REFERENCE_METRICS[metric]
            candidates = {label: figures[metric] for label, figures in ours.items()
                          if figures.get(metric) is not None and math.isfinite(figures[metric])}
            best = "-"
            if candidates:
                pick = max if described.unit == "%" else min  # shares: the highest; times: the lowest
                label = pick(candidates, key=candidates.get)
                best = f"{fmt(candidates[label])} ({label})"
            rows.append([peer["solver"], f"{described.description} ({described.unit})", fmt(value), best,
                         peer["source"], peer["note"]])
    return [Block("h3", "Beside published figures of other solvers"),
            Block("p", "Figures the peers' own documentation gives for their solvers (not methods of this "
                       "study: other hardware, seeds and sample sizes), beside the best of our methods under "
                       "the same success rule."),
            Block("table", header=["peer", "metric", "theirs", "ours: best (method)", "source", "note"],
                  rows=rows)]


def _write_csv(path: Path, protocol: dict[str, dict]) -> None:
    """protocol.csv: a row per method, the rule's and the check's verdicts and the error percentiles."""
    names = [f"p{p:g}" for p in PERCENTILES]
    table = {}
    for label, figures in protocol.items():
        row = {key: figures[key] for key in ("poses", "percent_rule", "percent_check", "check_only",
                                             "rule_only")}
        for which in ("solved", "all"):
            for error, unit in (("position", "m"), ("rotation", "rad")):
                row.update({f"{error}_{which}_{name}_{unit}": value
                            for name, value in zip(names, figures[f"{error}_{which}"], strict=True)})
        table[label] = row
    write_table(path, table)


CASE_KINDS = (ProtocolTargets(),)
