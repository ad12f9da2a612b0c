"""Scene.hole: lookup by name, and the error for a name the scene does not have."""

import pytest

from wbik.apps.riveting.scene import build_scene
from wbik.errors import InvalidConfigurationError


def test_hole_by_name():
    scene = build_scene()
    assert [scene.hole(hole.name) for hole in scene.holes] == scene.holes


def test_unknown_hole_names_the_range():
    scene = build_scene()
    with pytest.raises(InvalidConfigurationError, match=r"no hole 'h99'; holes are h0\.\.h32"):
        scene.hole("h99")
