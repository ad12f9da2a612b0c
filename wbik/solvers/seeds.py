"""The seed sets of ``bounded_lm``'s restarts, built once per chain from a fixed random stream: a seed's
distance^2 to a target is w^2 |p* - p_i|^2 + 3 - trace(R*^T R_i) (~ angle^2), w the position weight.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from wbik.solvers.levenberg_marquardt import JointBounds
from wbik.solvers.vectorised_chain import VectorisedChain
from wbik.targets import Target

_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class SeedLibrary:
    """Configurations q (N, n) and k-d trees over their tip poses in the base frame: ``pose_tree`` on
    [w p, R / sqrt 2] (Euclidean distance^2 = the distance^2 above), ``position_tree`` on w p."""

    q: np.ndarray
    pose_tree: cKDTree
    position_tree: cKDTree

    def query(self, position: np.ndarray, rotation: np.ndarray | None, weight: float, count: int):
        """cKDTree.query's (distances, indices) of the ``count`` entries nearest one target or each of B."""
        point = weight * position
        if rotation is None:
            return self.position_tree.query(point, k=count)
        rows = rotation.reshape(point.shape[:-1] + (9,)) / math.sqrt(2)
        return self.pose_tree.query(np.concatenate((point, rows), axis=-1), k=count)


def seed_library(chain, size: int, weight: float, kinematics: VectorisedChain | None) -> SeedLibrary:
    """The chain's library of ``size`` uniform configurations, cached per (chain, size, weight)."""
    cache = _CACHE.setdefault(chain, {})
    key = ("library", size, weight)
    if key not in cache:
        q = chain.random(np.random.default_rng(size), size)
        tips = kinematics.tip_poses(q) if size and kinematics is not None else np.zeros((0, 4, 4))
        positions = weight * tips[:, :3, 3]
        rotations = tips[:, :3, :3].reshape(-1, 9) / math.sqrt(2)
        cache[key] = SeedLibrary(q[:len(tips)], cKDTree(np.hstack((positions, rotations)).reshape(-1, 12)),
                                 cKDTree(positions.reshape(-1, 3)))
    return cache[key]


@dataclass(frozen=True)
class SeedTable:
    """Configurations q (N, n) searched by brute force: distance^2 = offset_i - features_i . [w p*, vec R*] +
    w^2 |p*|^2 + 3, features_i = [2 w p_i, vec R_i], offset_i = w^2 |p_i|^2."""

    q: np.ndarray
    features: np.ndarray  # (N, 12)
    position_features: np.ndarray  # (N, 3): 2 w p_i, contiguous
    offsets: np.ndarray  # (N,)

    def nearest_rows(self, positions: np.ndarray, rotations: np.ndarray | None, weight: float,
                     chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
        """The entry nearest each of B targets and its distance^2: (q (B, n), (B,))."""
        if not len(self.q):
            return self.q[:0], np.zeros(0)
        weighted = weight * positions
        queries = weighted if rotations is None else np.hstack((weighted, rotations.reshape(-1, 9)))
        features = self.position_features if rotations is None else self.features
        constant = np.einsum("bi,bi->b", weighted, weighted) + (0.0 if rotations is None else 3.0)
        best = np.empty(len(positions), dtype=int)
        for begin in range(0, len(positions), chunk):  # scores (chunk, N): row-wise argmin, in cache
            scores = queries[begin:begin + chunk].dot(features.T)
            np.subtract(self.offsets, scores, out=scores)
            best[begin:begin + chunk] = np.argmin(scores, axis=1)
        distances2 = (self.offsets[best] - np.einsum("bi,bi->b", features[best], queries)) + constant
        return self.q[best], distances2

    def nearest(self, target: Target, weight: float) -> tuple[np.ndarray, float]:
        """The entry nearest a target (pose distance, or position only) and its distance^2."""
        position = weight * target.position
        if target.rotation is None:
            scores = self.offsets - self.position_features.dot(position)
            constant = float(position.dot(position))
        else:
            scores = self.offsets - self.features.dot(np.concatenate((position, target.rotation.reshape(9))))
            constant = float(position.dot(position)) + 3.0
        index = int(np.argmin(scores))
        return self.q[index], float(scores[index]) + constant


def seed_table(chain, size: int, weight: float, kinematics: VectorisedChain | None,
               margin: float) -> SeedTable:
    """The chain's table, cached: ``size`` configurations uniform inside the limits shrunk by ``margin`` x
    the range at both ends (full-turn joints: the whole turn)."""
    cache = _CACHE.setdefault(chain, {})
    key = ("table", size, weight, margin)
    if key not in cache:
        bounds = JointBounds.of_chain(chain)
        inset = np.where(bounds.wraps, 0.0, margin * (chain.upper - chain.lower))
        q = np.random.default_rng([size, 1]).uniform(chain.lower + inset, chain.upper - inset,
                                                     size=(size, chain.nq))
        tips = kinematics.tip_poses(q) if size and kinematics is not None else np.zeros((0, 4, 4))
        positions = weight * tips[:, :3, 3]
        features = np.hstack((2.0 * positions, tips[:, :3, :3].reshape(-1, 9))).reshape(-1, 12)
        cache[key] = SeedTable(q[:len(tips)], features, np.ascontiguousarray(features[:, :3]),
                               np.einsum("bi,bi->b", positions, positions))
    return cache[key]
