"""From URDF text to wbik's Pinocchio model (docs/guide/robots.md): a continuous joint, which Pinocchio
parses as (cos, sin), becomes the revolute joint about its axis limited to [-pi, pi] (ids and nv kept);
frames sharing a link's name get their kind's suffix (``NAME_joint``); ``<mimic>`` joints are read.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError

CONTINUOUS_LIMIT = math.pi
"""A continuous joint's range is [-CONTINUOUS_LIMIT, CONTINUOUS_LIMIT] (rad)."""

_BOUNDED_OF = {"JointModelRUBX": pin.JointModelRX, "JointModelRUBY": pin.JointModelRY,
               "JointModelRUBZ": pin.JointModelRZ}
_SUFFIX = {pin.FrameType.JOINT: "joint", pin.FrameType.FIXED_JOINT: "joint", pin.FrameType.OP_FRAME: "frame",
           pin.FrameType.SENSOR: "sensor"}


@dataclass(frozen=True)
class Mimic:
    """A URDF ``<mimic>``: ``follower = multiplier * leader + offset``."""

    follower: str
    leader: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass
class ParsedModel:
    """A URDF parsed into wbik's model: ``continuous`` joints' names, ``renamed`` {new frame name: old
    name}, ``mimic`` {follower joint: Mimic}, and ``source_model``, Pinocchio's own parse (cos, sin)."""

    model: pin.Model
    continuous: tuple[str, ...] = ()
    renamed: dict[str, str] = field(default_factory=dict)
    mimic: dict[str, Mimic] = field(default_factory=dict)
    source_model: pin.Model | None = None


def is_unbounded_revolute(joint) -> bool:
    """Whether a Pinocchio joint model is an unbounded revolute joint (cos, sin)."""
    name = joint.shortname()
    return name in _BOUNDED_OF or name == "JointModelRevoluteUnboundedUnaligned"


def _unique_frame_names(model: pin.Model) -> list[str]:
    """Each frame's name, the non-link frames of a shared name renamed by their kind."""
    names = [frame.name for frame in model.frames]
    taken = set(names)
    for name in [name for name, count in Counter(names).items() if count > 1]:
        indices = [i for i, frame in enumerate(model.frames) if frame.name == name]
        bodies = [i for i in indices if model.frames[i].type == pin.FrameType.BODY]
        if len(bodies) > 1:
            raise RobotDescriptionError(f"two links are named {name!r}; give each link its own name")
        keeper = bodies[0] if bodies else indices[0]
        for index in (i for i in indices if i != keeper):
            suffix = _SUFFIX.get(model.frames[index].type, "frame")
            new, count = f"{name}_{suffix}", 2
            while new in taken:
                new, count = f"{name}_{suffix}{count}", count + 1
            taken.add(new)
            names[index] = new
    return names


def angle_model(model: pin.Model) -> ParsedModel:
    """``model`` with one angle per revolute joint and unique frame names (itself if nothing changes)."""
    unbounded = [j for j in range(1, model.njoints) if is_unbounded_revolute(model.joints[j])]
    names = _unique_frame_names(model)
    renamed = {new: frame.name for new, frame in zip(names, model.frames, strict=True) if new != frame.name}
    if not unbounded and not renamed:
        return ParsedModel(model, source_model=model)
    rebuilt = pin.Model()
    rebuilt.name = model.name
    rebuilt.gravity = model.gravity
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        q_slice = slice(joint.idx_q, joint.idx_q + joint.nq)
        v_slice = slice(joint.idx_v, joint.idx_v + joint.nv)
        if joint_id in unbounded:  # the bounded revolute joint about the same axis
            bounded = _BOUNDED_OF.get(joint.shortname())
            new_joint = bounded() if bounded else pin.JointModelRevoluteUnaligned(
                np.asarray(joint.extract().axis, dtype=float))
            lower, upper = np.array([-CONTINUOUS_LIMIT]), np.array([CONTINUOUS_LIMIT])
        else:
            new_joint = joint
            lower, upper = model.lowerPositionLimit[q_slice], model.upperPositionLimit[q_slice]
        new_id = rebuilt.addJoint(model.parents[joint_id], new_joint, model.jointPlacements[joint_id],
                                  model.names[joint_id], model.effortLimit[v_slice],
                                  model.velocityLimit[v_slice], lower, upper,
                                  model.friction[v_slice], model.damping[v_slice])
        rebuilt.inertias[new_id] = model.inertias[joint_id]
    for index in range(1, len(model.frames)):
        frame = pin.Frame(model.frames[index])
        frame.name = names[index]
        rebuilt.addFrame(frame, False)  # the bodies' inertias are already in the joints' inertias
    for quantity in ("armature", "rotorInertia", "rotorGearRatio"):
        setattr(rebuilt, quantity, getattr(model, quantity).copy())
    continuous = tuple(model.names[j] for j in unbounded)
    return ParsedModel(rebuilt, continuous, renamed, source_model=model)


def angles_of(parsed: pin.Model, angles: pin.Model, q: np.ndarray) -> np.ndarray:
    """A configuration of ``parsed`` (cos, sin per continuous joint) as one of ``angles``."""
    out = pin.neutral(angles)
    for joint_id in range(1, parsed.njoints):
        joint, target = parsed.joints[joint_id], angles.joints[joint_id]
        values = q[joint.idx_q:joint.idx_q + joint.nq]
        if is_unbounded_revolute(joint):
            out[target.idx_q] = math.atan2(values[1], values[0])
        else:
            out[target.idx_q:target.idx_q + target.nq] = values
    return out


_JOINT_BLOCK = re.compile(r"<joint\b([^>]*?)>(.*?)</joint\s*>", re.DOTALL)
_ATTRIBUTE = re.compile(r"""\b(\w+)\s*=\s*(["'])(.*?)\2""", re.DOTALL)
_MIMIC = re.compile(r"<mimic\b([^>]*?)/?>", re.DOTALL)
_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)


def _attributes(tag_text: str) -> dict[str, str]:
    """The ``name="value"`` attributes of a tag's text."""
    return {key: value for key, _, value in _ATTRIBUTE.findall(tag_text)}


def mimic_joints(text: str) -> dict[str, Mimic]:
    """{follower: Mimic} of URDF text's ``<mimic>`` joints, read as leniently as URDF readers do."""
    text = _COMMENT.sub("", text)
    mimics = {}
    for attributes, body in _JOINT_BLOCK.findall(text):
        found = _MIMIC.search(body)
        if found is None:
            continue
        own = _attributes(attributes)
        mimic = _attributes(found.group(1))
        if "name" not in own or "joint" not in mimic:
            continue
        try:
            multiplier = float(mimic.get("multiplier", 1.0))
            offset = float(mimic.get("offset", 0.0))
        except ValueError as exc:
            raise RobotDescriptionError(
                f"joint {own['name']!r}: <mimic> multiplier and offset must be numbers ({exc})") from None
        mimics[own["name"]] = Mimic(own["name"], mimic["joint"], multiplier, offset)
    return mimics


def parse_urdf(text: str, floating_base: bool = False, source: str = "URDF") -> ParsedModel:
    """URDF text as wbik's model (:func:`angle_model`) with its mimic joints, or RobotDescriptionError."""
    try:
        model = (pin.buildModelFromXML(text, pin.JointModelFreeFlyer()) if floating_base
                 else pin.buildModelFromXML(text))
    except (RuntimeError, ValueError) as exc:
        raise RobotDescriptionError(
            f"{source} does not parse as a URDF: {exc}. Check that it is well-formed XML with one root "
            "link and that every joint names existing parent and child links") from exc
    parsed = angle_model(model)
    parsed.mimic = {name: mimic for name, mimic in mimic_joints(text).items()
                    if parsed.model.existJointName(name)}
    parsed.source_model = model
    return parsed


_TYPE_CONTINUOUS = re.compile(r"""\btype\s*=\s*(["'])continuous\1""")
_LIMIT = re.compile(r"<limit\b([^>]*?)(/?)>", re.DOTALL)
_BOUND_ATTRIBUTE = re.compile(r"""\s(lower|upper)\s*=\s*(["']).*?\2""", re.DOTALL)


def continuous_as_revolute(text: str, limit: float) -> str:
    """URDF text with every continuous joint revolute in [-limit, limit] (effort and velocity kept)."""

    def one_joint(match: re.Match) -> str:
        attributes, body = match.group(1), match.group(2)
        if not _TYPE_CONTINUOUS.search(attributes):
            return match.group(0)
        attributes = _TYPE_CONTINUOUS.sub('type="revolute"', attributes)
        bounds = f' lower="{-limit!r}" upper="{limit!r}"'
        found = _LIMIT.search(body)
        if found is None:
            body = f'<limit{bounds} effort="0" velocity="0"/>{body}'
        else:
            kept = _BOUND_ATTRIBUTE.sub("", found.group(1))
            body = f"{body[:found.start()]}<limit{bounds}{kept}{found.group(2)}>{body[found.end():]}"
        return f"<joint{attributes}>{body}</joint>"

    return _JOINT_BLOCK.sub(one_joint, text)


_LINK_BLOCK = re.compile(r"<link\b([^>]*?)(/>|>(.*?)</link\s*>)", re.DOTALL)
_CHILD = re.compile(r"""<child\b[^>]*?\blink\s*=\s*(["'])(.*?)\1""", re.DOTALL)
MASSLESS_ROOT = "wbik_massless_root"


def with_massless_root(text: str) -> str:
    """URDF text whose root link, if it has an ``<inertial>``, hangs by a fixed joint from a massless root."""
    uncommented = _COMMENT.sub("", text)
    children = {match.group(2) for match in _CHILD.finditer(uncommented)}
    for match in _LINK_BLOCK.finditer(uncommented):
        name = _attributes(match.group(1)).get("name")
        if name is None or name in children:
            continue
        if "<inertial" not in (match.group(3) or ""):
            return text
        root = (f'<link name="{MASSLESS_ROOT}"/><joint name="{MASSLESS_ROOT}_joint" type="fixed">'
                f'<parent link="{MASSLESS_ROOT}"/><child link="{name}"/></joint>')
        first_link = re.search(r"<link\b", text)
        return text[:first_link.start()] + root + text[first_link.start():]
    return text


def reduced_model(model: pin.Model, locked: list[int], q: np.ndarray) -> pin.Model:
    """``pin.buildReducedModel(model, locked, q)``, also where a joint has a link's name (Pinocchio then
    fails on the ambiguous name): such joints are renamed for the call, and in the result keep their
    names while their frames are ``NAME_joint``, as :func:`angle_model` names them."""
    frame_names = {frame.name for frame in model.frames}
    clashing = {joint_id: model.names[joint_id] for joint_id in range(1, model.njoints)
                if model.names[joint_id] in frame_names
                and model.frames[model.getFrameId(model.names[joint_id])].parentJoint != joint_id}
    if not clashing:
        return pin.buildReducedModel(model, locked, q)
    work = pin.Model(model)
    temporary = {}
    for joint_id, name in clashing.items():
        work.names[joint_id] = temporary_name = f"{name}__wbik_renamed_joint"
        temporary[temporary_name] = name
    for index, frame in enumerate(work.frames):  # Pinocchio finds a joint frame's joint by its name
        if frame.type == pin.FrameType.JOINT and frame.parentJoint in clashing:
            renamed = pin.Frame(frame)
            renamed.name = work.names[frame.parentJoint]
            work.frames[index] = renamed
    reduced = pin.buildReducedModel(work, locked, q)
    for joint_id in range(1, reduced.njoints):
        if reduced.names[joint_id] in temporary:
            reduced.names[joint_id] = temporary[reduced.names[joint_id]]
    for index, frame in enumerate(reduced.frames):
        if frame.name in temporary:
            renamed = pin.Frame(frame)
            renamed.name = f"{temporary[frame.name]}_joint"
            reduced.frames[index] = renamed
    return reduced


_NAME_ATTRIBUTE = re.compile(r"""(\bname\s*=\s*)(["'])(.*?)\2""", re.DOTALL)


def fixed_joints_renamed(text: str) -> str:
    """URDF text whose fixed joints named like a link are renamed ``NAME_joint`` (as :func:`angle_model`)."""
    uncommented = _COMMENT.sub("", text)
    links = {_attributes(match.group(1)).get("name") for match in _LINK_BLOCK.finditer(uncommented)}

    def one_joint(match: re.Match) -> str:
        attributes = match.group(1)
        own = _attributes(attributes)
        if own.get("type") != "fixed" or own.get("name") not in links:
            return match.group(0)
        renamed = _NAME_ATTRIBUTE.sub(lambda name: f'{name.group(1)}"{name.group(3)}_joint"', attributes,
                                      count=1)
        return f"<joint{renamed}>{match.group(2)}</joint>"

    return _JOINT_BLOCK.sub(one_joint, text)
