"""Typed errors for input a caller must fix; each message says what was wrong and what to do about it.
"No solution" is never an error: solvers return ``IKResult(success=False, reason=...)``."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class WbikError(Exception):
    """Base class of every error wbik raises on purpose."""


def closest_name(word, choices: Iterable) -> str | None:
    """The choice closest to ``word`` (difflib's ratio >= 0.6), None if none is."""
    close = difflib.get_close_matches(str(word), [str(choice) for choice in choices], n=1)
    return close[0] if close else None


def did_you_mean(word, choices: Iterable) -> str:
    """' (did you mean X?)' for the closest of ``choices``, or '': the tail of an unknown-name message."""
    close = closest_name(word, choices)
    return f" (did you mean {close!r}?)" if close is not None else ""


class UnknownNameError(WbikError, KeyError):
    """A name (robot, chain, frame, method) that does not exist; lists the ones that do."""

    kind = "name"

    def __init__(self, name: str, known: list[str] | tuple[str, ...] = (), hint: str = ""):
        self.name, self.known, self.hint = name, sorted(known), hint
        message = f"unknown {self.kind} {name!r}; known {self.kind}s: {', '.join(self.known) or '(none)'}"
        super().__init__(message + (f". {hint}" if hint else ""))

    def __str__(self) -> str:  # KeyError would quote the message
        return self.args[0]

    def __reduce__(self):  # rebuilt from its fields in another process (a study worker's error)
        return type(self), (self.name, self.known, self.hint)


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


class SoleError(RobotDescriptionError):
    """A sole that is no frame of the model or has non-finite (k, 3) contact points; ``sole``: its frame."""

    def __init__(self, message: str, sole: str = ""):
        self.sole = sole
        super().__init__(message)


class MissingDependencyError(WbikError, ImportError):
    """An optional dependency (PyKDL, Chromium, ...) is not installed; says how to get it."""


class UnsupportedError(WbikError, NotImplementedError):
    """The method does not apply to this robot, chain or target kind."""


class InvalidOptionError(WbikError, TypeError):
    """A keyword option the callee does not take; ``accepted``: the options it takes."""

    def __init__(self, message: str, option: str = "", accepted: list[str] | tuple[str, ...] = ()):
        self.option, self.accepted = option, sorted(accepted)
        super().__init__(message)


class InvalidSettingError(WbikError, ValueError):
    """A setting (tolerance, time budget, seed, ...) of the wrong type or outside its allowed range."""


class InvalidToleranceError(InvalidSettingError):
    """A tolerance of the shared FK check that is not a positive finite number."""


class InvalidBudgetError(InvalidSettingError):
    """A time or iteration budget (``timeout_s``, ...) that is not a positive finite number."""


class UsageError(WbikError, ValueError):
    """A command-line argument or path that cannot be used as given (a file where a folder is needed)."""


class NoQPSolutionError(WbikError, RuntimeError):
    """One QP step found no displacement: its hard constraints conflict (or the ``backend`` failed, with
    its own ``status``); ``conflict``: an irreducible set of conflicting rows
    (:class:`wbik.qp.elastic.ConflictRow`, empty for a numerical failure). ``IKProblem.solve`` turns it
    into a failed solution: an IK call returns, never raises it."""

    def __init__(self, message: str, backend: str = "", status: object = None, conflict: tuple = ()):
        self.backend, self.status, self.conflict = backend, status, tuple(conflict)
        super().__init__(message)
