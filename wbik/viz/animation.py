"""``Animation``: what a scenario runner hands to the viewer: sample times (s; one sample: a still), the
full configuration at each, :class:`Overlays` and fixed boxes (three.js interpolates: give knots)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.viz.environment import SceneBox

Feet = tuple[str, ...]


def _per_sample(value, count: int, what: str) -> tuple[Feet, ...] | None:
    if value is None:
        return None
    rows = tuple(tuple(str(name) for name in entry) for entry in value)
    if len(rows) != count:
        raise InvalidConfigurationError(f"animation {what}: one entry per sample expected ({count}), "
                                        f"got {len(rows)}")
    return rows


@dataclass(frozen=True)
class PushArrow:
    """A push on ``frame`` from ``start_s`` to ``end_s`` (s), ``force_n`` (world, N), drawn as an arrow."""

    frame: str
    start_s: float
    end_s: float
    force_n: tuple[float, float, float]

    def __post_init__(self) -> None:
        force = np.asarray(self.force_n, dtype=float).reshape(-1)
        if force.shape != (3,) or not np.all(np.isfinite(force)) or not np.any(force):
            raise InvalidConfigurationError(f"a push needs a finite, non-zero force (x, y, z) in N, "
                                            f"got {self.force_n}")
        if not self.end_s >= self.start_s:
            raise InvalidConfigurationError(f"a push ends after it starts, got {self.start_s} to "
                                            f"{self.end_s} s")
        object.__setattr__(self, "force_n", tuple(float(f) for f in force))

    def shifted(self, seconds: float) -> PushArrow:
        return replace(self, start_s=self.start_s + seconds, end_s=self.end_s + seconds)


@dataclass(frozen=True)
class Overlays:
    """Drawn with the robot: ``trace_frame``'s path; per sample the soles down (``support``: with the CoM),
    the frames in ``contacts``, the ``zmp`` and the measured ``cop`` (K, 3; world, m; NaN rows for none);
    the ``pushes``."""

    trace_frame: str | None = None
    support: tuple[Feet, ...] | None = None
    contacts: tuple[Feet, ...] | None = None
    zmp: np.ndarray | None = None
    cop: np.ndarray | None = None
    pushes: tuple[PushArrow, ...] = ()


@dataclass(frozen=True)
class Animation:
    """Full configurations of ``robot`` at ``times`` (s), :class:`Overlays` and fixed boxes."""

    robot: object
    times: np.ndarray
    configurations: np.ndarray
    overlays: Overlays = field(default_factory=Overlays)
    name: str = ""
    environment: tuple[SceneBox, ...] = ()

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float).reshape(-1)
        rows = np.asarray(self.configurations, dtype=float)
        nq = self.robot.model.nq
        if rows.ndim != 2 or rows.shape != (len(times), nq):
            raise InvalidConfigurationError(
                f"animation {self.name!r}: {len(times)} times need {len(times)} configurations of "
                f"{nq} values ({self.robot.name}); got an array of shape {rows.shape}")
        if len(times) == 0:
            raise InvalidConfigurationError(f"animation {self.name!r} has no samples")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(rows))):
            raise InvalidConfigurationError(
                f"animation {self.name!r}: times and configurations must be finite")
        if np.any(np.diff(times) <= 0):
            raise InvalidConfigurationError(f"animation {self.name!r}: times must be strictly increasing")
        overlays = self.overlays
        points = {}
        for what in ("zmp", "cop"):
            value = getattr(overlays, what)
            points[what] = None if value is None else np.asarray(value, dtype=float)
            if value is not None and points[what].shape != (len(times), 3):
                raise InvalidConfigurationError(f"animation {self.name!r}: the {what.upper()} needs one "
                                                f"(x, y, z) per sample ({len(times)}, 3), got "
                                                f"{points[what].shape}")
        if not all(isinstance(push, PushArrow) for push in overlays.pushes):
            raise InvalidConfigurationError(f"animation {self.name!r}: pushes must be PushArrow")
        boxes = tuple(self.environment)
        if not all(isinstance(box, SceneBox) for box in boxes):
            raise InvalidConfigurationError(f"animation {self.name!r}: environment items must be SceneBox")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "configurations", rows)
        object.__setattr__(self, "environment", boxes)
        object.__setattr__(self, "overlays", replace(
            overlays, support=_per_sample(overlays.support, len(times), "support"),
            contacts=_per_sample(overlays.contacts, len(times), "contacts"), **points,
            pushes=tuple(overlays.pushes)))

    @property
    def frames(self) -> int:
        """Number of samples."""
        return len(self.times)

    @classmethod
    def from_chain(cls, robot, chain, times, rows, reference: np.ndarray | None = None,
                   overlays: Overlays | None = None, name: str = "") -> Animation:
        """Joint rows of one chain (others at ``reference``, default the nominal configuration)."""
        chain = robot.chain(chain) if isinstance(chain, str) or chain is None else chain
        reference = robot.nominal if reference is None else np.asarray(reference, dtype=float)
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        full = [chain.full_configuration(row, reference=reference) for row in rows]
        return cls(robot, times, np.array(full), overlays or Overlays(trace_frame=chain.tip_frame), name)

    @classmethod
    def from_keyframes(cls, robot, start: np.ndarray, keyframes: Sequence[np.ndarray],
                       seconds: float = 1.0, samples: int = 30, support: Sequence[Feet] | None = None,
                       contacts: Sequence[Feet] | None = None, trace_frame: str | None = None,
                       name: str = "") -> Animation:
        """From ``start`` through each keyframe (``seconds``, ``samples`` samples each, on the configuration
        manifold); ``support`` / ``contacts``: one entry per keyframe (the start takes the first's)."""
        if samples < 1 or not seconds > 0:
            raise InvalidConfigurationError(f"keyframe animation needs samples >= 1 and seconds > 0, "
                                            f"got {samples} and {seconds}")
        def per_sample(entries):
            if entries is None or not len(keyframes):
                return None
            return (entries[0], *(entry for entry in entries for _ in range(samples)))

        times, rows = [0.0], [np.asarray(start, dtype=float)]
        previous = rows[0]
        for index, q in enumerate(keyframes):
            q = np.asarray(q, dtype=float)
            for step in range(1, samples + 1):
                rows.append(pin.interpolate(robot.model, previous, q, step / samples))
                times.append((index + step / samples) * seconds)
            previous = q
        overlays = Overlays(trace_frame, per_sample(support), per_sample(contacts))
        return cls(robot, np.array(times), np.array(rows), overlays, name)

    def with_environment(self, boxes) -> Animation:
        """The same animation with the scene's fixed boxes ``boxes`` added (by name)."""
        merged = {box.name: box for box in (*self.environment, *boxes)}
        return replace(self, environment=tuple(merged.values()))

    def then(self, other: Animation, pause: float = 0.5) -> Animation:
        """This animation, then ``other`` starting ``pause`` s after this one ends."""
        if other.robot.model.nq != self.robot.model.nq or other.robot.name != self.robot.name:
            raise InvalidConfigurationError(
                f"cannot join animations of {self.robot.name} and {other.robot.name}")
        if not pause > 0:
            raise InvalidConfigurationError(f"pause between animations must be > 0 s, got {pause}")
        times = np.concatenate([self.times, other.times - other.times[0] + self.times[-1] + pause])

        def joined(overlay: str):  # both parts; where one has none: no feet, NaN ZMP rows
            parts = [(getattr(part.overlays, overlay), part.frames) for part in (self, other)]
            if all(value is None for value, _ in parts):
                return None
            if overlay in ("zmp", "cop"):
                return np.vstack([np.full((n, 3), np.nan) if value is None else value for value, n in parts])
            return sum((((),) * n if value is None else value for value, n in parts), ())

        later = tuple(push.shifted(times[self.frames] - other.times[0]) for push in other.overlays.pushes)
        overlays = Overlays(self.overlays.trace_frame or other.overlays.trace_frame, joined("support"),
                            joined("contacts"), joined("zmp"), joined("cop"), self.overlays.pushes + later)
        rows = np.vstack([self.configurations, other.configurations])
        name = " + ".join(n for n in (self.name, other.name) if n)
        both = replace(self, times=times, configurations=rows, overlays=overlays, name=name)
        return both.with_environment(other.environment)

    def subsampled(self, every: int) -> Animation:
        """Every ``every``-th sample (the last one kept)."""
        if int(every) != every or every < 1:
            raise InvalidConfigurationError(f"subsample step must be a positive integer, got {every}")
        index = np.unique(np.append(np.arange(0, self.frames, int(every)), self.frames - 1))

        def pick(rows):
            return None if rows is None else tuple(rows[i] for i in index)

        overlays = self.overlays
        return replace(self, times=self.times[index], configurations=self.configurations[index],
                       overlays=replace(overlays, support=pick(overlays.support),
                                        contacts=pick(overlays.contacts), zmp=pick(overlays.zmp),
                                        cop=pick(overlays.cop)))
