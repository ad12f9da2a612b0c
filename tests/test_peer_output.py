"""Nothing a compiled peer prints reaches the user's terminal: the text is captured at the file-descriptor
level and logged, or put into the refusal's reason."""

from __future__ import annotations

import logging
import os

import pytest

import wbik
from wbik.errors import WbikError
from wbik.peer_output import captured_output

CHAINS = [("ur5", "base_link", "wrist_3_joint"),  # a joint frame as tip: TRAC-IK prints and refuses
          ("ur5", "base_link", "tool0"), ("panda", "panda_link0", "panda_link8"),
          ("example-robot-data:baxter", "torso", "right_gripper_base_link"),
          ("example-robot-data:bravo7_no_ee", "link1", "end_effector_ball")]


def test_output_written_to_the_descriptors_is_captured(capfd, caplog):
    with caplog.at_level(logging.DEBUG, logger="wbik.peers"), captured_output("a peer") as printed:
        os.write(1, b"to stdout\n")
        os.write(2, b"to stderr")
    assert capfd.readouterr() == ("", "")
    assert printed.text == "to stdout\nto stderr"
    assert printed.reason() == " (a peer printed: 'to stdout to stderr')"
    assert "a peer printed: to stdout" in caplog.text


@pytest.mark.parametrize(("robot", "base", "tip"), CHAINS, ids=[f"{c[0]}-{c[2]}" for c in CHAINS])
def test_no_method_prints_while_built_or_solving(capfd, robot, base, tip):
    """Every installed method built on the chain (or refusing it) and solving its nominal pose once."""
    model = wbik.load(robot)
    refusals = {}
    for method in wbik.methods(installed=True):
        try:
            solver = wbik.solver(method, model, base=base, tip=tip)
            solver.solve(solver.chain.fk(solver.chain.nominal))
        except WbikError as refused:
            refusals[method] = str(refused)
    assert capfd.readouterr() == ("", "")
    if tip == "wrist_3_joint":
        assert "TRAC-IK printed: \"Couldn't find chain" in refusals["trac_ik"]
