"""Dynamic walking: footsteps -> ZMP reference -> CoM by preview control -> whole-body QP tracking,
judged by the multibody ZMP of the planned motion.

The chain, one concept per module:

- :mod:`~wbik.motion.walking.footsteps`: where the feet go (straight, turning, sideways, in place);
- :mod:`~wbik.motion.walking.timeline`: when (single and double support phases);
- :mod:`~wbik.motion.walking.zmp_reference`: the ZMP reference inside the support (piecewise linear:
  at the stance sole's centre in single support, from one sole to the next in double support);
- :mod:`~wbik.motion.walking.preview`: the CoM from the linear inverted pendulum (cart-table model)
  by Kajita's preview controller, x_zmp = x_c - (z_c / g) x_c'';
- :mod:`~wbik.motion.walking.swing`: swing-foot trajectories (quintic along the ground, a height
  bump with zero velocity and acceleration at lift-off and touch-down);
- :mod:`~wbik.motion.walking.pattern`: the walk pattern, every reference on the control grid;
- :mod:`~wbik.motion.walking.tracking`: one whole-body QP step per control tick (CoM, swing foot,
  trunk, stance contacts, joint limits, self-collision);
- :mod:`~wbik.motion.walking.multibody_zmp`: the ZMP of the whole robot's centroidal dynamics along a
  joint trajectory (finite differences on the configuration manifold);
- :mod:`~wbik.motion.walking.figures`: what a walk is judged by (ZMP margin, CoM tracking, slip,
  clearance, joint velocity and acceleration peaks);
- :mod:`~wbik.motion.walking.static_gait`: the quasi-static gait on the same footsteps (the seed's
  strategy: CoM over the stance sole, one QP solve per division, servo-speed timing);
- :mod:`~wbik.motion.walking.placo_pattern`: PlaCo's walk pattern generator on the same footsteps;
- :mod:`~wbik.motion.walking.scenario`: the ``walk`` scenario kind.
"""

from wbik.motion.walking.footsteps import Feet
from wbik.motion.walking.footsteps import Footstep
from wbik.motion.walking.footsteps import StepCommand
from wbik.motion.walking.footsteps import plan_footsteps
from wbik.motion.walking.multibody_zmp import multibody_zmp
from wbik.motion.walking.multibody_zmp import trajectory_derivatives
from wbik.motion.walking.pattern import WalkPattern
from wbik.motion.walking.pattern import walk_pattern
from wbik.motion.walking.preview import PreviewController
from wbik.motion.walking.timeline import Timing
from wbik.motion.walking.timeline import timeline

__all__ = ["Feet", "Footstep", "PreviewController", "StepCommand", "Timing", "WalkPattern", "multibody_zmp",
           "plan_footsteps", "timeline", "trajectory_derivatives", "walk_pattern"]
