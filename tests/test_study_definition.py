"""Study files: parsing (YAML and TOML), validation errors that name the field, overrides."""

from __future__ import annotations

import pytest

from wbik.study.definition import COMPARISONS_DIR, StudyDefinitionError, load_study, study_from_dict

MINIMAL = {"name": "tiny", "robot": "arm3r", "chain": "arm", "target": "position", "poses": 10,
           "methods": ["dls", {"label": "dls_short", "method": "dls", "timeout_s": 0.5,
                               "options": {"max_iterations": 5}}]}


def test_minimal_study_defaults_and_single_case():
    study = study_from_dict(MINIMAL)
    assert [case.name for case in study.cases] == ["arm3r_arm_position"]
    assert study.baseline == "dls"
    assert study.timeout_of(study.method("dls")) == 0.005
    assert study.timeout_of(study.method("dls_short")) == 0.5
    assert study.tolerances == {"position": 1e-6, "rotation": 1e-6}
    assert not study.method("dls").per_pose


def test_yaml_and_toml_files_give_the_same_study(tmp_path):
    (tmp_path / "s.yaml").write_text(
        "name: tiny\nrobot: arm3r\nchain: arm\ntarget: position\nposes: 10\n"
        "tolerances: {position: 1e-6, rotation: 2e-6}\nmethods: [dls]\n")
    (tmp_path / "s.toml").write_text(
        'name = "tiny"\nrobot = "arm3r"\nchain = "arm"\ntarget = "position"\nposes = 10\n'
        'methods = ["dls"]\n[tolerances]\nposition = 1e-6\nrotation = 2e-6\n')
    from_yaml, from_toml = load_study(tmp_path / "s.yaml"), load_study(tmp_path / "s.toml")
    assert from_yaml.tolerances == {"position": 1e-6, "rotation": 2e-6}  # '1e-6' is a string in YAML 1.1
    assert from_yaml.fingerprint() == from_toml.fingerprint()


@pytest.mark.parametrize("change, words", [
    ({"poses": 0}, "poses must be a positive integer"),
    ({"target": "orientation"}, "target must be 'pose', 'position' or 'wholebody'"),
    ({"methods": ["no_such_method"]}, "unknown method 'no_such_method'"),
    ({"methods": ["dls", "dls"]}, "labels must be unique"),
    ({"baseline": "kdl"}, "baseline 'kdl' is not one of the method labels"),
    ({"colour": "red"}, "unknown field(s) ['colour']"),
    ({"start": "home"}, "start must be one of"),
    ({"methods": [{"method": "dls", "options": {"timeout_s": 1}}]}, "options.timeout_s is set by the study"),
    ({"name": "a b"}, "name must be a name of letters"),
    ({"methods": [{"method": "dls", "per_pose": "yes"}]}, "per_pose must be true or false"),
    ({"thesis": {"significance": {"dls": {"x": "zero"}}}}, "significance maps method labels"),
    ({"thesis": {"reference": {"kdl": {"percent_solved": 72.5}}}}, "name method 'kdl'"),
    ({"thesis": {"reference": {"dls": {"speed": 1}}}}, "unknown metrics ['speed']"),
])
def test_mistakes_raise_clear_errors(change, words):
    with pytest.raises(StudyDefinitionError) as caught:
        study_from_dict({**MINIMAL, **change}, source="bad.yaml")
    assert words in str(caught.value)
    assert "bad.yaml" in str(caught.value)


def test_missing_file_lists_the_shipped_studies(tmp_path):
    with pytest.raises(StudyDefinitionError, match="golem3_thesis.yaml"):
        load_study(tmp_path / "nope.yaml")


def test_shipped_studies_are_valid_and_the_default_is_golem3():
    names = {path.stem: load_study(path) for path in COMPARISONS_DIR.glob("*.yaml")}
    assert {"default", "golem3_thesis", "golem3_position", "robots"} <= set(names)
    default = load_study()
    assert (default.cases[0].robot, default.cases[0].chain, default.poses) == ("golem3", "right_arm", 1000)
    thesis, position = names["golem3_thesis"], names["golem3_position"]
    assert thesis.poses == position.poses == 10000
    assert thesis.seed == position.seed  # the position study uses the same 10,000 positions
    assert {"analytic", "kdl", "kdl_restarts", "trac_ik", "newton", "dls", "qp", "placo",
            "bounded_lm"} <= {m.label for m in thesis.methods}
    robots = {(c.robot, c.chain) for c in names["robots"].cases}
    assert {("ur5", "arm"), ("pincher", "arm"), ("bioloid", "right_leg"), ("bioloid", "right_arm"),
            ("arm3r", "arm"), ("panda", "arm")} <= robots


def test_overrides_change_the_fingerprint_and_validate():
    study = study_from_dict(MINIMAL)
    smaller = study.with_overrides(poses=5, methods=["dls_short"])
    assert smaller.poses == 5 and [m.label for m in smaller.methods] == ["dls_short"]
    assert smaller.baseline == "dls_short"
    assert smaller.fingerprint() != study.fingerprint()
    moved = study.with_overrides(robot="ur5", chain="arm")
    assert moved.cases[0].name == "ur5_arm_position"
    with pytest.raises(StudyDefinitionError, match="--methods names"):
        study.with_overrides(methods=["kdl"])
