"""Method ``analytic``: the solver over the closed forms (:class:`AnalyticSolver`), and which closed form
a chain gets (bound by its robot, else recognised from its structure)."""

from __future__ import annotations

import time

import numpy as np

from wbik.errors import RobotDescriptionError, UnsupportedError
from wbik.geometry import joint_gap
from wbik.solvers.analytic.batch import batch_targets, evaluate_batch
from wbik.solvers.analytic.closed_form import (
    BRANCH_MERGE,
    Choice,
    ClosedForm,
    kernel_failure_reason,
    no_solution_reason,
    wrap_into_limits,
)
from wbik.solvers.analytic.compiled import CompiledForm
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.analytic.nearby_arm import nearby_arm
from wbik.solvers.analytic.recognition import (
    Recognised,
    first_recognised,
    recognise_eaik,
    recognise_family,
    recognise_search,
)
from wbik.solvers.analytic.redundancy import check_redundancy_options, lock_redundant_joint
from wbik.solvers.analytic.stacked_planar import STACKED_PLANAR
from wbik.solvers.analytic.structure import chain_lines
from wbik.solvers.analytic.ur_type import UR_TYPE
from wbik.solvers.analytic.yaw_planar import YAW_PLANAR
from wbik.solvers.base import Solver
from wbik.solvers.batch_results import IKResults
from wbik.solvers.check import evaluate
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate, IKResult
from wbik.targets import Target, as_target

FAMILIES = (UR_TYPE, YAW_PLANAR, STACKED_PLANAR)  # recognition's order (a new family: its module, one entry)


def refusal(chain, reasons: dict[str, list[str]]) -> str:
    """The message of a chain without a closed form: per target kind, why each way was refused."""
    kinds = {"pose": "full poses", "position": "positions"}
    parts = "; ".join(f"for {kinds.get(kind, kind)}, {'; '.join(why)}" for kind, why in reasons.items())
    return (f"no closed form for {chain.robot.name}.{chain.name} ({chain.nq} joints): {parts}. Use a "
            "numerical method (e.g. 'dls') instead")


def refusal_reasons(chain, kind: str, options: dict | None = None,
                    redundancy: dict | None = None) -> Recognised | list[str]:
    """The closed form recognised for ``kind`` targets (a family, EAIK, a joint held), or the reasons."""
    try:
        chain_lines(chain)
    except RobotDescriptionError as unreadable:
        return [f"its joint lines cannot be read ({unreadable})"]
    redundancy = dict(redundancy or {})
    held = redundancy.get("joint") is not None
    recognisers = [] if held else [lambda: recognise_family(chain, kind, options, FAMILIES),
                                   lambda: recognise_eaik(chain, kind), lambda: recognise_search(chain, kind)]
    if not held and chain.nq == 6:  # a 6R: a nearby arm's closed form before the 1-D search forms
        recognisers.insert(2, lambda: nearby_arm(chain, kind, options, redundancy, FAMILIES))
    if held or chain.nq >= 7:  # a held joint's family or EAIK, a nearby arm's, then a held search form
        recognisers += [lambda: lock_redundant_joint(chain, kind, options, redundancy, FAMILIES, (0,)),
                        lambda: nearby_arm(chain, kind, options, redundancy, FAMILIES),
                        lambda: lock_redundant_joint(chain, kind, options, redundancy, FAMILIES, (1,))]
    return first_recognised(*recognisers)


def _closed_form(chain, kind: str, **options) -> ClosedForm:
    """The closed form the robot binds to (chain, kind), built (the caller checks it)."""
    return chain.robot.closed_forms[(chain.name, kind)](chain, **options)


class AnalyticSolver(Solver):
    """Closed-form IK. ``families`` names per target kind what solves the chain ("bound:<module:Name>",
    "ur_type", "yaw_planar", "stacked_planar", "eaik:<EAIK's class>", "search: <structure> (1-D)", with a
    held joint); a chain with neither kind is refused when built, a missing kind when asked for
    (UnsupportedError saying why)."""

    name = "analytic"
    budgeted = False

    def __init__(self, robot, chain=None, closed_form_options: dict[str, dict] | None = None,
                 redundant_joint: str | int | None = None, redundancy: str = "search",
                 grid_size: int = 16, **options):
        """``closed_form_options``: keyword arguments per target kind, e.g. ``{"position": {"yaw": 0.3}}``.
        A 7-joint chain holds ``redundant_joint`` (name or index; default: the first that leaves a closed
        form), searched over its range (``redundancy="search"``, starting from a grid of ``grid_size``
        values), at the start's value (``"seed"``) or also at ``grid_size`` values (``"grid"``)."""
        super().__init__(robot, chain, **options)
        self._forms: dict[str, ClosedForm] = {}
        self.closed_form_options = dict(closed_form_options or {})
        held = check_redundancy_options(self.chain, redundant_joint, redundancy, grid_size)
        self.redundancy = {"joint": held, "mode": redundancy, "grid_size": int(grid_size)}
        self.families: dict[str, str] = {}
        self._refusals: dict[str, str] = {}
        self._recognise_forms()
        self.revolute = ~self.chain.is_prismatic
        self._limits_by_joint = (self.chain.lower[:, None, None], self.chain.upper[:, None, None],
                                 self.revolute[:, None, None])  # of a joint-major (n, K, B) batch
        self._finite_limits = bool(np.isfinite(self._limits_by_joint[:2]).all())  # no isfinite pass then

    def _recognise_forms(self) -> None:
        """Per target kind the bound form, the recognised one or why none; UnsupportedError if none."""
        reasons = {}
        for kind in ("pose", "position"):
            binding = self.robot.closed_forms.get((self.chain.name, kind))
            if binding is not None and self.redundancy["joint"] is None:
                name = getattr(binding, "__qualname__", type(binding).__name__)
                self.families[kind] = f"bound:{binding.__module__}:{name}"
                continue
            found = refusal_reasons(self.chain, kind, self.closed_form_options.get(kind, {}), self.redundancy)
            if isinstance(found, list):
                reasons[kind] = found
                self._refusals[kind] = refusal(self.chain, {kind: found})
                continue
            self._forms[kind] = found.form
            self.families[kind] = found.family
        if not self.families:
            raise UnsupportedError(refusal(self.chain, reasons))

    @property
    def family(self) -> str:
        """The family of the full-pose closed form, else of the position one (see ``families``)."""
        return self.families.get("pose") or self.families["position"]

    def check_target_kind(self, kind: str) -> None:
        """Also an UnsupportedError when the chain has no closed form of this kind."""
        super().check_target_kind(kind)
        self.closed_form(kind)

    def _form_of(self, target: Target) -> ClosedForm:
        """The closed form of the target's kind."""
        kind = "position" if target.rotation is None else "pose"
        return self._forms.get(kind) or self.closed_form(kind)

    def closed_form(self, kind: str) -> ClosedForm:
        """The closed form of ``kind`` targets (a bound one built on first use), else UnsupportedError."""
        if kind not in self._forms:
            if kind in self._refusals:
                raise UnsupportedError(self._refusals[kind])
            form = _closed_form(self.chain, kind, **self.closed_form_options.get(kind, {}))
            check_fk_against_model(form)
            self._forms[kind] = form
        return self._forms[kind]

    def _wrapped_by_joint(self, form: ClosedForm, positions, rotations, q0s):
        """Every branch wrapped into the limits nearest q0: (Q (n, K, B), real (K, B), usable (K, B))."""
        q_all, real = form.branches_by_joint(positions, rotations, q0s)
        lower, upper, revolute = self._limits_by_joint
        q_all, in_limits = wrap_into_limits(q_all, _by_joint(q0s), lower, upper, revolute, axis=0)
        usable = real & in_limits
        if not self._finite_limits:
            usable &= np.all(np.isfinite(q_all), axis=0)
        return q_all, real, usable

    @staticmethod
    def _screen(form: ClosedForm, q: np.ndarray, positions, rotations):
        """(max(|p - p*|, angle(R*^T R)), p, R) by the form's FK of joints q (..., n), the trace summed
        in order as the kernels do."""
        reached_p, reached_r = form.fk(q)
        d = reached_p - positions
        residual = np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2])
        if rotations is not None:
            products = (rotations * reached_r).reshape(reached_r.shape[:-2] + (9,))
            trace = products[..., 0]
            for k in range(1, 9):
                trace = trace + products[..., k]
            residual = np.maximum(residual, np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))
        return residual, reached_p, reached_r

    def _choose(self, form: ClosedForm, positions, rotations, q0s) -> Choice:
        """The nearest branch per target that passes the screen (the next ones by distance where it fails)."""
        q_all, real, usable = self._wrapped_by_joint(form, positions, rotations, q0s)
        squares = q_all - _by_joint(q0s)
        squares *= squares
        distance = np.sqrt(np.add.reduce(squares, axis=0))  # |q - q0| per branch (K, B)
        distance[~usable] = np.inf
        targets = np.arange(len(q0s))
        nearest = np.argmin(distance, axis=0)  # the first nearest, as a stable sort's first
        chosen = q_all[:, nearest, targets].T.copy()
        with np.errstate(invalid="ignore"):  # a target without a usable branch may bring NaN joints
            residual, reached_p, reached_r = self._screen(form, chosen, positions, rotations)
        found = usable[nearest, targets]
        screened = residual <= form.screen_tolerance
        retry = np.flatnonzero(found & ~screened)
        found &= screened
        if not found.all():
            missed = ~found
            chosen[missed], reached_p[missed], reached_r[missed] = 0.0, 0.0, 0.0
            order = np.argsort(distance[:, retry], axis=0, kind="stable")  # order[rank, i]: of retry[i]
            for rank in range(1, len(order)):
                keep = usable[order[rank], retry]
                retry, order = retry[keep], order[:, keep]
                if not len(retry):
                    break
                candidates = q_all[:, order[rank], retry].T
                residual, candidate_p, candidate_r = self._screen(
                    form, candidates, positions[retry], None if rotations is None else rotations[retry])
                passed = residual <= form.screen_tolerance
                done = retry[passed]
                chosen[done], found[done] = candidates[passed], True
                reached_p[done], reached_r[done] = candidate_p[passed], candidate_r[passed]
                retry, order = retry[~passed], order[:, ~passed]
        return Choice(chosen, found, real.T, usable.T, reached_p, reached_r)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        form = self._form_of(target)
        rotation = None if form.target_kind == "position" else target.rotation
        if form.kernel is not None:
            q = np.empty(len(q0))
            status = form.kernel.nearest_into(target.position, rotation, q0, q)
            if status <= 0:
                return Candidate(None, 1, kernel_failure_reason(status))
            return Candidate(q, 1, extra={"branches": status})
        choice = self._choose(form, target.position[None], None if rotation is None else rotation[None],
                              q0[None])
        if not choice.found[0]:
            return Candidate(None, 1, no_solution_reason(bool(choice.real.any()), bool(choice.usable.any())))
        return Candidate(choice.q[0], 1, extra={"branches": int(choice.real.sum())})

    def _solve_targets(self, targets: list, q0s) -> IKResults:
        """One choice (the kernel where built) and one batched check; per-pose time = the choice's / B."""
        positions, rotations = batch_targets(targets, self)
        count = len(positions)
        if not count:
            return IKResults([])
        q0_array = (np.broadcast_to(self.chain.nominal, (count, self.chain.nq)).copy() if q0s is None
                    else np.array(self._batch_starts(q0s, count)))
        form = self.closed_form("position" if rotations is None else "pose")
        form_rotations = rotations if form.target_kind == "pose" else None
        start = time.perf_counter()
        if isinstance(form.kernel, CompiledForm) and form_rotations is not None:
            joints, errors, info = form.kernel.nearest_many(positions, rotations, q0_array)
            per_pose = (time.perf_counter() - start) / count
            branches, outcomes = info.T.astype(int)
            reasons = [""] * count
            for index in np.flatnonzero(outcomes != 1).tolist():
                reasons[index] = kernel_failure_reason(int(outcomes[index]))
            measured = (errors[:, :3], errors[:, 3:6], errors[:, 6], errors[:, 7])
            return evaluate_batch(self.chain, form, positions, rotations, joints, outcomes == 1, reasons,
                                  self.tolerances, per_pose, self.name, branches, measured=measured)
        choice = self._choose(form, positions, form_rotations, q0_array)
        per_pose = (time.perf_counter() - start) / count
        any_real, any_usable = choice.real.any(axis=1).tolist(), choice.usable.any(axis=1).tolist()
        reasons = ["" if ok else no_solution_reason(r, u)
                   for ok, r, u in zip(choice.found.tolist(), any_real, any_usable, strict=True)]
        return evaluate_batch(self.chain, form, positions, rotations, choice.q, choice.found, reasons,
                              self.tolerances, per_pose, self.name, choice.real.sum(axis=1),
                              reached=(choice.reached_p, choice.reached_r))

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct branch, wrapped into the limits nearest the nominal, passing the check."""
        target = as_target(target)
        form = self._form_of(target)
        nominal = self.chain.nominal
        if isinstance(form.kernel, CompiledForm):
            return form.kernel.results(target.position, target.rotation, nominal, self.name, self.tolerances)
        start = time.perf_counter()
        positions = target.position[None]
        rotations = None if form.target_kind == "position" else target.rotation[None]
        q_all, _, usable = self._wrapped_by_joint(form, positions, rotations, nominal[None])
        q_all = q_all[:, usable[:, 0], 0].T
        passed = self._screen(form, q_all, positions, rotations)[0] <= form.screen_tolerance
        distinct: list[np.ndarray] = []
        for q in q_all[passed]:
            if not any(joint_gap(q, other, self.revolute) < BRANCH_MERGE for other in distinct):
                distinct.append(q)
        elapsed = time.perf_counter() - start
        results = [evaluate(self.chain, target, Candidate(q, 1), self.tolerances, elapsed, self.name)
                   for q in distinct]
        return [r for r in results if r.success]


def _by_joint(q: np.ndarray) -> np.ndarray:
    """Joints (B, n) as a joint-major batch's reference (n, 1, B)."""
    return np.ascontiguousarray(q.T)[:, None, :]


IK_METHODS = (
    IKMethod("analytic", AnalyticSolver,
             "closed-form IK: every branch, nearest to q0, vectorised batches"),
)
