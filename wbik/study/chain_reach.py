"""An upper bound of a chain's reach for any revolute angles (prismatic joints inside their limits), by
the triangle inequality over o_j - o_{j-1} = R_{j-1}(q) t_j + [prismatic j] q_j a_j and p - o_k = R_k t_tip:
|p - c| <= [prismatic 1] s_1 + sum_{j=2..k} (|t_j| + [prismatic j] s_j) + |t_tip|, with o_j the joint
origins, c the first one at q_1 = 0 and s_j = max(|l_j|, |u_j|)."""

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
    """The chain's reach bound, from its reduced model."""
    model = chain.model
    tip = model.frames[chain.tip_id]
    path = list(model.supports[tip.parentJoint])[1:]  # the joints from the root to the tip's
    travel = np.maximum(np.abs(chain.lower), np.abs(chain.upper))
    index = {model.getJointId(name): k for k, name in enumerate(chain.joint_names)}
    lengths = [(0.0 if position == 0 else float(np.linalg.norm(model.jointPlacements[joint].translation)))
               + (float(travel[index[joint]]) if chain.is_prismatic[index[joint]] else 0.0)  # link + slide
               for position, joint in enumerate(path)]
    lengths.append(float(np.linalg.norm(tip.placement.translation)))
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    first = data.oMi[path[0]] if path else pin.SE3.Identity()
    if path and chain.is_prismatic[index[path[0]]]:  # the first origin at q_1 = 0
        first = data.oMi[model.parents[path[0]]] * model.jointPlacements[path[0]]
    centre = chain.base_placement.actInv(first.translation)
    return ReachBound(np.asarray(centre, dtype=float), float(sum(lengths)), tuple(lengths))
