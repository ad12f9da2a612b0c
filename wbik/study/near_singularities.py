"""The target set ``near_singularities``: FK of joints where the smallest singular value of the chain's
6 x n Jacobian is below ``sigma_max``, reached by Newton steps from uniform joints (docs/guide/studies.md)."""

from __future__ import annotations

import numpy as np

from wbik.robot import Chain
from wbik.study.blocks import Block, fmt
from wbik.study.spec import StudyDefinitionError
from wbik.study.target_parameters import Parameter, integer, number
from wbik.study.target_sets import Drawing, TargetSetKind, target_stream

DIFFERENCE_STEP = 1e-6  # central-difference step of dJ/dq (rad or m)


def sigma_min(chain: Chain, q: np.ndarray) -> float:
    """The smallest singular value of the chain's 6 x n Jacobian at q."""
    return float(np.linalg.svd(chain.fk_jacobian(q)[1], compute_uv=False)[-1])


def sigma_min_gradient(chain: Chain, q: np.ndarray) -> tuple[float, np.ndarray]:
    """(sigma_min(q), its gradient): u^T (dJ/dq_k) v per joint, dJ/dq_k by central differences."""
    jacobian = chain.fk_jacobian(q)[1]
    left, values, right = np.linalg.svd(jacobian, full_matrices=False)
    u, v = left[:, -1], right[-1]
    gradient = np.array([u @ (chain.fk_jacobian(q + step)[1] - chain.fk_jacobian(q - step)[1]) @ v
                         for step in DIFFERENCE_STEP * np.eye(chain.nq)])
    return float(values[-1]), gradient / (2.0 * DIFFERENCE_STEP)


def drive_to_sigma(chain: Chain, q: np.ndarray, goal: float, bound: float,
                   steps: int) -> tuple[np.ndarray, float, int]:
    """Newton steps dq = -(sigma_min(q) - goal) g / |g|^2, clipped into the limits and halved until they
    help, until sigma_min < bound and |sigma_min - goal| <= bound / 10: (q, sigma_min(q), steps taken)."""
    sigma, gradient = sigma_min_gradient(chain, q)
    for step in range(steps):
        if sigma < bound and abs(sigma - goal) <= bound / 10.0:
            return q, sigma, step
        norm = float(gradient @ gradient)
        if not norm > 0.0:
            break
        delta = -(sigma - goal) * gradient / norm
        for _ in range(9):
            trial = np.clip(q + delta, chain.lower, chain.upper)
            trial_sigma = sigma_min(chain, trial)
            if abs(trial_sigma - goal) < abs(sigma - goal):
                break
            delta /= 2.0
        else:
            break
        q = trial
        sigma, gradient = sigma_min_gradient(chain, q)
    return q, sigma, steps


class NearSingularities(TargetSetKind):
    """Targets from joints near a singularity."""

    parameters = {
        "sigma_max": Parameter(1e-3, "a positive number (a bound on the Jacobian's smallest singular value)",
                               number(0.0, 1e3, low_open=True), "bound on sigma_min at the target's joints"),
        "steps": Parameter(30, "an integer >= 1 (Newton steps per start)", integer(1, 10000),
                           "Newton steps per start"),
        "attempts": Parameter(20, "an integer >= 1 (starts per target)", integer(1, 10000),
                              "uniform starts tried per target"),
    }

    def drawn_from(self, parameters: dict) -> str:
        return (f"FK of joints driven from uniform ones, by Newton steps on the smallest singular value of "
                f"the 6 x n Jacobian, below sigma_max = {parameters['sigma_max']:g}")

    def draw(self, chain: Chain, count: int, seed: int, parameters: dict) -> Drawing:
        bound = parameters["sigma_max"]
        q = np.empty((count, chain.nq))
        sigmas, goals = np.empty(count), np.empty(count)
        attempts_used, steps_used = np.empty(count, dtype=int), np.empty(count, dtype=int)
        for i in range(count):
            rng = target_stream(seed, self.target_set, i)
            goal = rng.uniform(0.0, bound)
            attempt, sigma = 0, np.inf
            while not sigma < bound:
                if attempt == parameters["attempts"]:
                    raise StudyDefinitionError(
                        f"near_singularities: target {i} of {chain.robot.name}.{chain.name}: no start of "
                        f"{parameters['attempts']} reached sigma_min < {bound:g} in {parameters['steps']} "
                        "Newton steps; raise targets.sigma_max, targets.steps or targets.attempts")
                attempt += 1
                start = rng.uniform(chain.lower, chain.upper)
                found, sigma, steps = drive_to_sigma(chain, start, goal, bound, parameters["steps"])
            q[i], sigmas[i], goals[i] = found, sigma, goal
            attempts_used[i], steps_used[i] = attempt, steps
        return Drawing(q, {"sigma_min": sigmas, "sigma_goal": goals, "attempts": attempts_used,
                           "steps": steps_used},
                       {"method": "Newton steps on sigma_min(q) = s, s uniform in [0, sigma_max), "
                                  "dJ/dq by central differences"})

    def drawing_blocks(self, analysis: dict) -> list[Block]:
        extras = analysis["extras"]
        if (sigma := extras.get("sigma_min")) is None or not sigma.size:
            return []
        bound = analysis["parameters"]["sigma_max"]
        attempts, steps = extras["attempts"], extras["steps"]
        return [Block("p", (
            f"Smallest singular value of the 6 x n Jacobian at the targets' joints: median "
            f"{fmt(float(np.median(sigma)))}, max {fmt(float(np.max(sigma)))} (bound {bound:g}); each "
            f"target's goal s uniform in [0, {bound:g}). Starts per target: mean "
            f"{fmt(float(np.mean(attempts)))}, max {int(np.max(attempts))}; Newton steps: median "
            f"{fmt(float(np.median(steps)))}, max {int(np.max(steps))}."))]


CASE_KINDS = (NearSingularities("near_singularities"),)
