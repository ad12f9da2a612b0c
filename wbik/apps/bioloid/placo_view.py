"""The animation of PlaCo's walk (``bioloid_placo_walk``): PlaCo's own whole-body IK on its plan.

:func:`wbik.apps.bioloid.placo_walk.placo_walk` measures PlaCo's plan (footsteps, CoM and ZMP) but keeps
no robot configuration. Here the same plan is made again with the same parameters (every value is
read from ``placo_walk``'s module or restated below, and the footsteps are compared with the ones
the report holds: a mismatch raises) and PlaCo's ``WalkTasks`` (feet on PlaCo's foot trajectories,
CoM on its CoM trajectory, trunk pitched) are solved by PlaCo's kinematics solver every
``SAMPLE_S`` seconds. The soles on the ground (PlaCo's foot trajectory within
``GROUND_TOLERANCE`` of the floor) are the support of each sample.

PlaCo's solver treats every walk task as soft, and the plan's 40 mm foot rise at the standing CoM
height is not always within reach of the Bioloid's legs: on tasks/bioloid_walk_placo.yaml the stance
sole leaves the floor for a few samples of some single supports (how far and when:
docs/measurements.md, Bioloid PlaCo walk). The animation shows PlaCo's plan as PlaCo's IK follows it;
the report's figures are PlaCo's plan itself (wbik.apps.bioloid.placo_walk), not this IK.
"""

from __future__ import annotations

import numpy as np

from wbik.errors import InvalidConfigurationError

SAMPLE_S = 0.05
"""s between two samples of the animation (PlaCo's own plan is on a 10 ms grid)."""
SETTLE_ITERATIONS = 50
"""Solver iterations at t = 0 to bring the standing robot into PlaCo's walking posture."""
ITERATIONS = 10
"""Solver iterations per later sample (each starts from the previous sample)."""


def placo_walk_animation(robot, steps: int = 4, step_length: float = 0.03, margin: float = 0.005,
                         single_support_s: float = 0.5, footstep_x: list[float] | None = None):
    """PlaCo's walk of ``steps`` steps as a :class:`wbik.viz.animation.Animation` (see the module
    docstring); ``footstep_x``: the report's footsteps (m), which the re-planned ones must equal."""
    from wbik.apps.bioloid.placo_walk import GROUND_TOLERANCE
    from wbik.apps.bioloid.placo_walk import plan_walk
    from wbik.motion.walking.placo_pattern import WalkIK
    from wbik.motion.walking.placo_pattern import soles_on_ground
    from wbik.solvers.placo import placo_configuration
    from wbik.viz.animation import Animation
    from wbik.viz.animation import Overlays

    humanoid, _, footsteps, trajectory = plan_walk(robot, steps, step_length, margin, single_support_s)
    planned_x = [float(step.frame[0, 3]) for step in footsteps]
    if footstep_x is not None and (len(planned_x) != len(footstep_x)
                                   or not np.allclose(planned_x, footstep_x, atol=1e-9)):
        raise InvalidConfigurationError(
            f"PlaCo's re-planned footsteps {planned_x} differ from the report's {list(footstep_x)}: "
            "wbik.apps.bioloid.placo_view no longer mirrors wbik.apps.bioloid.placo_walk")
    ik = WalkIK(humanoid)
    times = np.append(np.arange(0.0, trajectory.t_end, SAMPLE_S), trajectory.t_end)
    rows, support = [], []
    for index, t in enumerate(times):
        ik.follow(trajectory, float(t), SETTLE_ITERATIONS if index == 0 else ITERATIONS)
        rows.append(placo_configuration(robot, humanoid))
        support.append(soles_on_ground(trajectory, float(t), "l_sole", "r_sole", tolerance=GROUND_TOLERANCE))
    return Animation(robot, times, np.array(rows), Overlays("pelvis", tuple(support), tuple(support)),
                     "PlaCo walk pattern generator")
