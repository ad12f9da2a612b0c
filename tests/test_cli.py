"""The wbik command: robots, methods, fk, solve, errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from wbik.cli import main


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_robots_lists_builtins(capsys):
    code, out, _ = run(["robots"], capsys)
    assert code == 0 and "pincher" in out and "golem3" in out


def test_fk_json_matches_seed(capsys):
    code, out, _ = run(["fk", "pincher", "--q", "15", "30", "45", "60", "--deg", "--json"], capsys)
    assert code == 0
    payload = json.loads(out)
    assert np.allclose(np.array(payload["position"]) * 1000, [213.5636, 57.2242, 187.9335], atol=1e-4)


def test_solve_json_round_trip(capsys):
    code, out, _ = run(["solve", "pincher", "--xyz", "0.15", "0.2", "0.2", "--json"], capsys)
    payload = json.loads(out)
    assert code == 0 and payload["success"] and payload["position_error"] < 1e-6
    assert len(payload["q"]) == 4


def test_solve_with_rpy_prints_joints(capsys):
    code, out, _ = run(["solve", "ur5", "--chain", "arm", "--xyz", "0.4", "0.2", "0.3",
                        "--rpy", "3.14159", "0", "0", "--timeout", "0.5"], capsys)
    assert "shoulder_pan_joint" in out and "rotation error" in out


def test_unknown_robot_is_a_clean_error(capsys):
    code, _, err = run(["fk", "nao", "--q", "0"], capsys)
    assert code == 2 and "unknown robot 'nao'" in err and "pincher" in err


def test_console_script_help():
    out = subprocess.run([sys.executable, "-m", "wbik.cli", "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "solve" in out.stdout and "fk" in out.stdout
