"""Strict priorities: any number of levels of equality and inequality tasks, each solved in what the
levels above it leave free (wbik.qp.step), and never changing what they achieved.

The property is checked on one QP step with tasks of constant rows (J, e) drawn at random, the first
level feasible by construction (its targets are met by a displacement inside the step box): with the
levels below it or without them, its linearised errors (|J dq + g e| for an equality task,
|max(0, J dq + g e)| for an inequality task) agree to a tenth of DAQP's primal tolerance (1e-6 by
default), and an inequality task is never made worse by more. DAQP, a dual active-set solver, holds the
rows a level leaves to the ones below it far inside that tolerance: over 1,200 random stacks (seeds 0-399,
two to four levels) the largest change was 1.9e-8 (the third of four levels, seed 231), the next 4.7e-9;
a leak between levels moves a residual by the rows' own scale (0.1). Then the same on a robot: a reach
above a posture, a floor (an inequality task) above a reach.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.qp import IKProblem, JointPositionLimits, PositionTask, PostureTask, RegularizationTask
from wbik.qp.tasks import PositionBoxTask, Task

AGREE = 1e-7
"""A level's errors with and without the levels below it: a tenth of DAQP's primal tolerance (see the module
docstring)."""


class ConstantTask(Task):
    """A task whose rows are constant: J (m x nv) and e (m); an inequality task wants e <= 0."""

    def __init__(self, jacobian: np.ndarray, error: np.ndarray, inequality: bool = False, **options):
        self.dimension = jacobian.shape[0]
        self.inequality = inequality
        super().__init__(**options)
        self._jacobian, self._error = jacobian, error

    def error(self, kinematics):
        return self._error

    def jacobian(self, kinematics):
        return self._jacobian


@pytest.fixture(scope="module")
def panda():
    return wbik.load("panda")


def residual(task: ConstantTask, dq: np.ndarray) -> float:
    value = task._jacobian @ dq + task.gain * task._error
    return float(np.linalg.norm(np.maximum(value, 0.0) if task.inequality else value))


def levels_by_construction(rng: np.random.Generator, nv: int, count: int) -> list[list[ConstantTask]]:
    """``count`` levels of 1-2 tasks of 1-3 rows; level 0 feasible by construction (met by a
    displacement x0 inside the step box: e = -J x0, an inequality met with room to spare)."""
    x0 = rng.uniform(-0.08, 0.08, nv)
    levels = []
    for level in range(count):
        tasks = []
        for _ in range(rng.integers(1, 3)):
            rows = int(rng.integers(1, 4))
            jacobian = rng.normal(size=(rows, nv))
            inequality = bool(rng.integers(0, 2))
            if level == 0:
                error = -jacobian @ x0 - (rng.uniform(0.0, 0.05, rows) if inequality else 0.0)
            else:
                error = rng.normal(scale=0.1, size=rows)
            tasks.append(ConstantTask(jacobian, error, inequality, weight=float(rng.uniform(0.5, 2.0)),
                                      priority=level))
        levels.append(tasks)
    return levels


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), count=st.integers(2, 4))
def test_a_lower_level_never_changes_what_a_higher_level_achieved(panda, seed, count):
    model = panda.model
    levels = levels_by_construction(np.random.default_rng(seed), model.nv, count)
    constraints = [JointPositionLimits()]

    def step(upto: int) -> np.ndarray:
        tasks = [task for level in levels[:upto + 1] for task in level]
        return IKProblem(model, tasks, constraints).step(panda.nominal)

    full = step(count - 1)
    for upto in range(count - 1):
        alone = step(upto)
        for task in levels[upto]:
            with_lower, without = residual(task, full), residual(task, alone)
            if task.inequality:
                assert with_lower <= without + AGREE, (upto, task)  # never made worse
            else:
                assert abs(with_lower - without) <= AGREE, (upto, with_lower, without)


def test_an_inequality_level_keeps_the_hand_above_a_floor_while_a_lower_level_reaches(panda):
    """A floor 0.2 m under the hand (an inequality task, level 0) above a reach 0.35 m down (level 1):
    the hand stops on the floor, exactly; with the reach above the floor it goes through it."""
    model = panda.model
    start = panda.frame_placement(panda.nominal, "panda_hand_tcp").translation
    floor = start[2] - 0.2
    target = start + np.array([0.1, 0.0, -0.35])

    def solve(floor_priority: int, reach_priority: int):
        tasks = [PositionBoxTask("panda_hand_tcp", lower=[-np.inf, -np.inf, floor], priority=floor_priority),
                 PositionTask("panda_hand_tcp", target, priority=reach_priority),
                 RegularizationTask(1e-9, priority=max(floor_priority, reach_priority))]
        solution = IKProblem(model, tasks, [JointPositionLimits()]).solve(panda.nominal)
        return solution, panda.frame_placement(solution.q, "panda_hand_tcp").translation

    held, hand = solve(0, 1)
    # on the floor, right above the target; the loop's merit (level k weighted by 1e-6^k) lets the
    # curvature of the kinematics leave the floor's error under 1e-6, not under its own tolerance
    assert not held.success and abs(hand[2] - floor) < 1e-6
    assert np.linalg.norm(hand[:2] - target[:2]) < 1e-6
    assert held.task_errors["PositionBoxTask[panda_hand_tcp]"] < 1e-6
    through, hand = solve(1, 0)
    assert through.task_errors["PositionTask[panda_hand_tcp]"] < 1e-6 and hand[2] < floor - 0.1


def test_a_posture_one_level_below_the_goals_leaves_them_exact(panda):
    model = panda.model
    goal = panda.nominal.copy()
    goal[:7] = [0.4, -0.1, 0.2, -1.9, -0.1, 1.9, 0.8]
    target = panda.frame_placement(goal, "panda_hand_tcp").translation
    far = panda.nominal.copy()
    far[:7] = [-1.0, 0.5, -1.0, -1.0, 1.0, 1.0, -1.0]
    for posture_priority, exact in ((0, False), (1, True)):
        tasks = [PositionTask("panda_hand_tcp", target),
                 PostureTask(far, weight=1e-2, priority=posture_priority),
                 RegularizationTask(1e-9, priority=posture_priority)]
        solution = IKProblem(model, tasks, [JointPositionLimits()]).solve(panda.nominal)
        error = solution.task_errors["PositionTask[panda_hand_tcp]"]
        assert (error < 1e-7) is exact, (posture_priority, error)
