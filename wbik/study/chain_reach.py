"""An upper bound of a chain's reach: no joint values (revolute angles inside their limits or not,
prismatic joints inside theirs) put the tip farther than ``radius`` from ``centre``.

Proof (triangle inequality). With o_j the origins of the chain's joint frames (joint j's frame is its
parent's moved by the fixed placement (R_j, t_j), then by the joint's motion) and p the tip's origin,

    o_j - o_{j-1} = R_{j-1}(q) t_j + [prismatic j] q_j a_j,    p - o_k = R_k(q) t_tip,

so |p - c| <= [prismatic 1] s_1 + sum_{j=2..k} (|t_j| + [prismatic j] s_j) + |t_tip| = radius, with c the
first joint's origin at q_1 = 0 (a revolute first joint does not move it) and s_j = max(|l_j|, |u_j|).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.robot import Chain


@dataclass(frozen=True)
class ReachBound:
    """|p(q) - centre| <= radius (base frame, m); ``lengths``: the terms of the sum, then the tip's offset."""

    centre: np.ndarray
    radius: float
    lengths: tuple[float, ...]


def reach_bound(chain: Chain) -> ReachBound:
    """The chain's reach bound (module docstring), from its reduced model."""
    model = chain.model
    tip = model.frames[chain.tip_id]
    path = []
    joint = tip.parentJoint
    while joint > 0:
        path.append(joint)
        joint = model.parents[joint]
    path.reverse()
    travel = np.maximum(np.abs(chain.lower), np.abs(chain.upper))
    index = {model.getJointId(name): k for k, name in enumerate(chain.joint_names)}
    lengths = []
    for position, joint in enumerate(path):
        link = 0.0 if position == 0 else float(np.linalg.norm(model.jointPlacements[joint].translation))
        slide = float(travel[index[joint]]) if chain.is_prismatic[index[joint]] else 0.0
        lengths.append(link + slide)
    lengths.append(float(np.linalg.norm(tip.placement.translation)))
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    first = data.oMi[path[0]] if path else pin.SE3.Identity()
    if path and chain.is_prismatic[index[path[0]]]:  # the first origin at q_1 = 0
        first = data.oMi[model.parents[path[0]]] * model.jointPlacements[path[0]]
    centre = chain.base_placement.actInv(first.translation)
    return ReachBound(np.asarray(centre, dtype=float), float(sum(lengths)), tuple(lengths))
