"""Trajectories: joint and Cartesian paths, time laws, time scaling, the trajectory object.

>>> import numpy as np, wbik
>>> from wbik import motion
>>> robot = wbik.load("arm3r")
>>> solver = wbik.solver("dls", robot)
>>> path = motion.waypoint_path(solver, np.full(3, np.pi / 2), [(2, -3, 3), (0, -2, 2)], samples=10)
>>> trajectory = motion.make_trajectory(motion.time_scale(path, "quintic", velocity_limit=1.0))
"""

from wbik.motion.cartesian import FunctionReference, PolylineReference, follow, linear_path, waypoint_path
from wbik.motion.joint import joint_path
from wbik.motion.path import JointPath, tracking_errors
from wbik.motion.profiles import LAWS, TimeLaw, time_law
from wbik.motion.timing import TimedPath, time_scale
from wbik.motion.trajectory import Trajectory, make_trajectory

__all__ = ["LAWS", "FunctionReference", "JointPath", "PolylineReference", "TimeLaw", "TimedPath",
           "Trajectory", "follow", "joint_path", "linear_path", "make_trajectory", "time_law",
           "time_scale", "tracking_errors", "waypoint_path"]
