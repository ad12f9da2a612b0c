"""The target set ``near_limits``: FK of uniform joints, ``joints`` of them then set to u - s (u - l) or
l + s (u - l) (a fair coin), s uniform in [0, ``fraction``]."""

from __future__ import annotations

import numpy as np

from wbik.geometry import TWO_PI
from wbik.robot import Chain
from wbik.schema import Text
from wbik.study.blocks import Block, fmt
from wbik.study.target_parameters import Parameter, integer, number
from wbik.study.target_sets import Drawing, TargetSetKind, target_stream


def limited_joints(chain: Chain) -> np.ndarray:
    """Indices of the joints whose limits restrict the pose: prismatic, or revolute with a range < 2 pi."""
    return np.flatnonzero(chain.is_prismatic | (chain.upper - chain.lower < TWO_PI - 1e-12))


def limit_distance(q: np.ndarray, chain: Chain) -> np.ndarray:
    """Per joint, the distance of q (..., n) to its nearer limit as a fraction of its range."""
    return np.minimum(q - chain.lower, chain.upper - q) / (chain.upper - chain.lower)


class NearLimits(TargetSetKind):
    """Targets from joints near their limits."""

    parameters = {
        "fraction": Parameter(0.02, "a number in (0, 0.5] (a share of the joint's range)",
                              number(0.0, 0.5, low_open=True), "how near a limit, as a share of the range"),
        "joints": Parameter(1, "an integer >= 1 (joints near a limit per target)", integer(1),
                            "joints put near a limit per target"),
        "eligible": Parameter("limited", "'limited' or 'all'", Text(("limited", "all")),
                              "which joints may be put near a limit"),
    }

    def eligible(self, chain: Chain, parameters: dict) -> tuple[np.ndarray, bool]:
        """(the joints that may be put near a limit, whether a chain without limited ones takes all)."""
        if parameters["eligible"] == "all":
            return np.arange(chain.nq), False
        limited = limited_joints(chain)
        return (limited, False) if len(limited) else (np.arange(chain.nq), True)

    def drawn_from(self, parameters: dict) -> str:
        count = parameters["joints"]
        share = 100 * parameters["fraction"]
        return (f"FK of uniform joints inside the limits, {count} joint{'s' if count > 1 else ''} of each "
                f"({parameters['eligible']} joints eligible) then set within {share:g} % of its range from a "
                f"limit")

    def draw(self, chain: Chain, count: int, seed: int, parameters: dict) -> Drawing:
        eligible, fell_back = self.eligible(chain, parameters)
        how_many = min(parameters["joints"], len(eligible))
        span = chain.upper - chain.lower
        q = np.empty((count, chain.nq))
        chosen = np.empty(count, dtype=int)
        for i in range(count):
            rng = target_stream(seed, self.target_set, i)
            q[i] = rng.uniform(chain.lower, chain.upper)
            joints = rng.choice(eligible, size=how_many, replace=False)
            share = rng.uniform(0.0, parameters["fraction"], size=how_many)
            upper = rng.random(how_many) < 0.5
            q[i, joints] = np.where(upper, chain.upper[joints] - share * span[joints],
                                    chain.lower[joints] + share * span[joints])
            chosen[i] = joints[0]
        nearest = np.min(limit_distance(q, chain), axis=1)
        return Drawing(q, {"joint": chosen, "limit_fraction": nearest},
                       {"eligible": [chain.joint_names[j] for j in eligible], "fell_back_to_all": fell_back,
                        "joints_per_target": how_many})

    def drawing_blocks(self, analysis: dict) -> list[Block]:
        facts, extras = analysis["facts"], analysis["extras"]
        if not facts:
            return []
        fell_back = (" (no joint of this chain has a range shorter than 2 pi: every joint is eligible, and a "
                     "pose near such a limit is also reached by an angle 2 pi away)")
        text = f"Eligible joints: {', '.join(facts['eligible'])}"
        text += (fell_back if facts["fell_back_to_all"] else "") + "."
        fraction = extras.get("limit_fraction")
        if fraction is not None and fraction.size:
            text += (f" Nearest limit per target, as a share of the joint's range: median "
                     f"{fmt(float(np.median(fraction)))}, max {fmt(float(np.max(fraction)))}.")
        return [Block("p", text)]


CASE_KINDS = (NearLimits("near_limits"),)
