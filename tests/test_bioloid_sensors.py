"""Bioloid foot sensors: CoP, static stance loads (CoP = CoM projection), Eq. 23, checksum, Eq. 24."""

import numpy as np
import pytest

import wbik
from wbik.apps.bioloid import sensors
from wbik.errors import InvalidConfigurationError

# a 100 x 60 mm sole: half sizes a = 0.05, b = 0.03
CORNERS = np.array([[0.05, 0.03, 0], [-0.05, 0.03, 0], [-0.05, -0.03, 0], [0.05, -0.03, 0]])


def test_fsr_order_back_then_front_left_first():
    positions = sensors.fsr_positions(CORNERS)
    assert positions[:, :2].tolist() == [[-0.05, 0.03], [-0.05, -0.03], [0.05, 0.03], [0.05, -0.03]]


def test_center_of_pressure_by_hand():
    positions = sensors.fsr_positions(CORNERS)[:, :2]
    # 1 N on each back sensor, 3 N on each front one: x = (2 * -0.05 + 6 * 0.05) / 8 = 0.025
    assert sensors.center_of_pressure([1, 1, 3, 3], positions) == pytest.approx([0.025, 0.0])
    # all on FSR4 (front right)
    assert sensors.center_of_pressure([0, 0, 0, 2], positions) == pytest.approx([0.05, -0.03])
    assert sensors.center_of_pressure([0, 0, 0, 0], positions) is None
    with pytest.raises(InvalidConfigurationError, match="non-negative"):
        sensors.center_of_pressure([1, -1, 0, 0], positions)


@pytest.mark.parametrize("cop", [(0.0, 0.0), (0.02, 0.01), (-0.01, -0.012)])
def test_rectangle_loads_inside_the_diamond_are_the_closed_form(cop):
    positions = sensors.fsr_positions(CORNERS)
    weight = 10.0
    loads = sensors.support_loads(positions, weight, cop)
    signs = np.sign(positions[:, :2])
    expected = weight / 4 * (1 + signs[:, 0] * cop[0] / 0.05 + signs[:, 1] * cop[1] / 0.03)
    assert loads == pytest.approx(expected, abs=1e-9)


def test_loads_outside_the_diamond_lift_a_sensor_and_keep_equilibrium():
    positions = sensors.fsr_positions(CORNERS)
    cop = (0.045, 0.025)  # near the front-left corner: |x/a| + |y/b| = 1.73 > 1
    loads = sensors.support_loads(positions, 10.0, cop)
    assert np.all(loads >= 0) and loads.sum() == pytest.approx(10.0)
    assert sensors.center_of_pressure(loads, positions[:, :2]) == pytest.approx(cop, abs=1e-9)
    assert loads[1] == pytest.approx(0.0, abs=1e-9)  # FSR2, back right, the far corner, lifts off
    # it is the minimum-norm one: no feasible load set found by a random search has a smaller norm
    rng = np.random.default_rng(1)
    matrix = np.vstack((np.ones(4), positions[:, 0], positions[:, 1]))
    null = np.linalg.svd(matrix)[2][-1]
    for t in rng.uniform(-20, 20, 2000):
        other = loads + t * null
        if np.all(other >= 0):
            assert other @ other >= loads @ loads - 1e-9


def test_outside_the_support_polygon_raises():
    with pytest.raises(InvalidConfigurationError, match="outside the support polygon"):
        sensors.support_loads(sensors.fsr_positions(CORNERS), 10.0, (0.06, 0.0))


def test_bioloid_standing_cop_is_the_com_projection():
    robot = wbik.load("bioloid")
    stance = sensors.stance_loads(robot, robot.nominal)
    com = robot.center_of_mass(robot.nominal)
    assert stance.cop_world == pytest.approx(com[:2], abs=1e-9)
    total = sum(loads.sum() for loads in stance.loads.values())
    assert total == pytest.approx(robot.mass * 9.81)
    # symmetric stance: both feet carry half, the front pair more when the CoM is ahead of the soles
    right, left = stance.loads["r_sole"], stance.loads["l_sole"]
    assert right.sum() == pytest.approx(left.sum())
    assert np.sign(right[2] - right[0]) == np.sign(com[0] - robot.frame_placement(robot.nominal, "r_sole")
                                                   .translation[0])
    # hand value: 8 supports at x = +-0.05 around the sole centres (x = 0): F = W/8 (1 +- c_x / 0.05)
    weight = robot.mass * 9.81
    assert right[2] == pytest.approx(weight / 8 * (1 + com[0] / 0.05), rel=1e-9)


def test_sharp_equation_23():
    # computed values of bioloid.md 6.2
    adc = [100, 200, 300, 400, 500, 600, 700]
    expected = [626.8, 270.3, 165.3, 116.6, 88.9, 71.3, 59.1]
    assert sensors.sharp_distance_mm(adc) == pytest.approx(expected, abs=0.06)
    assert sensors.sharp_adc_value([100.0, 120.0]) == pytest.approx([453.9, 390.6], abs=0.06)
    distances = np.linspace(100, 800, 15)
    assert sensors.sharp_distance_mm(sensors.sharp_adc_value(distances)) == pytest.approx(distances)
    with pytest.raises(InvalidConfigurationError):
        sensors.sharp_distance_mm(0)


def test_bus_facts():
    request = sensors.read_request(0x3A, 0x04, 0x02)
    assert request == bytes([0xFF, 0xFF, 0x3A, 0x04, 0x02, 0x04, 0x02, 0xB9])
    response = bytes([0xFF, 0xFF, 0x3A, 0x04, 0x00, 0xE8, 0x03])
    response += bytes([sensors.checksum(response[2:])])
    assert sensors.parse_response(response) == (0x3A, 0x00, 1000)
    with pytest.raises(InvalidConfigurationError, match="checksum"):
        sensors.parse_response(response[:-1] + b"\x00")
    # Eq. 24: 9 bytes of 10 bits at 115200 baud = 0.78 ms
    assert sensors.send_time_s(9, 10, 115200) == pytest.approx(0.78125e-3)


def test_divider_voltage():
    assert sensors.fsr_divider_voltage(10e3) == pytest.approx(2.5)
    assert sensors.fsr_divider_voltage(0.0) == pytest.approx(5.0)
