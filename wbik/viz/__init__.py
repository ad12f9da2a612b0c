"""Visualisation in meshcat: robots, frames, IK targets, CoM and support polygon, animations.

``Viewer`` draws a scene (with or without a meshcat server); ``Viewer.export_html`` writes it as
one self-contained HTML page; ``wbik.viz.browser`` renders such a page with headless Chromium;
``wbik.viz.environment`` holds the fixed boxes drawn around a robot (a staircase, a table).
"""

from wbik.viz.environment import SceneBox
from wbik.viz.scene import SceneRecorder
from wbik.viz.scene import ServerWindow
from wbik.viz.scene import scene_html
from wbik.viz.viewer import SupportView
from wbik.viz.viewer import Viewer

__all__ = ["SceneBox", "SceneRecorder", "ServerWindow", "SupportView", "Viewer", "scene_html"]
