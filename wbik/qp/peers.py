"""How other IK libraries (peers: PlaCo, Pink, mink) express wbik's QP tasks and constraints.

Each peer has forms keyed by class beside its method (``PLACO`` in :mod:`wbik.solvers.placo`, ``PINK``,
``MINK``): ``build(item, target)`` adds an item to the peer's problem, or the peer says why it cannot; a
class takes its nearest base's form, an item without one is ``unsupported``. A new task's forms::

    @PINK.form(HeightTask)
    def height_in_pink(task: HeightTask, pink) -> None:   # pink: wbik.solvers.pink.PinkProblem
        pink.tasks.append(...)

    PLACO.cannot(HeightTask, "PlaCo has no ...")
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from wbik.registry import RegistryError

__all__ = ["PeerForm", "PeerForms", "Unsupported", "frame_weights", "largest_weight"]

Build = Callable[[Any, Any], None]


class Unsupported(str):
    """What a peer could not express: "unsupported by PEER: WHAT: WHY", with those as attributes."""

    peer: str
    what: str
    why: str

    def __new__(cls, peer: str, what: str, why: str) -> Unsupported:
        text = super().__new__(cls, f"unsupported by {peer}: {what}: {why}")
        text.peer, text.what, text.why = str(peer), str(what), str(why)
        return text

    def __reduce__(self):
        return Unsupported, (self.peer, self.what, self.why)


@dataclass(frozen=True)
class PeerForm:
    """How a peer expresses one class's items: ``build(item, target)`` or None and ``why``; ``refuse``."""

    build: Build | None = None
    why: str = ""
    refuse: Callable[[Any], str | None] | None = None


class PeerForms:
    """The forms of one peer, by class; ``peer``: its method's name, ``title``: its authors'."""

    def __init__(self, peer: str, title: str):
        self.peer, self.title = peer, title
        self._forms: dict[type, PeerForm] = {}
        self._lock = threading.RLock()

    def __repr__(self) -> str:
        return f"PeerForms({self.peer!r}, {len(self._forms)} forms)"

    def register(self, kind: type, form: PeerForm, replace: bool = False) -> None:
        """Register ``form`` for the class ``kind`` (a second one only with ``replace``)."""
        if not isinstance(kind, type) or not isinstance(form, PeerForm):
            raise RegistryError(f"{self.title}: a form is registered for a class as a PeerForm, got "
                                f"{kind!r} and {form!r}")
        with self._lock:
            if kind in self._forms and not replace:
                raise RegistryError(f"{self.title} already has a form for {kind.__name__} (pass replace=True "
                                    "to change it)")
            self._forms[kind] = form

    def form(self, kind: type, *, refuse: Callable[[Any], str | None] | None = None,
             replace: bool = False) -> Callable[[Build], Build]:
        """Decorator: the decorated ``build(item, target)`` is this peer's form of ``kind``."""
        def decorate(build: Build) -> Build:
            self.register(kind, PeerForm(build, refuse=refuse), replace)
            return build

        return decorate

    def cannot(self, kind: type, why: str, replace: bool = False) -> None:
        """Say that this peer cannot express ``kind``, and why (listed in ``unsupported``)."""
        self.register(kind, PeerForm(None, why), replace)

    def lookup(self, kind: type) -> PeerForm | None:
        """The form of ``kind``: its own, else its nearest base class's; None without any."""
        with self._lock:
            return next((self._forms[base] for base in kind.__mro__ if base in self._forms), None)

    def refusal(self, item) -> str | None:
        """Why this peer cannot express ``item`` (a task or a constraint), or None when it can."""
        if (form := self.lookup(type(item))) is None:
            return (f"{self.title} has no form for {type(item).__name__} (a form registers with "
                    f"{self.peer.upper()}.form of wbik.solvers.{self.peer})")
        if form.build is None:
            return form.why
        return None if form.refuse is None else form.refuse(item)

    def build(self, item, target) -> None:
        """Add ``item`` to ``target`` through its form (:meth:`refusal` must be None)."""
        if (form := self.lookup(type(item))) is None or form.build is None:
            raise RegistryError(f"{self.title} cannot express {item!r}: {self.refusal(item)}")
        form.build(item, target)


def largest_weight(task, default: float) -> float:
    """The largest of a task's per-row weights (``default`` for a task without rows)."""
    weight = np.asarray(task.weight, dtype=float)
    return float(np.max(weight)) if weight.size else default


def frame_weights(task) -> tuple[float, float]:
    """(position weight, orientation weight) of a 6-row frame task, from its per-row weights."""
    weight = np.asarray(task.weight, dtype=float)
    return float(np.max(weight[:3])), float(np.max(weight[3:]))
