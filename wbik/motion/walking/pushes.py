"""Pushes on a walking robot in physics: the stated push in each direction during a single support, and the
largest impulse a controller recovers from (no fall), by bisection."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from wbik.errors import InvalidSettingError
from wbik.motion.walking.physics import Measured, Push, Simulation
from wbik.motion.walking.placo_pattern import PlacoWalk
from wbik.motion.walking.stabiliser import (
    PhysicsSettings,
    play_closed_loop,
    play_open_loop,
)
from wbik.motion.walking.tracking import Tracker, WalkMotion
from wbik.viz.animation import PushArrow

DIRECTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}
"""Push directions in the frame of the walk's start heading (x ahead, y to the left)."""

Play = Callable[[Push | None], tuple[Simulation, Measured]]
"""One run of a walk in a fresh scene, pushed or not."""


@dataclass(frozen=True)
class PushSettings:
    """A push of ``impulse_n_s`` (N s) over ``duration_s`` (s) on the trunk, starting ``phase`` (0 to 1) into
    the walk's ``step``-th single support (1: the first), in each of ``directions``; the largest recovered
    searched in [0, ``search_up_to_n_s``] to ``resolution_n_s`` (N s)."""

    impulse_n_s: float
    step: int = 2
    phase: float = 0.5
    duration_s: float = 0.1
    directions: tuple[str, ...] = ("forward", "left")
    search_up_to_n_s: float = 0.0
    resolution_n_s: float = 0.0

    def __post_init__(self) -> None:
        unknown = [d for d in self.directions if d not in DIRECTIONS]
        if unknown:
            raise InvalidSettingError(f"push directions are among {sorted(DIRECTIONS)}, got {unknown}")
        if self.search_up_to_n_s > 0 and not self.resolution_n_s > 0:
            raise InvalidSettingError("a search for the largest push recovered needs resolution_n_s > 0")


def single_supports(support: list[tuple]) -> list[tuple[int, int]]:
    """(first tick, tick after the last) of each single support in a walk's soles down per tick."""
    spans, start = [], None
    for k, soles in enumerate([*support, ()]):
        if len(soles) == 1 and start is None:
            start = k
        elif len(soles) != 1 and start is not None:
            spans.append((start, k))
            start = None
    return spans


def push_in(settings: PushSettings, support: list[tuple], dt: float, body: str, heading: float,
            direction: str, impulse: float) -> Push:
    """The push ``direction`` of a walk whose soles down per tick are ``support`` (every ``dt`` s), its start
    heading ``heading`` (rad)."""
    spans = single_supports(support)
    if not 1 <= settings.step <= len(spans):
        raise InvalidSettingError(f"push step {settings.step}: the walk has {len(spans)} single supports")
    first, after = spans[settings.step - 1]
    x, y = DIRECTIONS[direction]
    cos, sin = math.cos(heading), math.sin(heading)
    return Push(body, (cos * x - sin * y, sin * x + cos * y), impulse,
                dt * (first + settings.phase * (after - first)), settings.duration_s)


def largest_recovered(recovers: Callable[[float], bool], up_to: float, resolution: float) -> float:
    """The largest impulse in [0, ``up_to``] ``recovers`` holds for, to ``resolution`` (bisection: recovery
    taken as monotonic in the impulse)."""
    if recovers(up_to):
        return up_to
    low, high = 0.0, up_to
    while high - low > resolution:
        middle = 0.5 * (low + high)
        low, high = (middle, high) if recovers(middle) else (low, middle)
    return low


def push_figures(play: Play, settings: PushSettings, support: list[tuple], dt: float, body: str,
                 heading: float, stated: bool = True) -> tuple[dict, Measured | None]:
    """Per direction: the run with the stated push (``stated``) and the largest push recovered; and the first
    stated run, its push recorded as an arrow on ``body``."""
    found: dict = {}
    first: Measured | None = None
    for direction in settings.directions:
        def push(impulse: float, direction: str = direction) -> Push:
            return push_in(settings, support, dt, body, heading, direction, impulse)

        entry = found.setdefault(direction, {})
        if stated:
            applied = push(settings.impulse_n_s)
            measured = play(applied)[1]
            entry.update(push_impulse_n_s=applied.impulse_n_s, at_s=applied.at_s, **measured.figures())
            if first is None and applied.impulse_n_s > 0:
                first = measured
                force = applied.force(applied.at_s, applied.duration_s)
                measured.pushes.append(PushArrow(body, applied.at_s, applied.at_s + applied.duration_s,
                                                 tuple(force.tolist())))
        if settings.search_up_to_n_s > 0:
            entry["largest_push_recovered_n_s"] = largest_recovered(
                lambda impulse, push=push: play(push(impulse))[1].fell_at_s is None,
                settings.search_up_to_n_s, settings.resolution_n_s)
    return found, first


def push_description(settings: PushSettings, body: str) -> dict:
    """The push as reported: its settings and the body pushed."""
    return {**asdict(settings), "directions": list(settings.directions), "body": body}


def players(motion: WalkMotion, new_tracker: Callable[[], Tracker], q0, settings: PhysicsSettings,
            placo: dict[str, PlacoWalk], lead: np.ndarray | None = None) -> dict[str, Play]:
    """The runs of a walk in physics: ``closed_loop`` (the stabiliser, a fresh ``new_tracker()``),
    ``open_loop`` (the planned joints) and each of ``placo``'s walks played open loop."""
    pattern = motion.pattern

    def scene(q_start, push: Push | None) -> Simulation:
        sim = settings.simulation(pattern.robot, q_start, pattern.ground_z)
        sim.push = push
        return sim

    def closed(push: Push | None):
        sim = scene(motion.q[0], push)
        return sim, play_closed_loop(sim, new_tracker(), pattern, q0, settings.gains, settings.settle_s,
                                     lead, settings.step_adaptation)[0]

    def planned(q, dt: float, lead: np.ndarray | None = None) -> Play:
        def play(push: Push | None):
            sim = scene(q[0], push)
            return sim, play_open_loop(sim, dt, q, settings.settle_s, lead)
        return play

    return {"closed_loop": closed, "open_loop": planned(motion.q, pattern.dt, lead),
            **{label: planned(walk.q, float(walk.times[1] - walk.times[0])) for label, walk in placo.items()}}


def physics_compared(physics: dict, plays: dict[str, Play], walks: dict[str, tuple[list, float, np.ndarray]],
                     push: PushSettings | None, body: str, heading: float) -> Measured | None:
    """Into a walk's ``physics`` figures: each compared run's unpushed figures (``compared``: the plays other
    than ``closed_loop`` and ``open_loop``), and with a ``push`` per run and direction the largest push
    recovered (and the closed loop's run with the stated push); ``walks[label]``: (soles down per tick,
    dt (s), planned q). Returns the closed loop's first run with the stated push (None without one)."""
    shown = None
    for label, play in plays.items():
        if label == "closed_loop":
            target = physics
        elif label == "open_loop":
            target = physics["open_loop"]
        else:
            sim, measured = play(None)
            q = walks[label][2]
            target = physics.setdefault("compared", {})[label] = {
                **measured.figures(), "base_travel_m": float(np.linalg.norm(sim.state()[0][:2] - q[0][:2])),
                "planned_travel_m": float(np.linalg.norm(q[-1][:2] - q[0][:2]))}
        if push is None:
            continue
        support, dt, _ = walks[label]
        found, first = push_figures(play, push, support, dt, body, heading, stated=label == "closed_loop")
        if label == "closed_loop":
            target["pushed"], shown = found, first
        if push.search_up_to_n_s > 0:
            target["largest_push_recovered_n_s"] = {direction: figures.get("largest_push_recovered_n_s")
                                                for direction, figures in found.items()}
    return shown
