"""Every robot example-robot-data ships: it loads (or is refused with a typed error), and on its longest
chain every chain method either solves a handful of reachable poses or says, typed, why it does not
apply. No raw exception anywhere."""

from __future__ import annotations

import numpy as np
import pytest

import wbik
from wbik.errors import WbikError
from wbik.kinematic_tree import longest_chain
from wbik.models.erd import example_robot_names
from wbik.solvers.result import IKResult


@pytest.mark.parametrize("name", example_robot_names())
def test_every_example_robot_loads_and_every_method_solves_or_says_why_not(name):
    try:
        robot = wbik.load(f"example-robot-data:{name}")
    except WbikError as refusal:  # e.g. an SDF model: typed and explained
        assert str(refusal), name
        assert name == "cassie", f"{name} refused: {refusal}"
        return
    frames = longest_chain(robot.model)
    if frames is None:  # a drone without joints, say: nothing to solve, and nothing crashes
        assert all(robot.model.joints[j].nq != 1 for j in range(1, robot.model.njoints))
        return
    chain = robot.chain_between(*frames)
    rng = np.random.default_rng(5)
    targets = [chain.fk(chain.random(rng)) for _ in range(3)]
    verdicts = {}
    for method in wbik.methods():
        try:
            solver = wbik.solver(method, robot, chain=chain.name, timeout_s=0.005)
            results = [solver.solve(target) for target in targets]
        except WbikError as refusal:  # not applicable, with its reason
            assert len(str(refusal)) > 10, (method, refusal)
            verdicts[method] = f"not applicable: {refusal}"
            continue
        for result, target in zip(results, targets, strict=True):
            assert isinstance(result, IKResult)
            if result.success:
                assert chain.in_limits(result.q)
                assert np.linalg.norm(chain.fk(result.q).translation - target.translation) <= 1e-6
            else:
                assert result.reason, (method, result)
        verdicts[method] = sum(r.success for r in results)
    assert verdicts["bounded_lm"] >= 2, verdicts  # our own method solves reachable poses of any chain
