"""Typed errors. Every message says what was wrong and what to do about it.

"No solution" is never an error: solvers return ``IKResult(success=False, reason=...)``.
These exceptions are for input a caller must fix.
"""

from __future__ import annotations


class WbikError(Exception):
    """Base class of every error wbik raises on purpose."""


class UnknownNameError(WbikError, KeyError):
    """A name (robot, chain, frame, method) that does not exist; lists the ones that do."""

    kind = "name"

    def __init__(self, name: str, known: list[str] | tuple[str, ...] = (), hint: str = ""):
        self.name = name
        self.known = sorted(known)
        known_text = ", ".join(self.known) if self.known else "(none)"
        message = f"unknown {self.kind} {name!r}; known {self.kind}s: {known_text}"
        if hint:
            message += f". {hint}"
        super().__init__(message)

    def __str__(self) -> str:  # KeyError would quote the message
        return self.args[0]


class UnknownRobotError(UnknownNameError):
    kind = "robot"


class UnknownChainError(UnknownNameError):
    kind = "chain"


class UnknownFrameError(UnknownNameError):
    kind = "frame"


class UnknownMethodError(UnknownNameError):
    kind = "method"


class InvalidTargetError(WbikError, ValueError):
    """A target with NaN/inf, the wrong shape, or the wrong type."""


class InvalidRotationError(InvalidTargetError):
    """A 3x3 matrix that is not a rotation (not orthonormal, or det != +1)."""


class InvalidConfigurationError(WbikError, ValueError):
    """A joint vector with NaN/inf or the wrong length."""


class RobotDescriptionError(WbikError, ValueError):
    """A URDF or DH table that cannot be turned into a model."""


class MissingDependencyError(WbikError, ImportError):
    """An optional dependency (PyKDL, Chromium, ...) is not installed; says how to get it."""


class UnsupportedError(WbikError, NotImplementedError):
    """The method does not apply to this robot, chain or target kind."""
