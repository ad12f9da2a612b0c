"""A constraint is one class: a user's own, handed to ``WholeBody(constraints=[...])``, is held by the QP,
measured by the shared check, named by the diagnosis in its own words, listed as unsupported by a peer
that has no form for it, and solved by the peer once a form is registered."""

from __future__ import annotations

import numpy as np
import pytest

import wbik
from wbik.qp.constraint import SLACK, InequalityConstraint, Measure
from wbik.qp.rows import InequalityRows
from wbik.qp.tasks import PositionTask
from wbik.solvers.placo import PLACO


class AboveFloor(InequalityConstraint):
    """A frame's origin stays at least ``height`` (m) above the world's z = 0: -J_z dq <= z - height."""

    label_kind = "floor"
    quantity = "height above the floor"

    def __init__(self, frame: str, height: float):
        self.frame, self.height, self.frame_id = frame, float(height), -1
        self.name = f"{frame} above {height:g} m"

    def start(self, kinematics):
        self.frame_id = kinematics.frame_id(self.frame)

    def _z(self, kinematics) -> float:
        return float(kinematics.placement(self.frame_id).translation[2])

    def inequality(self, kinematics):
        room = np.array([self._z(kinematics) - self.height])
        return InequalityRows(-kinematics.jacobian(self.frame_id)[2:3], room)

    def labels(self, kinematics, rows):
        return [self.label(self.frame, "", self._z(kinematics), self.height, "m")]

    def violation(self, kinematics):
        return max(self.height - self._z(kinematics), 0.0)

    def measure(self, kinematics, tolerances):
        self.start(kinematics)
        clearance = self._z(kinematics) - self.height
        return Measure(self.name, self.quantity, clearance, "m", clearance >= -SLACK,
                       f"{self.frame} {-clearance * 1e3:.3g} mm below the floor")

    def blocker_text(self, label):
        return f"the floor under {label.subject} (at {label.bound:g} m)"

    def advice(self, label):
        return f"the target is under the floor of {label.subject}: raise it above {label.bound:g} m"


@pytest.fixture(scope="module")
def ur5():
    return wbik.load("ur5")


def _problem(ur5, target_z: float) -> wbik.WholeBody:
    start = ur5.frame_placement(ur5.nominal, "tcp").translation
    target = np.array([start[0], start[1], target_z])
    return wbik.WholeBody(ur5, [PositionTask("tcp", target, name="tool")], limits="position",
                          constraints=[AboveFloor("tcp", 0.25)])


def test_the_qp_holds_a_user_constraint_the_check_measures_it_and_the_diagnosis_names_it(ur5):
    reachable = wbik.solver("qp", ur5).solve(_problem(ur5, 0.28), ur5.nominal)
    assert reachable.success and reachable.measures["tcp above 0.25 m"].value >= 0.03 - 1e-6
    blocked = wbik.solver("qp", ur5).solve(_problem(ur5, 0.10), ur5.nominal)
    assert not blocked.success
    floor = blocked.measures["tcp above 0.25 m"]
    assert floor.holds and floor.quantity == "height above the floor"
    assert floor.value == pytest.approx(0.0, abs=1e-5)  # held at the floor, the goal 0.15 m further down
    assert blocked.diagnosis.blockers[0].text == "the floor under tcp (at 0.25 m)"
    assert "raise it above 0.25 m" in blocked.reason
    # the check judges a configuration below the floor by the constraint's own words
    low = ur5.nominal.copy()
    low[1] += 0.6  # the shoulder lifts the arm's far end down (below 0.25 m)
    assert ur5.frame_placement(low, "tcp").translation[2] < 0.25
    checked = wbik.check_problem(_problem(ur5, 0.10), low, q0=ur5.nominal)
    assert not checked.success and "mm below the floor" in checked.reason


def test_a_peer_without_a_form_lists_it_and_solves_it_once_a_form_is_registered(ur5):
    problem = _problem(ur5, 0.28)
    solver = wbik.solver("placo", ur5)
    assert any("tcp above 0.25 m" in item and "PlaCo has no form for AboveFloor" in item
               for item in solver.unsupported(problem))

    @PLACO.form(AboveFloor)
    def floor_in_placo(constraint, placo):  # PlaCo's hard position task would pin it: a soft floor here
        held = placo.kinematics.placement(constraint.frame_id).translation.copy()
        held[2] = max(held[2], constraint.height)
        added = placo.solver.add_position_task(constraint.frame, held)
        added.mask.set_axises("z")
        added.configure(constraint.name, "soft", 1e-3)

    assert solver.unsupported(problem) == []  # (the class is this test's: its form stays harmless)
    result = solver.solve(problem, ur5.nominal)
    assert result.measures["tcp above 0.25 m"].holds
