"""Every scenario file in tasks/ runs as shipped, passes its expectations and can be watched: its
runner's report carries an animation, and the exported HTML page holds the robot's meshes and one
animation key per sample for every robot geometry (helpers: tests/scenario_pages.py).

Outputs the runners would write (servo tables, trajectories, riveting reports) are sent to tmp_path.
Two files are watched elsewhere, with the same checks, by the tests that run them anyway:
bioloid_stairs.yaml (tests/test_bioloid_stairs.py) and ur5_riveting.yaml, whose three planners run
300 s of simulated time each (minutes): here it plays its documented shorter variant (``max_cycles:
1``, the first planner only, no expectations; the animation shows the first planner's first 40 s
either way), and its full run's verdict is scripts/riveting_full_run.py's. The push files (a walk whose
``physics.push`` searches for the largest push recovered: a bisection of a minute or more) play their stated
push in its first direction only, without the search and PlaCo's comparison, and Talos's walk file without
PlaCo's comparison; their full runs are ``wbik run``'s.
"""

from __future__ import annotations

import pytest
from scenario_pages import TASKS, check_page, check_support, quiet_spec, watch

TASK_FILES = sorted(TASKS.glob("*.yaml"))
RIVETING = TASKS / "ur5_riveting.yaml"
WATCHED_ELSEWHERE = (RIVETING, TASKS / "bioloid_stairs.yaml")


@pytest.mark.parametrize("path", [p for p in TASK_FILES if p not in WATCHED_ELSEWHERE], ids=lambda p: p.stem)
def test_every_task_file_passes_and_is_watchable(path, tmp_path):
    spec = stated_pushes_only(quiet_spec(path, tmp_path))
    report, animation, viewer, commands, size = watch(path, spec, tmp_path)
    assert report.passed, f"{path.name}: {report.verdict}"
    if spec["kind"] == "walk":  # every walk of the file (straight, turning, sideways, ...) judged and met
        walks = report.as_dict()["walks"]
        assert len(walks) == len(spec["walks"]) and all(walk["verdict"] == "PASSED" for walk in walks)
    assert report.animation is animation and report.as_dict()["animation_frames"] == animation.frames
    if spec["kind"] == "bioloid_stance_sensors":
        assert animation.frames == 1
    else:
        assert animation.frames >= 20 and animation.times[-1] > animation.times[0]
    check_page(animation, viewer, commands, size)
    check_support(animation, commands)
    if spec["kind"] in ("bioloid_walk", "bioloid_turn") or spec.get("generators") == ["wholebody"]:
        # whole-body samples: every sole the animation calls down is on the floor (z = 0)
        robot = animation.robot
        heights = [abs(robot.frame_placement(q, sole).translation[2])
                   for q, feet in zip(animation.configurations, animation.overlays.support, strict=True)
                   for sole in feet]
        assert len(heights) >= animation.frames and max(heights) < 1e-6


def stated_pushes_only(spec: dict) -> dict:
    """A walk file with pushes: its first stated push, not the other directions, the search for the largest
    nor PlaCo's walks; Talos's walk file without PlaCo's walks (each also played in physics, a minute of the
    suite; the Bioloid's file keeps them, so PlaCo's comparison and its physics runs stay covered)."""
    physics = spec.get("physics") or {} if spec["kind"] == "walk" else {}
    push = physics.get("push")
    if push is not None:
        push["search_up_to_n_s"] = 0.0
        push["directions"] = push["directions"][:1]
    if push is not None or (physics and spec["robot"] != "bioloid"):
        for walk in spec["walks"]:
            walk["compare"] = []
    return spec


def test_riveting_short_variant_is_watchable(tmp_path):
    spec = quiet_spec(RIVETING, tmp_path)
    spec.update(max_cycles=1, planners=spec["planners"][:1], expect=None)
    report, animation, viewer, commands, size = watch(RIVETING, spec, tmp_path)
    assert animation.name == f"riveting, {spec['planners'][0]['name']}"
    assert 100 < animation.frames <= 401
    check_page(animation, viewer, commands, size)

