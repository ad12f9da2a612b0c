"""Target sets of the study (a case's ``targets:``): each set draws what it says (joints near a limit,
near a singularity, on the reach envelope), from the study's seed, target i independent of the count;
a study file names them with typed errors for mistakes; files that name no set keep their fingerprints;
a small study with every reachable set runs end to end, saves the drawing with the poses and resumes."""

from __future__ import annotations

import numpy as np
import pytest

from wbik.study import run_study, study_from_dict
from wbik.study.case_kinds import case_kinds
from wbik.study.context import case_chain
from wbik.study.near_limits import limit_distance, limited_joints
from wbik.study.near_singularities import sigma_min
from wbik.study.reach_boundary import reach_along, stationarity_residual
from wbik.study.runner import pending_tasks
from wbik.study.spec import StudyDefinitionError
from wbik.study.target_parameters import defaults
from wbik.study.target_sets import read_drawing


def _draw(name: str, chain, count: int, seed: int = 7, **parameters):
    kind = case_kinds()[name]
    return kind.draw(chain, count, seed, {**defaults(name, kind.all_parameters), **parameters})


@pytest.fixture(scope="module")
def panda():
    return case_chain("panda", (), "arm")


@pytest.fixture(scope="module")
def ur5():
    return case_chain("ur5", (), "arm")


def test_near_limit_targets_have_a_joint_within_the_fraction(panda):
    drawing = _draw("near_limits", panda, 40, fraction=0.02, joints=2)
    q = drawing.q_true
    assert np.all(q >= panda.lower) and np.all(q <= panda.upper)
    distance = limit_distance(q, panda)  # a share of each joint's range
    assert np.all(np.sum(distance <= 0.02 + 1e-12, axis=1) >= 2)  # two joints per target
    assert np.allclose(drawing.extras["limit_fraction"], distance.min(axis=1))
    assert set(drawing.facts["eligible"]) == set(panda.joint_names)  # every Panda range is < 2 pi


def test_near_limits_takes_the_limited_joints_else_falls_back_to_all(ur5):
    assert len(limited_joints(ur5)) == 0  # the UR5's ranges are 2 pi and 4 pi
    drawing = _draw("near_limits", ur5, 10)
    assert drawing.facts["fell_back_to_all"]
    assert np.all(limit_distance(drawing.q_true, ur5).min(axis=1) <= 0.02 + 1e-12)


def test_near_singular_targets_have_sigma_min_below_the_bound(ur5, panda):
    for chain, bound in ((ur5, 1e-3), (panda, 2e-3)):
        drawing = _draw("near_singularities", chain, 8, sigma_max=bound)
        sigmas = [sigma_min(chain, q) for q in drawing.q_true]  # at the generating configurations
        assert max(sigmas) < bound
        assert np.allclose(sigmas, drawing.extras["sigma_min"])
        assert all(chain.in_limits(q) for q in drawing.q_true)
        # drawn from uniform joints, which are far from singular: the drive did the work
        uniform = chain.random(np.random.default_rng(1), 50)
        assert np.median([sigma_min(chain, q) for q in uniform]) > 10 * bound


def test_reach_boundary_targets_are_as_far_as_the_tip_goes(ur5):
    drawing = _draw("reach_boundary", ur5, 10)
    samples = ur5.random(np.random.default_rng(3), 3000)
    positions = np.array([ur5.fk(q).translation for q in samples])
    beaten = 0
    for q, direction, support in zip(drawing.q_true, drawing.extras["direction"], drawing.extras["support"],
                                     strict=True):
        assert stationarity_residual(ur5, direction, q) < 1e-6  # a critical point of d . p on the box
        assert reach_along(ur5, direction, q)[0] == pytest.approx(support)
        beaten += bool(np.max(positions @ direction) > support + 1e-9)
    assert beaten <= 1  # no random configuration gets farther along d (a local maximum may be beaten)


def test_target_i_does_not_depend_on_how_many_are_drawn(ur5):
    for name in ("near_limits", "near_singularities", "unreachable"):
        few, more = _draw(name, ur5, 3), _draw(name, ur5, 6)
        assert np.array_equal(few.q_true[:3], more.q_true[:3], equal_nan=True), name


CASE = {"robot": "ur5", "chain": "arm"}


def _study(case: dict, **study) -> object:
    return study_from_dict({"name": "s", "poses": 4, "methods": ["bounded_lm"], "cases": [case], **study},
                           source="t.yaml")


def test_a_case_names_its_target_set_with_parameters():
    study = _study({**CASE, "targets": {"set": "near_singularities", "sigma_max": "1e-3"}})
    case = study.cases[0]
    assert (case.target, case.name) == ("near_singularities", "ur5_arm_near_singularities")
    assert case.targets["sigma_max"] == 1e-3 and case.targets["restarts"] == 8  # defaults filled in
    assert _study({**CASE, "targets": "near_limits"}).cases[0].targets["fraction"] == 0.02
    assert _study({**CASE, "target": "near_limits"}).cases[0].targets == \
        _study({**CASE, "targets": "near_limits"}).cases[0].targets
    assert _study({**CASE, "target": "pose", "targets": "unreachable"}).cases[0].target == "unreachable"


@pytest.mark.parametrize(("targets", "extra", "words"), [
    ("near_limit", {}, "cases[0].targets must name a target set (uniform, near_limits, near_singularities, "
                       "reach_boundary, unreachable), got 'near_limit' (did you mean 'near_limits'?)"),
    ({"set": "near_limits", "fraction": 0.7}, {}, "cases[0].targets.fraction must be a number in (0, 0.5]"),
    ({"set": "near_limits", "fractoin": 0.1}, {}, "cases[0].targets has unknown field(s) ['fractoin'] "
                                                   "(did you mean 'fraction'?)"),
    ({"set": "unreachable", "reach_factor": [0.9, 1.2]}, {}, "cases[0].targets.reach_factor must be a pair"),
    ({"set": "unreachable", "restarts": 3}, {}, "cases[0].targets has unknown field(s) ['restarts']"),
    ({"fraction": 0.1}, {}, "cases[0].targets.set must name a target set"),
    ("near_limits", {"target": "position"},
     "cases[0].target: the target set 'near_limits' draws pose targets, got 'position'"),
    (["near_limits"], {}, "cases[0].targets must name a target set"),
])
def test_target_set_mistakes_name_the_key(targets, extra, words):
    with pytest.raises(StudyDefinitionError) as caught:
        _study({**CASE, "targets": targets, **extra})
    assert words in str(caught.value)


def test_files_that_name_no_set_keep_their_fingerprint():
    plain = _study(CASE)
    assert plain.cases[0].targets is None
    assert plain.fingerprint() == "d1d23f98810330f2"  # computed before target sets existed
    by_frames = _study({"robot": "example-robot-data:ur10", "base": "base_link", "tip": "tool0"})
    assert by_frames.fingerprint() == "b8245debd8bdc2a7"
    named = _study({**CASE, "targets": "uniform"})
    assert named.fingerprint() != plain.fingerprint()
    changed = _study({**CASE, "targets": {"set": "uniform", "restarts": 2}})
    assert changed.fingerprint() != named.fingerprint()


def test_every_reachable_set_runs_end_to_end_and_resumes(tmp_path):
    study = study_from_dict({
        "name": "sets", "seed": 5, "poses": 6, "chunk_size": 3, "timeout_s": 0.005,
        "cases": [{**CASE, "targets": {"set": name, "restarts": 2, "restart_targets": 2}}
                  for name in ("uniform", "near_limits", "near_singularities", "reach_boundary")]
        + [{**CASE, "name": "plain"}],
        "methods": ["analytic", "bounded_lm"]}, source="t.yaml")
    output = run_study(study, tmp_path / "out", jobs=1, progress=False, log=lambda message: None)
    uniform = output / "ur5_arm_uniform" / "poses.npz"
    with np.load(output / "plain" / "poses.npz") as plain, np.load(uniform) as same:
        assert np.array_equal(plain["q_true"], same["q_true"])  # uniform: today's targets
        assert np.array_equal(plain["q0"], same["q0"])
    extras, facts = read_drawing(output / "ur5_arm_near_singularities" / "poses.npz")
    assert extras["sigma_min"].shape == (6,)
    assert facts["parameters"]["sigma_max"] == 1e-3 and facts["seed"] == 5
    report = (output / "report.md").read_text()
    for name in ("uniform", "near_limits", "near_singularities", "reach_boundary"):
        assert f"## Case ur5_arm_{name}: ur5.arm, {name} targets" in report
        assert (output / f"ur5_arm_{name}" / "figures" / "start_distance.png").is_file()
        assert (output / f"ur5_arm_{name}" / "coverage.csv").is_file()
    assert report.count("### Solution coverage and distance from the start") == 4
    assert report.count("### How the targets were drawn") == 3  # uniform has nothing to add
    assert "largest violation median" in report and "bound 0.001" in report
    tasks, done, total = pending_tasks(study, output, log=lambda message: None)
    assert (tasks, done, total) == ([], 60, 60)  # resumes: every chunk is there
