"""The animation of PlaCo's walk (``bioloid_placo_walk``): PlaCo's own IK on its plan every ``SAMPLE_S``.

The plan is made again with :func:`wbik.apps.bioloid.placo_walk.plan_walk` (its footsteps must equal the
report's) and followed by :func:`~wbik.apps.bioloid.placo_walk.follow_plan`; PlaCo's soft walk tasks let
the stance sole leave the floor for a few samples (docs/measurements.md, Bioloid PlaCo walk). The report's
figures are the plan's, not this IK's.
"""

from __future__ import annotations

import numpy as np

from wbik.apps.bioloid.placo_walk import follow_plan
from wbik.apps.bioloid.placo_walk import plan_walk
from wbik.errors import InvalidConfigurationError

SAMPLE_S = 0.05  # s between two samples of the animation (PlaCo's own plan is on a 10 ms grid)
ITERATIONS = 10  # solver iterations per sample after the first (each from the previous sample)


def placo_walk_animation(robot, steps: int = 4, step_length: float = 0.03, margin: float = 0.005,
                         single_support_s: float = 0.5, footstep_x: list[float] | None = None):
    """PlaCo's walk of ``steps`` steps as a :class:`wbik.viz.animation.Animation`; ``footstep_x``: the
    report's footsteps (m), which the re-planned ones must equal."""
    from wbik.viz.animation import Animation
    from wbik.viz.animation import Overlays

    walker, _, footsteps, trajectory = plan_walk(robot, steps, step_length, margin, single_support_s)
    planned_x = [float(step.frame[0, 3]) for step in footsteps]
    if footstep_x is not None and (len(planned_x) != len(footstep_x)
                                   or not np.allclose(planned_x, footstep_x, atol=1e-9)):
        raise InvalidConfigurationError(
            f"PlaCo's re-planned footsteps {planned_x} differ from the report's {list(footstep_x)}: "
            "wbik.apps.bioloid.placo_view no longer mirrors wbik.apps.bioloid.placo_walk")
    times = np.append(np.arange(0.0, trajectory.t_end, SAMPLE_S), trajectory.t_end)
    rows, support = follow_plan(robot, walker, trajectory, times, ITERATIONS)
    return Animation(robot, times, rows, Overlays("pelvis", tuple(support), tuple(support)),
                     "PlaCo walk pattern generator")
