"""Kinds of study cases (:class:`CaseKind`, a case's ``target:``), the common part of their chunk tasks
(:class:`ChunkTask`) and their registry: a kind samples a case's inputs, solves its tasks and reports its
rows; the runner and the report know no kind."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wbik.errors import WbikError
from wbik.registry import DeclaredRegistry
from wbik.schema import Context, Key, Map
from wbik.study.context import _frozen, chunk_seed
from wbik.study.metrics import AngleConvention
from wbik.study.sampling import PoseSet
from wbik.study.spec import CaseSpec, MethodSpec, Study

__all__ = ["CASE_KIND_MODULES", "CASE_KIND_REGISTRY", "CaseKind", "ChunkTask", "RegisteredMethods",
           "case_kind", "case_kinds", "kinds_of", "register_case_kind"]


@dataclass(frozen=True)
class ChunkTask:
    """What every chunk task holds (plain data, cheap to pickle); a kind's task class adds its payload."""

    kind: CaseKind  # solves the chunk in the worker (``kind.solve(task)``)
    case: str
    robot: str
    robot_params: tuple
    label: str
    method: str
    options: tuple
    timeout_s: float | None
    tolerances: tuple
    seed: int
    chunk: int
    first_pose: int
    q0: np.ndarray  # the start configuration of each pose of the chunk
    batch: bool = field(default=True, kw_only=True)
    """Also time the method's batched path (``solve_many``) over the case, where it has one."""
    registered: tuple = field(default=(), kw_only=True)
    """What user code registered at run time that the chunk needs (:meth:`CaseKind.run_time_entries`)."""

    @property
    def count(self) -> int:
        """How many poses the chunk holds."""
        return len(self.q0)


class CaseKind(ABC):
    """A kind of study case: from the study file's case to the rows of every method and the case's
    section of the report. Instances are small and picklable (a chunk task carries one)."""

    name: str
    """The case's ``target:`` in a study file (the registry's key)."""
    target: str
    """What each input is: "pose" or "position" for a chain solver, or the kind's own word ("wholebody")."""
    entry_keys: tuple[str, ...] = ()
    """Keys of a case entry that only this kind takes (they imply it without ``target:``)."""
    methods_note: str = ""
    """A paragraph under the report's methods table when the study has cases of this kind."""
    study_note: str = ""
    """A paragraph after the machine's load when the study has cases of this kind."""

    # -- the study file ----------------------------------------------------------------------------
    def entry_schema(self) -> dict[str, Key]:
        """Schema nodes of this kind's own case-entry keys (besides definition's ``CASE_KEYS``)."""
        return {}

    def entry(self, item: dict, path: str, ctx: Context) -> dict:
        """A checked case entry of this kind, completed and checked across its keys (``ctx.fail``)."""
        return item

    @abstractmethod
    def methods(self) -> dict[str, str]:
        """The methods a case of this kind can run: {name: description}."""

    def method_factory(self, method: str):
        """What builds ``method``'s solver (None: not known here); a root of the code fingerprint."""
        return None

    def code_roots(self, case: CaseSpec) -> list:
        """Objects besides the kind, its methods and robot whose modules ``case``'s rows come from."""
        return []

    def method_option_schema(self, method: str) -> Map | None:
        """The keyword options ``method`` takes, typed (:func:`wbik.options.option_schema`; None: any)."""
        return None

    @abstractmethod
    def axes(self, angles: AngleConvention | None = None) -> list[str]:
        """The error axes of the kind's rows (columns ``err_<axis>``); ``angles``: a reference's."""

    # -- sampling and tasks (main process) ---------------------------------------------------------
    @abstractmethod
    def sample(self, study: Study, case: CaseSpec) -> PoseSet:
        """The case's inputs, drawn from the study's seed (the runner saves them as ``poses.npz``)."""

    @abstractmethod
    def budget(self, method: str, timeout_s: float, options: dict) -> tuple[float | None, dict]:
        """(timeout_s, options) to build ``method`` with for a study budget of ``timeout_s`` s."""

    def unbudgeted(self, method: str) -> bool:
        """Whether ``method`` takes no budget (a closed form)."""
        return False

    def budget_text(self, method: MethodSpec, seconds: float) -> str:
        """The budget ``method`` is built with, for the report's methods table: "N iterations (~T s)" for a
        loop of ours, "T s wall clock" else."""
        try:
            timeout_s, options = self.budget(method.method, seconds, method.options)
        except WbikError:
            return f"{seconds:g} s"
        if self.unbudgeted(method.method):
            return "none (closed form)"
        if timeout_s is None:
            how = "set in the file" if "max_iterations" in method.options else f"~{seconds:g} s"
            return f"{options['max_iterations']} iterations ({how})"
        return f"{seconds:g} s wall clock"

    @abstractmethod
    def task(self, study: Study, case: CaseSpec, method: MethodSpec, poses: PoseSet, chunk: int,
             start: int, stop: int) -> ChunkTask:
        """The task of poses [start, stop) of ``case`` for ``method``."""

    def chunk_fields(self, study: Study, case: CaseSpec, method: MethodSpec, poses: PoseSet, chunk: int,
                     start: int, stop: int) -> dict:
        """The :class:`ChunkTask` fields of :meth:`task`, with the method's budget."""
        timeout_s, options = self.budget(method.method, study.timeout_of(method), method.options)
        return {"kind": self, "case": case.name, "robot": case.robot,
                "robot_params": _frozen(case.robot_params), "label": method.label, "method": method.method,
                "options": _frozen(options), "timeout_s": timeout_s,
                "tolerances": (study.tolerances["position"], study.tolerances["rotation"]),
                "seed": chunk_seed(study.seed, case.name, method.label, chunk), "chunk": chunk,
                "first_pose": start, "q0": poses.q0[start:stop],
                "registered": self.run_time_entries(case, method.method)}

    def run_time_entries(self, case: CaseSpec, method: str) -> tuple:
        """What user code registered at run time (``wbik.register``) that the tasks of ``case`` for
        ``method`` need: a task carries it to the workers, which register it (:meth:`register_entries`)."""
        return ()

    def register_entries(self, entries: tuple) -> None:  # noqa: B027 - a hook, none by default
        """Register, in this process, the entries a task carries (replacing a namesake)."""

    # -- in the worker -----------------------------------------------------------------------------
    @abstractmethod
    def build(self, task: ChunkTask):
        """The method's solver for ``task``, or a refusal of :mod:`wbik.study.applicability`."""

    @abstractmethod
    def refusal(self, task: ChunkTask, solver) -> str | None:
        """Why the built ``solver`` cannot take the case (``task`` holds its first pose); None if it can."""

    @abstractmethod
    def solve(self, task: ChunkTask) -> dict[str, np.ndarray]:
        """The rows of one chunk: equal-length columns, ``pose``, ``success``, ``reason``, ``time_s``,
        ``iterations`` and ``q`` among them."""

    def throughput(self, task: ChunkTask, workers: int) -> dict[str, np.ndarray] | None:
        """The study's throughput pass over a whole case (``task``: every pose), where the kind has one:
        the batched path timed in one process and over ``workers`` processes, as per-pose columns; None
        (the default) for a kind or method without one."""
        return None

    # -- the report --------------------------------------------------------------------------------
    @abstractmethod
    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        """Write the case's raw.csv, summary.csv, significance.csv and figures; return what its section
        shows (:func:`wbik.study.blocks.case_analysis`'s keys and the kind's own)."""

    @abstractmethod
    def blocks(self, study: Study, analysis: dict) -> list:
        """The case's section of the report."""


class RegisteredMethods:
    """The methods of a kind that runs the registered IK methods (:mod:`wbik.solvers.method_registry`)."""

    def methods(self) -> dict[str, str]:
        from wbik.solvers.method_registry import methods
        return methods()

    def method_factory(self, method: str):
        from wbik.solvers.method_registry import method_factory
        return method_factory(method)

    def method_option_schema(self, method: str) -> Map:
        """The types of ``method``'s keyword options (its factory's), less the study's settings."""
        from wbik.options import option_schema
        return option_schema(self.method_factory(method), leading=2, skip=("timeout_s", "tolerances", "seed"))

    def run_time_entries(self, case: CaseSpec, method: str) -> tuple:
        from wbik.solvers.method_registry import IK_METHOD_REGISTRY
        entry = IK_METHOD_REGISTRY.added_at_run_time(method)
        return () if entry is None else (entry,)

    def register_entries(self, entries: tuple) -> None:
        from wbik.solvers.method_registry import register_method
        for entry in entries:
            register_method(entry, replace=True)


CASE_KIND_MODULES: list = []
"""The registry's modules: :mod:`wbik.catalog` adds wbik's own, user code a module by name or a kind."""

CASE_KIND_REGISTRY: DeclaredRegistry[CaseKind] = DeclaredRegistry(
    "study case kind", "CASE_KINDS", CASE_KIND_MODULES, "wbik.study.case_kinds.CASE_KIND_MODULES", CaseKind)

register_case_kind = CASE_KIND_REGISTRY.register


def case_kinds() -> dict[str, CaseKind]:
    """Every case kind by name, in the order of :data:`CASE_KIND_MODULES`, then as registered."""
    return CASE_KIND_REGISTRY.entries()


def case_kind(case: CaseSpec) -> CaseKind:
    """The kind of ``case`` (its ``target``)."""
    return CASE_KIND_REGISTRY.get(case.target)


def kinds_of(cases: Iterable[CaseSpec]) -> list[CaseKind]:
    """The kinds of ``cases``, each once, in registry order."""
    targets = {case.target for case in cases}
    return [kind for name, kind in case_kinds().items() if name in targets]
