"""The thesis's half steps (bioloid.md 5.3) as whole-body QP behaviours.

The thesis replays Roboplus walking matrices for six half steps, needed by the state machine so the
robot can stop after half a step and read its foot sensors:

=========  ==========  =========================================================================
name       foot moved  what it does (Tables 18-23)
=========  ==========  =========================================================================
WalkSR1    right       puts the right foot forward (from beside the left one)
WalkSR2    left        brings the left foot, which is behind, next to the right one
BackSR     right       brings the right foot, which is in front, back next to the left one
WalkSL1    left        mirror of WalkSR1
WalkSL2    right       mirror of WalkSR2
BackSL     left        mirror of BackSR
=========  ==========  =========================================================================

We do not replay the matrices (they are not in our sources). Each half step is generated here
with the same engine as the whole-body step (:func:`wbik.apps.bioloid.step_wholebody.solve_phases`),
in three phases:

1. both feet down: the CoM moves over the foot that stays (hand-over to its sole alone);
2. the other foot is lifted by ``lift`` (a half sine bump), moved along the stance foot's heading
   and put down flat, at the height it started from (on stairs: the tread it stands on);
3. both feet down: the CoM goes back between the feet (the nominal stance's offset, turned).

Length: a WalkS*1 puts the moved foot ``length`` ahead of the other one along the heading (default
the code's step length ``xm - xf`` = 30 mm, so WalkS*1 + WalkS*2 is the code's StepForward, one
foot's advance); WalkS*2 and BackS* put it beside the other one (same along-heading coordinate);
the lateral spacing of the feet is kept. The lift defaults to ``HALF_STEP_LIFT`` = 15 mm: the
thesis observed that the Roboplus half step lifts the foot "much less" than its own 40 mm step,
"almost dragging" it (bioloid.md 7, Fig. 31), and found it smoother; the exact height is ours.

Every sample is verified by FK (contacts to 1e-6 m / rad, CoM inside the shrunk support polygon,
joint limits), as for the whole-body step.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import OTHER
from wbik.apps.bioloid.gait import SOLE
from wbik.apps.bioloid.gait import GaitParameters
from wbik.apps.bioloid.step_wholebody import BodyPhase
from wbik.apps.bioloid.step_wholebody import ComRamp
from wbik.apps.bioloid.step_wholebody import WholeBodyMotion
from wbik.apps.bioloid.step_wholebody import com_over_phase
from wbik.apps.bioloid.step_wholebody import current_soles
from wbik.apps.bioloid.step_wholebody import pelvis_rotation
from wbik.apps.bioloid.step_wholebody import sole_path
from wbik.apps.bioloid.step_wholebody import solve_phases
from wbik.apps.bioloid.step_wholebody import yaw_of
from wbik.errors import InvalidConfigurationError
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.robot import Robot

HALF_STEP_LIFT = 0.015
"""m, swing height of a half step (ours; the thesis says only "much less" than 40 mm)."""
RAMP_INSET = 0.008
"""m, the CoM goes this far inside the next stance sole before the other foot lifts."""
ALONG_TOLERANCE = 1e-4
"""m, a foot counts as beside the other one within this along the heading."""

HALF_STEPS: dict[str, tuple[str, str]] = {
    # name -> (foot moved, where it ends: "ahead" of the other foot or "beside" it)
    "WalkSR1": ("r", "ahead"), "WalkSR2": ("l", "beside"), "BackSR": ("r", "beside"),
    "WalkSL1": ("l", "ahead"), "WalkSL2": ("r", "beside"), "BackSL": ("l", "beside"),
}
DIRECTION = {"WalkSR1": 1, "WalkSR2": 1, "BackSR": -1, "WalkSL1": 1, "WalkSL2": 1, "BackSL": -1}
"""+1: the moved foot goes forward; -1: it goes back."""
NAMES = {"r": "right", "l": "left"}


def along(soles: dict[str, pin.SE3], side: str) -> float:
    """How far the ``side`` foot is ahead of the other one along the other foot's heading (m)."""
    reference = soles[OTHER[side]]
    return float(reference.rotation[:, 0] @ (soles[side].translation - reference.translation))


def recentre_goal(robot: Robot, soles: dict[str, pin.SE3]) -> np.ndarray:
    """The CoM xy between the feet where the nominal stance has it, turned with the feet."""
    nominal = current_soles(robot, robot.nominal)
    offset = robot.center_of_mass(robot.nominal)[:2] - 0.5 * (nominal["r"].translation
                                                             + nominal["l"].translation)[:2]
    heading = 0.5 * (yaw_of(soles["r"].rotation) + yaw_of(soles["l"].rotation))
    middle = 0.5 * (soles["r"].translation + soles["l"].translation)[:2]
    return middle + pin.utils.rotate("z", heading)[:2, :2] @ offset


def half_step_phases(robot: Robot, soles: dict[str, pin.SE3], name: str, gait: GaitParameters | None = None,
                     length: float | None = None, lift: float = HALF_STEP_LIFT
                     ) -> tuple[list[BodyPhase], dict[str, pin.SE3]]:
    """Phases of the half step ``name`` (a key of ``HALF_STEPS``) from the planted ``soles``
    ({"r": SE3, "l": SE3}); returns them and the soles planted afterwards.

    Raises InvalidConfigurationError when the half step does not apply: WalkS*2 needs the moved
    foot behind the other one, BackS* needs it in front, WalkS*1 needs it not ahead already."""
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
    if name.startswith("Back") and ahead <= ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{name} brings the {NAMES[moved]} foot back from in front,"
                                        f" but it is {ahead * 1e3:.1f} mm ahead of the other one")
    if name.endswith("2") and ahead >= -ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{name} brings the {NAMES[moved]} foot from behind, but it is "
                                        f"{ahead * 1e3:.1f} mm ahead of the other one")
    if name.endswith("1") and ahead > ALONG_TOLERANCE:
        raise InvalidConfigurationError(f"{name} puts the {NAMES[moved]} foot forward from beside the other "
                                        f"one, but it is already {ahead * 1e3:.1f} mm ahead")
    start, other = soles[moved], soles[stays]
    forward = other.rotation[:, 0]
    goal_along = length if ends == "ahead" else 0.0
    end = pin.SE3(start.rotation.copy(), start.translation + forward * (goal_along - ahead))
    heading = yaw_of(other.rotation)
    rotation = lambda s: pelvis_rotation(heading, gait.pitch)  # noqa: E731
    both = {SOLE[moved]: start, SOLE[stays]: other}
    after = {moved: end, stays: other}
    n = gait.divisions
    verb = "forward" if DIRECTION[name] > 0 else "back"
    phases = [
        com_over_phase(robot, f"{name}: CoM over the {NAMES[stays]} foot", dict(both), stays, other,
                       RAMP_INSET,
                       pelvis_rotation=rotation, divisions=n, speed_rpm=gait.servo_slow_rpm),
        BodyPhase(f"{name}: {NAMES[moved]} foot {verb}", {SOLE[stays]: other},
                  swing={SOLE[moved]: sole_path(start, end, lift=lift)}, pelvis_rotation=rotation,
                  divisions=2 * n, speed_rpm=gait.servo_fast_rpm),
        BodyPhase(f"{name}: CoM between the feet", {SOLE[moved]: end, SOLE[stays]: other},
                  pelvis_rotation=rotation, com=ComRamp(goal=recentre_goal(robot, after)),
                  divisions=n, speed_rpm=gait.servo_slow_rpm),
    ]
    return phases, after


def half_step(robot: Robot, name: str, q0: np.ndarray | None = None, gait: GaitParameters | None = None,
              margin: float = 0.005, length: float | None = None, lift: float = HALF_STEP_LIFT,
              backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """Solve the half step ``name`` from ``q0`` (default the nominal stance) sample by sample."""
    q = (robot.nominal if q0 is None else np.asarray(q0, dtype=float)).copy()
    phases, _ = half_step_phases(robot, current_soles(robot, q), name, gait, length, lift)
    return solve_phases(robot, q, phases, margin, backend, name=name)


def half_step_sequence(robot: Robot, names: list[str], q0: np.ndarray | None = None,
                       gait: GaitParameters | None = None, margin: float = 0.005,
                       length: float | None = None, lift: float = HALF_STEP_LIFT,
                       backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """Several half steps one after the other (each from where the previous one left the feet)."""
    q = (robot.nominal if q0 is None else np.asarray(q0, dtype=float)).copy()
    soles = current_soles(robot, q)
    phases: list[BodyPhase] = []
    for name in names:
        more, soles = half_step_phases(robot, soles, name, gait, length, lift)
        phases += more
    return solve_phases(robot, q, phases, margin, backend, name="+".join(names))
