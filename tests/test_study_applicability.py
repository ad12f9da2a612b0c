"""Which methods apply to a study case: decided by typed checks (wbik.study.applicability), before
solving - a solver's capability query, its typed refusals - never by the kind of any exception."""

from __future__ import annotations

import json

import pytest

from wbik.errors import MissingDependencyError, UnsupportedError
from wbik.solvers.dls import DampedLeastSquares
from wbik.solvers.method_registry import IK_METHOD_REGISTRY, register
from wbik.study import run_study, study_from_dict
from wbik.study.results import read_raw_csv

CASE = "ur5_arm_pose"


class PositionOnlyByQuery(DampedLeastSquares):
    """DLS that answers the capability query: position targets only. Counts its solves."""

    name = "position_only_by_query"
    solves = 0

    def check_target_kind(self, kind: str) -> None:
        if kind != "position":
            raise UnsupportedError(f"{self.name} takes position targets only (asked for {kind})")

    def solve(self, target, q0=None):
        type(self).solves += 1
        return super().solve(target, q0)


class AnyKindByQuery(PositionOnlyByQuery):
    name = "any_kind_by_query"

    def check_target_kind(self, kind: str) -> None:
        return None


class NeedsALibrary(DampedLeastSquares):
    def __init__(self, robot, chain=None, **options):
        raise MissingDependencyError("libfoo is not installed: pip install foo")


class ImportsBadly(DampedLeastSquares):
    def __init__(self, robot, chain=None, **options):
        import wbik_no_such_module  # noqa: F401 - a bug: should be a MissingDependencyError


class FailsEverySolve(DampedLeastSquares):
    def _solve(self, target, q0, deadline):
        raise RuntimeError("a bug in the method")


METHODS = {"position_only_by_query": PositionOnlyByQuery, "any_kind_by_query": AnyKindByQuery,
           "needs_a_library": NeedsALibrary, "imports_badly": ImportsBadly,
           "fails_every_solve": FailsEverySolve}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    with IK_METHOD_REGISTRY.isolated():  # the test's methods are gone afterwards
        for name, factory in METHODS.items():
            register(name, factory, "test only")
        study = study_from_dict({
            "name": "applicability", "robot": "ur5", "chain": "arm", "target": "pose", "poses": 6,
            "chunk_size": 3, "timeout_s": 1.0,
            "methods": [{"method": name, "options": {"max_iterations": 20}} for name in METHODS]})
        PositionOnlyByQuery.solves = AnyKindByQuery.solves = 0
        output = run_study(study, tmp_path_factory.mktemp("study") / "out", backend="sequential",
                           progress=False, log=lambda message: None)
        yield output


def _not_applicable(output) -> dict[str, str]:
    return json.loads((output / CASE / "not_applicable.json").read_text())


def test_a_solver_s_capability_query_decides_without_solving(run):
    reasons = _not_applicable(run)
    assert reasons["position_only_by_query"] == ("position_only_by_query takes position targets only "
                                                 "(asked for pose)")
    assert PositionOnlyByQuery.solves == 0  # asked, never solved
    rows = read_raw_csv(run / CASE / "raw.csv")
    assert "position_only_by_query" not in rows
    assert "any_kind_by_query" not in reasons and len(rows["any_kind_by_query"]["pose"]) == 6
    assert AnyKindByQuery.solves == 6  # its six poses, no probing solve


def test_a_typed_refusal_while_building_is_not_applicable_with_its_message(run):
    assert _not_applicable(run)["needs_a_library"] == "libfoo is not installed: pip install foo"


def test_an_untyped_import_error_is_a_bug_to_report_not_a_missing_dependency(run):
    reason = _not_applicable(run)["imports_badly"]
    assert reason.startswith("could not start (a bug to report): ModuleNotFoundError")
    assert "wbik_no_such_module" in reason


def test_a_method_that_raises_while_solving_applies_and_its_rows_say_what_it_raised(run):
    assert "fails_every_solve" not in _not_applicable(run)
    rows = read_raw_csv(run / CASE / "raw.csv")["fails_every_solve"]
    assert len(rows["pose"]) == 6 and not rows["success"].any()
    assert all(str(reason).startswith("raised RuntimeError: a bug in the method")
               for reason in rows["reason"])
    assert "fails_every_solve: could not start" not in (run / "report.md").read_text()


@pytest.mark.parametrize("robot_name, chain_name", [("ur5", "arm"), ("arm3r", "arm")])
def test_check_target_kind_refuses_exactly_what_solve_refuses(robot_name, chain_name):
    """The capability query the study asks agrees with solve() on both target kinds, for every
    method that can be built on the chain."""
    import wbik
    from wbik.errors import MissingDependencyError, UnsupportedError

    robot = wbik.load(robot_name)
    chain = robot.chain(chain_name)
    pose = chain.fk(chain.nominal)
    for method in set(wbik.methods()) - set(METHODS):  # the built-in ones (this module registers others)
        try:
            solver = wbik.solver(method, robot, chain=chain_name, timeout_s=0.005)
        except (UnsupportedError, MissingDependencyError):
            continue
        for kind, target in (("pose", pose), ("position", pose.translation)):
            try:
                solver.check_target_kind(kind)
                refused_by_query = None
            except UnsupportedError as error:
                refused_by_query = str(error)
            try:
                solver.solve(target)
                refused_by_solve = None
            except UnsupportedError as error:
                refused_by_solve = str(error)
            assert refused_by_query == refused_by_solve, (method, kind)
