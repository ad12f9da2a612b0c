"""The target set ``unreachable``: poses no configuration inside the limits reaches, each proved (a)
outside the reach bound (:mod:`wbik.study.chain_reach`) or (b) reachable only with a joint beyond its limit,
by a complete closed form; docs/guide/studies.md gives the proofs."""

from __future__ import annotations

from collections import Counter

import numpy as np

from wbik.geometry import TWO_PI, joint_gap
from wbik.robot import Chain
from wbik.study.blocks import Block, fmt, frequent_reasons
from wbik.study.chain_reach import reach_bound
from wbik.study.closed_form_branches import ClosedFormBranches, branch_excess, complete_closed_form
from wbik.study.near_singularities import sigma_min
from wbik.study.path_metrics import random_unit
from wbik.study.spec import Study
from wbik.study.statistics import P95, finite_statistic
from wbik.study.target_parameters import Parameter, integer, interval, number
from wbik.study.target_sets import Drawing, TargetSetKind, target_stream

OUTSIDE_REACH, BEYOND_LIMITS = 0, 1  # a target's source: (a) or (b)
GENERATING_BRANCH = 1e-6  # rad or m (revolute modulo 2 pi): a branch this near the generating joints is them
REJECTIONS = {
    "missing": "the closed form does not return the generating joints",
    "singular": "a solution where the Jacobian is (nearly) singular",
    "inside": "a solution inside the limits, or within the margin of them",
}


def eligible_joints(chain: Chain, beyond_low: float) -> np.ndarray:
    """Joints that can be set ``beyond_low`` beyond a limit and stay outside the range on the circle."""
    return np.flatnonzero(chain.is_prismatic | ((TWO_PI - (chain.upper - chain.lower)) / 2.0 > beyond_low))


def uniform_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix uniform on SO(3) (a normalised Gaussian quaternion)."""
    quaternion = rng.normal(size=4)
    w, x, y, z = quaternion / np.linalg.norm(quaternion)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def prove_beyond_limits(chain: Chain, form: ClosedFormBranches, q: np.ndarray, position: np.ndarray,
                        rotation: np.ndarray, parameters: dict) -> tuple[str | None, np.ndarray]:
    """(None if FK(q) is proved unreachable inside the limits, else a key of REJECTIONS; the branches)."""
    branches = form.branches(position[None], rotation[None])[0]
    revolute = ~chain.is_prismatic
    if not len(branches) or np.min(joint_gap(branches, q, revolute)) > GENERATING_BRANCH:
        return "missing", branches
    if min(sigma_min(chain, branch) for branch in branches) < parameters["sigma_proof"]:
        return "singular", branches
    if np.min(branch_excess(branches, chain)) < parameters["proof_margin"]:
        return "inside", branches
    return None, branches


class Unreachable(TargetSetKind):
    """Proved unreachable targets."""

    reachable = False
    parameters = {
        "beyond_limits": Parameter(0.5, "a number in [0, 1] (the share of targets reachable only outside the "
                                        "limits, where the chain allows a proof)", number(0.0, 1.0),
                                   "share of targets of source (b)"),
        "reach_factor": Parameter((1.05, 1.5), "a pair [a, b] with 1 < a <= b <= 100 (multiples of the reach "
                                               "bound)", interval(1.0 + 1e-9, 100.0),
                                  "distance of (a) targets from the centre, in reach bounds"),
        "beyond": Parameter((0.05, 0.5), "a pair [a, b] with 0 < a <= b <= 3 (rad or m beyond the limit)",
                            interval(1e-9, 3.0), "how far beyond its limit the (b) joint is set"),
        "proof_margin": Parameter(1e-3, "a positive number (rad or m)", number(0.0, 1.0, low_open=True),
                                  "how far outside the limits every branch must be"),
        "sigma_proof": Parameter(1e-4, "a positive number", number(0.0, 1e3, low_open=True),
                                 "smallest singular value of the Jacobian required at every branch"),
        "attempts": Parameter(50, "an integer >= 1 (candidates per target)", integer(1, 100000),
                              "candidates drawn per (b) target before it comes from (a)"),
    }

    def drawn_from(self, parameters: dict) -> str:
        low, high = parameters["reach_factor"]
        return (f"poses proved unreachable: (a) positions {low:g}-{high:g} times the chain's reach bound "
                f"from its centre, uniform rotations; (b) FK of joints with one beyond its limit, kept when "
                f"the complete closed form's branches all lie outside the limits (share "
                f"{parameters['beyond_limits']:g} where the chain allows it)")

    def draw(self, chain: Chain, count: int, seed: int, parameters: dict) -> Drawing:
        bound = reach_bound(chain)
        form = complete_closed_form(chain)
        eligible = eligible_joints(chain, parameters["beyond"][0])
        why_not = form if isinstance(form, str) else ""
        if not why_not and not len(eligible):
            why_not = ("no joint has a range shorter than 2 pi by enough: every angle of every joint has a "
                       "representative inside the limits")
        q_true = np.full((count, chain.nq), np.nan)
        positions, rotations = np.empty((count, 3)), np.empty((count, 3, 3))
        source = np.full(count, OUTSIDE_REACH)
        distance = np.full(count, np.nan)
        excess = np.full(count, np.nan)
        branch_count = np.full(count, -1)
        rejections: Counter = Counter()
        fell_back = 0
        for i in range(count):
            rng = target_stream(seed, self.target_set, i)
            if not why_not and rng.random() < parameters["beyond_limits"]:
                found = self._beyond_limits(chain, form, eligible, rng, parameters, rejections)
                if found is not None:
                    q_true[i], positions[i], rotations[i], branches = found
                    source[i] = BEYOND_LIMITS
                    excess[i] = float(np.min(branch_excess(branches, chain)))
                    branch_count[i] = len(branches)
                    continue
                fell_back += 1
            direction = random_unit(rng)
            factor = rng.uniform(*parameters["reach_factor"])
            positions[i] = bound.centre + factor * bound.radius * direction
            rotations[i] = uniform_rotation(rng)
            distance[i] = factor
        facts = {
            "reach_radius": bound.radius, "reach_centre": bound.centre.tolist(),
            "reach_lengths": list(bound.lengths),
            "closed_form": form.family if isinstance(form, ClosedFormBranches) else None,
            "beyond_limits_impossible": why_not,
            "eligible": [chain.joint_names[j] for j in eligible],
            "rejections": {REJECTIONS[key]: count for key, count in rejections.items()},
            "fell_back": fell_back,
            "proved": {"reach bound (triangle inequality)": int(np.sum(source == OUTSIDE_REACH))},
        }
        if isinstance(form, ClosedFormBranches):
            facts["proved"][f"closed form {form.family} (every branch outside the limits)"] = int(
                np.sum(source == BEYOND_LIMITS))
        extras = {"source": source, "reach_factor": distance, "branch_excess": excess,
                  "branches": branch_count, "positions": positions, "rotations": rotations}
        return Drawing(q_true, extras, facts)

    def _beyond_limits(self, chain: Chain, form: ClosedFormBranches, eligible: np.ndarray,
                       rng: np.random.Generator, parameters: dict, rejections: Counter):
        """(q, position, rotation, branches) of a proved (b) target, or None after ``attempts``."""
        low, high = parameters["beyond"]
        gap = TWO_PI - (chain.upper - chain.lower)
        for _ in range(parameters["attempts"]):
            q = rng.uniform(chain.lower, chain.upper)
            joint = int(rng.choice(eligible))
            top = high if chain.is_prismatic[joint] else min(high, gap[joint] / 2.0)
            delta = rng.uniform(low, top)
            q[joint] = chain.upper[joint] + delta if rng.random() < 0.5 else chain.lower[joint] - delta
            placement = chain.fk(q)
            rejection, branches = prove_beyond_limits(chain, form, q, placement.translation,
                                                      placement.rotation, parameters)
            if rejection is None:
                return q, placement.translation, placement.rotation, branches
            rejections[rejection] += 1
        return None

    def drawing_blocks(self, analysis: dict) -> list[Block]:
        facts = analysis["facts"]
        if not facts:
            return []
        lengths = " + ".join(f"{value:.4g}" for value in facts["reach_lengths"])
        text = (f"Reach bound: |p - c| <= R = {lengths} = {facts['reach_radius']:.4g} m from c = "
                f"({', '.join(f'{v:.4g}' for v in facts['reach_centre'])}) m (the sum of the link lengths "
                f"between consecutive joint origins; triangle inequality, wbik.study.chain_reach).")
        if facts["beyond_limits_impossible"]:
            text += f" No target reachable only outside the limits: {facts['beyond_limits_impossible']}."
        else:
            rejected = "; ".join(f"{why}: {count}" for why, count in facts["rejections"].items()) or "none"
            text += (f" Targets beyond the limits: joints eligible {', '.join(facts['eligible'])}; "
                     f"candidates rejected: {rejected}"
                     + (f"; {facts['fell_back']} targets drawn from (a) after every candidate was rejected"
                        if facts["fell_back"] else "") + ".")
        rows = [[method, count] for method, count in facts["proved"].items()
                if count or not facts["beyond_limits_impossible"]]
        return [Block("p", text), Block("table", header=["proved unreachable by", "targets"], rows=rows)]

    def blocks(self, study: Study, analysis: dict) -> list[Block]:
        blocks = super().blocks(study, analysis)
        at = next((i for i, block in enumerate(blocks) if block.text == "Poses solved and time"), len(blocks))
        blocks[at:at] = refusal_blocks(analysis)
        return blocks


def refusal_summary(rows: dict[str, np.ndarray], source: np.ndarray | None) -> dict[str, float]:
    """False successes, refusals and the time to refuse (ms, all calls) of one method's rows on
    unreachable targets, overall and per source."""
    success = rows["success"].astype(bool)
    times = rows["time_s"] * 1e3
    summary = {"targets": int(len(success)), "false_successes": int(success.sum()),
               "refused": int((~success).sum()), "time_median_ms": finite_statistic(times),
               "time_p95_ms": finite_statistic(times, P95)}
    if source is not None and len(source) == len(success):
        for name, code in (("a", OUTSIDE_REACH), ("b", BEYOND_LIMITS)):
            summary[f"time_median_ms_{name}"] = finite_statistic(times[source == code])
    return summary


MOST_REASONS = 4  # reasons shown per method; the rest are counted together


def grouped_reasons(rows_by_method: dict) -> list[list]:
    """[method, reason, targets]: each method's MOST_REASONS most frequent reasons, then the others."""
    every = max(len(rows["reason"]) for rows in rows_by_method.values())  # as many kinds as there can be
    by_method: dict[str, list] = {}
    for method, reason, count in frequent_reasons(rows_by_method, most=every):
        by_method.setdefault(method, []).append([method, reason, count])
    table = []
    for method, rows in by_method.items():
        table.extend(rows[:MOST_REASONS])
        if rest := rows[MOST_REASONS:]:
            kinds = f"{len(rest)} kind{'s' if len(rest) > 1 else ''}"
            table.append([method, f"other reasons ({kinds})", sum(row[2] for row in rest)])
    return table


def refusal_blocks(analysis: dict) -> list[Block]:
    """The unreachable targets' section: false successes, time to refuse, the reasons given."""
    rows_by_method = analysis["rows"]
    if not rows_by_method:
        return []
    source = analysis["extras"].get("source")
    pose_source = source[rows_by_method[next(iter(rows_by_method))]["pose"]] if source is not None else None
    summaries = {label: refusal_summary(rows, pose_source) for label, rows in rows_by_method.items()}
    counts = ", ".join(f"{int(np.sum(source == code))} {name}" for name, code in
                       (("outside the reach (a)", OUTSIDE_REACH), ("beyond the limits (b)", BEYOND_LIMITS))) \
        if source is not None else ""
    table = [[label, s["targets"], s["false_successes"], s["refused"], fmt(s["time_median_ms"]),
              fmt(s["time_p95_ms"]), fmt(s.get("time_median_ms_a")), fmt(s.get("time_median_ms_b"))]
             for label, s in summaries.items()]
    return [Block("h3", "Unreachable targets: false successes, time to refuse, reasons"),
            Block("p", f"Every target is proved unreachable inside the limits ({counts}). A false success is "
                       "a method's answer that passes the shared FK check on such a target (none can, unless "
                       "a proof is wrong). Time to refuse: per call, every call (ms)."),
            Block("table", header=["method", "targets", "false successes", "refused", "median ms",
                                   "p95 ms", "median ms (a)", "median ms (b)"], rows=table),
            Block("p", f"Reasons given (numbers replaced by #; the {MOST_REASONS} most frequent per method, "
                       "then the others together):"),
            Block("table", header=["method", "reason", "targets"], rows=grouped_reasons(rows_by_method))]


CASE_KINDS = (Unreachable("unreachable"),)
