"""The walks in MuJoCo's physics (wbik.motion.walking.physics, .stabiliser).

Expected values are independent of the code under test: Pinocchio's mass, CoM and centroidal momentum,
and statics (a body at rest presses the floor with its weight, its centre of pressure under its CoM).
"""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import InvalidSettingError
from wbik.motion.walking.physics import Measured, Push, Servos, Simulation
from wbik.motion.walking.pushes import PushSettings, largest_recovered, push_in, single_supports
from wbik.robot import robot_from_urdf_text

pytest.importorskip("mujoco")

AX12 = Servos(kp=37.05, damping=0.243, torque_limit=1.5, armature=1e-3, resolution=np.radians(0.29))
BLOCK = """<robot name="block">
  <link name="block"><inertial><origin xyz="0.02 -0.01 0.05"/><mass value="2.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="sole"/>
  <joint name="sole_joint" type="fixed"><parent link="block"/><child link="sole"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


def held(sim: Simulation, q: np.ndarray, seconds: float) -> Measured:
    measured = Measured()
    for _ in range(int(round(seconds / 0.01))):
        sim.run(q, 0.01, measured)
    return measured


def test_the_simulated_robot_has_pinocchios_mass_com_and_momentum(bioloid):
    import mujoco

    q = bioloid.nominal
    sim = Simulation(bioloid, AX12, q)
    assert sim.mass == pytest.approx(pin.computeTotalMass(bioloid.model), rel=1e-9)
    np.testing.assert_allclose(sim.com(), bioloid.center_of_mass(q), atol=1e-9)
    v = np.random.default_rng(0).normal(size=bioloid.model.nv)  # the base's velocity in its own frame
    qvel = np.zeros(sim.model.nv)
    qvel[sim.body.dof_index] = v[sim.body.v_index]
    qvel[:3] = pin.Quaternion(q[6], *q[3:6]).toRotationMatrix() @ v[:3]  # MuJoCo's: world linear velocity
    qvel[3:6] = v[3:6]
    sim.data.qvel[:] = qvel
    mujoco.mj_forward(sim.model, sim.data)
    mujoco.mj_subtreeVel(sim.model, sim.data)
    momentum = pin.computeCentroidalMomentum(bioloid.model, bioloid.model.createData(), q, v)
    np.testing.assert_allclose(sim.data.subtree_angmom[0], momentum.angular, atol=1e-9)
    np.testing.assert_allclose(sim.data.subtree_linvel[0] * sim.mass, momentum.linear, atol=1e-9)
    np.testing.assert_allclose(sim.state()[1], v, atol=1e-12)  # and read back in wbik's convention


def test_a_joint_whose_urdf_states_no_effort_gets_an_unlimited_servo():
    """A URDF effort of 0 (Romeo's hands) states no limit: the scene compiles, the servo holds the joint."""
    flap = """<link name="sole"/>
  <link name="flap"><inertial><origin xyz="0.05 0 0"/><mass value="0.1"/>
    <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="block"/><child link="flap"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="0" velocity="1"/></joint>"""
    robot = robot_from_urdf_text("block", BLOCK.replace('<link name="sole"/>', flap), floating_base=True,
                                 soles={"sole": [[0.05, 0.03, 0.0], [-0.05, 0.03, 0.0], [-0.05, -0.03, 0.0],
                                                 [0.05, -0.03, 0.0]]})
    sim = Simulation(robot, Servos(50.0, kv=1.0), robot.nominal)
    held(sim, robot.nominal, 0.3)
    hinge = robot.model.joints[robot.model.getJointId("hinge")].idx_q
    assert abs(sim.state()[0][hinge] - robot.nominal[hinge]) < 0.02  # held against the flap's weight
    assert sim.model.actuator_forcelimited[0] == 0


def test_a_block_at_rest_presses_its_weight_at_its_com():
    robot = robot_from_urdf_text("block", BLOCK, floating_base=True, soles={"sole": [
        [0.05, 0.03, 0.0], [-0.05, 0.03, 0.0], [-0.05, -0.03, 0.0], [0.05, -0.03, 0.0]]})
    sim = Simulation(robot, Servos(1.0), robot.nominal)
    measured = held(sim, robot.nominal, 0.5)
    total, moment, soles = sim.contact_forces()
    assert soles == {"sole"}
    assert total == pytest.approx(2.0 * 9.81, rel=1e-3)
    np.testing.assert_allclose(moment / total, [0.02, -0.01], atol=2e-4)
    assert measured.figures()["cop_margin_min_m"] == pytest.approx(0.02, abs=1e-3)  # 30 - 10 mm to y = -0.03


def test_the_bioloid_stands_on_its_servos_with_its_cop_under_its_com(bioloid):
    sim = Simulation(bioloid, AX12, bioloid.nominal)
    figures = held(sim, bioloid.nominal, 1.0).figures()
    assert not figures["fell"] and figures["ticks_without_contact"] == 0
    assert figures["cop_margin_min_m"] > 0.015
    total, moment, soles = sim.contact_forces()
    assert soles == set(bioloid.soles)
    np.testing.assert_allclose(moment / total, sim.com()[:2], atol=1e-3)  # at rest: the CoM's projection
    assert np.linalg.norm(sim.state()[1]) < 0.05


def test_a_short_walk_reports_its_physics_open_and_closed_loop():
    from wbik.scenarios import run_scenario

    arms = [f"{s}_{n}" for s in "rl" for n in ("shoulder_pitch", "shoulder_roll", "elbow")]
    spec = {"kind": "walk", "name": "one step", "robot": "bioloid", "trunk": "pelvis", "locked": arms,
            "timing": {"single_support_s": 0.25, "double_support_s": 0.1, "start_s": 0.3, "end_s": 0.3},
            "clearance": 0.015, "margin": 0.004, "preview": {"horizon_s": 1.0, "q": 1.0, "r": 1.0e-5},
            "physics": {"servos": {"kp": AX12.kp, "damping": AX12.damping, "torque_limit": AX12.torque_limit,
                                   "armature": AX12.armature}, "settle_s": 0.2,
                        "push": {"impulse_n_s": 0.05, "step": 1, "duration_s": 0.05, "directions": ["left"],
                                 "search_up_to_n_s": 0.1, "resolution_n_s": 0.1}},
            "walks": [{"steps": 1, "length": 0.01}]}
    report = run_scenario(spec, source="one step")
    json.dumps(report)
    walk = report["walks"][0]
    physics = walk["physics"]
    for figures in (physics, physics["open_loop"]):
        assert isinstance(figures["fell"], bool) and figures["cop_margin_min_m"] is not None
    assert physics["push_impulse_n_s"] == 0.0  # the runs above: unpushed
    pushed = physics["pushed"]["left"]  # a small push sideways, halfway through the single support
    assert pushed["push_impulse_n_s"] == 0.05 and not pushed["fell"]
    assert pushed["at_s"] == pytest.approx(0.3 + 0.5 * 0.25, abs=0.006)
    assert physics["push"]["body"] == "pelvis"
    for figures in (physics, physics["open_loop"]):
        assert figures["largest_push_recovered_n_s"]["left"] in (0.0, 0.1)
    assert 0 < physics["tick_cpu"]["median_s"] <= physics["tick_cpu"]["p95_s"]
    checks = {check["name"]: check for check in walk["expectations"]}
    assert checks["physics_fell"]["figure"] is physics["fell"]
    assert checks["physics_cop_margin_min_m"]["threshold"] == 0.004  # the walk's margin
    assert checks["physics_cop_margin_min_m"]["figure"] == physics["cop_margin_min_m"]
    assert checks["physics_pushed_fell"]["figure"] is False


def test_the_stabiliser_corrects_against_the_measured_errors_only(bioloid):
    from wbik.motion.walking import StepCommand, Timing
    from wbik.motion.walking.stabiliser import Stabiliser, StabiliserGains
    from wbik.motion.walking.tracking import Tracker, TrackingSettings, walk

    settings = TrackingSettings(trunk="pelvis")
    motion = walk(bioloid, bioloid.nominal, StepCommand(1, 0.01), Timing(0.2, 0.05, 0.3, 0.3), clearance=0.01,
                  settings=settings)
    pattern, now = motion.pattern, 40
    gains = StabiliserGains(dcm=0.5, attitude=0.5, time_constant_s=0.0)  # no low-pass: one tick's answer

    def corrections(q, v):
        return Stabiliser(Tracker(bioloid, pattern.feet, bioloid.nominal, settings), pattern, gains
                          ).corrections(q, v, now)

    q = motion.q[now]
    v = pin.difference(bioloid.model, motion.q[now - 1], q) / pattern.dt
    offset, rotation = corrections(q, v)  # the plan as measured: (almost) nothing to correct
    assert np.linalg.norm(offset) < 1e-3 and np.linalg.norm(pin.log3(rotation)) < 1e-3
    moved = q.copy()
    moved[0] += 0.02  # the whole robot 20 mm ahead: the CoM is where it should be over its feet
    np.testing.assert_allclose(corrections(moved, v)[0], offset, atol=1e-12)
    faster = v.copy()
    faster[:3] += pin.Quaternion(q[6], *q[3:6]).toRotationMatrix().T @ [0.1, 0.0, 0.0]  # 0.1 m/s forward
    shifted = corrections(q, faster)[0] - offset
    assert shifted[0] == pytest.approx(-0.5 * 0.1 / pattern.info["omega"], rel=1e-6)
    assert abs(shifted[1]) < 1e-9
    pitched = q.copy()
    pitched[3:7] = (pin.Quaternion(pin.utils.rotate("y", 0.02)) * pin.Quaternion(q[6], *q[3:6])).coeffs()
    turned = pin.log3(corrections(pitched, v)[1] @ rotation.T)
    np.testing.assert_allclose(turned, [0.0, -0.5 * 0.02, 0.0], atol=1e-4)


def test_a_push_gives_its_impulse_to_a_free_body():
    robot = robot_from_urdf_text("block", BLOCK, floating_base=True, soles={"sole": [
        [0.05, 0.03, 0.0], [-0.05, 0.03, 0.0], [-0.05, -0.03, 0.0], [0.05, -0.03, 0.0]]})
    push = Push("block", (3.0, 4.0), 1.5, at_s=0.0123, duration_s=0.0456)  # not on the 1 ms steps
    steps = np.arange(0.0, 0.2, 1e-3)
    assert sum(np.linalg.norm(push.force(t, 1e-3)) * 1e-3 for t in steps) == pytest.approx(1.5, rel=1e-9)
    q = robot.nominal.copy()
    q[2] = 1.0  # in the air: no contact during the push
    sim = Simulation(robot, Servos(1.0), q)
    sim.push = push
    held(sim, q, 0.1)
    velocity = sim.data.qvel[:3]  # the block's origin; pushed at its CoM, it does not turn
    np.testing.assert_allclose(velocity[:2], [1.5 / 2.0 * 0.6, 1.5 / 2.0 * 0.8], rtol=1e-6)
    with pytest.raises(InvalidSettingError):
        Push("block", (0.0, 0.0), 1.0, 0.0, 0.1)


def test_a_push_falls_in_the_single_support_asked_and_the_search_brackets_the_largest():
    support = [("l", "r")] * 3 + [("l",)] * 4 + [("l", "r")] * 2 + [("r",)] * 6 + [("l", "r")]
    assert single_supports(support) == [(3, 7), (9, 15)]
    settings = PushSettings(impulse_n_s=2.0, step=2, phase=0.5, directions=("left",))
    push = push_in(settings, support, 0.01, "trunk", np.pi / 2, "left", 2.0)  # heading +y: left is -x
    assert push.at_s == pytest.approx(0.12) and np.allclose(push.direction, (-1.0, 0.0))
    with pytest.raises(InvalidSettingError):
        push_in(PushSettings(1.0, step=3), support, 0.01, "trunk", 0.0, "left", 1.0)
    with pytest.raises(InvalidSettingError):
        PushSettings(1.0, directions=("up",))
    tried = []
    found = largest_recovered(lambda impulse: tried.append(impulse) or impulse <= 0.37, 1.0, 0.01)
    assert 0.36 <= found <= 0.37 and len(tried) == 8  # the upper bound, then 7 halvings of 1.0 to < 0.01


def test_the_planned_torques_over_kp_keep_a_compliant_servo_on_its_target(bioloid):
    from wbik.motion.walking import StepCommand, Timing
    from wbik.motion.walking.planned_torques import planned_torques
    from wbik.motion.walking.tracking import TrackingSettings, walk

    motion = walk(bioloid, bioloid.nominal, StepCommand(1, 0.01), Timing(0.2, 0.05, 0.3, 0.3), clearance=0.01,
                  settings=TrackingSettings(trunk="pelvis"))
    q = motion.q[0]  # at rest on both feet
    servos = Servos(kp=AX12.kp, damping=AX12.damping, torque_limit=AX12.torque_limit, armature=AX12.armature)
    joints = Simulation(bioloid, servos, q).joints
    torques = planned_torques(motion.pattern, motion.q, joints, servos.armature)
    assert np.all(np.abs(torques) < 100.0) and np.abs(torques[0]).max() > 0.1  # the legs carry the weight
    sags = []
    for lead in (None, torques[0] / servos.kp):
        sim = Simulation(bioloid, servos, q)
        measured = Measured()
        for _ in range(50):
            sim.run(q, 0.01, measured, lead)
        sags.append(np.abs(sim.state()[0][sim.target_index] - q[sim.target_index]).max())
    assert sags[0] == pytest.approx(np.abs(torques[0]).max() / servos.kp, rel=0.1)  # sag: tau / kp
    assert sags[1] < 0.2 * sags[0]
