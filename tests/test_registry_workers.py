"""A method added with ``wbik.register`` runs in the study's worker processes too.

The registry is per process; the study's loky workers are fresh processes, so the task carries the
registered class (cloudpickle) and the worker registers it. The class is registered inside the test,
not at import, so a worker that merely imports this module does not see it: without the task
carrying it, the workers would raise UnknownMethodError.
"""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np

import wbik
from wbik.solvers.base import _DESCRIPTIONS, _REGISTRY
from wbik.solvers.dls import DampedLeastSquares
from wbik.study import load_study, run_study
from wbik.study.results import read_raw_csv

NAME = "user_dls_in_workers"

STUDY = f"""
name: registered
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
    wbik.register(NAME, UserDLS, "test only: DLS defined in a test module")
    try:
        study_file = tmp_path / "registered.yaml"
        study_file.write_text(STUDY)
        output = run_study(load_study(study_file), tmp_path / "out", jobs=2, backend="loky",
                           progress=False, log=lambda message: None)
    finally:
        _REGISTRY.pop(NAME, None)
        _DESCRIPTIONS.pop(NAME, None)
    rows = read_raw_csv(output / "arm3r_arm_position" / "raw.csv")
    assert set(rows) == {NAME, "dls"}
    mine = rows[NAME]
    assert np.array_equal(mine["pose"], np.arange(40))
    workers = {reason.rsplit("pid=", 1)[1] for reason in mine["reason"]}
    assert str(os.getpid()) not in workers  # solved in the worker processes, not here
    assert mine["success"].mean() > 0.5  # a working method, not rows of errors
    assert NAME in (output / "report.md").read_text()
