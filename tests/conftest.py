"""Shared test fixtures."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


@pytest.fixture(scope="session")
def riveting_cell():
    """The UR5 riveting cell: (robot, scene, collision model, arm chain, joint limits, q at rivet home)."""
    import wbik
    from wbik.apps.riveting.collision import CollisionModel
    from wbik.apps.riveting.moves import Limits
    from wbik.apps.riveting.scene import build_scene

    robot = wbik.load("ur5")
    scene = build_scene()
    collision = CollisionModel(robot, scene)
    chain = robot.chain("arm")
    limits = Limits(chain.velocity_limit, 5.0)
    q_home = wbik.solver("analytic", robot, chain="arm").solve(scene.rivet_home, robot.nominal).q
    return robot, scene, collision, chain, limits, q_home


@pytest.fixture
def compiled_twins(monkeypatch):
    """The compiled kernels picked even in a ``WBIK_PURE_PYTHON=1`` run of the suite (for the tests that
    compare them with their Python twins: tests/compiled_twins.py)."""
    from wbik.kernels.twins import PURE_PYTHON_VARIABLE

    monkeypatch.delenv(PURE_PYTHON_VARIABLE, raising=False)


@pytest.fixture(scope="module")
def require_chromium() -> str:
    """Chromium's path; the browser tests fail (they do not skip) where the set-up did not install it."""
    from wbik.errors import MissingDependencyError
    from wbik.viz.browser import find_chromium

    try:
        return find_chromium()
    except MissingDependencyError as exc:
        pytest.fail(f"the browser tests need Chromium: {exc}")
