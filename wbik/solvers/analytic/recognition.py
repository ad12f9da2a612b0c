"""The closed-form family of a chain, recognised from its kinematic structure.

A robot package may bind a closed form to a chain by hand (``closed_forms={(chain, kind):
"module:Class"}``); where it does not, ``analytic`` looks at the chain's joint lines at q = 0
(:mod:`.structure`) and tries each family wbik has, in :data:`FAMILIES`' order:

- ``ur_type`` (:mod:`.ur_type`, full poses): 6R, axes 2-4 parallel, axis 1 meeting axis 2 at a right
  angle, axis 5 meeting axes 4 and 6 at right angles (UR3/5/10 and the like);
- ``yaw_planar`` (:mod:`.yaw_planar`): a base axis meeting a planar 2R at a right angle, the tip in the
  plane (3R, positions), or a planar 3R with the tip off the last axis (4R, the Pincher: full poses, and
  positions when the two links are equal and the tip is in the plane);
- ``stacked_planar`` (:mod:`.stacked_planar`, full poses and positions): 6R, axes 1-3 parallel, axis 4
  meeting axis 3 at a right angle, axis 5 parallel to 4, axis 6 at a right angle to 5, the arm's
  vertical plane without a sideways offset (the Golem-III arm).

Matching walks standard Denavit-Hartenberg frames along the lines (:func:`walk`), choosing each axis'
direction so that the twist angles are the family's (alpha = 0 between parallel axes, +-pi/2 between
perpendicular ones), and reads off the link lengths a, offsets d and, per joint, the DH angle at q = 0
and the sign between the joint and its DH z axis. The family's own FK is T_f(u) = B D(u + o_f) E with
D the product of its DH rows (:data:`CANONICAL`, checked against each family's FK in the tests), so the
chain is T(q) = G T_f(s q + o - o_f) X with G = F_0 B^-1 and X = E^-1 F_n^-1 T(0): the form is the
family's, seen through :class:`~wbik.solvers.analytic.aligned.AlignedForm`. Parallel, perpendicular,
intersecting and "zero offset" are decided within :data:`~.structure.STRUCTURE_TOLERANCE`.

A recognised form is held to the model's FK like a bound one
(:func:`~wbik.solvers.analytic.model_agreement.check_fk_against_model`): a form whose FK differs is
refused and the next family tried. Where no family matches, full poses go to EAIK's decomposition
(:mod:`.eaik_family`), and a 7-joint chain to one joint held at a value (:mod:`.redundancy`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from wbik.dh import rot_x
from wbik.dh import rot_z
from wbik.dh import trans
from wbik.errors import InvalidOptionError
from wbik.errors import MissingDependencyError
from wbik.errors import RobotDescriptionError
from wbik.errors import UnsupportedError
from wbik.solvers.analytic.aligned import AlignedForm
from wbik.solvers.analytic.aligned import FamilyChain
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.analytic.structure import STRUCTURE_TOLERANCE
from wbik.solvers.analytic.structure import ChainLines
from wbik.solvers.analytic.structure import angle_between
from wbik.solvers.analytic.structure import chain_lines

HALF_PI = 0.5 * math.pi
UR_FLANGE_SHARE = 0.1
"""The UR-type form divides by d6, the distance along axis 6 from the wrist centre to its flange frame,
which any non-zero value describes (the tool transform takes the rest): the tip's own distance when it
is at least UR_FLANGE_MINIMUM of the chain's length, else this share of the length (a well-conditioned
division either way)."""
UR_FLANGE_MINIMUM = 0.01


class Mismatch(Exception):
    """A chain is not of a family: the message says which relation fails (a user reads it)."""


@dataclass(frozen=True)
class Canonical:
    """A family's FK as DH rows: T_f(u) = base D(u + offsets) tool, with twist angles ``alphas``."""

    alphas: tuple[float, ...]
    offsets: tuple[float, ...]
    base: np.ndarray
    tool: np.ndarray


def _rotation4(rows) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = rows
    return matrix


CANONICAL = {
    "ur_type": Canonical((HALF_PI, 0.0, 0.0, HALF_PI, -HALF_PI, 0.0), (0.0,) * 6,
                         _rotation4(np.diag([-1.0, -1.0, 1.0])),  # link0 -> base_link, Rz(pi)
                         _rotation4([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])),  # link6 -> ee
    "yaw_2r": Canonical((HALF_PI, 0.0, 0.0), (0.0, 0.0, 0.0), np.eye(4), np.eye(4)),
    "pitch_arm": Canonical((-HALF_PI, 0.0, 0.0, 0.0), (0.0, -HALF_PI, 0.0, 0.0), np.eye(4),
                           _rotation4([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])),
    "stacked_planar": Canonical((0.0, 0.0, HALF_PI, 0.0, -HALF_PI, HALF_PI),
                                (-HALF_PI, 0.0, HALF_PI, -HALF_PI, 0.0, -HALF_PI), np.eye(4), rot_z(HALF_PI)),
}
"""Each family's FK as DH rows (standard convention, rho = 0 for the stacked-planar arm): ur_type's
``fk`` is base_link -> ee_link of the ROS-Industrial description, Rz(pi) D(u) E; the pitch arm's tool
frame "noa" adds a fixed rotation; the stacked-planar arm's gripper frame Rz(pi/2)."""


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
    """DH frame 0 and the sign s_1 of joint 1 (z_0 = s_1 h_1): on axis 1 at the foot of the base origin,
    as near to the ``preferred`` rotation as the axis allows (z_0 the direction of h_1 nearer to its z,
    x_0 its x made orthogonal), so that a chain described in the family's frames keeps them."""
    axis, point = lines.axes[0], lines.origins[0]
    sign = 1.0 if np.dot(axis, preferred[:, 2]) >= 0.0 else -1.0
    z = sign * axis
    x = preferred[:, 0] - np.dot(preferred[:, 0], z) * z
    if np.linalg.norm(x) < 1e-6:  # the preferred x is along the axis: its y, turned
        x = np.cross(preferred[:, 1], z)
    return _frame(x, z, point - np.dot(point, axis) * axis), sign


@dataclass
class Walk:
    """Standard DH frames F_0..F_k laid along the first k + 1 joint lines at q = 0 (in the base frame),
    and per row i = 1..k: theta_i (the DH angle at q = 0), d_i, a_i, alpha_i; ``signs`` s_1..s_k+1 with
    z_i-1 = s_i h_i."""

    frames: list[np.ndarray]
    signs: list[float]
    theta: list[float]
    d: list[float]
    a: list[float]
    alpha: list[float]


def walk(lines: ChainLines, first: np.ndarray, first_sign: float, alphas: tuple[float, ...],
         a_signs: tuple[float, ...]) -> Walk:
    """DH frames along the lines with twist angles ``alphas`` (0: the axes must be parallel; +-pi/2:
    perpendicular, meeting or not). Between parallel axes x_i is their common perpendicular through
    O_i-1 (d_i = 0); between perpendicular ones, x_i is the common normal (x_i = z_i-1 x h_i+1 where
    they meet), and the direction of z_i gives alpha_i its sign. ``a_signs`` orient x_i so that a_i has
    the family's sign. Mismatch when an angle or a distance breaks the pattern."""
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
        theta = math.atan2(float(np.dot(np.cross(x_previous, x), z)), float(np.dot(x_previous, x)))
        result.frames.append(_frame(x, new_z, new_origin))
        result.signs.append(sign)
        result.theta.append(theta)
        result.d.append(d)
        result.a.append(a)
        result.alpha.append(math.atan2(float(np.dot(np.cross(z, new_z), x)), float(np.dot(z, new_z))))
    return result


def tip_offset(lines: ChainLines, frame: np.ndarray) -> tuple[float, np.ndarray]:
    """The tip's origin relative to a frame on the last axis: (distance along its z, the rest (3,))."""
    offset = lines.tip[:3, 3] - frame[:3, 3]
    along = float(np.dot(offset, frame[:3, 2]))
    return along, offset - along * frame[:3, 2]


def close_walk(result: Walk, theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Append the last DH row (theta at q = 0, d, a, alpha): F_n = F_n-1 Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    frame = result.frames[-1] @ rot_z(theta) @ trans(z=d) @ trans(x=a) @ rot_x(alpha)
    result.frames.append(frame)
    result.theta.append(theta)
    result.d.append(d)
    result.a.append(a)
    result.alpha.append(alpha)
    return frame


def angle_about(z: np.ndarray, start: np.ndarray, end: np.ndarray) -> float:
    """The angle (rad) turning direction ``start`` onto ``end`` about ``z`` (both orthogonal to z)."""
    return math.atan2(float(np.dot(np.cross(start, end), z)), float(np.dot(start, end)))


# --- the families -----------------------------------------------------------------------------------
@dataclass
class Match:
    """A family found on a chain: its form on the family's joints (``build(family_chain)``), the chain's
    base and tool transforms G and X and its joint map u = s q + o, and the parameters in words."""

    family: str
    build: Callable[[FamilyChain], ClosedForm]
    base: np.ndarray
    tool: np.ndarray
    signs: np.ndarray
    offsets: np.ndarray
    parameters: str


def _aligned(canonical: Canonical, lines: ChainLines, result: Walk) -> tuple[np.ndarray, np.ndarray,
                                                                               np.ndarray, np.ndarray]:
    """(G, X, s, o) of a finished walk: G = F_0 B^-1, X = E^-1 F_n^-1 T(0), u = s q + theta0 - o_f."""
    base = result.frames[0] @ np.linalg.inv(canonical.base)
    tool = np.linalg.inv(canonical.tool) @ np.linalg.inv(result.frames[-1]) @ lines.tip
    offsets = np.array(result.theta) - np.array(canonical.offsets)
    return base, tool, np.array(result.signs), offsets


def _require(condition: bool, reason: str) -> None:
    if not condition:
        raise Mismatch(reason)


def _revolute(lines: ChainLines, count: int) -> None:
    _require(lines.count == count, f"it has {lines.count} joints, the family {count}")
    _require(not lines.prismatic.any(), "it has a prismatic joint")


def _no_options(options: dict, family: str) -> None:
    if options:
        raise InvalidOptionError(f"the recognised {family} form takes no options, got {sorted(options)}",
                                 option=sorted(options)[0])


def _parameters(geometry, names: tuple[str, ...]) -> str:
    """A geometry's numbers in words, e.g. "d1=0.1273, a2=-0.612"."""
    return ", ".join(f"{name}={getattr(geometry, name):.6g}" for name in names)


def _small(value: float, lines: ChainLines) -> bool:
    return abs(value) <= STRUCTURE_TOLERANCE * lines.length


def match_ur_type(lines: ChainLines, kind: str, options: dict) -> Match:
    from wbik.solvers.analytic.ur_type import URArm
    from wbik.solvers.analytic.ur_type import URGeometry

    _require(kind == "pose", "the family solves full poses only")
    _revolute(lines, 6)
    canonical = CANONICAL["ur_type"]
    first, sign = first_frame(lines, canonical.base[:3, :3])
    result = walk(lines, first, sign, canonical.alphas[:5], (1.0, -1.0, -1.0, 1.0, 1.0))
    for row, pair in ((0, "1 and 2"), (3, "4 and 5"), (4, "5 and 6")):
        _require(_small(result.a[row], lines), f"axes {pair} miss each other by {abs(result.a[row]):.3g} m")
    length = lines.length
    along, _ = tip_offset(lines, result.frames[-1])
    d6 = along if abs(along) >= UR_FLANGE_MINIMUM * length else math.copysign(UR_FLANGE_SHARE * length, along)
    close_walk(result, 0.0, d6, 0.0, 0.0)
    geometry = URGeometry(d1=result.d[0], a2=result.a[1], a3=result.a[2], d4=result.d[3], d5=result.d[4],
                          d6=d6)

    parameters = _parameters(geometry, ("d1", "a2", "a3", "d4", "d5", "d6"))
    _no_options(options, "ur_type")
    return Match("ur_type", lambda chain: URArm(chain, geometry), *_aligned(canonical, lines, result),
                 parameters)


def match_yaw_planar(lines: ChainLines, kind: str, options: dict) -> Match:
    from wbik.solvers.analytic import yaw_planar

    _require(lines.count in (3, 4), f"it has {lines.count} joints, the family 3 (yaw + planar 2R) or 4 "
                                    "(yaw + planar 3R)")
    _revolute(lines, lines.count)
    three = lines.count == 3
    _require(not three or kind == "position", "a yaw + planar 2R arm is solved for positions only")
    canonical = CANONICAL["yaw_2r" if three else "pitch_arm"]
    first, sign = first_frame(lines, np.eye(3))
    result = walk(lines, first, sign, canonical.alphas[:-1], (1.0,) * (lines.count - 1))
    _require(_small(result.a[0], lines), f"axes 1 and 2 miss each other by {abs(result.a[0]):.3g} m")
    last = result.frames[-1]
    sideways, reach = tip_offset(lines, last)
    distance = float(np.linalg.norm(reach))
    on_axis = _small(distance, lines)
    if kind == "position":
        _require(_small(sideways, lines), f"the tip is {abs(sideways):.3g} m off the arm's plane")
        _require(not on_axis, f"the tip is on the last axis ({distance:.3g} m from it)")
    theta = 0.0 if on_axis else angle_about(last[:3, 2], last[:3, 0], reach / distance)
    close_walk(result, theta, 0.0, 0.0 if on_axis else distance, 0.0)
    base, tool, signs, offsets = _aligned(canonical, lines, result)
    _no_options(options, "yaw_planar")
    if three:
        geometry = yaw_planar.Yaw2RGeometry(l1=result.d[0], l2=result.a[1], l3=result.a[2])
        return Match("yaw_planar", lambda chain: yaw_planar.Yaw2RPosition(chain, geometry), base, tool, signs,
                     offsets, "yaw + planar 2R, " + _parameters(geometry, ("l1", "l2", "l3")))
    a, b = result.a[1], result.a[2]
    if kind == "position":
        _require(_small(a - b, lines), f"its links differ ({a:.6g} and {b:.6g} m); the family's position "
                                       "search needs equal links")
        b = a
    geometry = yaw_planar.PitchArmGeometry(h=result.d[0], a=a, b=b, t=result.a[3])
    family = yaw_planar.PitchArmPose if kind == "pose" else yaw_planar.PitchArmPosition
    return Match("yaw_planar", lambda chain: family(chain, geometry), base, tool, signs, offsets,
                 "yaw + planar 2R + pitch, " + _parameters(geometry, ("h", "a", "b", "t")))


def match_stacked_planar(lines: ChainLines, kind: str, options: dict) -> Match:
    from wbik.solvers.analytic import stacked_planar

    _revolute(lines, 6)
    canonical = CANONICAL["stacked_planar"]
    first, sign = first_frame(lines, np.eye(3))
    result = walk(lines, first, sign, canonical.alphas[:5], (1.0,) * 5)
    _require(_small(result.a[2], lines), f"axes 3 and 4 miss each other by {abs(result.a[2]):.3g} m")
    _require(_small(result.d[4], lines),
             f"the forearm is {abs(result.d[4]):.3g} m off the arm's vertical plane")
    along, off_axis = tip_offset(lines, result.frames[-1])
    if kind == "position":
        distance = float(np.linalg.norm(off_axis))
        _require(_small(distance, lines), f"the tip is {distance:.3g} m off the roll axis (6), so positions "
                                          "depend on the roll")
    close_walk(result, 0.0, along, 0.0, HALF_PI)
    geometry = stacked_planar.StackedPlanarGeometry(l1=result.a[0], l2=result.a[1], l4=result.a[3],
                                                    l5=result.a[4], l6=along, h=result.d[2], rho=0.0)
    base, tool, signs, offsets = _aligned(canonical, lines, result)
    parameters = _parameters(geometry, ("l1", "l2", "l4", "l5", "l6", "h"))
    if kind == "pose":
        _no_options(options, "stacked_planar pose")
        return Match("stacked_planar", lambda chain: stacked_planar.StackedPlanarPose(chain, geometry), base,
                     tool, signs, offsets, parameters)
    unknown = set(options) - {"yaw"}
    if unknown:
        raise InvalidOptionError(f"the recognised stacked_planar position form takes the option 'yaw' (the "
                                 f"roll joint's value, rad), not {sorted(unknown)}",
                                 option=sorted(unknown)[0], accepted=["yaw"])

    def build(family_chain: FamilyChain) -> ClosedForm:
        chain = family_chain.chain
        yaw = options.get("yaw", float(np.clip(chain.nominal[5], chain.lower[5], chain.upper[5])))
        yaw = float(yaw)
        if not math.isfinite(yaw) or not chain.lower[5] <= yaw <= chain.upper[5]:
            raise InvalidOptionError(f"yaw (the roll joint {chain.joint_names[5]}) must be inside "
                                     f"[{chain.lower[5]}, {chain.upper[5]}] rad, got {yaw}", option="yaw",
                                     accepted=["yaw"])
        family_yaw = family_chain.signs[5] * yaw + family_chain.offsets[5]
        return stacked_planar.StackedPlanarPosition(family_chain, geometry, family_yaw)

    return Match("stacked_planar", build, base, tool, signs, offsets, parameters + ", roll held")


FAMILIES: tuple[tuple[str, Callable[[ChainLines, str, dict], Match]], ...] = (
    ("ur_type", match_ur_type),
    ("yaw_planar", match_yaw_planar),
    ("stacked_planar", match_stacked_planar),
)
"""The families wbik has, in the order they are tried, with the function matching each."""


@dataclass(frozen=True)
class Recognised:
    """A chain's closed form found from its structure: the form, its family ("ur_type", ...,
    "eaik:<EAIK's class>", with a locked joint named after it) and its parameters in words."""

    form: ClosedForm
    family: str
    parameters: str = ""


def recognise_family(chain, kind: str, options: dict | None = None) -> Recognised:
    """The first family of :data:`FAMILIES` the chain matches whose form agrees with the model's FK.
    UnsupportedError listing, family by family, why none did."""
    options = dict(options or {})
    lines = chain_lines(chain)
    reasons = []
    for family, matcher in FAMILIES:
        try:
            match = matcher(lines, kind, options)
        except Mismatch as mismatch:
            reasons.append(f"{family}: {mismatch}")
            continue
        inner = match.build(FamilyChain(chain, match.signs, match.offsets))
        form = AlignedForm(chain, inner, match.base, match.tool, match.signs, match.offsets)
        try:
            check_fk_against_model(form)
        except RobotDescriptionError as refused:
            reasons.append(f"{family}: the structure matches but the form is refused ({refused})")
            continue
        return Recognised(form, family, match.parameters)
    raise UnsupportedError("; ".join(reasons))


def recognise_eaik(chain, kind: str, probe: bool = True) -> Recognised:
    """EAIK's decomposition of the chain as a closed form (full poses), or UnsupportedError saying why.
    ``probe=False`` (a chain rebuilt at each value of a held joint, checked at its nominal value) skips
    EAIK's probe and the model agreement: the form's FK is the lines' product of exponentials, built as
    the checked one is."""
    if kind != "pose":
        raise UnsupportedError("EAIK: solves full poses only")
    from wbik.solvers.analytic.eaik_family import EAIKForm

    try:
        form = EAIKForm(chain, probe=probe)
    except UnsupportedError as refused:
        raise UnsupportedError(f"EAIK: {refused}") from None
    except MissingDependencyError as missing:
        raise UnsupportedError(f"EAIK: {missing}") from None
    if probe:
        check_fk_against_model(form)
    return Recognised(form, f"eaik:{form.family}")
