"""Visualisation in meshcat: :class:`Viewer` draws robots, frames, IK targets, the CoM and support polygon
and animations, with or without a server, and exports them as self-contained HTML pages."""

from wbik.viz.environment import SceneBox
from wbik.viz.scene import SceneRecorder, ServerWindow, scene_html
from wbik.viz.viewer import SupportView, Viewer

__all__ = ["SceneBox", "SceneRecorder", "ServerWindow", "SupportView", "Viewer", "scene_html"]
