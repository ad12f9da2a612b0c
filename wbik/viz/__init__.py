"""Meshcat visualisation: :class:`Viewer` (robots, targets, CoM, animations; served or exported as HTML)."""

from wbik.viz.environment import SceneBox
from wbik.viz.scene import SceneRecorder, ServerWindow, scene_html
from wbik.viz.viewer import SupportView, Viewer

__all__ = ["SceneBox", "SceneRecorder", "ServerWindow", "SupportView", "Viewer", "scene_html"]
