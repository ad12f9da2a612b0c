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


def test_argparse_errors_exit_2(capsys):
    code, _, err = run(["solve", "pincher", "--xyz", "a", "b", "c"], capsys)
    assert code == 2 and "invalid float value" in err
    code, _, err = run([], capsys)
    assert code == 2 and "COMMAND" in err


def test_bad_input_exits_2_with_one_line_and_debug_adds_the_traceback(capsys):
    code, _, err = run(["solve", "pincher", "--xyz", "nan", "0", "0"], capsys)
    assert code == 2 and err.startswith("wbik: error: ") and "Traceback" not in err
    code, _, err = run(["--debug", "solve", "pincher", "--xyz", "nan", "0", "0"], capsys)
    assert code == 2 and "Traceback" in err and "InvalidTargetError" in err


def test_not_solved_exits_1(capsys):
    code, out, err = run(["solve", "pincher", "--xyz", "10", "10", "10"], capsys)
    assert code == 1 and "NOT solved" in out and err == ""


def test_internal_error_exits_3(capsys, monkeypatch):
    import wbik.commands.methods as methods_command

    def broken(args):
        raise RuntimeError("simulated bug")

    monkeypatch.setattr(methods_command, "run", broken)
    code, _, err = run(["methods"], capsys)
    assert code == 3 and "internal error: RuntimeError: simulated bug" in err and "Traceback" not in err
    code, _, err = run(["methods", "--debug"], capsys)
    assert code == 3 and "Traceback" in err


def test_a_subcommand_module_without_its_declarations_is_an_error(capsys, monkeypatch):
    import types

    import wbik.cli

    hollow = types.ModuleType("wbik.commands.hollow")
    monkeypatch.setattr(wbik.cli, "SUBCOMMANDS", (*wbik.cli.SUBCOMMANDS, hollow))
    code, _, err = run(["robots"], capsys)
    assert code == 3 and "wbik.commands.hollow has no HELP, docstring, run(args)" in err


def test_run_prints_the_kind_report_and_exits_by_its_verdict(capsys, tmp_path):
    from pathlib import Path

    tasks = Path(__file__).resolve().parents[1] / "tasks"
    code, out, _ = run(["run", str(tasks / "motion_bioloid_foot_sensors.yaml")], capsys)
    assert code == 0
    assert out.splitlines()[0] == "motion_bioloid_foot_sensors (bioloid_stance_sensors, bioloid): PASSED"
    assert "CoP - CoM" in out and "cop_error_max_m" in out
    failing = tmp_path / "stance.yaml"
    failing.write_text((tasks / "motion_bioloid_foot_sensors.yaml").read_text().replace(
        "cop_error_max_m: 1.0e-9", "cop_error_max_m: {threshold: -1.0, expected_to_fail: false}"))
    code, out, _ = run(["run", str(failing), "--json"], capsys)
    report = json.loads(out)
    assert code == 1 and report["passed"] is False and report["verdict"] == "FAILED"
    assert report["moves"][0]["expectations"][0]["threshold"] == -1.0


def test_output_file_where_a_folder_is_needed(capsys, tmp_path):
    existing = tmp_path / "results.txt"
    existing.write_text("not a folder")
    code, _, err = run(["study", "--output", str(existing)], capsys)
    assert code == 2 and "existing file" in err
    code, _, err = run(["study", "--report-only", "--output", str(tmp_path)], capsys)
    assert code == 2 and "no results" in err
    code, _, err = run(["run", "tasks/does-not-matter.yaml", "--output", str(tmp_path)], capsys)
    assert code == 2 and "is a folder" in err


def test_a_reader_that_leaves_early_is_no_internal_error():
    process = subprocess.Popen([sys.executable, "-m", "wbik.cli", "methods"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE)
    process.stdout.close()  # the reader is gone before wbik writes (as `wbik methods | head -0`)
    code = process.wait(timeout=120)
    error = process.stderr.read().decode()
    assert code == 141 and "internal error" not in error, (code, error)
