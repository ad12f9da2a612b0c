"""Bioloid foot sensors (bioloid.md 6): four FSRs per sole (ASSUMED at its corners: FSR1 back left, FSR2
back right, FSR3 front left, FSR4 front right), the Sharp distance sensor, the foot board's bus. Static
loads (rigid body on equal springs, unilateral): min |F|^2 s.t. A F = W (1, c_x, c_y), F >= 0."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from qpsolvers import solve_qp

from wbik.errors import InvalidConfigurationError, RobotDescriptionError
from wbik.robot import Robot

QP_TOLERANCE = 1e-7
"""Shares of the weight below which DAQP's answer counts a sensor unloaded, and its equality residual
above which the CoP counts as outside the supports (DAQP's own tolerances are about 1e-9)."""

GRAVITY = 9.81  # m/s^2
FSR_NAMES = ("FSR1", "FSR2", "FSR3", "FSR4")


def fsr_positions(corners: np.ndarray) -> np.ndarray:
    """The 4 FSR positions (4, 3) in the sole frame, ordered FSR1..FSR4, from the sole's 4 corners."""
    corners = np.asarray(corners, dtype=float)
    if corners.shape != (4, 3):
        raise RobotDescriptionError(f"a sole needs 4 corners (4, 3), got shape {corners.shape}")
    back = corners[corners[:, 0] < np.mean(corners[:, 0])]
    front = corners[corners[:, 0] > np.mean(corners[:, 0])]
    if len(back) != 2 or len(front) != 2:
        raise RobotDescriptionError("sole corners must be two at the back (-x) and two at the front (+x)")
    return np.array([*back[np.argsort(-back[:, 1])], *front[np.argsort(-front[:, 1])]])  # left (+y) first


def robot_fsr_positions(robot: Robot, sole: str) -> np.ndarray:
    """FSR positions of ``sole`` ('r_sole' or 'l_sole') from ``robot.soles``."""
    if sole not in robot.soles:
        raise RobotDescriptionError(
            f"{robot.name} has no sole {sole!r} in robot.soles; known: {sorted(robot.soles)}")
    return fsr_positions(robot.soles[sole])


def center_of_pressure(loads: Sequence[float], positions: np.ndarray) -> np.ndarray | None:
    """sum F_i p_i / sum F_i in the frame of ``positions``; None when nothing presses."""
    loads = np.asarray(loads, dtype=float)
    positions = np.asarray(positions, dtype=float)
    if loads.ndim != 1 or positions.ndim != 2 or len(loads) != len(positions):
        raise InvalidConfigurationError(
            f"need one load per sensor position: {loads.shape} loads, {positions.shape} positions")
    if not np.all(np.isfinite(loads)) or np.any(loads < 0):
        raise InvalidConfigurationError(f"FSR loads must be finite and non-negative, got {loads.tolist()}")
    total = float(loads.sum())
    if total <= 0.0:
        return None
    return loads @ positions / total


def support_loads(points_xy: np.ndarray, weight: float, cop_xy: Sequence[float],
                  tolerance: float = 1e-9) -> np.ndarray:
    """Minimum-norm loads >= 0 carrying ``weight`` with their CoP at ``cop_xy``: min |f|^2 s.t. A f = w (1,
    cop), f >= 0 with A = (1; x; y), a QP (DAQP) whose loaded set then gives the exact least-norm loads
    A_S^T (A_S A_S^T)^+ b; InvalidConfigurationError when ``cop_xy`` is outside the supports' hull."""
    points = np.asarray(points_xy, dtype=float)[:, :2]
    if not weight > 0:
        raise InvalidConfigurationError(f"weight must be positive, got {weight}")
    count = len(points)
    matrix = np.vstack((np.ones(count), points[:, 0], points[:, 1]))
    rhs = np.array([1.0, cop_xy[0], cop_xy[1]])  # per newton of weight
    shares = solve_qp(np.eye(count), np.zeros(count), A=matrix, b=rhs, lb=np.zeros(count), solver="daqp")
    residual = np.inf if shares is None else np.linalg.norm(matrix @ shares - rhs)
    if residual > QP_TOLERANCE * (1.0 + np.abs(rhs[1:]).max()):
        raise InvalidConfigurationError(
            f"the CoM projection {np.asarray(cop_xy).tolist()} is outside the support polygon: "
            "no non-negative support loads balance the weight (the stance is not static)")
    loaded = np.flatnonzero(shares > QP_TOLERANCE)
    sub = matrix[:, loaded]
    exact = sub.T @ np.linalg.pinv(sub @ sub.T) @ rhs
    scale = 1.0 + np.abs(rhs[1:]).max()
    if np.all(exact >= -tolerance) and np.linalg.norm(sub @ exact - rhs) <= tolerance * scale:
        shares = np.zeros(count)
        shares[loaded] = np.maximum(exact, 0.0)
    return weight * shares


@dataclass
class StanceLoads:
    """Expected FSR loads of a static stance and the resulting centres of pressure."""

    weight: float  # N
    com_xy: np.ndarray  # world ground projection of the CoM (m)
    loads: dict[str, np.ndarray]  # sole -> (4,) N, FSR1..FSR4
    cop_sole: dict[str, np.ndarray | None]  # sole -> CoP in the sole frame (x, y), m (None if unloaded)
    cop_world: np.ndarray  # overall CoP on the ground (x, y), m

    def as_dict(self) -> dict:
        return {"weight_N": self.weight, "com_xy_m": self.com_xy.tolist(),
                "cop_world_xy_m": self.cop_world.tolist(),
                "loads_N": {sole: dict(zip(FSR_NAMES, map(float, v), strict=True))
                            for sole, v in self.loads.items()},
                "cop_sole_xy_m": {sole: None if v is None else v.tolist()
                                  for sole, v in self.cop_sole.items()}}


def stance_loads(robot: Robot, q: np.ndarray, soles: Sequence[str] = ("r_sole", "l_sole"),
                 gravity: float = GRAVITY, contact_height: float = 1e-4) -> StanceLoads:
    """Expected FSR loads standing still at q on the (flat) soles within ``contact_height`` of the lowest."""
    placements = {sole: robot.frame_placement(q, sole) for sole in soles}
    ground = min(p.translation[2] for p in placements.values())
    contact = [s for s, p in placements.items() if p.translation[2] <= ground + contact_height]
    for sole in contact:
        if abs(placements[sole].rotation[2, 2] - 1.0) > 1e-6:
            raise InvalidConfigurationError(f"{sole} touches the ground but is not flat; static FSR loads "
                                            "need the soles flat on the floor")
    local = {sole: robot_fsr_positions(robot, sole) for sole in soles}
    stacked = np.vstack([((placements[sole].rotation @ local[sole].T).T + placements[sole].translation)[:, :2]
                         for sole in contact])
    com_xy = robot.center_of_mass(q)[:2]
    all_loads = support_loads(stacked, robot.mass * gravity, com_xy)
    loads = {sole: np.zeros(4) for sole in soles}
    for index, sole in enumerate(contact):
        loads[sole] = all_loads[4 * index:4 * index + 4]
    cop_sole = {sole: center_of_pressure(loads[sole], local[sole][:, :2]) for sole in soles}
    return StanceLoads(robot.mass * gravity, com_xy, loads, cop_sole, center_of_pressure(all_loads, stacked))


def fsr_divider_voltage(fsr_resistance_ohm, supply_v: float = 5.0, pulldown_ohm: float = 10e3):
    """ADC voltage of the FSR divider (bioloid.md 6.2): V = supply * R_pd / (R_pd + R_fsr)."""
    resistance = np.asarray(fsr_resistance_ohm, dtype=float)
    if np.any(resistance < 0):
        raise InvalidConfigurationError("an FSR resistance cannot be negative")
    return supply_v * pulldown_ohm / (pulldown_ohm + resistance)


SHARP_GAIN = 3027.4
SHARP_EXPONENT = 1.2134
SHARP_PEAK_MM = 60.0  # ASSUMED: where the output peaks (below 10 cm it falls: two distances, Fig. 18)
SHARP_RANGE_MM = 800.0  # rated range 10-80 cm: nothing nearer on the beam reads this
SHARP_MOUNT_XYZ = (0.05, 0.0, 0.012)  # ASSUMED: beam origin in the sole frame (m), at the toe, along +x
FSR_ONE_NEWTON_OHM = 10e3  # ASSUMED force law: R = 10 kOhm * (1 N / F) (FSR-400 order; no curve given)


def sharp_distance_mm(adc_value):
    """Eq. 23: distance (mm) = (3027.4 / ADC)^1.2134 * 10, valid 10-80 cm (below, the curve folds)."""
    adc = np.asarray(adc_value, dtype=float)
    if np.any(adc <= 0):
        raise InvalidConfigurationError("Sharp ADC values must be positive (zero means no reflection)")
    return (SHARP_GAIN / adc) ** SHARP_EXPONENT * 10.0


def sharp_adc_value(distance_mm):
    """Inverse of Eq. 23: ADC = 3027.4 / (distance / 10)^(1 / 1.2134)."""
    distance = np.asarray(distance_mm, dtype=float)
    if np.any(distance <= 0):
        raise InvalidConfigurationError("distances must be positive")
    return SHARP_GAIN / (distance / 10.0) ** (1.0 / SHARP_EXPONENT)


def sharp_adc_folded(true_distance_mm):
    """ADC value for an object at ``true_distance_mm`` (inf: none): Eq. 23 inverted from ``SHARP_PEAK_MM``
    to ``SHARP_RANGE_MM``, linear to 0 below the peak (our fold)."""
    distance = np.asarray(true_distance_mm, dtype=float)
    if np.any(distance < 0) or np.any(np.isnan(distance)):
        raise InvalidConfigurationError("Sharp distances must be >= 0 (inf: nothing on the beam)")
    clipped = np.minimum(distance, SHARP_RANGE_MM)
    far = sharp_adc_value(np.maximum(clipped, SHARP_PEAK_MM))
    near = sharp_adc_value(SHARP_PEAK_MM) * clipped / SHARP_PEAK_MM
    return np.where(clipped >= SHARP_PEAK_MM, far, near)


def sharp_reading_mm(true_distance_mm):
    """What the foot board reports (mm): Eq. 23 of the folded ADC value (touching: the range limit)."""
    adc = np.asarray(sharp_adc_folded(true_distance_mm), dtype=float)
    return sharp_distance_mm(np.where(adc > 0, adc, sharp_adc_value(SHARP_RANGE_MM)))


def sharp_ray(robot: Robot, q: np.ndarray, sole: str) -> tuple[np.ndarray, np.ndarray]:
    """World origin and unit direction of the Sharp beam of the foot whose sole frame is ``sole``."""
    placement = robot.frame_placement(q, sole)
    origin = placement.translation + placement.rotation @ np.asarray(SHARP_MOUNT_XYZ, dtype=float)
    return origin, placement.rotation[:, 0].copy()


def fsr_reading_mv(force_n, supply_v: float = 5.0, pulldown_ohm: float = 10e3):
    """FSR divider voltage (mV) for a force (N): 5000 F / (F + 1 N) (ASSUMED: PSThreshold is in mV)."""
    force = np.asarray(force_n, dtype=float)
    if np.any(force < 0) or not np.all(np.isfinite(force)):
        raise InvalidConfigurationError("FSR forces must be finite and >= 0")
    resistance = FSR_ONE_NEWTON_OHM / np.maximum(force, 1e-300)
    return np.where(force > 0, 1e3 * fsr_divider_voltage(resistance, supply_v, pulldown_ohm), 0.0)


class MovingAverage:
    """The board's noise filter: the mean of the last ``window`` samples (bioloid.md 6.2)."""

    def __init__(self, window: int = 3):
        if int(window) != window or window < 1:
            raise InvalidConfigurationError(f"moving-average window must be a positive integer, got {window}")
        self.window = int(window)
        self.samples: list[np.ndarray] = []

    def add(self, value) -> np.ndarray:
        self.samples.append(np.asarray(value, dtype=float).copy())
        del self.samples[:-self.window]
        return self.value

    @property
    def value(self) -> np.ndarray:
        if not self.samples:
            raise InvalidConfigurationError("the moving average has no sample yet")
        return np.mean(self.samples, axis=0)


PS_THRESHOLD = 1000.0  # PSThreshold (bioloid.md 5.6): a front FSR strictly below reads "no pressure"
PS_READS = 2  # consecutive low reads of both front sensors that mean a step down (bioloid.md 6.5)


class StepDownDetector:
    """Step down detected when FSR3 and FSR4 are both < ``threshold`` on ``reads`` consecutive reads."""

    def __init__(self, threshold: float = PS_THRESHOLD, reads: int = PS_READS):
        self.threshold = float(threshold)
        self.reads = int(reads)
        self.count = 0

    def update(self, fsr3: float, fsr4: float) -> bool:
        self.count = self.count + 1 if fsr3 < self.threshold and fsr4 < self.threshold else 0
        return self.count >= self.reads

    def reset(self) -> None:
        self.count = 0


READ_INSTRUCTION = 0x02


def checksum(body: Sequence[int]) -> int:
    """Bitwise NOT of the byte sum (headers 0xFF 0xFF excluded), low byte."""
    return ~sum(int(b) for b in body) & 0xFF


def read_request(device_id: int, address: int, size: int = 2) -> bytes:
    """0xFF 0xFF ID LEN=4 INST=0x02 ADDR SIZE CHECKSUM (Fig. 20)."""
    body = [device_id, 0x04, READ_INSTRUCTION, address, size]
    if any(not 0 <= b <= 0xFF for b in body):
        raise InvalidConfigurationError(f"packet fields must be bytes, got {body}")
    return bytes([0xFF, 0xFF, *body, checksum(body)])


def parse_response(packet: bytes) -> tuple[int, int, int | None]:
    """(id, error byte, value or None) of a response 0xFF 0xFF ID LEN ERR [LO HI] CHECKSUM (Fig. 21)."""
    if len(packet) < 6 or packet[0] != 0xFF or packet[1] != 0xFF:
        raise InvalidConfigurationError(f"not a response packet: {packet.hex(' ')}")
    length = packet[3]
    body = packet[2:4 + length - 1]
    if len(packet) != 4 + length or checksum(body) != packet[-1]:
        raise InvalidConfigurationError(f"bad length or checksum in {packet.hex(' ')}")
    parameters = packet[5:-1]
    value = int.from_bytes(parameters, "little") if parameters else None
    return packet[2], packet[4], value


def send_time_s(byte_count: int, bits_per_word: int = 10, baud: float = 115200.0) -> float:
    """Eq. 24: time to send = bytes * bits per word / baud rate (s)."""
    return byte_count * bits_per_word / baud
