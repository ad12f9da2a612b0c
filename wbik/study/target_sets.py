"""Target sets (``targets: near_limits`` or ``{set: near_singularities, sigma_max: 1.0e-3}``): chain targets
drawn by a stated method, each a case kind (:class:`TargetSetKind`); reachable sets add the solution coverage
(:mod:`wbik.study.solution_coverage`)."""

from __future__ import annotations

import json
import zlib
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.files import json_plain
from wbik.robot import Chain
from wbik.schema import Key
from wbik.study.blocks import Block, write_table
from wbik.study.chain_targets import ChainChunkTask, ChainTargets
from wbik.study.context import _frozen, case_chain, chain_of
from wbik.study.sampling import PoseSet, poses_of_joints, sample_joints, saved_extras, start_configurations
from wbik.study.solution_coverage import (
    COVERAGE_PARAMETERS,
    closed_form_of,
    coverage_blocks,
    coverage_columns,
    coverage_summary,
    distance_histogram,
)
from wbik.study.spec import CaseSpec, Study
from wbik.study.target_parameters import Parameter, defaults, parameters_map


@dataclass
class Drawing:
    """The joints drawn (count, n; NaN for unreachable targets), per-target ``extras``, report ``facts``."""

    q_true: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    facts: dict = field(default_factory=dict)


@dataclass
class DrawnTargets(PoseSet):
    """Poses with the drawing's extras and facts (saved as ``drawn_<name>`` arrays and ``drawn_facts``)."""

    extras: dict[str, np.ndarray] = field(default_factory=dict)
    facts: dict = field(default_factory=dict)

    def saved_arrays(self) -> dict[str, np.ndarray]:
        return {**super().saved_arrays(), **{f"drawn_{k}": np.asarray(v) for k, v in self.extras.items()},
                "drawn_facts": np.array(json.dumps(json_plain(self.facts), sort_keys=True, default=str))}


def read_drawing(path: Path) -> tuple[dict[str, np.ndarray], dict]:
    """(extras, facts) saved with a case's poses ({}, {} for poses of another kind)."""
    extras = saved_extras(path, "drawn_")
    facts = extras.pop("facts", None)
    return extras, {} if facts is None else json.loads(str(facts))


def target_stream(seed: int, name: str, index: int) -> np.random.Generator:
    """The random stream of item ``index`` of ``name``: ``default_rng([seed, crc32(name), index])``."""
    return np.random.default_rng([seed, zlib.crc32(name.encode()), index])


@dataclass(frozen=True)
class TargetSetChunkTask(ChainChunkTask):
    """A chunk of a target set's targets: the chain chunk and the set's parameters."""

    parameters: tuple = ()
    study_seed: int = 0


class TargetSetKind(ChainTargets):
    """A target set of full poses as a case kind: its ``parameters``, :meth:`draw` and :meth:`drawn_from`."""

    parameters: dict[str, Parameter] = {}  # a case's ``targets:`` keys besides ``set``
    reachable = True  # every target is FK of joints inside the limits (then: solution coverage)

    def __init__(self, name: str, target: str = "pose"):
        super().__init__(name, target)
        self.target_set = name

    @property
    def all_parameters(self) -> dict[str, Parameter]:
        """The set's parameters and, for a reachable set, the coverage's."""
        return {**self.parameters, **(COVERAGE_PARAMETERS if self.reachable else {})}

    def entry_schema(self) -> dict[str, Key]:
        return {"targets": Key(parameters_map(self.target_set, self.all_parameters), self.target_set,
                               doc="the target set and its parameters")}

    def parameters_of(self, case: CaseSpec) -> dict:
        """The case's parameters (its ``targets:``, completed when it was read), else the defaults."""
        return dict(case.targets) if case.targets else defaults(self.target_set, self.all_parameters)

    def draw(self, chain: Chain, count: int, seed: int, parameters: dict) -> Drawing:
        """The joints of ``count`` targets, with their measurements and the drawing's facts."""
        raise NotImplementedError

    def drawn_from(self, parameters: dict) -> str:
        """How the targets are drawn, in the report's words."""
        return self.sampled_from

    def sampling_text(self, case: CaseSpec) -> str:
        return self.drawn_from(self.parameters_of(case))

    def sample(self, study: Study, case: CaseSpec) -> PoseSet:
        chain = chain_of(case)
        parameters = self.parameters_of(case)
        drawing = self.draw(chain, study.poses_of(case), study.seed, parameters)
        return self.drawn_targets(chain, drawing, study, parameters)

    def drawn_targets(self, chain: Chain, drawing: Drawing, study: Study, parameters: dict) -> DrawnTargets:
        """The drawing's targets (extras' ``positions``/``rotations``, else FK of its joints), with q0s."""
        extras = dict(drawing.extras)
        if "positions" in extras:
            poses = PoseSet(drawing.q_true, extras.pop("positions"), extras.pop("rotations"),
                            start_configurations(chain, len(drawing.q_true), study.seed, study.start))
        else:
            poses = poses_of_joints(chain, drawing.q_true, study.seed, self.target, study.start)
        return DrawnTargets(poses.q_true, poses.positions, poses.rotations, poses.q0, extras,
                            {"parameters": parameters, "seed": study.seed, **drawing.facts})

    task_type = TargetSetChunkTask

    def task_fields(self, study: Study, case: CaseSpec) -> dict:
        return {"parameters": _frozen(self.parameters_of(case)), "study_seed": study.seed}

    def solve(self, task: TargetSetChunkTask) -> dict[str, np.ndarray]:
        """The chain rows, and for a reachable set the solution coverage's columns."""
        columns = super().solve(task)
        if not self.reachable:
            return columns
        chain = case_chain(task.robot, task.robot_params, task.chain, task.base, task.tip)
        solver = cache(lambda: self.build(task))  # built at the first restart
        columns.update(coverage_columns(chain, columns, task.q0, task.positions, task.rotations,
                                        task.first_pose, task.study_seed, dict(task.parameters),
                                        lambda target, q0: solver().solve(target, q0)))
        return columns

    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        analysis = super().analyse(study, case, output)
        directory = store.case_dir(output, case.name)
        extras, facts = read_drawing(directory / "poses.npz")
        analysis.update(parameters=self.parameters_of(case), extras=extras, facts=facts)
        if self.reachable and analysis["rows"]:
            form = closed_form_of(analysis["chain"])
            analysis["coverage_form"] = (form if isinstance(form, str)
                                         else f"closed form {form.family} (complete: every branch)")
            analysis["coverage"] = {label: coverage_summary(rows) for label, rows in analysis["rows"].items()
                                    if "start_distance" in rows}
            write_table(directory / "coverage.csv", analysis["coverage"])
            if study.figures:
                analysis["images"]["start_distance"] = distance_histogram(
                    analysis["rows"], f"{case.robot}.{analysis['chain'].name} ({case.target})",
                    directory / "figures" / "start_distance.png")
        return analysis

    def drawing_blocks(self, analysis: dict) -> list[Block]:
        """The report's paragraphs and tables on how the case's targets were drawn."""
        return []

    def blocks(self, study: Study, analysis: dict) -> list[Block]:
        blocks = super().blocks(study, analysis)
        if drawn := self.drawing_blocks(analysis):
            blocks[2:2] = [Block("h3", "How the targets were drawn"), *drawn]
        if analysis.get("coverage"):
            parameters = analysis["parameters"]
            blocks.extend(coverage_blocks(analysis["coverage"], parameters, analysis["coverage_form"],
                                          parameters["restarts"] > 0 and parameters["restart_targets"] > 0,
                                          analysis["images"].get("start_distance")))
        return blocks


class UniformTargets(TargetSetKind):
    """FK of uniform joints inside the limits (a ``pose`` case's, same seed), with solution coverage."""

    def draw(self, chain: Chain, count: int, seed: int, parameters: dict) -> Drawing:
        return Drawing(sample_joints(chain, count, seed))


CASE_KINDS = (UniformTargets("uniform"),)
