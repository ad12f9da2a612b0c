"""The target set ``reach_boundary``: FK of joints maximising the tip's reach d . p(q) along a direction d
uniform on the sphere, over the joint box (L-BFGS-B, best of ``starts``; docs/guide/studies.md)."""

from __future__ import annotations

import numpy as np

from wbik.robot import Chain
from wbik.study.blocks import Block, fmt
from wbik.study.path_metrics import random_unit
from wbik.study.target_parameters import Parameter, integer
from wbik.study.target_sets import Drawing, TargetSetKind, target_stream


def reach_along(chain: Chain, direction: np.ndarray, q: np.ndarray) -> tuple[float, np.ndarray]:
    """(d . p(q), J_v(q)^T d): the tip's reach along ``direction`` and its gradient."""
    placement, jacobian = chain.fk_jacobian(q)
    return float(direction @ placement.translation), jacobian[:3].T @ direction


def stationarity_residual(chain: Chain, direction: np.ndarray, q: np.ndarray,
                          tolerance: float = 1e-9) -> float:
    """The largest violation of the first-order conditions of a maximum of d . p over the joint box."""
    gradient = reach_along(chain, direction, q)[1]
    at_upper = q >= chain.upper - tolerance
    at_lower = q <= chain.lower + tolerance
    violation = np.where(at_upper, np.maximum(-gradient, 0.0),
                         np.where(at_lower, np.maximum(gradient, 0.0), np.abs(gradient)))
    return float(np.max(violation))


def farthest_along(chain: Chain, direction: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """The best of L-BFGS-B's maximisers of d . p(q) over the joint box from each start."""
    from scipy.optimize import minimize

    bounds = list(zip(chain.lower, chain.upper, strict=True))
    best, best_value = starts[0], -np.inf

    def negative(q):
        value, gradient = reach_along(chain, direction, q)
        return -value, -gradient

    for start in starts:
        result = minimize(negative, start, jac=True, bounds=bounds, method="L-BFGS-B",
                          options={"maxiter": 500, "ftol": 1e-15, "gtol": 1e-10})
        q = np.clip(result.x, chain.lower, chain.upper)
        value = reach_along(chain, direction, q)[0]
        if value > best_value:
            best, best_value = q, value
    return best


class ReachBoundary(TargetSetKind):
    """Targets on the reach envelope."""

    parameters = {
        "starts": Parameter(4, "an integer >= 1 (L-BFGS-B starts per target)", integer(1, 1000),
                            "uniform starts of the maximisation per target"),
    }

    def drawn_from(self, parameters: dict) -> str:
        return (f"FK of joints maximising the tip's reach d . p(q) along a random direction d (L-BFGS-B over "
                f"the joint box, best of {parameters['starts']} uniform starts)")

    def draw(self, chain: Chain, count: int, seed: int, parameters: dict) -> Drawing:
        q = np.empty((count, chain.nq))
        directions = np.empty((count, 3))
        support, residual = np.empty(count), np.empty(count)
        for i in range(count):
            rng = target_stream(seed, self.target_set, i)
            direction = random_unit(rng)
            starts = rng.uniform(chain.lower, chain.upper, size=(parameters["starts"], chain.nq))
            q[i] = farthest_along(chain, direction, starts)
            directions[i] = direction
            support[i] = reach_along(chain, direction, q[i])[0]
            residual[i] = stationarity_residual(chain, direction, q[i])
        return Drawing(q, {"direction": directions, "support": support, "stationarity": residual},
                       {"method": "L-BFGS-B maximisation of d . p(q) over the joint box"})

    def drawing_blocks(self, analysis: dict) -> list[Block]:
        extras = analysis["extras"]
        if "stationarity" not in extras or not extras["stationarity"].size:
            return []
        residual, support = extras["stationarity"], extras["support"]
        return [Block("p", (
            f"Reach along the targets' directions d . p: median {fmt(float(np.median(support)))} m, max "
            f"{fmt(float(np.max(support)))} m. First-order conditions of the maximum at the targets' joints: "
            f"largest violation median {fmt(float(np.median(residual)))}, max {fmt(float(np.max(residual)))} "
            f"(m/rad; 0 at an exact critical point)."))]


CASE_KINDS = (ReachBoundary("reach_boundary"),)
