"""(a) The thesis's step forward generated faithfully: closed-form leg IK per phase, per leg.

As the code's ``StepForwardL``: each leg's hip moves on a line between two key points (hip relative to
that leg's ankle) in 5 divisions, each solved by the foot -> hip closed form (eq. 10-22, pitch 20 deg,
roll 0) for each leg on its own, so the two legs do not form a closed chain. The phase's anchor sole
stays planted; the other sole ends where the other leg puts it. Per sample (bioloid.md 4.5):
``inconsistency`` (mm, deg), in double support the other sole's pose error against where it is planted
(flat at z = 0 with its x, y, yaw; a dragged sole only has to stay on the ground); ``com_margin`` (m,
negative outside) in the planted soles' polygon; ``clearance`` (m) of a lifted sole's lowest corner;
``limit_excess`` (rad) beyond the URDF limits.
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import SIDES
from wbik.apps.bioloid.gait import SOLE
from wbik.apps.bioloid.gait import GaitParameters
from wbik.apps.bioloid.gait import SampledMotion
from wbik.apps.bioloid.gait import pose_error
from wbik.apps.bioloid.gait import sole_corners
from wbik.apps.bioloid.gait import start_q
from wbik.apps.bioloid.gait import step_forward_phases
from wbik.apps.bioloid.servo import leg_ang_from_q
from wbik.apps.bioloid.servo import leg_q_from_ang
from wbik.qp.support_polygon import SupportPolygon
from wbik.robot import Robot
from wbik.robot_packages.bioloid.closed_form import leg_foot_to_hip
from wbik.robot_packages.bioloid.model import LEG_JOINTS


def leg_q_indices(robot: Robot, side: str) -> np.ndarray:
    """Configuration indices of one leg's 6 joints (hip yaw .. ankle roll)."""
    model = robot.model
    return np.array([model.joints[model.getJointId(f"{side}_{name}")].idx_q for name in LEG_JOINTS])


def flatten_on_ground(placement: pin.SE3) -> pin.SE3:
    """The same x, y and yaw, on the ground (z = 0) and flat (no roll, no pitch)."""
    rotation = placement.rotation
    yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    flat = pin.utils.rotate("z", float(yaw))
    return pin.SE3(flat, np.array([placement.translation[0], placement.translation[1], 0.0]))


def place_on_anchor(robot: Robot, q: np.ndarray, anchor_frame: str, placement: pin.SE3) -> np.ndarray:
    """q with the floating base moved so that ``anchor_frame`` is at ``placement`` (world)."""
    q = q.copy()
    q[:7] = pin.SE3ToXYZQUAT(pin.SE3.Identity())
    in_base = robot.frame_placement(q, anchor_frame)
    q[:7] = pin.SE3ToXYZQUAT(placement * in_base.inverse())
    return q


def _worst_inconsistency(samples: list[dict]) -> tuple[float | None, float | None]:
    double = [s for s in samples if s["inconsistency_mm"] is not None]
    return (max((s["inconsistency_mm"] for s in double), default=None),
            max((s["inconsistency_deg"] for s in double), default=None))


@dataclass
class FaithfulStep:
    """The faithful motion and its per-sample measurements (see the module docstring)."""

    motion: SampledMotion
    samples: list[dict] = field(default_factory=list)

    def summary(self) -> dict:
        lifted = [s["clearance_m"] for s in self.samples if s["clearance_m"] is not None]
        margins = [s["com_margin_m"] for s in self.samples]
        worst_mm, worst_deg = _worst_inconsistency(self.samples)
        return {
            "samples": len(self.samples),
            "max_inconsistency_mm": worst_mm or 0.0, "max_inconsistency_deg": worst_deg or 0.0,
            "min_com_margin_mm": 1e3 * min(margins),
            "samples_com_outside": int(sum(m < 0.0 for m in margins)),
            "min_clearance_mm": None if not lifted else 1e3 * min(lifted),
            "max_limit_excess_deg": float(np.degrees(max(s["limit_excess_rad"] for s in self.samples))),
            "unreachable_samples": int(sum(not s["reachable"] for s in self.samples)),
            "per_phase": self.per_phase(),
        }

    def per_phase(self) -> list[dict]:
        rows = []
        for index, name in enumerate(self.motion.phase_names):
            chosen = [s for s in self.samples if s["phase"] == index]
            worst_mm, worst_deg = _worst_inconsistency(chosen)
            rows.append({"phase": name, "max_inconsistency_mm": worst_mm, "max_inconsistency_deg": worst_deg,
                         "min_com_margin_mm": 1e3 * min(s["com_margin_m"] for s in chosen)})
        return rows


def step_forward_faithful(robot: Robot, gait: GaitParameters | None = None, first: str = "left",
                          q0: np.ndarray | None = None, round_degrees: bool = False) -> FaithfulStep:
    """The code's StepForwardL (or its mirror, ``first="right"``) by the per-leg closed form from ``q0``
    (default the nominal, whose soles are where the feet are planted); ``round_degrees``: round the
    code's ang[] to whole degrees as the C code does."""
    gait = gait or GaitParameters()
    phases = step_forward_phases(gait, first)
    q = start_q(robot, q0)
    legs = {side: leg_q_indices(robot, side) for side in SIDES}
    planted = {side: flatten_on_ground(robot.frame_placement(q, SOLE[side])) for side in SIDES}
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    joint_index = np.concatenate(list(legs.values()))

    configurations, phase_of, support = [q.copy()], [-1], [("r_sole", "l_sole")]
    samples: list[dict] = []
    for index, phase in enumerate(phases):
        for division in range(1, gait.divisions + 1):
            fraction = division / gait.divisions
            reachable = True
            for side in SIDES:
                point = phase.hip_point(side, fraction)
                angles, ok = leg_foot_to_hip(point, 0.0, gait.pitch, gait.roll, side)
                if round_degrees:
                    angles = leg_q_from_ang(np.round(leg_ang_from_q(angles)))
                q[legs[side]] = angles
                reachable = reachable and bool(ok)
            q = place_on_anchor(robot, q, SOLE[phase.anchor], planted[phase.anchor])
            sample = {"phase": index, "division": division, "reachable": reachable,
                      "inconsistency_mm": None, "inconsistency_deg": None, "clearance_m": None}
            down_soles = {}
            for side in phase.down:
                reached = robot.frame_placement(q, SOLE[side])
                if side == phase.anchor:
                    down_soles[side] = planted[side]
                    continue
                wanted = flatten_on_ground(reached) if side == phase.dragged else planted[side]
                position, rotation = pose_error(reached, wanted)
                sample["inconsistency_mm"] = 1e3 * position
                sample["inconsistency_deg"] = float(np.degrees(rotation))
                down_soles[side] = wanted
                if side == phase.dragged:
                    planted[side] = wanted
            if phase.lifted is not None:
                reached = robot.frame_placement(q, SOLE[phase.lifted])
                sample["clearance_m"] = float(np.min(sole_corners(robot, SOLE[phase.lifted], reached)[:, 2]))
                if division == gait.divisions:  # touchdown: planted where it comes down
                    planted[phase.lifted] = flatten_on_ground(reached)
            points = np.vstack([sole_corners(robot, SOLE[s], p)[:, :2] for s, p in down_soles.items()])
            com = robot.center_of_mass(q)
            sample["com_margin_m"] = SupportPolygon(points).margin_of(com[:2])
            sample["com"] = com.tolist()
            joints = q[joint_index]
            sample["limit_excess_rad"] = float(max(np.max(lower[joint_index] - joints),
                                                   np.max(joints - upper[joint_index]), 0.0))
            samples.append(sample)
            configurations.append(q.copy())
            phase_of.append(index)
            support.append(tuple(SOLE[s] for s in phase.down))
    motion = SampledMotion(f"step_forward_{first}_faithful", robot, np.array(configurations),
                           np.array(phase_of), [p.name for p in phases], support,
                           {"gait": gait, "generator": "faithful closed-form per leg"})
    return FaithfulStep(motion, samples)
