"""The poses of a study: FK of joint vectors uniform inside the limits (``default_rng(seed)``: pose i
depends on the seed and the chain only, so pose and position studies of a seed share positions), so
every pose has a solution; start configurations from ``default_rng([seed, 1])``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wbik.files import atomic_write_bytes
from wbik.robot import Chain


@dataclass
class PoseSet:
    """N sampled poses: the joints they came from, the targets and the start configurations."""

    q_true: np.ndarray  # (N, n)
    positions: np.ndarray  # (N, 3)
    rotations: np.ndarray | None  # (N, 3, 3), None for position-only targets
    q0: np.ndarray  # (N, n)

    def __len__(self) -> int:
        return len(self.q_true)

    def saved_arrays(self) -> dict[str, np.ndarray]:
        """The arrays :meth:`save` writes, by name: q_true, positions, q0 and rotations (when given)."""
        rotations = {} if self.rotations is None else {"rotations": self.rotations}
        return {"q_true": self.q_true, "positions": self.positions, "q0": self.q0, **rotations}

    def save(self, path: Path) -> None:
        """Write :meth:`saved_arrays` atomically (temporary file renamed into place)."""
        atomic_write_bytes(path, lambda handle: np.savez(handle, **self.saved_arrays()))

    @classmethod
    def load(cls, path: Path) -> PoseSet:
        with np.load(path) as data:
            return cls(data["q_true"], data["positions"],
                       data["rotations"] if "rotations" in data else None, data["q0"])


def saved_extras(path: Path, prefix: str) -> dict[str, np.ndarray]:
    """The arrays saved beside a case's poses under names ``prefix<name>``, by name ({} if none)."""
    if not path.is_file():
        return {}
    with np.load(path, allow_pickle=False) as data:
        return {key[len(prefix):]: data[key] for key in data.files if key.startswith(prefix)}


def sample_joints(chain: Chain, count: int, seed: int) -> np.ndarray:
    """(count, n) joint vectors uniform inside the chain's limits."""
    return chain.random(np.random.default_rng(seed), count)


def start_configurations(chain: Chain, count: int, seed: int, start: str) -> np.ndarray:
    """(count, n) q0: the chain's nominal, its mid-range, or uniform random inside the limits."""
    if start in ("nominal", "mid_range"):
        return np.tile(getattr(chain, start), (count, 1))
    if start == "random":
        return chain.random(np.random.default_rng([seed, 1]), count)
    raise ValueError(f"unknown start {start!r}: nominal, mid_range or random")


def poses_of_joints(chain: Chain, q_true: np.ndarray, seed: int, target: str = "pose",
                    start: str = "nominal") -> PoseSet:
    """The targets of kind "pose" or "position" that FK of the joint vectors ``q_true`` (count, n)
    reaches, with the study's start configurations."""
    count = len(q_true)
    placements = [chain.fk(q) for q in q_true]
    positions = np.array([placement.translation for placement in placements], dtype=float).reshape(count, 3)
    rotations = np.array([placement.rotation for placement in placements], dtype=float).reshape(count, 3, 3)
    return PoseSet(q_true, positions, rotations if target == "pose" else None,
                   start_configurations(chain, count, seed, start))
