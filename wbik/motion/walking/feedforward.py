"""What the cart-table model leaves out of a walk, fed forward into its ZMP reference from the plan (the
footsteps and the swing trajectories, as the preview already reads them; never the tracked motion): a start
from rest, and the angular momentum of the swinging leg."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.motion.walking.footsteps import SIDES, Feet
from wbik.motion.walking.preview import GRAVITY
from wbik.robot import Robot

ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def rest_start(reference: np.ndarray, com: np.ndarray, ticks: int, omega: float, dt: float) -> np.ndarray:
    """The first ``ticks`` samples (the start's double support) of ``reference`` (K, 2) as p = xi - xi'/omega,
    xi a quintic from rest at the CoM ``com`` to the divergent component of the rest of the reference,
    xi_s = omega int_0^inf exp(-omega s) p_ref(T_s + s) ds, reached with xi' = omega (xi_s - p_ref(T_s)),
    xi'' = omega xi': the pendulum tracking it leaves rest without the jolt of a reference that starts
    moving at once, and meets the reference at T_s."""
    later = reference[ticks:]
    weights = omega * dt * np.exp(-omega * dt * np.arange(len(later)))
    weights[0] *= 0.5  # the trapezoid rule; normalised below (the reference ends)
    divergent = weights @ later / weights.sum()
    speed = omega * (divergent - reference[ticks])
    xi, xi_rate = quintic_between((com[:2], (0.0, 0.0), (0.0, 0.0)), (divergent, speed, omega * speed),
                                  ticks * dt, dt * np.arange(ticks))
    shaped = reference.copy()
    shaped[:ticks] = xi - xi_rate / omega
    return shaped


def quintic_between(start, end, duration: float, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The quintic x(t) with (x, x', x'') = ``start`` at 0, ``end`` at ``duration``: x and x' at ``times``."""
    t = duration
    conditions = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0],
                           [1, t, t ** 2, t ** 3, t ** 4, t ** 5],
                           [0, 1, 2 * t, 3 * t ** 2, 4 * t ** 3, 5 * t ** 4],
                           [0, 0, 2, 6 * t, 12 * t ** 2, 20 * t ** 3]], dtype=float)
    coefficients = np.linalg.solve(conditions, np.vstack([*start, *end]))
    powers = np.vander(times, 6, increasing=True)
    rates = np.column_stack([np.zeros_like(times), *(n * powers[:, n - 1] for n in range(1, 6))])
    return powers @ coefficients, rates @ coefficients


class SwingMomentum:
    """The ZMP shift of the swing foot's planned motion, d = (-L'_y, L'_x) / (m g): with the centroidal map
    A_ang and the task Jacobians frozen at ``q0`` (CoM, swing foot, trunk rotation, stance foot; the ``held``
    joints left out), the swing foot's twist V makes the angular momentum L = H V, H = A_ang A^+ (its swing
    columns); H is turned with the walk's heading."""

    def __init__(self, robot: Robot, q0: np.ndarray, feet: Feet, trunk: str, held: tuple[str, ...] = ()):
        model, data = robot.model, robot.model.createData()
        fixed = {model.joints[model.getJointId(name)].idx_v for name in held}
        free = [index for index in range(model.nv) if index not in fixed]
        pin.computeJointJacobians(model, data, q0)
        pin.updateFramePlacements(model, data)
        momentum = pin.computeCentroidalMap(model, data, q0)[3:, free]
        com = pin.jacobianCenterOfMass(model, data, q0, False)[:, free]
        trunk_rotation = pin.getFrameJacobian(model, data, model.getFrameId(trunk), ALIGNED)[3:, free]
        sole = {side: pin.getFrameJacobian(model, data, model.getFrameId(feet.frame(side)), ALIGNED)[:, free]
                for side in SIDES}
        self.weight = robot.mass * GRAVITY
        self.swing_map = {side: (momentum @ np.linalg.pinv(np.vstack(
            [com, sole[side], trunk_rotation, sole["right" if side == "left" else "left"]])))[:, 3:9]
            for side in SIDES}

    def zmp_shift(self, swing: list[str | None], swing_poses: list[pin.SE3 | None], heading: np.ndarray,
                  dt: float) -> np.ndarray:
        """The shift (K, 2) to add to the reference of ticks whose swinging side is ``swing[k]`` and swing
        pose ``swing_poses[k]``, the heading turned by ``heading[k]`` (rad) since the start."""
        count = len(swing)
        twists = {side: np.zeros((count, 6)) for side in SIDES}
        for k, side in enumerate(swing):  # central differences, one-sided at the swing's ends
            behind = k > 0 and side is not None and swing[k - 1] == side
            ahead = k + 1 < count and side is not None and swing[k + 1] == side
            if not (behind or ahead):
                continue
            first, last = swing_poses[k - 1 if behind else k], swing_poses[k + 1 if ahead else k]
            span = (2.0 if behind and ahead else 1.0) * dt
            twists[side][k, :3] = (last.translation - first.translation) / span
            twists[side][k, 3:] = first.rotation @ pin.log3(first.rotation.T @ last.rotation) / span
        cos, sin = np.cos(heading)[:, None], np.sin(heading)[:, None]
        shift = np.zeros((count, 2))
        for side in SIDES:
            rates = np.gradient(twists[side], dt, axis=0).reshape(count, 2, 3)  # linear, angular
            local = rates.copy()  # into the heading frame: R_z(-heading)
            local[..., 0] = cos * rates[..., 0] + sin * rates[..., 1]
            local[..., 1] = -sin * rates[..., 0] + cos * rates[..., 1]
            momentum_rate = local.reshape(count, 6) @ self.swing_map[side].T
            turned = np.column_stack([-momentum_rate[:, 1], momentum_rate[:, 0]]) / self.weight
            shift[:, 0] -= cos[:, 0] * turned[:, 0] - sin[:, 0] * turned[:, 1]
            shift[:, 1] -= sin[:, 0] * turned[:, 0] + cos[:, 0] * turned[:, 1]
        return shift
