"""Trajectories: joint and Cartesian paths, time laws, time scaling, the trajectory object.

>>> import numpy as np, wbik
>>> from wbik import motion
>>> robot = wbik.load("arm3r")
>>> solver = wbik.solver("dls", robot)
>>> path = motion.waypoint_path(solver, np.full(3, np.pi / 2), [(2, -3, 3), (0, -2, 2)], samples=10)
>>> trajectory = motion.make_trajectory(motion.time_scale(path, "quintic", velocity_limit=1.0))
"""

from wbik.motion.cartesian import FunctionReference
from wbik.motion.cartesian import PolylineReference
from wbik.motion.cartesian import follow
from wbik.motion.cartesian import linear_path
from wbik.motion.cartesian import waypoint_path
from wbik.motion.joint import joint_path
from wbik.motion.path import JointPath
from wbik.motion.path import tracking_errors
from wbik.motion.profiles import LAWS
from wbik.motion.profiles import TimeLaw
from wbik.motion.profiles import time_law
from wbik.motion.timing import TimedPath
from wbik.motion.timing import time_scale
from wbik.motion.trajectory import Trajectory
from wbik.motion.trajectory import make_trajectory

__all__ = ["LAWS", "FunctionReference", "JointPath", "PolylineReference", "TimeLaw", "TimedPath",
           "Trajectory", "follow", "joint_path", "linear_path", "make_trajectory", "time_law",
           "time_scale", "tracking_errors", "waypoint_path"]
