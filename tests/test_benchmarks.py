"""The one benchmark command runs from a fresh clone and reports every speed goal it lists.

Speed is not asserted here (it depends on the machine): the test checks that ``benchmarks/all.py
--quick`` runs, that each goal has a row with finite figures measured in the same run, and that the
verdict follows from the ratio and the goal's bound.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOALS = {  # a phrase of each goal's row -> rows expected
    "interface overhead <= 5 us": 5,
    "UR5 closed-form solve <= 1.5x EAIK": 1,
    "UR5 closed-form solve_all <= 3x EAIK": 1,
    "UR5 closed-form solve_many per pose <= 0.5x": 1,
    "UR5 closed-form solve_many per pose, a list of SE3": 1,
    "Golem-III closed-form solve <= 20 us": 1,
    "eaik method solve <= 1.5x EAIK's own call": 2,
    "bounded_lm mean time <= 0.4x TRAC-IK": 5,
    "bounded_lm success >= TRAC-IK": 5,
    "solve_many throughput": 4,
    "whole-body QP step <= 1.2x PlaCo": 2,
    "whole-body QP step faster than Pink": 1,
    "converged whole-body IK <= 2x PlaCo": 1,
    "converged whole-body IK faster than Pink": 1,
    "at least 5 kHz per step": 1,
}


def test_all_benchmarks_report_every_goal_as_a_ratio(tmp_path):
    output = tmp_path / "bench.json"
    completed = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "all.py"), "--quick", "--json",
                                str(output)], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert completed.returncode == 0, completed.stderr[-3000:]
    document = json.loads(output.read_text())
    assert document["machine"]["cores"] >= 1 and document["quick"] is True
    rows = document["ratios"]
    for phrase, count in GOALS.items():
        found = [row for row in rows if phrase in row["goal"]]
        assert len(found) == count, (phrase, [row["goal"] for row in found])
    for row in rows:
        assert math.isfinite(row["ours"]) and math.isfinite(row["peer"]) and row["peer"] > 0, row
        assert math.isclose(row["ratio"], row["ours"] / row["peer"]), row
        if row["limit"] is None:
            assert row["met"] is None, row
        else:
            lower = row["better"] == "lower"
            met = row["ratio"] <= row["limit"] if lower else row["ratio"] >= row["limit"]
            assert row["met"] == met, row
    assert "goals met" in completed.stdout and "machine:" in completed.stdout


def test_the_interface_phases_cover_a_solve():
    """``interface_overhead.py --phases`` times every step of a trivial solve alone on each chain: a row per
    step with a positive time for every chain (no comparison of times: a loaded machine reorders them)."""
    completed = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "interface_overhead.py"),
                                "--calls", "200", "--rounds", "1", "--phases"],
                               capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert completed.returncode == 0, completed.stderr[-3000:]
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from interface_overhead import CHAINS, LABEL, PHASES
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    table = completed.stdout.split("where one trivial solve's time goes")[1].splitlines()[2:]
    rows = {line[:LABEL].strip(): [float(value) for value in line[LABEL:].split()]
            for line in table if line.strip()}
    assert set(rows) == {*PHASES, "rest (Python between the steps)", "solve"}
    for label in PHASES:
        assert len(rows[label]) == len(CHAINS), label
        assert all(value > 0 for value in rows[label]), label
