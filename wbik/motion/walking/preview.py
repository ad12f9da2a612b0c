"""Kajita's preview controller (ICRA 2003) on the cart-table model: per axis the jerk u drives
x = (c, c', c''), x_(k+1) = A x_k + B u_k, p = c - (z_c / g) c''; minimising sum Q e^2 + R (delta u)^2,
e = p - p_ref, gives u_k = -G_i sum e_i - G_x x_k - sum_(j=1..N) G_d(j) p_ref(k + j)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_discrete_are

from wbik.errors import InvalidConfigurationError

GRAVITY = 9.80665  # m/s^2


@dataclass
class PreviewRun:
    """CoM position, velocity, acceleration (K, 2) and the pendulum's ZMP (K, 2) at the ticks."""

    com: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    zmp: np.ndarray


class PreviewController:
    """Preview control: ``dt``, ``horizon_s`` (s), ``com_height`` z_c (m), weights ``q`` (error), ``r``."""

    def __init__(self, dt: float, com_height: float, horizon_s: float = 1.0, q: float = 1.0, r: float = 1e-6):
        for name, value in dict(dt=dt, com_height=com_height, horizon_s=horizon_s, q=q, r=r).items():
            if not (math.isfinite(value) and value > 0):
                raise InvalidConfigurationError(f"preview control: {name} must be > 0, got {value}")
        self.dt, self.com_height, self.gravity = float(dt), float(com_height), GRAVITY
        self.steps = max(1, int(round(horizon_s / dt)))
        T = self.dt
        self.A = np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
        self.B = np.array([T ** 3 / 6, T * T / 2, T])
        self.C = np.array([1.0, 0.0, -self.com_height / self.gravity])
        CA, CB = self.C @ self.A, float(self.C @ self.B)
        augmented_A = np.block([[np.ones((1, 1)), CA[None, :]], [np.zeros((3, 1)), self.A]])
        augmented_B = np.r_[CB, self.B].reshape(4, 1)
        Q = np.diag([float(q), 0.0, 0.0, 0.0])
        R = np.array([[float(r)]])
        P = solve_discrete_are(augmented_A, augmented_B, Q, R)
        gain = np.linalg.solve(R + augmented_B.T @ P @ augmented_B, augmented_B.T @ P @ augmented_A)
        self.gain_integral = float(gain[0, 0])
        self.gain_state = gain[0, 1:].copy()
        closed = (augmented_A - augmented_B @ gain).T
        X = -closed @ P @ np.array([1.0, 0.0, 0.0, 0.0])
        preview = np.zeros(self.steps)
        preview[0] = -self.gain_integral
        scale = np.linalg.inv(R + augmented_B.T @ P @ augmented_B) @ augmented_B.T
        for j in range(1, self.steps):
            preview[j] = (scale @ X).item()
            X = closed @ X
        self.gain_preview = preview  # G_d(1..N), G_d(1) = -G_i

    @property
    def omega(self) -> float:
        """sqrt(g / z_c) (rad/s)."""
        return math.sqrt(self.gravity / self.com_height)

    def zmp_of(self, com: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """The pendulum's ZMP c - (z_c / g) c''."""
        return np.asarray(com) - self.com_height / self.gravity * np.asarray(acceleration)

    def start(self, com_xy: np.ndarray) -> PreviewState:
        """A controller state with the CoM at rest at (x, y)."""
        state = np.zeros((3, 2))
        state[0] = np.asarray(com_xy, dtype=float)[:2]
        return PreviewState(self, state)

    def run(self, reference: np.ndarray, com_xy: np.ndarray) -> PreviewRun:
        """Every tick of ``reference`` p_ref (K, 2) (held beyond), from rest at ``com_xy``."""
        reference = np.asarray(reference, dtype=float)
        count = len(reference)
        padded = np.vstack([reference, np.repeat(reference[-1:], self.steps, axis=0)])
        state = self.start(com_xy)
        com, velocity, acceleration = (np.zeros((count, 2)) for _ in range(3))
        for k in range(count):
            com[k], velocity[k], acceleration[k] = state.x
            state.step(padded[k + 1:k + 1 + self.steps], padded[k])
        return PreviewRun(com, velocity, acceleration, self.zmp_of(com, acceleration))


class PreviewState:
    """One controller's running state: x (3, 2) = rows c, c', c'' for x and y, and sum e."""

    def __init__(self, controller: PreviewController, x: np.ndarray):
        self.controller = controller
        self.x = x
        self.error_sum = np.zeros(2)

    def step(self, future: np.ndarray, current: np.ndarray) -> np.ndarray:
        """Advance one tick (``current`` p_ref now, ``future`` the next N); the jerk applied (2,)."""
        c = self.controller
        current = np.asarray(current, dtype=float)
        self.error_sum += c.C @ self.x - current
        # in coordinates centred on the current reference: the model is invariant to a shift, the
        # horizon's truncated gains are not (their sum misses G_x's position gain by a few 1e-4)
        relative = self.x.copy()
        relative[0] -= current
        jerk = (-c.gain_integral * self.error_sum - c.gain_state @ relative
                - c.gain_preview @ (future - current))
        self.x = c.A @ self.x + np.outer(c.B, jerk)
        return jerk
