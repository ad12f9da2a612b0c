"""Method ``mink`` (mink 1.3.0 on MuJoCo behind the one interface): MuJoCo's model of the same URDF has our
FK, mink solves most reachable poses within its default budget, the joints outside the chain stay where
they are, the chains it refuses, threads.

Expected poses come from Pinocchio FK of random joints inside the limits; answers are checked with an
independent FK on the robot's full model (not the chain's reduced model the shared check uses).
"""

from __future__ import annotations

import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import InvalidSettingError, UnsupportedError
from wbik.mujoco_model import mujoco_body, mujoco_urdf

POSES = 100
# (robot, chain) -> the least share of POSES random reachable poses mink solves from the nominal within its
# default budget (250 iterations). Measured on these poses (seed 2024): UR5 83, Panda 80, Kinova Jaco 80,
# UR10 84, Golem-III right arm 56. The rest end in local minima (a single start, as mink runs).
SOLVED = {("ur5", "arm"): 75, ("panda", "arm"): 72, ("kinova", "arm"): 72,
          ("example-robot-data:ur10", "default"): 75, ("golem3", "right_arm"): 48}

_ROBOTS: dict[str, wbik.Robot] = {}


def load(name: str) -> wbik.Robot:
    if name not in _ROBOTS:
        if name == "kinova":  # the Jaco j2s6s200 of example-robot-data: continuous joints
            robot = wbik.load("example-robot-data:kinova")
            robot.chain_between("base", "j2s6s200_end_effector", name="arm")
            _ROBOTS[name] = robot
        else:
            _ROBOTS[name] = wbik.load(name)
    return _ROBOTS[name]


def independent_fk(chain, q) -> pin.SE3:
    """Base -> tip pose on the robot's full model (the solver works on the chain's reduced model)."""
    model = chain.robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, chain.full_configuration(q))
    base, tip = model.getFrameId(chain.base_frame), model.getFrameId(chain.tip_frame)
    return data.oMf[base].inverse() * data.oMf[tip]


def mink_fk(solver, q) -> pin.SE3:
    """MuJoCo's pose (mink's Configuration, a site per frame) of the chain's tip in its base frame at
    chain joints q, the others nominal."""
    chain = solver.chain
    full = chain.full_configuration(chain.check_q(q))
    placements = []
    for frame in (chain.base_frame, chain.tip_frame):
        body = mujoco_body(solver.robot, masses=False, frames=[frame])
        configuration = solver._configuration(body)
        configuration.update(body.qpos(full))
        placements.append(pin.SE3(configuration.get_transform_frame_to_world(body.site(frame), "site")
                                  .as_matrix()))
    return placements[0].actInv(placements[1])


@pytest.fixture(scope="module", params=list(SOLVED), ids=[f"{r}.{c}" for r, c in SOLVED])
def case(request):
    robot_name, chain_name = request.param
    return request.param, wbik.solver("mink", load(robot_name), chain_name)


def test_registered():
    assert "mink" in wbik.methods()


def test_mujoco_fk_of_the_tip_equals_ours(case):
    """mink's own frame transform (Configuration.get_transform of the tip site in the base site, joints
    mapped by name) equals the chain's FK to 1e-9 on random joints; continuous joints (the Kinova's)
    also a turn away from [-pi, pi]. Measured: below 2e-15 everywhere."""
    _, solver = case
    chain = solver.chain
    for q in chain.random(np.random.default_rng(3), 50):
        np.testing.assert_allclose(mink_fk(solver, q).homogeneous, independent_fk(chain, q).homogeneous,
                                   atol=1e-9)
        turned = q + 2 * np.pi * chain.continuous
        np.testing.assert_allclose(mink_fk(solver, turned).homogeneous, chain.fk(q).homogeneous, atol=1e-9)


def test_solves_most_random_reachable_poses_within_the_default_budget(case):
    key, solver = case
    chain = solver.chain
    assert solver.max_iterations == 250 and solver.timeout_s is None
    poses = [independent_fk(chain, q) for q in chain.random(np.random.default_rng(2024), POSES)]
    results = [solver.solve(pose) for pose in poses]
    solved = [r for r in results if r.success]
    assert len(solved) >= SOLVED[key], (key, len(solved))
    for result in results:
        assert result.iterations <= solver.max_iterations
        if result.success:
            assert chain.in_limits(result.q)
        else:
            assert result.reason


def test_joints_outside_the_chain_are_held_at_the_nominal():
    """Golem-III's right arm: the torso, the other arm, the head and the grippers are frozen (mink's
    DofFreezingTask as an equality constraint), and the target, in the torso frame, is mapped to MuJoCo's
    world through the base site."""
    robot = load("golem3")
    solver = wbik.solver("mink", robot, "right_arm")
    chain, built = solver.chain, solver.built
    q = chain.random(np.random.default_rng(5))
    result = solver.solve(independent_fk(chain, q), q0=q + 0.05)
    assert result.success
    reached = built.q(solver._configuration(built).data.qpos)  # where mink left the whole robot
    outside = np.delete(np.arange(robot.model.nq), chain.q_index)
    np.testing.assert_array_equal(reached[outside], robot.nominal[outside])
    np.testing.assert_allclose(reached[chain.q_index], result.q, atol=1e-12)


def test_a_position_target_frees_the_orientation():
    solver = wbik.solver("mink", load("ur5"), "arm")
    chain = solver.chain
    results = [solver.solve(chain.fk(q).translation) for q in chain.random(np.random.default_rng(8), 30)]
    assert sum(r.success for r in results) >= 27  # measured 30 / 30


def test_budget_and_settings():
    robot = load("ur5")
    solver = wbik.solver("mink", robot, "arm", max_iterations=3)
    far = pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.0]))
    result = solver.solve(far)
    assert not result.success and result.iterations <= 3 and result.reason
    assert wbik.solver("mink", robot, "arm", max_step=np.inf).solve(far).reason
    bad = (("damping", -1.0), ("chain_damping", -1.0), ("limit_gain", 1.5), ("max_step", -0.1))
    for option, value in bad:
        with pytest.raises(InvalidSettingError, match=option):
            wbik.solver("mink", robot, "arm", **{option: value})


def test_a_urdf_mujoco_refuses_is_a_typed_refusal(tmp_path):
    """MuJoCo gives a URDF link named 'world' to its world body, which cannot carry a joint."""
    urdf = tmp_path / "world_child.urdf"
    urdf.write_text("""<robot name="world_child">
  <link name="base"/><link name="upper"/><link name="world"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="upper"/><child link="world"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""")
    with pytest.raises(UnsupportedError, match="MuJoCo cannot compile the URDF"):
        wbik.solver("mink", wbik.load(str(urdf)))


def test_the_urdf_mujoco_reads_keeps_fixed_links_and_no_geometry():
    text = mujoco_urdf(load("ur5").urdf_text)
    assert '<compiler fusestatic="false"' in text
    for element in ("<visual", "<collision", "<inertial", "<mesh"):
        assert element not in text


def test_mujoco_warnings_are_collected_not_logged_to_the_working_directory(tmp_path, monkeypatch):
    """The double pendulum's joints have equal lower and upper limits, which MuJoCo ignores with a warning;
    MuJoCo's default handler would append it to MUJOCO_LOG.TXT in the working directory."""
    monkeypatch.chdir(tmp_path)
    solver = wbik.solver("mink", wbik.load("example-robot-data:double_pendulum"))
    assert any("equal lower and upper limits" in warning for warning in solver.built.warnings)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_four_threads_on_one_solver_match_the_sequential_run():
    """An iteration budget, DAQP and MuJoCo are deterministic: the same joints from any thread."""
    solver = wbik.solver("mink", load("ur5"), "arm")
    chain = solver.chain
    targets = [chain.fk(q) for q in chain.random(np.random.default_rng(7), 24)]
    targets.append(pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.0])))
    sequential = [solver.solve(target) for target in targets]
    previous = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        with ThreadPoolExecutor(max_workers=4) as pool:
            threaded = list(pool.map(solver.solve, targets))
    finally:
        sys.setswitchinterval(previous)
    for alone, shared in zip(sequential, threaded, strict=True):
        assert shared.success == alone.success
        np.testing.assert_array_equal(shared.q, alone.q)


def test_importing_wbik_and_listing_methods_imports_neither_mujoco_nor_ik_geo():
    code = ("import sys, wbik; wbik.methods(); "
            "print(sorted(m for m in ('mujoco', 'mink', 'ik_geo') if m in sys.modules))")
    output = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert output.strip() == "[]"
