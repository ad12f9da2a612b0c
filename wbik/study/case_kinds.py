"""Kinds of study cases: what a kind does (:class:`CaseKind`), the common part of its chunk tasks
(:class:`ChunkTask`) and where kinds are registered.

A case's ``target:`` in a study file names its kind: ``pose`` and ``position`` (targets of one chain,
:mod:`wbik.study.chain_targets`), ``wholebody`` (whole-body problems of a case sampler,
:mod:`wbik.study.wholebody`). The runner, the applicability check and the report know no kind: they
ask the case's kind object to sample the case's inputs, cut them into chunk tasks, build and solve
(in the worker), refuse a method that does not apply, and analyse and report the rows.

A kind is declared where it lives, in that module's ``CASE_KINDS`` tuple::

    CASE_KINDS = (ChainTargets("pose"), ChainTargets("position"))

The modules holding kinds are listed by name in :data:`CASE_KIND_MODULES` and imported on first use
(:class:`wbik.registry.DeclaredRegistry`); user code adds a kind with :func:`register_case_kind`. A
chunk task carries its kind object, so a kind added at run time reaches the study's worker processes
with the task (loky and Dask pickle with cloudpickle).
"""

from __future__ import annotations

from abc import ABC
from abc import abstractmethod
from dataclasses import dataclass
from dataclasses import field
from typing import TYPE_CHECKING

import numpy as np

from wbik.errors import WbikError
from wbik.registry import DeclaredRegistry

if TYPE_CHECKING:
    from collections.abc import Iterable
    from pathlib import Path

    from wbik.schema import Context
    from wbik.schema import Key
    from wbik.schema import Map
    from wbik.study.metrics import AngleConvention
    from wbik.study.sampling import PoseSet
    from wbik.study.spec import CaseSpec
    from wbik.study.spec import MethodSpec
    from wbik.study.spec import Study

__all__ = ["CASE_KIND_MODULES", "CASE_KIND_REGISTRY", "CaseKind", "ChunkTask", "case_kind", "case_kinds",
           "kinds_of", "register_case_kind"]


@dataclass(frozen=True)
class ChunkTask:
    """What every chunk task holds (plain data, cheap to pickle); a kind's task class adds its own
    payload (the targets, the sampler, what user code registered at run time, ...)."""

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
    """Also time the method's batched path (``solve_many``) over the chunk, where it has one (the
    throughput; not for budget curves)."""

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
    """What each input is: "pose" (position and rotation) or "position" for a chain solver, or the
    kind's own word (whole-body problems: "wholebody")."""
    entry_keys: tuple[str, ...] = ()
    """Keys of a study file's case entry that only this kind takes (they imply it without ``target:``)."""
    methods_note: str = ""
    """A paragraph under the report's methods table when the study has cases of this kind."""
    study_note: str = ""
    """A paragraph after the machine's load when the study has cases of this kind."""

    # -- the study file ----------------------------------------------------------------------------
    def entry_schema(self) -> dict[str, Key]:
        """The schema of the keys a case entry of this kind takes besides every case's
        (:data:`wbik.study.definition.CASE_KEYS`): its own (``entry_keys``), and any common key it
        reads otherwise (:mod:`wbik.schema` nodes, with their defaults)."""
        return {}

    def entry(self, item: dict, path: str, ctx: Context) -> dict:
        """A case entry of this kind, checked against its schema (defaults filled in), completed where
        the kind knows more and checked across its keys (``ctx.fail`` naming the key's path for a
        mistake)."""
        return item

    @abstractmethod
    def methods(self) -> dict[str, str]:
        """The methods a case of this kind can run: {name: description}."""

    @abstractmethod
    def method_options(self, method: str) -> set[str] | None:
        """The keyword options ``method`` takes (None: any)."""

    def method_factory(self, method: str):
        """What builds ``method``'s solver (a Solver subclass or a callable; None: not known here). Its
        module is among those a report's code fingerprint starts from (:mod:`wbik.study.provenance`)."""
        return None

    def code_roots(self, case: CaseSpec) -> list:
        """Objects besides the kind, its methods and its robot whose modules ``case``'s rows come from
        (a sampler, ...), for the code fingerprint."""
        return []

    def method_option_schema(self, method: str) -> Map | None:
        """The types of ``method``'s options (:func:`wbik.options.option_schema`; None: unchecked)."""
        return None

    @abstractmethod
    def axes(self, angles: AngleConvention | None = None) -> list[str]:
        """The error axes of the kind's rows (their columns ``err_<axis>``), in report order;
        ``angles``: a reference's Euler angles."""

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
        """The budget ``method`` is built with for a study budget of ``seconds``, for the report's
        methods table: "N iterations (~T s)" for a loop of ours, "T s wall clock" else."""
        try:
            timeout_s, options = self.budget(method.method, seconds, method.options)
        except WbikError:
            return f"{seconds:g} s"
        if self.unbudgeted(method.method):
            return "none (closed form)"
        if timeout_s is None:
            if "max_iterations" in method.options:
                return f"{options['max_iterations']} iterations (set in the file)"
            return f"{options['max_iterations']} iterations (~{seconds:g} s)"
        return f"{seconds:g} s wall clock"

    @abstractmethod
    def task(self, study: Study, case: CaseSpec, method: MethodSpec, poses: PoseSet, chunk: int,
             start: int, stop: int) -> ChunkTask:
        """The task of poses [start, stop) of ``case`` for ``method``."""

    # -- in the worker -----------------------------------------------------------------------------
    @abstractmethod
    def build(self, task: ChunkTask):
        """The method's solver for ``task`` (raising a refusal of :mod:`wbik.study.applicability`
        when it does not apply)."""

    @abstractmethod
    def refusal(self, task: ChunkTask, solver) -> str | None:
        """Why the built ``solver`` cannot take the case (``task`` holds its first pose); None if it can."""

    @abstractmethod
    def solve(self, task: ChunkTask) -> dict[str, np.ndarray]:
        """The rows of one chunk: equal-length columns, ``pose``, ``success``, ``reason``,
        ``time_s``, ``iterations`` and ``q`` among them (written as the chunk's file)."""

    # -- the report --------------------------------------------------------------------------------
    @abstractmethod
    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        """Write the case's raw.csv, summary.csv, significance.csv and figures; return the numbers
        its report section shows (``case``, ``rows``, ``not_applicable``, ``summaries``, ``tests``,
        ``baseline``, ``images`` and the kind's own)."""

    @abstractmethod
    def blocks(self, study: Study, analysis: dict) -> list:
        """The case's section of the report."""


CASE_KIND_MODULES: list = []
"""The sources of the registry's modules: :mod:`wbik.catalog` adds wbik's own (a new kind: its module plus
one line there), user code a module by name or a kind (:func:`register_case_kind`)."""

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
