"""A method added with ``wbik.register`` runs in the study's worker processes too.

The registry is per process; the study's loky workers are fresh processes, so the task carries the
registered class (cloudpickle) and the worker registers it. The class is registered inside the test,
not at import, so a worker that merely imports this module does not see it: without the task
carrying it, the workers would raise UnknownMethodError.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import replace

import numpy as np
import pytest

import wbik
from wbik.solvers.dls import DampedLeastSquares
from wbik.solvers.method_registry import IK_METHOD_REGISTRY
from wbik.study import load_study, run_study
from wbik.study.results import read_raw_csv

NAME = "user_dls_in_workers"

STUDY = f"""
name: registered
figures: false
robot: arm3r
chain: arm
target: position
poses: 40
chunk_size: 10
timeout_s: 1.0
methods:
  - {{method: {NAME}, options: {{max_iterations: 60}}}}
  - {{method: dls, options: {{max_iterations: 60}}}}
"""


class UserDLS(DampedLeastSquares):
    """A user's method: DLS whose rows say which process solved them."""

    name = NAME

    def solve(self, target, q0=None):
        answer = super().solve(target, q0)
        return replace(answer, reason=f"{answer.reason} pid={os.getpid()}")


def test_a_registered_method_runs_in_loky_workers_and_reaches_the_report(tmp_path):
    with IK_METHOD_REGISTRY.isolated():  # the test's method is gone afterwards
        wbik.register(NAME, UserDLS, "test only: DLS defined in a test module")
        study_file = tmp_path / "registered.yaml"
        study_file.write_text(STUDY)
        output = run_study(load_study(study_file), tmp_path / "out", jobs=2, backend="loky",
                           progress=False, log=lambda message: None)
    rows = read_raw_csv(output / "arm3r_arm_position" / "raw.csv")
    assert set(rows) == {NAME, "dls"}
    mine = rows[NAME]
    assert np.array_equal(mine["pose"], np.arange(40))
    workers = {reason.rsplit("pid=", 1)[1] for reason in mine["reason"]}
    assert str(os.getpid()) not in workers  # solved in the worker processes, not here
    assert mine["success"].mean() > 0.5  # a working method, not rows of errors
    assert NAME in (output / "report.md").read_text()


# -- whole-body samplers and methods registered from user code -------------------------------------------
SAMPLER = "user_tool_reach_in_workers"
METHOD = "user_qp_in_workers"

WHOLEBODY_STUDY = f"""
name: registered_wholebody
figures: false
seed: 5
poses: 12
chunk_size: 3
timeout_s: 0.05
cases:
  - {{target: wholebody, scenario: {SAMPLER}}}
methods: [{METHOD}, qp]
"""


def tool_reach(rng: np.random.Generator, index: int):
    """A user's sampler on the UR5: the tool to the point of a random arm configuration."""
    from wbik.qp.tasks import PositionTask
    from wbik.wholebody.cases import WholeBodyCase, cached_robot
    from wbik.wholebody.problem import WholeBody

    robot = cached_robot("ur5")
    q_true = robot.chain("arm").random(rng)
    target = robot.frame_placement(q_true, "tcp").translation.copy()
    problem = WholeBody(robot, [PositionTask("tcp", target, name="tcp")], limits="position",
                        name=f"{SAMPLER}[{index}]")
    return WholeBodyCase(problem, robot.nominal.copy(), target, q_true)


def _user_qp():
    from wbik.solvers.qp import QPSolver

    class UserQP(QPSolver):
        """A user's whole-body method: our QP, whose rows say which process solved them."""

        name = METHOD

        def solve(self, problem, q0=None):
            answer = super().solve(problem, q0)
            return replace(answer, reason=f"{answer.reason} pid={os.getpid()}")

    return UserQP


def _raw_rows(output) -> dict[str, list[dict]]:
    import csv

    rows: dict[str, list[dict]] = {}
    for row in csv.DictReader((output / SAMPLER / "raw.csv").open()):
        rows.setdefault(row["method"], []).append(row)
    return rows


def test_a_registered_sampler_and_wholebody_method_run_in_loky_workers(tmp_path, request):
    """Registered inside the test (into fresh registries of this process), so a worker knows them
    only from the task; solved with 2 loky workers, the rows equal a sequential run's in this
    process, and a task without its entries fails in a fresh process."""
    from joblib.externals.loky import ProcessPoolExecutor

    from wbik.errors import UnknownNameError
    from wbik.solvers import method_registry
    from wbik.solvers.method import IKMethod
    from wbik.study import study_from_dict
    from wbik.study.runner import pending_tasks, solve_chunk
    from wbik.wholebody import cases

    isolated = contextlib.ExitStack()
    request.addfinalizer(isolated.close)
    isolated.enter_context(cases.CASE_REGISTRY.isolated())
    isolated.enter_context(method_registry.IK_METHOD_REGISTRY.isolated())
    sampler = cases.CaseSampler(SAMPLER, "ur5", tool_reach, "test only: the UR5's tool to a random point")
    method = IKMethod(METHOD, _user_qp(), "test only: our QP defined in a test")
    cases.register_sampler(sampler)
    method_registry.register_method(method)
    assert cases.CASE_REGISTRY.added_at_run_time(SAMPLER) is sampler
    assert method_registry.IK_METHOD_REGISTRY.added_at_run_time(METHOD) is method
    assert cases.CASE_REGISTRY.added_at_run_time("bioloid_com_shift") is None  # a listed one: not carried
    assert method_registry.IK_METHOD_REGISTRY.added_at_run_time("qp") is None

    import yaml

    study = study_from_dict(yaml.safe_load(WHOLEBODY_STUDY), source="test")
    parallel = run_study(study, tmp_path / "loky", jobs=2, backend="loky", progress=False,
                         log=lambda message: None)
    sequential = run_study(study, tmp_path / "sequential", backend="sequential", progress=False,
                           log=lambda message: None)
    rows, expected = _raw_rows(parallel), _raw_rows(sequential)
    assert set(rows) == {METHOD, "qp"}
    assert [row["pose"] for row in rows[METHOD]] == [str(i) for i in range(12)]
    workers = {row["reason"].rsplit("pid=", 1)[1] for row in rows[METHOD]}
    assert str(os.getpid()) not in workers  # solved in the worker processes, not here
    assert all(row["reason"].endswith(f"pid={os.getpid()}") for row in expected[METHOD])
    for label in (METHOD, "qp"):  # the same cases and answers wherever they were solved
        assert [row["success"] for row in rows[label]] == [row["success"] for row in expected[label]]
        q = [[float(v) for k, v in row.items() if k.startswith("q_")] for row in rows[label]]
        q_expected = [[float(v) for k, v in row.items() if k.startswith("q_")] for row in expected[label]]
        np.testing.assert_array_equal(q, q_expected)
    assert sum(row["success"] == "1" for row in rows[METHOD]) >= 6  # a working method, not rows of errors
    assert METHOD in (parallel / "report.md").read_text()

    # without the entries it carries, a task fails in a fresh process: the carrying is what works
    tasks, _, _ = pending_tasks(study, tmp_path / "again", log=lambda message: None)
    task = next(t for t in tasks if t.method == METHOD)
    assert {type(entry).__name__ for entry in task.registered} == {"CaseSampler", "IKMethod"}
    assert next(t for t in tasks if t.method == "qp").registered == (sampler,)
    with ProcessPoolExecutor(max_workers=1) as fresh_process:
        for carried, missing in (((), METHOD), ((method,), SAMPLER)):  # the solver is built first
            with pytest.raises(UnknownNameError, match=missing):
                fresh_process.submit(solve_chunk, replace(task, registered=carried)).result()
        assert len(fresh_process.submit(solve_chunk, task).result()["pose"]) == 3  # the same process
