"""Benchmark protocols (the case kind ``protocol``): a case's success rule judged on hand-made error rows
(per axis in the target's or the base's frame, or on the norms), the ``success:`` and ``peers:`` checks,
the shipped preset files loaded and run at a few poses, and per-axis verdicts of a run recomputed from
its rows."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from wbik.study import load_study, run_study, study_from_dict
from wbik.study.definition import with_overrides
from wbik.study.results import read_raw_csv
from wbik.study.spec import StudyDefinitionError
from wbik.study.success_rules import SuccessRule, error_percentiles, failure_reason, frame_errors, judge

BOUND = 1e-5
AXIS = SuccessRule(BOUND, BOUND, per="axis", frame="target")


def rz(angle: float) -> np.ndarray:
    return pin.utils.rotate("z", angle)


def test_per_axis_success_on_hand_made_error_rows():
    e = 0.8e-5
    position = np.array([
        [0.5e-5, -0.9e-5, 0.2e-5],  # every axis inside, in either frame (the target frame is R = I)
        [e, e, e],  # norm 1.39e-5 <= sqrt(3) 1e-5: passes a norm check; per axis inside in the base frame
        [1.2e-5, 0.0, 0.0],  # x outside
        [0.0, 0.0, 0.0],
        [np.nan, np.nan, np.nan],  # no joints
    ])
    rotation = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, -1.1e-5, 0.0],
                         [np.nan, np.nan, np.nan]])
    rotations = np.array([np.eye(3), rz(math.pi / 4), rz(math.pi / 2), np.eye(3), np.eye(3)])
    passed, worst, component = judge(AXIS, position, rotation, rotations)
    # row 1 in the target frame: R^T (e, e, e) = (sqrt(2) e, 0, e): |x| = 1.13e-5 > 1e-5
    assert passed.tolist() == [True, False, False, False, False]
    assert worst[1] == pytest.approx(math.sqrt(2) * e / BOUND) and component[1] == 0
    assert worst[2] == pytest.approx(1.2) and component[2] == 1  # R^T (1.2e-5, 0, 0) = (0, -1.2e-5, 0): y
    assert worst[3] == pytest.approx(1.1) and component[3] == 4  # rot_y
    assert math.isnan(worst[4])
    base = SuccessRule(BOUND, BOUND, per="axis", frame="base")
    assert judge(base, position, rotation, rotations)[0].tolist() == [True, True, False, False, False]
    norm = SuccessRule(math.sqrt(3) * BOUND, math.sqrt(3) * BOUND, per="norm")
    assert judge(norm, position, rotation, rotations)[0].tolist() == [True, True, True, True, False]


def test_frames_of_the_errors():
    position, rotation = np.array([[1.0, 2.0, 3.0]]), np.array([[0.0, 0.5, 0.0]])
    rotations = np.array([rz(math.pi / 2)])
    in_target, same = frame_errors(position, rotation, rotations, "target")
    assert np.allclose(in_target, [[2.0, -1.0, 3.0]]) and np.allclose(same, rotation)
    in_base_p, in_base_r = frame_errors(position, rotation, rotations, "base")
    assert np.allclose(in_base_p, position) and np.allclose(in_base_r, [[-0.5, 0.0, 0.0]])


def test_reasons_and_percentiles():
    assert failure_reason(AXIS, 1.3, 4) == ("outside the case's success rule: |rot_y| = 1.3e-05 rad > 1e-05 "
                                            "(target frame)")
    rule = SuccessRule(0.005, 0.05)
    assert failure_reason(rule, 2.0, 1) == "outside the case's success rule: rotation error 0.1 rad > 0.05"
    assert error_percentiles(np.array([1.0, 2.0, 3.0, np.nan]), (50, 100)) == [2.0, 3.0]
    assert all(math.isnan(v) for v in error_percentiles(np.array([np.nan])))


def _study(case: dict):
    return study_from_dict({"name": "p", "methods": ["bounded_lm"], "cases": [case]}, source="f.yaml")


def test_a_protocol_case_is_completed():
    case = _study({"robot": "panda", "chain": "arm", "success": {"per": "axis", "position": 1e-5,
                                                                 "rotation": 1e-5}}).cases[0]
    assert (case.name, case.target) == ("panda_arm_protocol", "protocol")
    assert case.success == {"position": 1e-5, "rotation": 1e-5, "per": "axis", "frame": "target"}
    assert case.peers == []
    peers = [{"solver": "X", "figures": {"percent_solved": 100}}]
    with_peers = _study({"robot": "panda", "chain": "arm", "success": {"position": 0.005, "rotation": 0.05},
                         "peers": peers})
    assert with_peers.cases[0].success == {"position": 0.005, "rotation": 0.05, "per": "norm"}
    no_peers = _study({"robot": "panda", "chain": "arm", "success": {"position": 0.005, "rotation": 0.05}})
    assert with_peers.fingerprint() == no_peers.fingerprint()  # peers are report text


@pytest.mark.parametrize(("case", "message"), [
    ({"success": {"position": 1e-5}}, r"cases\[0\]\.success: missing the required key 'rotation'"),
    ({"success": {"position": 1e-5, "rotation": 1e-5, "per": "each"}},
     r"cases\[0\]\.success\.per must be 'norm' or 'axis', got 'each'"),
    ({"success": {"position": 1e-5, "rotation": 1e-5, "frame": "base"}},
     r"cases\[0\]\.success\.frame applies to per: axis only"),
    ({"success": {"position": 0, "rotation": 1e-5}},
     r"cases\[0\]\.success\.position must be a positive bound"),
    ({"success": {"position": 1e-5, "rotation": 1e-5, "pre": "axis"}},
     r"cases\[0\]\.success has unknown field\(s\) \['pre'\]"),
    ({"target": "protocol"}, r"cases\[0\]: missing the required key 'success' \(a mapping"),
    ({"success": {"position": 1e-5, "rotation": 1e-5}, "peers": [{"figures": {}}]},
     r"cases\[0\]\.peers\[0\]: missing the required key 'solver'"),
    ({"success": {"position": 1e-5, "rotation": 1e-5}, "peers": [{"solver": "X", "figures": {"solved": 1}}]},
     r"cases\[0\]\.peers\[0\]\.figures has unknown field\(s\) \['solved'\]"),
])
def test_a_wrong_protocol_names_its_key(case, message):
    with pytest.raises(StudyDefinitionError, match=message):
        _study({"robot": "panda", "chain": "arm", **case})


def test_the_presets_load_as_their_protocols_say():
    tracik = load_study("comparisons/tracik_protocol.yaml")
    assert (tracik.poses, tracik.start, tracik.timeout_s) == (10000, "mid_range", 0.005)
    assert tracik.tolerances == {"position": pytest.approx(math.sqrt(3) * 1e-5),
                                 "rotation": pytest.approx(math.sqrt(3) * 1e-5)}
    panda = tracik.cases[0]
    assert panda.success == {"position": 1e-5, "rotation": 1e-5, "per": "axis", "frame": "target"}
    assert panda.reference.figures == {"trac_ik": {"percent_solved": 99.70, "time_mean_ms": 0.38},
                                       "kdl_5ms": {"percent_solved": 61.77, "time_mean_ms": 2.14}}
    curobo = load_study("comparisons/curobo_thresholds.yaml")
    assert curobo.poses == 2000 and curobo.cases[0].success == {"position": 0.005, "rotation": 0.05,
                                                                "per": "norm"}
    assert curobo.cases[0].peers[0]["figures"] == {"percent_solved": 100.0}
    assert curobo.cases[0].reference.figures == {"analytic_locked": {"time_mean_ms": 0.00367}}


@pytest.mark.parametrize("name", ["tracik_protocol", "curobo_thresholds"])
def test_the_presets_run_at_a_few_poses(name, tmp_path):
    study = with_overrides(load_study(f"comparisons/{name}.yaml"), poses=4, figures=False)
    output = run_study(study, tmp_path / name, jobs=2, backend="loky", progress=False,
                       log=lambda message: None)
    report = (output / "report.md").read_text()
    assert "### Success rule" in report and "### Errors at percentiles (p50, p98, max)" in report
    for case in study.cases:
        assert (output / case.name / "protocol.csv").is_file()
    if name == "tracik_protocol":
        assert "### Beside the TRAC-IK README" in report
    else:
        assert "### Beside published figures of other solvers" in report and "| cuRobo v2 |" in report


def test_per_axis_verdicts_of_a_run_follow_its_rows(tmp_path):
    """Every row of a small run: success = every axis of R*^T (p - p*) and log3(R*^T R) within the bound,
    recomputed here from raw.csv and the saved targets."""
    study = study_from_dict({
        "name": "axis", "seed": 8, "poses": 30, "chunk_size": 15, "timeout_s": 0.005, "start": "mid_range",
        "tolerances": {"position": math.sqrt(3) * BOUND, "rotation": math.sqrt(3) * BOUND},
        "cases": [{"robot": "panda", "chain": "arm", "success": {"per": "axis", "position": BOUND,
                                                                 "rotation": BOUND}}],
        "methods": [{"method": "dls", "options": {"max_iterations": 40}}, "bounded_lm"]}, source="test")
    output = run_study(study, tmp_path / "out", jobs=1, backend="sequential", progress=False,
                       log=lambda message: None)
    with np.load(output / "panda_arm_protocol" / "poses.npz") as poses:
        rotations = poses["rotations"]
    from wbik.study.results import load_method_rows

    for label, rows in read_raw_csv(output / "panda_arm_protocol" / "raw.csv").items():
        position = np.stack([rows[f"err_{axis}"] for axis in "xyz"], axis=1)
        rotation = np.stack([rows[f"err_rot_{axis}"] for axis in "xyz"], axis=1)
        in_target = np.einsum("bji,bj->bi", rotations, position)
        inside = np.all(np.abs(np.hstack([in_target, rotation])) <= BOUND, axis=1)
        assert np.array_equal(rows["success"], inside), label
        check = load_method_rows(output, "panda_arm_protocol", label, 2)["check_success"]
        assert not np.any(inside & ~check)  # inside the per-axis bounds: inside sqrt(3) x them
