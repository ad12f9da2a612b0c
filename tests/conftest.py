"""Shared test fixtures."""

from __future__ import annotations

import numpy as np
import pytest

LONGEST_FILES = ("test_view_every_task.py", "test_notebooks.py", "test_browser.py", "test_core_install.py",
                 "test_installed.py", "test_study_run.py", "test_study_budget_curves.py",
                 "test_hostile_study_files.py", "test_study_target_sets.py", "test_robust_numerics.py",
                 "test_study_compare.py", "test_walk_physics.py", "test_bioloid_stairs.py",
                 "test_riveting_full.py", "test_hostile_input.py", "test_docs.py",
                 "test_study_ownership.py", "test_robot_zoo.py", "test_walking.py",
                 "test_analytic_nearby_arm.py", "test_study_protocols.py", "test_riveting_cycle.py",
                 "test_scenario_kinds.py")
"""The test files that take longest (10-50 s each on one core, measured with --durations=0), longest first."""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The longest files first, the others in their order: each file runs on one worker (``--dist
    loadfile``, pyproject.toml), and a long file handed out last would leave the other workers idle."""
    rank = {name: index for index, name in enumerate(LONGEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: each file keeps its order


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
