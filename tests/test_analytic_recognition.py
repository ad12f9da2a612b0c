"""``analytic`` finds a chain's closed form from its structure: families of wbik on any URDF, EAIK's
decomposition where none matches, a held joint on 7-joint arms, a typed refusal where nothing applies.

Targets are FK poses (Pinocchio, the chain's reduced model) of random joints inside the limits; answers
are judged by FK again, never by the code under test. Robots come from example-robot-data's URDFs and
wbik's seed robots with their hand bindings removed (``dataclasses.replace(robot, closed_forms={})``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest
from closed_form_checks import fk_error
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.dh import DHJoint, DHTable
from wbik.errors import InvalidOptionError, InvalidSettingError, UnsupportedError
from wbik.kernels import eaik as eaik_kernel
from wbik.solvers.analytic import recognition, stacked_planar, ur_type, yaw_planar
from wbik.solvers.analytic import solver as analytic
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.structure import STRUCTURE_TOLERANCE, ChainLines, chain_lines

POSES = 50
FK_ERROR = 1e-9


def erd_urdf(relative: str) -> str:
    from example_robot_data.robots_loader import getModelPath

    return f"{getModelPath(relative)}/{relative}"


UR_URDFS = ("ur_description/urdf/ur5_robot.urdf", "ur_description/urdf/ur10_robot.urdf",
            "ur_description/urdf/ur3_robot.urdf", "ur_description/urdf/ur3_joint_limited_robot.urdf")
TALOS_ARM_URDF = "talos_data/robots/talos_left_arm.urdf"
_ROBOTS: dict[str, wbik.Robot] = {}


def robot(name: str) -> wbik.Robot:
    """Robots by name: "bare:<seed robot>" has no hand bindings; "erd:<path>" is an example-robot-data
    URDF; "talos7" is Talos' 7-joint left arm (torso_2_link -> gripper base)."""
    if name not in _ROBOTS:
        if name.startswith("bare:"):
            _ROBOTS[name] = dataclasses.replace(wbik.load(name[5:]), closed_forms={})
        elif name.startswith("erd:"):
            _ROBOTS[name] = wbik.load(erd_urdf(name[4:]))
        elif name == "ur10-rep103":  # ROS-Industrial's REP-103 frames: base (base_link turned by pi) -> tool0
            joints = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                      "wrist_2_joint", "wrist_3_joint")
            spec = wbik.ChainSpec("rep103", "base", "tool0", joints)
            _ROBOTS[name] = wbik.load(erd_urdf(UR_URDFS[1]), chains=[spec])
        elif name == "talos7":
            joints = tuple(f"arm_left_{i}_joint" for i in range(1, 8))
            spec = wbik.ChainSpec("left_arm", "torso_2_link", "gripper_left_base_link", joints)
            _ROBOTS[name] = wbik.load("erd:talos", chains=[spec])
        else:
            _ROBOTS[name] = wbik.load(name)
    return _ROBOTS[name]



def angle_gap(a, b) -> float:
    return float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))))


def round_trip(solver, kind: str, seed: int = 2025, from_original: bool = False,
               every_branch: bool = True) -> tuple[int, int]:
    """(solved within FK_ERROR, solve_all holding the original joints mod 2 pi) over POSES targets of
    random joints inside the limits, from the nominal start or (``from_original``) the joints themselves;
    solve_all only where ``every_branch``."""
    chain = solver.chain
    solved = contained = 0
    for q in chain.random(np.random.default_rng(seed), POSES):
        pose = chain.fk(q)
        target = pose if kind == "pose" else pose.translation.copy()
        result = solver.solve(target, q0=q if from_original else None)
        if result.success and chain.in_limits(result.q) and fk_error(chain, result.q, target) < FK_ERROR:
            solved += 1
        if every_branch:
            contained += any(angle_gap(branch.q, q) < 1e-7 for branch in solver.solve_all(target))
    return solved, contained


# --- the families' DH rows ---------------------------------------------------------------------------
def _dh(canonical, a, d):
    rows = zip(canonical.alphas, a, d, canonical.offsets, strict=True)
    table = DHTable([DHJoint(a=a_i, alpha=alpha, d=d_i, theta=theta) for alpha, a_i, d_i, theta in rows],
                    base=canonical.base, tool=canonical.tool)
    model = table.model()
    data, tool = model.createData(), model.getFrameId("tool")

    def transform(q):
        pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
        return data.oMf[tool].homogeneous

    return transform


@pytest.mark.parametrize("seed", range(3))
def test_canonical_rows_are_each_familys_fk(seed):
    """Each family module's CANONICAL writes its FK as DH rows; the model wbik.dh builds of them agrees."""
    rng = np.random.default_rng(seed)
    lengths = rng.uniform(0.05, 0.6, 8) * rng.choice([-1.0, 1.0], 8)
    d1, a2, a3, d4, d5, d6, _, _ = lengths
    cases = [
        (ur_type.CANONICAL, (0, a2, a3, 0, 0, 0), (d1, 0, 0, d4, d5, d6),
         lambda q: ur_type.fk(ur_type.URGeometry(d1, a2, a3, d4, d5, d6), q)),
        (yaw_planar.CANONICAL_PITCH, (0, a2, a3, d5), (d1, 0, 0, 0),
         lambda q: yaw_planar.pitch_arm_fk(yaw_planar.PitchArmGeometry(d1, a2, a3, d5), q)),
        (yaw_planar.CANONICAL_2R, (0, a2, a3), (d1, 0, 0),
         lambda q: yaw_planar.Yaw2RPosition.fk(
             type("Form", (), {"geometry": yaw_planar.Yaw2RGeometry(d1, a2, a3)})(), q)),
        (stacked_planar.CANONICAL, (a2, a3, 0, d4, d5, 0), (d1, 0, 0, 0, 0, d6),
         lambda q: stacked_planar.fk(stacked_planar.StackedPlanarGeometry(a2, a3, d4, d5, d6, d1, 0.0), q)),
    ]
    for canonical, a, d, family_fk in cases:
        transform = _dh(canonical, a, d)
        for q in rng.uniform(-3.0, 3.0, (5, len(a))):
            position, rotation = family_fk(q)
            expected = transform(q)
            np.testing.assert_allclose(position, expected[:3, 3], atol=1e-12)
            np.testing.assert_allclose(rotation, expected[:3, :3], atol=1e-12)


# --- families on URDFs they were not bound to --------------------------------------------------------
@pytest.mark.parametrize("path", UR_URDFS)
def test_ur_urdfs_are_recognised_and_solved(path):
    solver = wbik.solver("analytic", robot(f"erd:{path}"))
    assert solver.family == "ur_type"
    assert "position" not in solver.families  # the family takes full poses only
    solved, contained = round_trip(solver, "pose")
    assert solved == POSES and contained == POSES
    with pytest.raises(UnsupportedError, match="ur_type: the family solves full poses only"):
        solver.solve(np.array([0.3, 0.2, 0.3]))


def test_ur10_in_other_frames_and_joint_zeros():
    """The UR10 between REP-103's frames (base, turned by pi about z from base_link, to tool0): the same
    family through a joint offset of pi on the first joint and a tool transform, every pose solved."""
    solver = wbik.solver("analytic", robot("ur10-rep103"))
    assert solver.family == "ur_type"
    form = solver.closed_form("pose")
    assert abs(form.offsets[0]) == pytest.approx(math.pi)
    solved, contained = round_trip(solver, "pose")
    assert solved == POSES and contained == POSES


@pytest.mark.usefixtures("compiled_twins")
def test_ur10_urdf_keeps_the_compiled_kernel_where_built():
    """A UR URDF's frames are the family's (up to the URDF's rounding of pi/2): no base or joint change;
    the compiled kernel (where built) serves it as it serves the bound UR5, and the UR10 between other
    frames and joint zeros (REP-103) too."""
    from wbik.kernels.twins import compiled_twin

    built = compiled_twin("ur_type", "nearest") is not None
    form = wbik.solver("analytic", robot(f"erd:{UR_URDFS[1]}")).closed_form("pose")
    assert (form.kernel is not None) == built
    assert form.base is None and form.alignment.signs is None
    assert (wbik.solver("analytic", robot("ur10-rep103")).closed_form("pose").kernel is not None) == built
    np.testing.assert_array_equal(form.signs, np.ones(6))
    np.testing.assert_array_equal(form.offsets, np.zeros(6))
    geometry = form.inner.geometry  # ur_description's UR10 numbers, read back from the URDF's structure
    np.testing.assert_allclose([geometry.d1, geometry.a2, geometry.a3, geometry.d4, geometry.d5],
                               [0.1273, -0.612, -0.5723, 0.163941, 0.1157], atol=1e-9)


BOUND = [("ur5", "ee", "pose"), ("ur5", "arm", "pose"), ("pincher", "arm", "pose"),
         ("pincher", "arm", "position"), ("arm3r", "arm", "position"), ("golem3", "right_arm", "pose"),
         ("golem3", "right_arm", "position"), ("golem3", "left_arm", "pose"),
         ("golem3", "left_arm", "position")]
FAMILY_MODULES = {"ur_type": ur_type, "yaw_planar": yaw_planar, "stacked_planar": stacked_planar}


def bound_family(form) -> str:
    """The family a hand binding uses: the family module its class (or the class of the form it sees
    through its frames) derives from."""
    form = getattr(form, "inner", form)
    for name, module in FAMILY_MODULES.items():
        if any(cls.__module__ == module.__name__ for cls in type(form).__mro__):
            return name
    raise AssertionError(f"{type(form).__name__} uses no family of wbik")


@pytest.mark.parametrize(("name", "chain", "kind"), BOUND, ids=[f"{r}.{c}-{k}" for r, c, k in BOUND])
def test_seed_chains_without_bindings_are_recognised_as_their_bound_family(name, chain, kind):
    bound = wbik.solver("analytic", robot(name), chain)
    assert bound.families[kind].startswith("bound:")
    recognised = wbik.solver("analytic", robot(f"bare:{name}"), chain)
    assert recognised.families[kind] == bound_family(bound.closed_form(kind))
    solved, contained = round_trip(recognised, kind)
    assert solved == POSES
    if kind == "pose" or name == "arm3r":  # position forms of 4R and 6R arms pick one pitch / one roll
        assert contained == POSES


@pytest.mark.parametrize("chain", ["right_arm", "left_arm"])
def test_recognised_stacked_planar_positions_hold_the_roll_given(chain):
    """Position targets leave the roll free: the recognised form holds it at ``yaw`` in the chain's own
    joint (the left arm's roll turns the other way in the family's joints), as the bound form does."""
    options = {"position": {"yaw": 0.3}}
    solver = wbik.solver("analytic", robot("bare:golem3"), chain, closed_form_options=options)
    chain_ = solver.chain
    for q in chain_.random(np.random.default_rng(8), 20):
        target = chain_.fk(q).translation.copy()
        result = solver.solve(target)
        assert result.success and fk_error(chain_, result.q, target) < FK_ERROR
        assert result.q[5] == pytest.approx(0.3, abs=1e-12)
    with pytest.raises(InvalidOptionError, match="must be inside"):
        wbik.solver("analytic", robot("bare:golem3"), chain, closed_form_options={"position": {"yaw": 3.0}})
    with pytest.raises(InvalidOptionError, match="takes the option 'yaw'"):
        wbik.solver("analytic", robot("bare:golem3"), chain, closed_form_options={"position": {"roll": 0.3}})


@pytest.mark.parametrize("chain", ["ee", "arm"])
def test_recognised_ur5_gives_the_bound_forms_answers(chain):
    """The same branches and the same choice: joints within 1e-9 rad on ee_link (the family's frame),
    within 1e-7 on the tool frame, whose recognised form places the flange elsewhere along axis 6 (the
    two agree to rounding, amplified only at a stretched elbow or a wrist near its singularity)."""
    bound = wbik.solver("analytic", robot("ur5"), chain)
    recognised = wbik.solver("analytic", robot("bare:ur5"), chain)
    assert recognised.family == "ur_type"
    rng = np.random.default_rng(11)
    worst = 0.0
    tolerance = 1e-9 if chain == "ee" else 1e-7
    for q in bound.chain.random(rng, 300):
        pose, start = bound.chain.fk(q), bound.chain.random(rng)
        first, second = bound.solve(pose, start), recognised.solve(pose, start)
        assert first.success and second.success
        worst = max(worst, float(np.abs(first.q - second.q).max()))
        assert len(bound.solve_all(pose)) == len(recognised.solve_all(pose))
    assert worst <= tolerance


def test_a_wrong_recognition_is_refused_never_used(monkeypatch):
    """A family that matches the structure but builds a form off the model (1 um on the UR5's d4) is
    refused by the model agreement check; the chain falls back to EAIK's decomposition."""
    def shifted(lines, kind, options):
        match = ur_type.match(lines, kind, options)
        build = match.build

        def wrong(chain):
            form = build(chain)
            return ur_type.URArm(chain, dataclasses.replace(form.geometry, d4=form.geometry.d4 + 1e-6))

        return dataclasses.replace(match, build=wrong)

    families = tuple(recognition.Family("ur_type", shifted) if family is ur_type.UR_TYPE else family
                     for family in analytic.FAMILIES)
    monkeypatch.setattr(analytic, "FAMILIES", families)
    chain = robot("bare:ur5").chain("ee")
    with pytest.raises(UnsupportedError, match="ur_type: the structure matches but the form is refused"):
        recognition.recognise_family(chain, "pose", None, families)
    solver = wbik.solver("analytic", robot("bare:ur5"), "ee")
    assert solver.family == "eaik:6R-THREE_INNER_PARALLEL"
    assert round_trip(solver, "pose")[0] == POSES


# --- a new family: one module and one registration line -------------------------------------------------
class PlanarTwoLink(ClosedForm):
    """A small family written here: two parallel revolute axes, the tip in their plane (DH a = (l1, l2),
    alpha = 0), positions in the plane, both elbows."""

    target_kind = "position"

    def __init__(self, chain, lengths: tuple[float, float]):
        super().__init__(chain)
        self.lengths = lengths

    def branches(self, positions, rotations, q0):
        from wbik.solvers.analytic.subproblems import planar_2r

        first, second, real = planar_2r(positions[:, 0], positions[:, 1], *self.lengths)
        in_plane = np.abs(positions[:, 2]) <= 1e-9
        return np.stack((first, second), axis=-1), real[:, None] & in_plane[:, None] & np.ones(2, dtype=bool)

    def fk(self, q):
        l1, l2 = self.lengths
        x = l1 * np.cos(q[..., 0]) + l2 * np.cos(q[..., 0] + q[..., 1])
        y = l1 * np.sin(q[..., 0]) + l2 * np.sin(q[..., 0] + q[..., 1])
        position = np.stack((x, y, np.zeros_like(x)), axis=-1)
        return position, np.broadcast_to(np.eye(3), position.shape[:-1] + (3, 3))


def match_planar_two_link(lines, kind, options):
    recognition.require(kind == "position", "the family solves positions only")
    recognition.require_revolute(lines, 2)
    canonical = recognition.Canonical((0.0, 0.0), (0.0, 0.0), np.eye(4), np.eye(4))
    first, sign = recognition.first_frame(lines, np.eye(3))
    result = recognition.walk(lines, first, sign, canonical.alphas[:1], (1.0,))
    along, reach = recognition.tip_offset(lines, result.frames[-1])
    recognition.require(recognition.small(along, lines), "the tip is off the plane")
    recognition.close_walk(result, 0.0, 0.0, float(np.linalg.norm(reach)), 0.0)
    lengths = (result.a[0], result.a[1])
    return recognition.Match("planar_two_link", lambda chain: PlanarTwoLink(chain, lengths),
                             *recognition.aligned(canonical, lines, result), f"lengths {lengths}")


def test_a_family_registered_by_one_line_is_recognised(monkeypatch):
    """A two-link planar arm has no closed form of positions; registering the family above (its matcher
    and its form, one entry in FAMILIES) gives it one, found from the URDF's structure, solving by FK."""
    from wbik.robot import robot_from_urdf_text

    table = DHTable([DHJoint(a=0.5, alpha=0.0, d=0.0, name="shoulder"),
                     DHJoint(a=0.3, alpha=0.0, d=0.0, name="elbow")])
    arm = robot_from_urdf_text("planar", table.urdf(name="planar", base_link="base", tip_link="tip"),
                               [wbik.ChainSpec("arm", "base", "tip", ("shoulder", "elbow"))], np.zeros(2))
    assert "position" not in wbik.solver("analytic", arm, "arm").families  # EAIK's 2R takes poses only
    monkeypatch.setattr(analytic, "FAMILIES",
                        (*analytic.FAMILIES, recognition.Family("planar_two_link", match_planar_two_link)))
    solver = wbik.solver("analytic", arm, "arm")
    assert solver.families["position"] == "planar_two_link"
    chain = solver.chain
    for q in chain.random(np.random.default_rng(12), 20):
        target = chain.fk(q).translation.copy()
        result = solver.solve(target)
        assert result.success and fk_error(chain, result.q, target) < FK_ERROR
        assert any(angle_gap(branch.q, q) < 1e-9 for branch in solver.solve_all(target))


# --- EAIK where no family matches ----------------------------------------------------------------------
@pytest.mark.parametrize(("name", "chain", "family"), [
    ("bare:bioloid", "right_leg", "eaik:6R-THREE_INNER_PARALLEL"),
    ("bare:bioloid", "left_leg", "eaik:6R-THREE_INNER_PARALLEL"),
    ("arm3r", "arm", "eaik:3R"),
])
def test_eaik_decomposition_where_no_family_matches(name, chain, family):
    solver = wbik.solver("analytic", robot(name), chain)
    assert solver.families["pose"] == family
    solved, contained = round_trip(solver, "pose")
    assert solved == POSES and contained == POSES


def test_talos_arm_urdf_six_joints_by_eaik():
    arm = wbik.ChainSpec("arm", "arm_left_1_link", "arm_left_7_link",
                         tuple(f"arm_left_{i}_joint" for i in range(2, 8)))
    solver = wbik.solver("analytic", wbik.load(erd_urdf(TALOS_ARM_URDF), chains=[arm]))
    assert solver.family.startswith("eaik:6R-SPHERICAL")
    solved, contained = round_trip(solver, "pose")
    assert solved == POSES and contained == POSES


def test_kinova_with_continuous_joints_by_eaik():
    """The Kinova Jaco2 6-DOF of example-robot-data: three continuous joints (range [-pi, pi]) and two
    whose range is not centred on zero; answers inside the limits, every branch found."""
    joints = tuple(f"j2s6s200_joint_{i}" for i in range(1, 7))
    spec = wbik.ChainSpec("arm", "base", "j2s6s200_end_effector", joints)
    solver = wbik.solver("analytic", wbik.load("erd:kinova", chains=[spec]))
    assert solver.family.startswith("eaik:6R")
    solved, contained = round_trip(solver, "pose")
    assert solved == POSES and contained == POSES


# --- 7-joint arms: one joint held ----------------------------------------------------------------------
SEVEN = [("panda", "arm", "panda_joint7"), ("talos7", "left_arm", "arm_left_1_joint"),
         (f"erd:{TALOS_ARM_URDF}", None, "gripper_left_joint"), ("bare:golem3", "right_arm_lift", "mb")]


@pytest.mark.parametrize(("name", "chain", "held"), SEVEN, ids=[s[0] for s in SEVEN])
def test_seven_joint_arms_hold_a_joint_at_the_start(name, chain, held):
    """Holding q0's value of the default joint: from the original joints every pose is solved and the
    original joints come back (the branch at distance 0)."""
    solver = wbik.solver("analytic", robot(name), chain)
    assert solver.family.endswith(f"with {held} held (search)")
    solved, _ = round_trip(solver, "pose", from_original=True, every_branch=False)
    assert solved == POSES
    chain_ = solver.chain
    for q in chain_.random(np.random.default_rng(3), 10):
        result = solver.solve(chain_.fk(q), q0=q)
        assert angle_gap(result.q, q) < 1e-7


@pytest.mark.parametrize(("name", "chain"), [("panda", "arm"), ("talos7", "left_arm")])
def test_seven_joint_arms_sweep_the_held_joint_from_far_starts(name, chain):
    """From the nominal start a held value rarely suits a random pose; the grid over the joint's range
    finds a branch for most (measured: Panda 49/50, Talos 47/50) where the start's value alone does not
    (Panda 18/50, Talos 11/50)."""
    seed_only = wbik.solver("analytic", robot(name), chain, redundancy="seed")
    grid = wbik.solver("analytic", robot(name), chain, redundancy="grid", grid_size=16)
    assert grid.family.endswith("held (grid)")
    from_seed, _ = round_trip(seed_only, "pose", seed=7, every_branch=False)
    from_grid, _ = round_trip(grid, "pose", seed=7, every_branch=False)
    assert from_grid >= 0.9 * POSES and from_grid > from_seed


SEARCHED = [("erd:panda", "panda_link0", "panda_link8"),
            ("erd:talos", "torso_2_link", "gripper_left_base_link"), ("erd:icub", "chest", "l_hand"),
            ("erd:tiago_dual", "torso_lift_link", "arm_left_tool_link"),
            ("erd:pr2", "torso_lift_link", "l_gripper_palm_link")]


@pytest.mark.parametrize(("name", "base", "tip"), SEARCHED, ids=[s[0][4:] for s in SEARCHED])
def test_seven_joint_arms_search_the_held_joint_by_default(name, base, tip):
    """Default options on a chain named by base and tip, from the nominal start: the held joint searched
    solves at least 99 of 100 random poses (joints inside the limits), and its answer is never farther from
    the start than the branch holding the start's value (the search evaluates that value first)."""
    arm = wbik.load(name)
    searched = wbik.solver("analytic", arm, base=base, tip=tip)
    seed_only = wbik.solver("analytic", arm, base=base, tip=tip, redundancy="seed")
    assert searched.family.endswith("held (search)")
    chain = searched.chain
    solved = 0
    for q in chain.random(np.random.default_rng(11), 100):
        target = chain.fk(q)
        result = searched.solve(target)
        if result.success and chain.in_limits(result.q) and fk_error(chain, result.q, target) < FK_ERROR:
            solved += 1
        held = seed_only.solve(target)
        if held.success:
            assert result.success
            nominal = chain.nominal
            assert np.linalg.norm(result.q - nominal) <= np.linalg.norm(held.q - nominal) + 1e-9
    assert solved >= 99
    branches = searched.solve_all(chain.fk(chain.random(np.random.default_rng(12))))
    assert branches and all(branch.success for branch in branches)
    for i, one in enumerate(branches):
        assert all(angle_gap(one.q, other.q) >= 1e-6 for other in branches[:i])


def test_a_middle_joint_held_is_rebuilt_per_value():
    """The Panda's joint 5 held (EAIK's 6R-SPHERICAL_SECOND_TWO_PARALLEL per value): from the original
    joints every pose is solved, and the same value again reuses the built form."""
    solver = wbik.solver("analytic", robot("panda"), "arm", redundant_joint="panda_joint5", redundancy="seed")
    assert solver.family == "eaik:6R-SPHERICAL_SECOND_TWO_PARALLEL with panda_joint5 held (seed)"
    solved, _ = round_trip(solver, "pose", from_original=True, every_branch=False)
    assert solved == POSES


def _twin_case(name, chain, kernel):
    return pytest.param(name, chain, id=name, marks=pytest.mark.skipif(
        kernel is None, reason="the C extension is not built here: test_compiled checks that it is"))


@pytest.mark.parametrize(("name", "chain"), [
    _twin_case("bare:bioloid", "right_leg", eaik_kernel.choose_compiled),
    _twin_case("erd:" + TALOS_ARM_URDF, None, eaik_kernel.choose_compiled),
    _twin_case("panda", "arm", eaik_kernel.choose_compiled),
    _twin_case("bare:golem3", "right_arm_lift", stacked_planar._stacked_kernel)])
def test_compiled_choice_of_one_target_is_the_vectorised_one(compiled_twins, name, chain):
    """EAIK's family (the eaik method's compiled choice among EAIK's branches) and a held first or last
    joint (the 6-joint form's kernel on the moved target) solve one target through a kernel where built:
    the status and the branch of the vectorised choice, from the original joints and from random starts."""
    from compiled_twins import TWIN_TOLERANCE, assert_twins_agree

    solver = wbik.solver("analytic", robot(name), chain, redundancy="seed")  # a held joint's kernel
    assert solver.closed_form("pose").kernel is not None
    chain_ = solver.chain
    rng = np.random.default_rng(9)
    joints = chain_.random(rng, 100)
    starts = np.concatenate((joints[:50], chain_.random(rng, 50)))
    for q, q0 in zip(joints, starts, strict=True):
        assert_twins_agree(solver, wbik.targets.as_target(chain_.fk(q)), q0, False, TWIN_TOLERANCE)


def test_redundancy_options_are_checked():
    panda = robot("panda")
    for options, word in (({"redundancy": "sweep"}, "redundancy must be one of"),
                          ({"redundant_joint": "panda_joint9"}, "is not a joint"),
                          ({"redundant_joint": 7}, "index one"),
                          ({"grid_size": 0}, "grid_size")):
        with pytest.raises(InvalidSettingError, match=word):
            wbik.solver("analytic", panda, "arm", **options)
    held = wbik.solver("analytic", panda, "arm", redundant_joint=-1)
    assert held.family.endswith("panda_joint7 held (search)")
    middle = wbik.solver("analytic", panda, "arm", redundant_joint="panda_joint5")
    assert middle.family.endswith("panda_joint5 held (grid)")  # a middle joint: a form per value


BATCHED = [(f"erd:{UR_URDFS[1]}", None, "pose", {}), ("bare:pincher", "arm", "position", {}),
           ("bare:golem3", "left_arm", "pose", {}), ("bare:bioloid", "right_leg", "pose", {}),
           ("panda", "arm", "pose", {"redundancy": "grid", "grid_size": 8}), ("panda", "arm", "pose", {}),
           ("panda", "arm", "pose", {"redundant_joint": 4}), ("bare:golem3", "right_arm_lift", "pose", {})]


@pytest.mark.parametrize(("name", "chain", "kind", "options"), BATCHED,
                         ids=[f"{b[0]}-{b[2]}-{len(b[3])}" for b in BATCHED])
def test_solve_many_answers_as_solve(name, chain, kind, options):
    """The batched path (the forms' vectorised branches and FK, the batched check) and the per-call path
    pick the same branches; the answers reach their targets (FK)."""
    solver = wbik.solver("analytic", robot(name), chain, **options)
    chain_ = solver.chain
    joints = chain_.random(np.random.default_rng(4), 30)
    starts = chain_.random(np.random.default_rng(5), 30)
    targets = [chain_.fk(q) if kind == "pose" else chain_.fk(q).translation.copy() for q in joints]
    batched = solver.solve_many(targets, starts)
    assert any(result.success for result in batched)
    for many, target, start in zip(batched, targets, starts, strict=True):
        one = solver.solve(target, start)
        assert many.success == one.success
        if one.success:
            np.testing.assert_allclose(many.q, one.q, atol=1e-12)
            assert fk_error(chain_, many.q, target) < FK_ERROR


# --- no closed form: a typed error when the solver is built ---------------------------------------------
def test_a_chain_without_a_closed_form_is_refused_when_the_solver_is_built():
    golem = robot("golem3")
    head = wbik.ChainSpec("head_lift", "base_link", "head_link", ("mb", "m1", "m2"))
    lifted = wbik.load(str(golem.urdf_path), chains=[head], nominal=golem.nominal)
    with pytest.raises(UnsupportedError) as info:
        wbik.solver("analytic", lifted, "head_lift")
    message = str(info.value)
    for word in ("golem3.head_lift", "ur_type", "yaw_planar: it has a prismatic joint", "stacked_planar",
                 "EAIK takes revolute joints only", "for full poses", "for positions", "'dls'"):
        assert word in message, word


def test_more_than_one_redundant_joint_is_refused():
    joints = ("torso_1_joint", "torso_2_joint", *(f"arm_left_{i}_joint" for i in range(1, 8)))
    spec = wbik.ChainSpec("torso_arm", "base_link", "gripper_left_base_link", joints)
    with pytest.raises(UnsupportedError, match=r"9 joints.*holding one joint: for 7-joint chains"):
        wbik.solver("analytic", wbik.load("erd:talos", chains=[spec]), "torso_arm")


# --- the decision is robust to noise far below the tolerance ----------------------------------------------
DECIDED = [("bare:ur5", "ee"), ("bare:pincher", "arm"), ("bare:arm3r", "arm"), ("bare:golem3", "right_arm"),
           ("bare:golem3", "left_arm"), ("bare:bioloid", "right_leg"), (f"erd:{UR_URDFS[1]}", None),
           ("ur10-rep103", None), ("panda", "arm")]


def decisions(lines: ChainLines) -> tuple[bool, ...]:
    """Per family and target kind, whether the family matches the lines."""
    verdicts = []
    for family in analytic.FAMILIES:
        for kind in ("pose", "position"):
            try:
                family.match(lines, kind, {})
                verdicts.append(True)
            except recognition.Mismatch:
                verdicts.append(False)
    return tuple(verdicts)


def perturbed(lines: ChainLines, amplitude: float, rng: np.random.Generator) -> ChainLines:
    """Axes tilted, points moved by ``amplitude`` (relative to the chain's length), the tip too."""
    axes = lines.axes + amplitude * rng.standard_normal(lines.axes.shape)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    scale = amplitude * lines.length
    tip = lines.tip.copy()
    tip[:3, :3] = tip[:3, :3] @ pin.exp3(amplitude * rng.standard_normal(3))
    tip[:3, 3] += scale * rng.standard_normal(3)
    return ChainLines(axes, lines.origins + scale * rng.standard_normal(lines.origins.shape), tip,
                      lines.prismatic)


@settings(max_examples=40, deadline=None)
@given(case=st.sampled_from(DECIDED), seed=st.integers(0, 2**32 - 1),
       amplitude=st.floats(0.0, 1e-3 * STRUCTURE_TOLERANCE))
def test_recognition_does_not_flip_under_noise_far_below_the_tolerance(case, seed, amplitude):
    name, chain = case
    lines = chain_lines(robot(name).chain(chain))
    assert decisions(perturbed(lines, amplitude, np.random.default_rng(seed))) == decisions(lines)


@pytest.mark.parametrize(("name", "chain", "family"),
                         [("bare:ur5", "ee", 0), ("bare:golem3", "right_arm", 4)])
def test_noise_far_above_the_tolerance_breaks_the_match(name, chain, family):
    """The same perturbation 1000 times the tolerance: the family no longer matches (so the test above
    could fail, and the tolerance is not loose)."""
    lines = chain_lines(robot(name).chain(chain))
    assert decisions(lines)[family]
    assert not decisions(perturbed(lines, 1e3 * STRUCTURE_TOLERANCE, np.random.default_rng(1)))[family]


# --- the command line says which family solved --------------------------------------------------------
def test_cli_solve_names_the_family(capsys):
    import json

    from wbik.cli import main

    path = erd_urdf(UR_URDFS[1])
    chain = robot(f"erd:{UR_URDFS[1]}").chain()
    pose = chain.fk(np.array([0.3, -1.2, 1.4, -0.5, 1.1, 0.2]))
    rpy = pin.rpy.matrixToRpy(pose.rotation)
    arguments = ["solve", path, "--method", "analytic", "--xyz", *map(str, pose.translation),
                 "--rpy", *map(str, rpy)]
    assert main(arguments) == 0
    assert "(closed form: ur_type): solved" in capsys.readouterr().out
    assert main([*arguments, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["family"] == "ur_type"
    assert math.isfinite(rpy[0])


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), noise=st.floats(-1e-12, 1e-12))
def test_the_held_joint_search_does_not_hinge_on_the_last_bits_of_the_target(seed, noise):
    """A pose and the same pose moved by a relative 1e-12 (position and a rotation of that angle): the same
    verdict, and answers a continuous function of the target away from the grid's decisions (within 1e-6)."""
    solver = wbik.solver("analytic", robot("panda"), "arm")
    chain = solver.chain
    pose = chain.fk(chain.random(np.random.default_rng(seed)))
    moved = pin.SE3(pose.rotation @ pin.exp3(np.full(3, noise)), pose.translation * (1.0 + noise))
    first, second = solver.solve(pose), solver.solve(moved)
    assert first.success == second.success
    if first.success:
        assert angle_gap(first.q, second.q) < 1e-6
