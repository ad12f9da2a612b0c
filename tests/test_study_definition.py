"""Study files: parsing (YAML and TOML), validation errors that name the field, overrides."""

from __future__ import annotations

import pytest

from wbik.study.definition import COMPARISONS_DIR, load_study, study_from_dict, with_overrides
from wbik.study.spec import StudyDefinitionError

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
    ({"target": "orientation"}, "target must be 'pose', 'position', 'wholebody', 'path' or 'protocol'"),
    ({"methods": ["no_such_method"]}, "unknown method 'no_such_method'"),
    ({"methods": ["dls", "dls"]}, "labels must be unique"),
    ({"baseline": "kdl"}, "baseline 'kdl' is not one of the method labels"),
    ({"colour": "red"}, "unknown field(s) ['colour']"),
    ({"start": "home"}, "start must be one of"),
    ({"methods": [{"method": "dls", "options": {"timeout_s": 1}}]}, "options.timeout_s is set by the study"),
    ({"name": "a b"}, "name must be a name of letters"),
    ({"methods": [{"method": "dls", "per_pose": True}]}, "unknown field(s) ['per_pose']"),
    ({"reference": {"significance": {"dls": {"x": "zero"}}}}, "significance.dls.x must be a number"),
    ({"reference": {"significance": {"dls": {"x": 1.5}}}}, "between 0 and 1"),
    ({"reference": {"significance": {"dls": {"yaw": 0.1}}}}, "significance.dls has unknown field(s) ['yaw']"),
    ({"reference": {"significance": ["dls"]}}, "significance must be a mapping of method labels"),
    ({"reference": {"figures": {"kdl": {"percent_solved": 72.5}}}}, "name method 'kdl'"),
    ({"reference": {"figures": {"dls": {"speed": 1}}}}, "figures.dls has unknown field(s) ['speed']"),
    ({"reference": {"figures": {"dls": {"percent_solve": 1}}}}, "(did you mean 'percent_solved'?)"),
    ({"reference": {"figure": {}}}, "unknown field(s) ['figure'] (did you mean 'figures'?)"),
    ({"reference": {"figures": {"dls_shrot": {"percent_solved": 1}}}}, "(did you mean 'dls_short'?)"),
    ({"reference": "the thesis"}, "reference must be a mapping"),
    ({"reference": {"name": 3}}, "reference.name must be text"),
    ({"reference": {"angles": {"sequence": "zyx", "names": {"x": "yaw"}}}}, "apply to pose targets only"),
    ({"refrence": {}}, "unknown field(s) ['refrence'] (did you mean 'reference'?)"),
    ({"thesis": {}, "angle_names": {}}, "unknown field(s) ['angle_names', 'thesis']"),
    ({"methods": ["bounded_ml"]}, "unknown method 'bounded_ml' (did you mean 'bounded_lm'?)"),
])
def test_mistakes_raise_clear_errors(change, words):
    with pytest.raises(StudyDefinitionError) as caught:
        study_from_dict({**MINIMAL, **change}, source="bad.yaml")
    assert words in str(caught.value)
    assert "bad.yaml" in str(caught.value)


POSE = {**MINIMAL, "robot": "ur5", "chain": "arm", "target": "pose"}


@pytest.mark.parametrize("angles, words", [
    ({"sequence": "zyz", "names": {"x": "a"}}, "sequence must be one of xyz, xzy, yxz, yzx, zxy, zyx"),
    ({"sequence": "xzy"}, "names must name at least one angle"),
    ({"sequence": "zyx", "names": {"w": "a"}}, "names has unknown field(s) ['w']"),
    ({"sequence": "zyx", "names": {"x": "alpha"}}, "'alpha' is already an error column"),
    ({"sequence": "zyx", "names": {"x": "yaw", "y": "yaw"}}, "'yaw' is already an error column"),
    ({"sequence": "zyx", "names": {"x": "a b"}}, "names.x must be a name"),
    ({"sequenc": "zyx", "names": {"x": "a"}}, "(did you mean 'sequence'?)"),
])
def test_reference_angles_are_checked(angles, words):
    with pytest.raises(StudyDefinitionError) as caught:
        study_from_dict({**POSE, "reference": {"angles": angles}}, source="bad.yaml")
    assert words in str(caught.value) and "bad.yaml" in str(caught.value)


def test_reference_block_is_read_into_typed_fields():
    study = study_from_dict({**POSE, "reference": {
        "name": "paper", "source": "Table 2", "significance_source": "Table 3",
        "angles": {"sequence": "xyz", "names": {"z": "psi", "x": "phi"}},
        "figures": {"dls": {"percent_solved": 90, "time_median_ms": "1e-3"}},
        "significance": {"dls_short": {"phi": 0.01, "time": 0}}}})
    reference = study.cases[0].reference
    assert (reference.name, reference.title, reference.source) == ("paper", "Paper", "Table 2")
    assert reference.angles.sequence == "xyz"
    assert reference.angles.names == (("x", "phi"), ("z", "psi"))  # x, y, z order whatever the file's
    assert reference.figures == {"dls": {"percent_solved": 90.0, "time_median_ms": 1e-3}}
    assert reference.significance == {"dls_short": {"phi": 0.01, "time": 0.0}}
    assert reference.labels == ["dls", "dls_short"]
    assert with_overrides(study, robot="panda").cases[0].reference is None  # another robot: no reference


def test_a_reference_in_a_multi_case_study_belongs_to_its_case():
    cases = {"methods": ["dls"], "cases": [{"robot": "ur5", "chain": "arm"}]}
    with pytest.raises(StudyDefinitionError, match="reference: belongs inside each case"):
        study_from_dict({**cases, "reference": {"name": "paper"}})
    inside = study_from_dict({"methods": ["dls"], "cases": [{"robot": "ur5", "chain": "arm",
                                                               "reference": {"name": "paper"}}]})
    assert inside.cases[0].reference.name == "paper"


def test_the_default_study_carries_its_reference_block():
    """The figures and the angle names come from comparisons/default.yaml: the thesis's 94 % / 72.5 %
    solved and 1.95 ms / 200 ms medians (golem3.md), its Table 5.1 p-values, its yaw/pitch/roll."""
    reference = load_study().cases[0].reference
    assert reference.name == "thesis"
    assert reference.figures["analytic"]["percent_solved"] == 94.0
    assert reference.figures["kdl"] == {"percent_solved": 72.5, "time_median_ms": 200.0}
    assert reference.figures["analytic"]["time_median_ms"] == 1.95
    assert reference.significance["kdl"]["thesis_roll"] == 6.0e-6
    assert reference.significance_source == "Table 5.1"
    assert reference.angles.sequence == "zyx"
    assert dict(reference.angles.names) == {"x": "thesis_yaw", "y": "thesis_pitch", "z": "thesis_roll"}


def test_fingerprints_of_the_shipped_studies_did_not_change_with_the_reference_block():
    """Results folders of the shipped studies still resume: their fingerprints are the ones computed
    by the code before the reference block (angle_names + thesis fields), commit 9cf44be."""
    expected = {"default": "bb3092c5f08d4759", "golem3_position": "357168c7ef854492",
                "golem3_thesis": "33715208d3503b8b", "robots": "30eecfe5aa1f0a9f",
                "wholebody": "892485349d4ab669"}
    for name, fingerprint in expected.items():
        assert load_study(COMPARISONS_DIR / f"{name}.yaml").fingerprint() == fingerprint, name


def test_the_angle_convention_is_part_of_the_fingerprint():
    names = {"x": "phi", "y": "theta", "z": "psi"}
    zyx = study_from_dict({**POSE, "reference": {"angles": {"sequence": "zyx", "names": names}}})
    xyz = study_from_dict({**POSE, "reference": {"angles": {"sequence": "xyz", "names": names}}})
    figures_only = study_from_dict({**POSE, "reference": {"figures": {"dls": {"percent_solved": 1}}}})
    assert len({zyx.fingerprint(), xyz.fingerprint(), study_from_dict(POSE).fingerprint()}) == 3
    assert figures_only.fingerprint() == study_from_dict(POSE).fingerprint()  # figures change no result


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
    smaller = with_overrides(study, poses=5, methods=["dls_short"])
    assert smaller.poses == 5 and [m.label for m in smaller.methods] == ["dls_short"]
    assert smaller.baseline == "dls_short"
    assert smaller.fingerprint() != study.fingerprint()
    moved = with_overrides(study, robot="ur5", chain="arm")
    assert moved.cases[0].name == "ur5_arm_position"
    with pytest.raises(StudyDefinitionError, match="--methods names"):
        with_overrides(study, methods=["kdl"])


def test_the_study_code_names_no_seed_robot_and_no_thesis():
    """The study is generic: robots, reference figures and angle names come from the study files."""
    import re
    from pathlib import Path

    import wbik.study

    pattern = re.compile(r"golem|bioloid|pincher|ur5|thesis", re.IGNORECASE)
    found = [f"{path.name}:{number}: {line.strip()}"
             for path in sorted(Path(wbik.study.__file__).parent.glob("*.py"))
             for number, line in enumerate(path.read_text().splitlines(), 1) if pattern.search(line)]
    assert not found, found
