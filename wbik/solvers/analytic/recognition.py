"""The closed-form family of a chain, recognised from its joint lines at q = 0. A matcher lays DH frames
along the lines (:func:`walk`) with the family's twist angles and reads off a, d, the angles at q = 0 and
each joint's sign; with the family's FK T_f(u) = B D(u + o_f) E (:class:`Canonical`), the chain is
T(q) = G T_f(s q + o - o_f) X, G = F_0 B^-1, X = E^-1 F_n^-1 T(0) (:class:`~.aligned.AlignedForm`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from wbik.dh import rot_x, rot_z, trans
from wbik.errors import InvalidOptionError, MissingDependencyError, RobotDescriptionError, UnsupportedError
from wbik.solvers.analytic.aligned import AlignedForm, FamilyChain
from wbik.solvers.analytic.closed_form import (
    PROBE_POSES,
    PROBE_REQUIRED,
    PROBE_SEED,
    PROBE_TOLERANCE,
    ClosedForm,
)
from wbik.solvers.analytic.eaik_family import EAIKForm
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.analytic.one_d_search import TwoIntersectingForm, TwoParallelForm
from wbik.solvers.analytic.structure import (
    STRUCTURE_TOLERANCE,
    ChainLines,
    angle_between,
    chain_lines,
    poe_fk,
)

HALF_PI = 0.5 * math.pi


class Mismatch(Exception):
    """A chain is not of a family: the message says which relation fails (a user reads it)."""


@dataclass(frozen=True)
class Canonical:
    """A family's FK as DH rows: T_f(u) = base D(u + offsets) tool, with twist angles ``alphas``."""

    alphas: tuple[float, ...]
    offsets: tuple[float, ...]
    base: np.ndarray
    tool: np.ndarray


@dataclass
class Match:
    """A family found on a chain: ``build(family_chain)``, G, X, u = s q + o, the parameters in words."""

    family: str
    build: Callable[[FamilyChain], ClosedForm]
    base: np.ndarray
    tool: np.ndarray
    signs: np.ndarray
    offsets: np.ndarray
    parameters: str


@dataclass(frozen=True)
class Family:
    """A family recognition tries: its name and ``match(lines, kind, options) -> Match`` (Mismatch if not)."""

    name: str
    match: Callable[[ChainLines, str, dict], Match]


@dataclass(frozen=True)
class Recognised:
    """A chain's recognised closed form, its family and its parameters in words."""

    form: ClosedForm
    family: str
    parameters: str = ""


# --- DH frames along the lines -------------------------------------------------------------------------
def _frame(x: np.ndarray, z: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """The 4 x 4 frame with axes x (made orthogonal to z), z x x, z at ``origin``."""
    z = z / np.linalg.norm(z)
    x = x - np.dot(x, z) * z
    x = x / np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, origin
    return frame


def first_frame(lines: ChainLines, preferred: np.ndarray) -> tuple[np.ndarray, float]:
    """DH frame 0 and the sign s_1 (z_0 = s_1 h_1): on axis 1 at the foot of the base origin, as near the
    ``preferred`` rotation as the axis allows."""
    axis, point = lines.axes[0], lines.origins[0]
    sign = 1.0 if np.dot(axis, preferred[:, 2]) >= 0.0 else -1.0
    z = sign * axis
    x = preferred[:, 0] - np.dot(preferred[:, 0], z) * z
    if np.linalg.norm(x) < 1e-6:  # the preferred x is along the axis: its y, turned
        x = np.cross(preferred[:, 1], z)
    return _frame(x, z, point - np.dot(point, axis) * axis), sign


@dataclass
class Walk:
    """DH frames F_0..F_k along the first k + 1 lines at q = 0, per row theta (at q = 0), d, a, alpha, and
    ``signs`` s_1..s_k+1 (z_i-1 = s_i h_i)."""

    frames: list[np.ndarray]
    signs: list[float]
    theta: list[float]
    d: list[float]
    a: list[float]
    alpha: list[float]

    def add(self, frame: np.ndarray, theta: float, d: float, a: float, alpha: float) -> None:
        for values, value in zip((self.frames, self.theta, self.d, self.a, self.alpha),
                                 (frame, theta, d, a, alpha), strict=True):
            values.append(value)


def walk(lines: ChainLines, first: np.ndarray, first_sign: float, alphas: tuple[float, ...],
         a_signs: tuple[float, ...]) -> Walk:
    """DH frames along the lines with twist angles ``alphas`` (0: parallel axes; +-pi/2: perpendicular, z_i
    directed to give alpha_i its sign), x_i oriented so a_i has the sign of ``a_signs``; Mismatch else."""
    angle_tolerance, length_tolerance = STRUCTURE_TOLERANCE, STRUCTURE_TOLERANCE * lines.length
    result = Walk([first], [first_sign], [], [], [], [])
    for row, (alpha, a_sign) in enumerate(zip(alphas, a_signs, strict=True)):
        frame = result.frames[-1]
        x_previous, z, origin = frame[:3, 0], frame[:3, 2], frame[:3, 3]
        axis, point = lines.axes[row + 1], lines.origins[row + 1]
        cross = np.cross(z, axis)
        sine, cosine = float(np.linalg.norm(cross)), float(np.dot(z, axis))
        pair = f"axes {row + 1} and {row + 2}"
        degrees = math.degrees(angle_between(z, axis))
        if alpha == 0.0:
            if sine > angle_tolerance:
                raise Mismatch(f"{pair} are {degrees:.6g} deg apart, not parallel")
            sign = 1.0 if cosine >= 0.0 else -1.0
            offset = point - origin
            across = offset - np.dot(offset, z) * z
            distance = float(np.linalg.norm(across))
            if distance <= length_tolerance:
                raise Mismatch(f"{pair} coincide")
            x, a, d, new_origin = a_sign * across / distance, a_sign * distance, 0.0, origin + across
        else:
            if abs(cosine) > angle_tolerance:
                raise Mismatch(f"{pair} are {degrees:.6g} deg apart, not perpendicular")
            normal = cross / sine
            w0 = origin - point
            along_z, along_axis = float(np.dot(z, w0)), float(np.dot(axis, w0))
            t = (cosine * along_axis - along_z) / (1.0 - cosine * cosine)
            u = along_axis + cosine * t
            foot, new_origin = origin + t * z, point + u * axis
            gap = float(np.dot(new_origin - foot, normal))
            if abs(gap) <= length_tolerance:  # they meet: x_i's direction gives alpha_i its sign, z_i = +h
                x = normal * math.copysign(1.0, alpha)
                a = gap * math.copysign(1.0, alpha)
            else:
                x, a = normal * math.copysign(1.0, gap) * a_sign, abs(gap) * a_sign
            d = t
            plus = math.atan2(float(np.dot(cross, x)), cosine)  # alpha if z_i = +h
            sign = 1.0 if (plus > 0.0) == (alpha > 0.0) else -1.0
        new_z = sign * axis
        theta = angle_about(z, x_previous, x)
        result.signs.append(sign)
        result.add(_frame(x, new_z, new_origin), theta, d, a, angle_about(x, z, new_z))
    return result


def tip_offset(lines: ChainLines, frame: np.ndarray) -> tuple[float, np.ndarray]:
    """The tip's origin relative to a frame on the last axis: (distance along its z, the rest (3,))."""
    offset = lines.tip[:3, 3] - frame[:3, 3]
    along = float(np.dot(offset, frame[:3, 2]))
    return along, offset - along * frame[:3, 2]


def close_walk(result: Walk, theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Append the last DH row: F_n = F_n-1 Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    frame = result.frames[-1] @ rot_z(theta) @ trans(z=d) @ trans(x=a) @ rot_x(alpha)
    result.add(frame, theta, d, a, alpha)
    return frame


def angle_about(z: np.ndarray, start: np.ndarray, end: np.ndarray) -> float:
    """The angle (rad) turning direction ``start`` onto ``end`` about ``z`` (both orthogonal to z)."""
    return math.atan2(float(np.dot(np.cross(start, end), z)), float(np.dot(start, end)))


def aligned(canonical: Canonical, lines: ChainLines, result: Walk) -> tuple[np.ndarray, np.ndarray,
                                                                              np.ndarray, np.ndarray]:
    """(G, X, s, o) of a finished walk: G = F_0 B^-1, X = E^-1 F_n^-1 T(0), o = theta0 - o_f."""
    base = result.frames[0] @ np.linalg.inv(canonical.base)
    tool = np.linalg.inv(canonical.tool) @ np.linalg.inv(result.frames[-1]) @ lines.tip
    return base, tool, np.array(result.signs), np.array(result.theta) - np.array(canonical.offsets)


# --- what matchers check ----------------------------------------------------------------------------
def require(condition: bool, reason: str) -> None:
    if not condition:
        raise Mismatch(reason)


def require_revolute(lines: ChainLines, count: int) -> None:
    require(lines.count == count, f"it has {lines.count} joints, the family {count}")
    require(not lines.prismatic.any(), "it has a prismatic joint")


def no_options(options: dict, family: str) -> None:
    if options:
        raise InvalidOptionError(f"the recognised {family} form takes no options, got {sorted(options)}",
                                 option=sorted(options)[0])


def in_words(geometry, names: tuple[str, ...]) -> str:
    """A geometry's numbers in words, e.g. "d1=0.1273, a2=-0.612"."""
    return ", ".join(f"{name}={getattr(geometry, name):.6g}" for name in names)


def small(value: float, lines: ChainLines) -> bool:
    return abs(value) <= STRUCTURE_TOLERANCE * lines.length


# --- trying the families ------------------------------------------------------------------------------
def recognise_family(chain, kind: str, options: dict | None, families: tuple[Family, ...]) -> Recognised:
    """The first of ``families`` the chain matches with the model's FK; UnsupportedError saying why none."""
    options = dict(options or {})
    lines = chain_lines(chain)
    reasons = []
    for family in families:
        try:
            match = family.match(lines, kind, options)
        except Mismatch as mismatch:
            reasons.append(f"{family.name}: {mismatch}")
            continue
        inner = match.build(FamilyChain(chain, match.signs, match.offsets))
        form = AlignedForm(chain, inner, match.base, match.tool, match.signs, match.offsets)
        try:
            check_fk_against_model(form)
        except RobotDescriptionError as refused:
            reasons.append(f"{family.name}: the structure matches but the form is refused ({refused})")
            continue
        return Recognised(form, family.name, match.parameters)
    raise UnsupportedError("; ".join(reasons))


def recognise_eaik(chain, kind: str, probe: bool = True) -> Recognised:
    """EAIK's decomposition as a closed form, or UnsupportedError; ``probe=False`` skips the checks."""
    if kind != "pose":
        raise UnsupportedError("EAIK: solves full poses only")
    try:
        form = EAIKForm(chain, probe=probe)
    except (UnsupportedError, MissingDependencyError) as refused:
        raise UnsupportedError(f"EAIK: {refused}") from None
    if probe:
        check_fk_against_model(form)
    return Recognised(form, f"eaik:{form.family}")


def recognise_search(chain, kind: str) -> Recognised:
    """A 6R chain's search-based form (:mod:`.one_d_search`), or UnsupportedError saying why none."""
    lines = chain_lines(chain)
    if kind != "pose":
        raise UnsupportedError("search: solves full poses only")
    if lines.count != 6 or lines.prismatic.any():
        raise UnsupportedError(f"search: for 6 revolute joints (this chain has {lines.count} joints"
                               f"{', a prismatic one' if lines.prismatic.any() else ''})")
    if lines.parallel(1, 2):
        form = TwoParallelForm(chain, lines)
    elif lines.meeting_point(0, 1) is not None and lines.meeting_point(4, 5) is not None:
        form = TwoIntersectingForm(chain, lines)
    else:
        raise UnsupportedError("search: neither axes 2 and 3 parallel nor axes 1, 2 and 5, 6 meeting (the "
                               "1-D searches' structures); a general 6R needs IK-Geo's 2-D search (not "
                               "provided)")
    check_fk_against_model(form)
    joints = chain.random(np.random.default_rng(PROBE_SEED), PROBE_POSES)
    positions, rotations = poe_fk(lines, joints)
    branches, real = form.branches(positions, rotations, joints)
    reached_p, reached_r = poe_fk(lines, np.where(real[..., None], branches, 0.0))
    miss = np.maximum(np.linalg.norm(reached_p - positions[:, None], axis=-1),
                      np.abs(reached_r - rotations[:, None]).max(axis=(-2, -1)))
    reproduced = int(np.sum(np.any(real & (miss <= PROBE_TOLERANCE), axis=1)))
    if reproduced < PROBE_REQUIRED:
        raise UnsupportedError(f"search: {form.family} reproduces {reproduced} of {PROBE_POSES} FK poses of "
                               "random joints")
    return Recognised(form, form.family)


def first_recognised(*recognisers: Callable[[], Recognised]) -> Recognised | list[str]:
    """The first closed form of ``recognisers`` (tried in order), else each one's UnsupportedError reason."""
    reasons = []
    for recognise in recognisers:
        try:
            return recognise()
        except UnsupportedError as refused:
            reasons.append(str(refused))
    return reasons
