"""Dynamic walking: footsteps -> support timeline -> ZMP reference -> CoM by preview control -> swing
feet -> one whole-body QP step per tick, judged by the motion's multibody ZMP."""

from wbik.motion.walking.footsteps import Feet, Footstep, StepCommand, plan_footsteps
from wbik.motion.walking.multibody_zmp import multibody_zmp, trajectory_derivatives
from wbik.motion.walking.pattern import WalkPattern, walk_pattern
from wbik.motion.walking.preview import PreviewController
from wbik.motion.walking.timeline import Timing, timeline

__all__ = ["Feet", "Footstep", "PreviewController", "StepCommand", "Timing", "WalkPattern", "multibody_zmp",
           "plan_footsteps", "timeline", "trajectory_derivatives", "walk_pattern"]
