"""The compiled bounded_lm attempt (``lm_attempt`` of ``wbik/kernels/_lm_trial.c``) against its Python twin:
the loop of :meth:`BoundedLMSolver._attempt` on Pinocchio's kinematics with the Python trial.

The kernel's forward kinematics sums in another order than Pinocchio's, its trial in index order (LAPACK
in its own): on the TRAC-IK protocol's poses (measured on 2,000 of each chain below: identical verdicts and
iteration counts, answers within 1.2e-11 rad) both decide alike. A decision on the last bit (an accepted
step, a passed check) may fall either side on another CPU: 1 % of the iteration counts may differ.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from compiled_twins import compared_with_its_twin

import wbik
from wbik.kernels.twins import PURE_PYTHON_VARIABLE
from wbik.solvers import bounded_lm
from wbik.solvers.result import Tolerances
from wbik.targets import as_target

pytestmark = compared_with_its_twin(bounded_lm._LM_ATTEMPT)


def both_solvers(spec: str, monkeypatch) -> tuple:
    """bounded_lm on ``spec`` with the compiled attempt and with every Python twin, tolerance 1e-5."""
    robot_name, _, chain_name = spec.partition(":")
    robot = wbik.load(robot_name)
    compiled = wbik.solver("bounded_lm", robot, chain_name, tolerances=Tolerances(1e-5, 1e-5))
    with monkeypatch.context() as patch:
        patch.setenv(PURE_PYTHON_VARIABLE, "1")
        python = wbik.solver("bounded_lm", robot, chain_name, tolerances=Tolerances(1e-5, 1e-5))
    assert compiled._compiled is not None and python._compiled is None
    assert python._trial == python.policy.trial
    return compiled, python


@pytest.mark.parametrize("spec", ["ur5:arm", "golem3:right_arm", "pincher:arm", "bioloid:right_leg",
                                  "panda:arm", "golem3:right_arm_lift"])
def test_bounded_lm_decides_alike_with_either_twin(spec, monkeypatch):
    """TRAC-IK's protocol (FK poses of random joints, mid-range seed): the same verdicts, iteration counts on
    99 % of the poses, answers within 1e-9 rad (wrapped full-turn joints: UR5; a prismatic one: the lift)."""
    compiled, python = both_solvers(spec, monkeypatch)
    chain = compiled.chain
    iterations_differ = 0
    for q in chain.random(np.random.default_rng(9), 200):
        target = chain.fk(q)
        ours, theirs = compiled.solve(target, chain.mid_range), python.solve(target, chain.mid_range)
        assert ours.success == theirs.success
        if ours.iterations != theirs.iterations:
            iterations_differ += 1
        else:
            assert np.abs(ours.q - theirs.q).max() <= 1e-9
    assert iterations_differ <= 2  # (none here; see the module docstring)


def test_a_rotation_error_near_pi_hands_the_attempt_to_the_python_twin(monkeypatch):
    """The target turned by pi about the tip's z axis from the seed's pose: the kernel leaves the attempt
    to the Python loop (Pinocchio's log3), which decides as the Python twin does."""
    compiled, python = both_solvers("ur5:arm", monkeypatch)
    chain = compiled.chain
    seed = chain.mid_range + 0.3
    target = as_target(chain.fk(seed) * pin.SE3(pin.utils.rotate("z", math.pi), np.zeros(3)))
    last = np.empty(chain.nq)
    assert bounded_lm._LM_ATTEMPT(*compiled._compiled, target.rotation, target.position, seed, 30, math.inf,
                                  last) is None
    ours, theirs = (solver._attempt_function(target, True)(seed, math.inf, 30)
                    for solver in (compiled, python))
    assert ours[1:3] == theirs[1:3] and np.abs(ours[0] - theirs[0]).max() <= 1e-9


def test_bad_arguments_are_refused_with_the_argument_named(monkeypatch):
    compiled, _ = both_solvers("pincher:arm", monkeypatch)
    chain_array, joints, settings = compiled._compiled
    q, pose = compiled.chain.mid_range, compiled.chain.fk(compiled.chain.mid_range + 0.2)
    good = [chain_array, joints, settings, pose.rotation, pose.translation, q, 30, math.inf, np.empty(4)]
    assert isinstance(bounded_lm._LM_ATTEMPT(*good), tuple)
    for index, bad, name in [(0, chain_array[1:], "chain"), (1, joints[:3], "joints"),
                             (2, settings[1:], "settings"), (3, np.eye(4), "rotation"),
                             (4, np.zeros(2), "position"), (5, q[:3], "q"), (8, np.empty(3), "out"),
                             (7, "soon", "deadline")]:
        arguments = list(good)
        arguments[index] = bad
        with pytest.raises(TypeError, match=name):
            bounded_lm._LM_ATTEMPT(*arguments)
