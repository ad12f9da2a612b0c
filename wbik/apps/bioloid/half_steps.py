"""The thesis's half steps (bioloid.md 5.3) as whole-body QP behaviours.

The state machine stops after half a step to read the foot sensors. WalkSR1 puts the right foot
forward from beside the left one, WalkSR2 brings the left foot, behind, beside the right one, BackSR
brings the right foot, in front, back beside the left one; WalkSL1, WalkSL2 and BackSL are their
mirrors. The Roboplus matrices are not in our sources: each half step is generated with the whole-body
engine in three phases: the CoM over the foot that stays, the other foot lifted by ``lift`` (a half sine
bump), moved along the stance foot's heading and put down flat at its height, the CoM back between the
feet. A WalkS*1 ends ``length`` ahead (default the code's step, 30 mm, so WalkS*1 + WalkS*2 is one
StepForward), WalkS*2 and BackS* beside the other foot; the feet's lateral spacing is kept. The lift,
``HALF_STEP_LIFT``, is ours: the thesis saw the Roboplus half step "almost dragging" the foot
(bioloid.md 7, Fig. 31).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import OTHER
from wbik.apps.bioloid.gait import SIDE_NAME
from wbik.apps.bioloid.gait import SOLE
from wbik.apps.bioloid.gait import GaitParameters
from wbik.apps.bioloid.gait import start_q
from wbik.apps.bioloid.step_wholebody import BodyPhase
from wbik.apps.bioloid.step_wholebody import ComRamp
from wbik.apps.bioloid.step_wholebody import WholeBodyMotion
from wbik.apps.bioloid.step_wholebody import com_over_phase
from wbik.apps.bioloid.step_wholebody import current_soles
from wbik.apps.bioloid.step_wholebody import pelvis_rotation
from wbik.apps.bioloid.step_wholebody import recentre_goal
from wbik.apps.bioloid.step_wholebody import sole_path
from wbik.apps.bioloid.step_wholebody import solve_phases
from wbik.apps.bioloid.step_wholebody import yaw_of
from wbik.errors import InvalidConfigurationError
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.robot import Robot

HALF_STEP_LIFT = 0.015  # m, swing height (ours; the thesis says only "much less" than 40 mm)
ALONG_TOLERANCE = 1e-4  # m, a foot counts as beside the other one within this along the heading
HALF_STEPS: dict[str, tuple[str, str]] = {
    # name -> (foot moved, where it ends: "ahead" of the other foot or "beside" it)
    "WalkSR1": ("r", "ahead"), "WalkSR2": ("l", "beside"), "BackSR": ("r", "beside"),
    "WalkSL1": ("l", "ahead"), "WalkSL2": ("r", "beside"), "BackSL": ("l", "beside"),
}


def along(soles: dict[str, pin.SE3], side: str) -> float:
    """How far the ``side`` foot is ahead of the other one along the other foot's heading (m)."""
    reference = soles[OTHER[side]]
    return float(reference.rotation[:, 0] @ (soles[side].translation - reference.translation))


def half_step_phases(robot: Robot, soles: dict[str, pin.SE3], name: str, gait: GaitParameters | None = None,
                     length: float | None = None, lift: float = HALF_STEP_LIFT
                     ) -> tuple[list[BodyPhase], dict[str, pin.SE3]]:
    """Phases of the half step ``name`` (a key of ``HALF_STEPS``) from the planted ``soles``
    ({"r": SE3, "l": SE3}) and the soles planted afterwards. InvalidConfigurationError when it does not
    apply: WalkS*2 needs the moved foot behind, BackS* in front, WalkS*1 not ahead already."""
    if name not in HALF_STEPS:
        raise InvalidConfigurationError(f"unknown half step {name!r}; known: {', '.join(HALF_STEPS)}")
    gait = gait or GaitParameters()
    length = gait.step_length if length is None else float(length)
    if not 0.0 < length <= 0.06:
        raise InvalidConfigurationError(f"half step length must be in (0, 0.06] m, got {length}")
    if not 0.0 <= lift <= 0.05:
        raise InvalidConfigurationError(f"half step lift must be in [0, 0.05] m, got {lift}")
    moved, ends = HALF_STEPS[name]
    stays = OTHER[moved]
    ahead = along(soles, moved)
    foot = f"{name} brings the {SIDE_NAME[moved]} foot"
    if name.startswith("Back") and ahead <= ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{foot} back from in front, but it is {ahead * 1e3:.1f} mm ahead of "
                                        "the other one")
    if name.endswith("2") and ahead >= -ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{foot} from behind, but it is {ahead * 1e3:.1f} mm ahead of the "
                                        "other one")
    if name.endswith("1") and ahead > ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{name} puts the {SIDE_NAME[moved]} foot forward from beside the "
                                        f"other one, but it is already {ahead * 1e3:.1f} mm ahead")
    start, other = soles[moved], soles[stays]
    end = pin.SE3(start.rotation.copy(),
                  start.translation + other.rotation[:, 0] * ((length if ends == "ahead" else 0.0) - ahead))
    heading = yaw_of(other.rotation)
    rotation = lambda s: pelvis_rotation(heading, gait.pitch)  # noqa: E731
    after = {moved: end, stays: other}
    n = gait.divisions
    phases = [
        com_over_phase(robot, f"{name}: CoM over the {SIDE_NAME[stays]} foot",
                       {SOLE[moved]: start, SOLE[stays]: other}, stays, other,
                       pelvis_rotation=rotation, divisions=n, speed_rpm=gait.servo_slow_rpm),
        BodyPhase(f"{name}: {SIDE_NAME[moved]} foot {'back' if name.startswith('Back') else 'forward'}",
                  {SOLE[stays]: other}, swing={SOLE[moved]: sole_path(start, end, lift=lift)},
                  pelvis_rotation=rotation, divisions=2 * n, speed_rpm=gait.servo_fast_rpm),
        BodyPhase(f"{name}: CoM between the feet", {SOLE[moved]: end, SOLE[stays]: other},
                  pelvis_rotation=rotation, com=ComRamp(goal=recentre_goal(robot, after)),
                  divisions=n, speed_rpm=gait.servo_slow_rpm),
    ]
    return phases, after


def half_step_sequence(robot: Robot, names: list[str], q0: np.ndarray | None = None,
                       gait: GaitParameters | None = None, margin: float = 0.005,
                       length: float | None = None, lift: float = HALF_STEP_LIFT,
                       backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """Half steps one after the other from ``q0`` (default the nominal), solved sample by sample."""
    q = start_q(robot, q0)
    soles = current_soles(robot, q)
    phases: list[BodyPhase] = []
    for name in names:
        more, soles = half_step_phases(robot, soles, name, gait, length, lift)
        phases += more
    return solve_phases(robot, q, phases, margin, backend, name="+".join(names))


def half_step(robot: Robot, name: str, q0: np.ndarray | None = None, gait: GaitParameters | None = None,
              margin: float = 0.005, length: float | None = None, lift: float = HALF_STEP_LIFT,
              backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """The half step ``name`` from ``q0`` (default the nominal), solved sample by sample."""
    return half_step_sequence(robot, [name], q0, gait, margin, length, lift, backend)
