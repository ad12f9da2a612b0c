"""Study case kinds: a kind is one class plus one registration line. A kind registered here (chain
targets drawn near the joint limits, with a metric of its own) runs a study end to end, in loky
workers; chunk tasks are per kind, small and picklable."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from wbik.study import run_study, study_from_dict
from wbik.study.case_kinds import CASE_KIND_REGISTRY, case_kinds, register_case_kind
from wbik.study.chain_targets import ChainChunkTask, ChainTargets
from wbik.study.context import case_chain
from wbik.study.results import read_raw_csv
from wbik.study.runner import pending_tasks
from wbik.study.spec import StudyDefinitionError
from wbik.study.wholebody import WholeBodyChunkTask

SHARE = 0.05  # joints within 5 % of their range from a limit
FIRST_MODULES = ["wbik.study.chain_targets", "wbik.study.wholebody"]
"""The modules of the first kinds (pose, position, wholebody): the kind below is registered beside them
only (the shipped target set near_limits has its name)."""


class NearLimits(ChainTargets):
    """Targets of one chain from joints near their limits; a metric of its own: how close each
    answer comes to a limit (``err_limit``, rad or m)."""

    sampled_from = "FK of joints within 5 % of their range from a limit"

    def joints(self, chain, count: int, seed: int) -> np.ndarray:
        rng = np.random.default_rng(seed)
        span = chain.upper - chain.lower
        inside = rng.uniform(0.0, SHARE, (count, chain.nq)) * span
        at_upper = rng.random((count, chain.nq)) < 0.5
        return np.where(at_upper, chain.upper - inside, chain.lower + inside)

    def axes(self, angles=None) -> list[str]:
        return [*super().axes(angles), "limit"]

    def solve(self, task) -> dict[str, np.ndarray]:
        columns = super().solve(task)
        chain = case_chain(task.robot, task.robot_params, task.chain, task.base, task.tip)
        q = columns["q"]
        columns["err_limit"] = np.min(np.minimum(q - chain.lower, chain.upper - q), axis=1)
        return columns


STUDY = {"name": "near_limits", "robot": "ur5", "chain": "arm", "target": "near_limits", "poses": 20,
         "chunk_size": 10, "seed": 3, "timeout_s": 0.05, "baseline": "dls",
         "methods": [{"method": "dls", "options": {"max_iterations": 60}}, "bounded_lm"]}


@pytest.fixture
def near_limits():
    with CASE_KIND_REGISTRY.isolated(FIRST_MODULES):  # the kind is gone afterwards
        register_case_kind(NearLimits("near_limits", target="pose"))
        yield


def test_the_shipped_kinds_are_registered_by_target():
    kinds = case_kinds()
    assert list(kinds) == ["pose", "position", "wholebody", "uniform", "near_limits", "near_singularities",
                           "reach_boundary", "unreachable", "path", "protocol"]
    assert (kinds["pose"].target, kinds["position"].target) == ("pose", "position")


def test_a_kind_registered_from_a_test_runs_a_study_end_to_end(near_limits, tmp_path):
    study = study_from_dict(STUDY, source="test")
    assert study.cases[0].name == "ur5_arm_near_limits"
    output = run_study(study, tmp_path / "out", jobs=2, backend="loky", progress=False,
                       log=lambda message: None)
    case = output / "ur5_arm_near_limits"
    rows = read_raw_csv(case / "raw.csv")
    assert set(rows) == {"dls", "bounded_lm"}
    for columns in rows.values():
        assert np.array_equal(columns["pose"], np.arange(20))
        assert {"err_x", "err_rot_z", "err_gamma", "err_limit"} <= set(columns)  # pose axes and the metric
        solved = columns["success"] & np.isfinite(columns["err_limit"])
        assert np.all(columns["err_limit"][solved] >= 0)
    assert rows["bounded_lm"]["success"].sum() >= 10  # a working study, not rows of errors
    with np.load(case / "poses.npz") as poses:
        import wbik

        chain = wbik.load("ur5").chain("arm")
        span = chain.upper - chain.lower
        distance = np.minimum(poses["q_true"] - chain.lower, chain.upper - poses["q_true"])
        assert np.all(distance <= SHARE * span + 1e-12) and poses["rotations"].shape == (20, 3, 3)
    for name in ("summary.csv", "significance.csv", "figures/errors.png"):
        assert (case / name).is_file(), name
    report = (output / "report.md").read_text()
    assert "## Case ur5_arm_near_limits: ur5.arm, near_limits targets" in report
    assert "20 near_limits targets from FK of joints within 5 % of their range from a limit" in report
    assert "### Error per axis (solved poses)" in report
    assert "| method | x | y | z | rot_x | rot_y | rot_z | alpha | beta | gamma | limit |" in report
    assert "err_limit_abs_median" in (case / "summary.csv").read_text().splitlines()[0]


def test_an_unregistered_target_is_refused_with_the_registered_ones():
    message = "target must be 'pose', 'position' or 'wholebody', got 'near_limits'"
    with CASE_KIND_REGISTRY.isolated(FIRST_MODULES), pytest.raises(StudyDefinitionError, match=message):
        study_from_dict(STUDY, source="test")


def test_chunk_tasks_are_per_kind_small_and_picklable(tmp_path):
    study = study_from_dict({"name": "both", "seed": 1, "poses": 4, "chunk_size": 2, "timeout_s": 0.05,
                             "cases": [{"robot": "arm3r", "chain": "arm", "target": "position"},
                                       {"target": "wholebody", "scenario": "bioloid_com_shift"}],
                             "methods": ["qp"]}, source="test")
    tasks, done, total = pending_tasks(study, tmp_path, log=lambda message: None)
    assert (len(tasks), done, total) == (4, 0, 8)
    chain, wholebody = tasks[0], tasks[-1]
    assert isinstance(chain, ChainChunkTask) and isinstance(wholebody, WholeBodyChunkTask)
    assert chain.kind is case_kinds()["position"] and wholebody.kind is case_kinds()["wholebody"]
    assert not hasattr(chain, "scenario") and not hasattr(wholebody, "rotations")
    for task in tasks:
        data = pickle.dumps(task)
        assert len(data) < 2000  # a few hundred bytes and the poses
        again = pickle.loads(data)
        assert type(again.kind) is type(task.kind) and again.kind.name == task.kind.name
        assert np.array_equal(again.q0, task.q0) and again.count == 2
