"""Robot (a Pinocchio model with named chains) and Chain (one serial chain of it).

A chain is solved on its own reduced model (the other joints locked at the robot's nominal
configuration): q has one value per chain joint, poses and Jacobians are in the chain's base frame,
which must not move with the chain's joints.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import threading
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pinocchio as pin

from wbik.errors import (
    InvalidConfigurationError,
    RobotDescriptionError,
    SoleError,
    UnknownChainError,
    UnsupportedError,
    did_you_mean,
)
from wbik.files import atomic_write_text
from wbik.geometry import pose_errors, wrap_to_pi
from wbik.kernels.chain_fk import compiled_chain, tip_errors, tip_pose
from wbik.kernels.twins import chosen, compiled_twin
from wbik.kinematic_tree import ChainPath, chain_path, frame_index, leaf_frames
from wbik.urdf import Mimic, angles_of, parse_urdf, reduced_model
from wbik.validation import numeric_array

_CHAIN_BUILD_LOCK = threading.Lock()


class PerThreadData:
    """``owner.data``: this thread's Pinocchio Data of ``owner.model`` (kept in ``owner._local``)."""

    def __get__(self, owner, owner_type=None) -> pin.Data:
        if owner is None:
            return self
        try:
            return owner._local.data
        except AttributeError:
            owner._local.data = owner.model.createData()
            return owner._local.data


CachedT = TypeVar("CachedT")


def _python_plain_finite(q, n: int) -> bool:
    """Whether ``q`` is a float64 (n,) array of finite values (compiled twin:
    ``wbik.kernels._pose.plain_finite``)."""
    return (type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (n,)
            and all(map(math.isfinite, q.tolist())))


plain_finite = chosen(_python_plain_finite, compiled_twin("pose", "plain_finite"), "pose")
"""plain_finite(q, n) -> bool: the start joints' fast-path test (see the Python twin)."""


class ChainCache:
    """A value per chain, shared by threads, weakly keyed; the caller computes it between get and store."""

    def __init__(self) -> None:
        self._values: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
        self._lock = threading.Lock()

    def get(self, chain) -> Any:
        """The value stored for ``chain``, None when there is none yet."""
        with self._lock:
            return self._values.get(chain)

    def store(self, chain, value: CachedT) -> CachedT:
        with self._lock:
            self._values[chain] = value
        return value


@dataclass(frozen=True)
class ChainSpec:
    """Base frame, tip frame and the joints between them, in order; with no joints, every joint between
    base and tip (mimic joints locked), as KDL, TRAC-IK and MoveIt take a chain."""

    name: str
    base_frame: str
    tip_frame: str
    joints: tuple[str, ...] = ()
    description: str = ""


class Chain:
    """One serial chain: q -> pose of ``tip_frame`` in ``base_frame``.

    ``model``/``data``: the reduced model; ``lower``/``upper`` (rad or m), ``velocity_limit``,
    ``nominal`` and ``mid_range`` ((lower + upper) / 2) per joint. Continuous joints (``continuous``) have
    the range [-pi, pi] and are wrapped into it (:meth:`clip`); ``unbounded_lower``/``unbounded_upper``
    are the limits with -inf/inf there. ``locked_mimic``: mimic joints between base and tip, locked.
    """

    def __init__(self, robot: Robot, spec: ChainSpec):
        self.robot, self.spec = robot, spec
        self.name, self.base_frame, self.tip_frame = spec.name, spec.base_frame, spec.tip_frame
        full = robot.model
        for frame in (spec.base_frame, spec.tip_frame):
            robot.frame_id(frame)  # raises UnknownFrameError with the known names
        path = (ChainPath(spec.joints) if spec.joints
                else chain_path(full, spec.base_frame, spec.tip_frame, robot.mimic))
        self.joint_names, self.locked_mimic = list(path.joints), path.locked_mimic
        joint_ids = []
        for joint in self.joint_names:
            if not full.existJointName(joint):
                raise RobotDescriptionError(
                    f"chain {spec.name!r} names joint {joint!r}, which {robot.name!r} does not have")
            joint_id = full.getJointId(joint)
            if full.joints[joint_id].nq != 1 or full.joints[joint_id].nv != 1:
                raise UnsupportedError(
                    f"chain {spec.name!r}: joint {joint!r} is {_joint_kind(full.joints[joint_id])}, "
                    "not a 1-DOF revolute, continuous or prismatic joint; leave it out of the chain "
                    "(it is then locked)")
            joint_ids.append(joint_id)
        self.q_index = np.array([full.joints[j].idx_q for j in joint_ids])
        self.v_index = np.array([full.joints[j].idx_v for j in joint_ids])
        locked = [j for j in range(1, full.njoints) if j not in joint_ids]
        self.model = reduced_model(full, locked, robot.nominal)
        self._local = threading.local()
        order = [self.model.getJointId(name) for name in self.joint_names]
        if order != sorted(order):
            raise RobotDescriptionError(
                f"chain {spec.name!r}: list the joints in kinematic order from base to tip")
        self.base_id = self.model.getFrameId(spec.base_frame)
        self.tip_id = self.model.getFrameId(spec.tip_frame)
        if self.model.frames[self.base_id].parentJoint != 0:
            raise RobotDescriptionError(
                f"chain {spec.name!r}: base frame {spec.base_frame!r} moves with the chain's joints; "
                "choose a base frame upstream of the first chain joint")
        pin.framesForwardKinematics(self.model, self.data, pin.neutral(self.model))
        self.base_placement = self.data.oMf[self.base_id].copy()
        self._base_inverse = self.base_placement.inverse()
        self._base_is_identity = bool(self.base_placement.isIdentity())
        self._base_rotation_t = self.base_placement.rotation.T.copy()
        self.base_inverse_matrix = None if self._base_is_identity else self._base_inverse.homogeneous
        if self.base_inverse_matrix is not None:
            self.base_inverse_matrix.flags.writeable = False
        """None where the base frame is the model's root frame, else its inverse placement (4 x 4)."""
        self.lower = robot.model.lowerPositionLimit[self.q_index].copy()
        self.upper = robot.model.upperPositionLimit[self.q_index].copy()
        self.velocity_limit = robot.model.velocityLimit[self.v_index].copy()
        self.nominal = robot.nominal[self.q_index].copy()
        self.mid_range = 0.5 * (self.lower + self.upper)
        self.is_prismatic = np.array([full.joints[j].shortname().startswith("JointModelP")
                                      for j in joint_ids])
        self.continuous = np.array([name in robot.continuous_joints for name in self.joint_names], dtype=bool)
        self.any_continuous = bool(self.continuous.any())
        self.unbounded_lower = np.where(self.continuous, -np.inf, self.lower)
        self.unbounded_upper = np.where(self.continuous, np.inf, self.upper)
        for array in (self.continuous, self.unbounded_lower, self.unbounded_upper):
            array.flags.writeable = False

    data = PerThreadData()

    @property
    def nq(self) -> int:
        return len(self.joint_names)

    def __repr__(self) -> str:
        return (f"Chain({self.robot.name}.{self.name}: {self.base_frame} -> {self.tip_frame}, "
                f"{self.nq} joints {self.joint_names})")

    def check_q(self, q: Sequence[float]) -> np.ndarray:
        """q as a float array (a copy) of n finite values, or InvalidConfigurationError."""
        if plain_finite(q, self.nq):  # the common case, fast (docs/measurements.md, robot)
            return q.copy()
        array = numeric_array(q, "joint values", InvalidConfigurationError).reshape(-1)
        if array.shape != (self.nq,):
            raise InvalidConfigurationError(
                f"chain {self.name!r} has {self.nq} joints {self.joint_names}; got {array.size} values")
        return array

    def fk(self, q: np.ndarray) -> pin.SE3:
        """Pose of the tip frame in the base frame (a new SE3; only the tip frame is placed)."""
        model, data = self.model, self.data
        pin.forwardKinematics(model, data, q)
        tip = pin.updateFramePlacement(model, data, self.tip_id)  # a copy, not a view into data
        return tip if self._base_is_identity else self._base_inverse * tip

    @cached_property
    def compiled_fk(self):
        """The compiled chain FK's copy of the reduced model (:mod:`wbik.kernels.chain_fk`), or None."""
        return compiled_chain(self.model, self.tip_id, self.lower, self.upper, self.base_inverse_matrix)

    def root_tip(self, q: np.ndarray) -> np.ndarray:
        """The tip frame's 4 x 4 pose in the model's root frame (:attr:`base_inverse_matrix` takes it into the
        base frame); only the tip frame is placed. Pinocchio's FK: of float64 joints in C++ where the compiled
        chain FK is built (the same bits for finite joints), else through its binding."""
        compiled = self.compiled_fk
        plain = type(q) is np.ndarray and q.dtype == np.float64 and q.shape == self.lower.shape
        if compiled is not None and plain:
            pose = np.empty((4, 4))
            tip_pose(compiled, q, pose)
            return pose
        model, data = self.model, self.data  # (data: a per-thread lookup, once)
        pin.forwardKinematics(model, data, q)
        return pin.updateFramePlacement(model, data, self.tip_id).homogeneous

    def tip_errors(self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray | None,
                   position_error: np.ndarray, rotation_error: np.ndarray) -> tuple[float, float, bool]:
        """The shared check's errors of float64 joints q on a target in the base frame:
        :func:`wbik.geometry.pose_errors` of their tip pose (e_p, e_R written into the last two arrays;
        returns |e_p|, |e_R| and whether the formula kept the axis), FK and errors in one compiled call
        where the compiled chain FK is built."""
        compiled = self.compiled_fk
        if compiled is not None and tip_errors is not None:
            return tip_errors(compiled, q, position, rotation, position_error, rotation_error,
                              self.base_inverse_matrix)
        return pose_errors(self.root_tip(q), position, rotation, position_error, rotation_error,
                           self.base_inverse_matrix)

    def fk_jacobian(self, q: np.ndarray) -> tuple[pin.SE3, np.ndarray]:
        """(tip pose, 6 x n Jacobian [v; w]) in base-frame axes, v taken at the tip origin."""
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        jacobian = pin.getFrameJacobian(self.model, self.data, self.tip_id,
                                        pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        rotation_t = self._base_rotation_t
        jacobian = np.vstack((rotation_t @ jacobian[:3], rotation_t @ jacobian[3:]))
        return self._base_inverse * self.data.oMf[self.tip_id], jacobian

    def in_limits(self, q: np.ndarray, tolerance: float = 1e-9) -> bool:
        return bool(np.all(q >= self.lower - tolerance) and np.all(q <= self.upper + tolerance))

    def clip(self, q: np.ndarray) -> np.ndarray:
        """q (n,) or (B, n) in range: continuous joints wrapped into (-pi, pi], the others clipped."""
        return np.clip(self.wrap_continuous(q), self.lower, self.upper)

    def wrap_continuous(self, q: np.ndarray) -> np.ndarray:
        """q with its continuous joints wrapped into (-pi, pi] (q itself if the chain has none)."""
        if not self.any_continuous:
            return q
        return np.where(self.continuous, wrap_to_pi(q), q)

    def random(self, rng: np.random.Generator, count: int | None = None) -> np.ndarray:
        """Uniform joint values inside the limits: shape (n,) or (count, n)."""
        shape = (self.nq,) if count is None else (count, self.nq)
        return rng.uniform(self.lower, self.upper, size=shape)

    def full_configuration(self, q: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
        """The robot's full configuration with this chain at q and the rest at ``reference``."""
        full = (self.robot.nominal if reference is None else reference).copy()
        full[self.q_index] = q
        return full


def _sole_corners(sole, corners) -> np.ndarray:
    """(k, 3) finite contact points of a sole in its frame (m), read-only, or SoleError: a flat sole's
    corners (k >= 3), an edge (k = 2) or a point foot (k = 1, ``[0, 0, 0]`` also accepted)."""
    try:
        array = np.array(corners, dtype=float)
    except (TypeError, ValueError):
        array = np.empty(0)
    if array.shape == (3,):
        array = array.reshape(1, 3)  # one point
    if array.ndim != 2 or array.shape[1] != 3 or array.shape[0] < 1 or not np.all(np.isfinite(array)):
        raise SoleError(
            f"sole {sole!r}: contact points must be finite points (k, 3) in the sole frame (m), k >= 1 (a "
            f"point foot [[0, 0, 0]], an edge, or a rectangle's 4 corners), got "
            f"{np.shape(array) if array.size else repr(corners)}", str(sole))
    array.setflags(write=False)
    return array


FactsT = TypeVar("FactsT")


@dataclass
class Robot:
    """A Pinocchio model with named chains, limits, a nominal configuration and typed facts.

    ``soles``: {sole frame: (k, 3) contact points in it (m)}, the feet of the support polygon.
    ``closed_forms``: {(chain, target kind): closed form class or factory (chain, **options)}.
    ``facts``: the robot package's frozen dataclass (lengths, servo IDs, assumptions) or None, read with
    :meth:`require_facts`. ``continuous_joints``: revolute in ``model``, range [-pi, pi]; ``mimic``:
    {follower joint: Mimic}; ``renamed_frames``: {new name: URDF name} (:mod:`wbik.urdf`).
    """

    name: str
    model: pin.Model
    urdf_text: str
    chains: dict[str, ChainSpec]
    nominal: np.ndarray
    urdf_path: Path | None = None
    package_dirs: list[str] = field(default_factory=list)
    soles: dict[str, np.ndarray] = field(default_factory=dict)
    closed_forms: dict[tuple[str, str], str] = field(default_factory=dict)
    facts: Any = None
    continuous_joints: tuple[str, ...] = ()
    mimic: dict[str, Mimic] = field(default_factory=dict)
    renamed_frames: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._local = threading.local()
        self.nominal = np.asarray(self.nominal, dtype=float)
        self.soles = self._checked_soles(self.soles)
        self.closed_forms = self._checked_closed_forms(self.closed_forms)
        facts = self.facts
        if facts is not None and not (dataclasses.is_dataclass(facts) and not isinstance(facts, type)
                                      and type(facts).__dataclass_params__.frozen):
            raise RobotDescriptionError(
                f"robot {self.name!r}: facts must be an instance of a frozen dataclass (the robot "
                f"package's typed facts) or None, got {type(self.facts).__name__}")
        self._chains: dict[str, Chain] = {}

    def _mapping(self, value, what: str) -> Mapping:
        """``value`` if it is a mapping, else RobotDescriptionError."""
        if not isinstance(value, Mapping):
            raise RobotDescriptionError(f"robot {self.name!r}: {what}, got {type(value).__name__}")
        return value

    def _checked_soles(self, soles) -> dict[str, np.ndarray]:
        soles = self._mapping(soles, "soles must map a sole frame to its (k, 3) contact points")
        checked = {}
        for sole, corners in soles.items():
            if not isinstance(sole, str) or not self.model.existFrame(sole):
                raise SoleError(
                    f"robot {self.name!r}: sole {sole!r} is not a frame of the model"
                    f"{did_you_mean(sole, self.frame_names)}; soles are named by their frames, e.g. "
                    f"{self.frame_names[-1]!r}", str(sole))
            checked[sole] = _sole_corners(sole, corners)
        return checked

    def _checked_closed_forms(self, closed_forms) -> dict[tuple[str, str], Any]:
        closed_forms = self._mapping(closed_forms, "closed_forms must map (chain, target kind) to a closed "
                                                   "form's class or factory")
        for key, binding in closed_forms.items():
            if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(k, str) for k in key)
                    and key[0] in self.chains):
                raise RobotDescriptionError(
                    f"robot {self.name!r}: closed form key {key!r} is not (chain, target kind) with a chain "
                    f"of {sorted(self.chains)}; e.g. ('arm', 'pose')")
            if not callable(binding):
                raise RobotDescriptionError(
                    f"robot {self.name!r}: closed form of {key!r} must be a closed form's class or a factory "
                    f"(chain, **options) -> ClosedForm, e.g. the robot package's closed_form.MyArm, got "
                    f"{binding!r}")
        return dict(closed_forms)

    def require_facts(self, kind: type[FactsT], needed_by: str) -> FactsT:
        """``facts`` if it is a ``kind``, else RobotDescriptionError saying that ``needed_by`` needs them."""
        if isinstance(self.facts, kind):
            return self.facts
        has = "no facts" if self.facts is None else f"facts of type {type(self.facts).__name__}"
        raise RobotDescriptionError(
            f"{needed_by} needs a robot with {kind.__name__}; robot {self.name!r} has {has}. Load the robot "
            f"through its package (wbik.load(name)) or pass facts={kind.__name__}(...)")

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, nq={self.model.nq}, nv={self.model.nv}, chains={list(self.chains)})"

    data = PerThreadData()

    @property
    def has_floating_base(self) -> bool:
        return self.model.njoints > 1 and self.model.joints[1].shortname() == "JointModelFreeFlyer"

    @cached_property
    def frame_names(self) -> list[str]:
        return [frame.name for frame in self.model.frames]

    def frame_id(self, name: str) -> int:
        return frame_index(self.model, name)

    def chain(self, name: str | None = None) -> Chain:
        """The chain called ``name`` (the only chain, if the robot has one and name is None)."""
        if name is None:
            if len(self.chains) != 1:
                hint = (f"{self.name} has several chains: pass chain=..." if self.chains else
                        f"{self.name} is a tree with no chain declared: name one by its base and tip, "
                        f"robot.chain_between(base, tip), or --base and --tip on the command line (tips: "
                        f"{', '.join(leaf_frames(self.model)[:8])})")
                raise UnknownChainError("(none given)", list(self.chains), hint=hint)
            name = next(iter(self.chains))
        if not isinstance(name, str):
            raise UnknownChainError(repr(name), list(self.chains), hint="A chain is named by a string")
        if name not in self.chains:
            raise UnknownChainError(name, list(self.chains))
        if name not in self._chains:
            with _CHAIN_BUILD_LOCK:  # one Chain per name, also when threads ask at once
                if name not in self._chains:
                    self._chains[name] = Chain(self, self.chains[name])
        return self._chains[name]

    def chain_between(self, base: str, tip: str, name: str | None = None) -> Chain:
        """The chain from frame ``base`` to frame ``tip`` with every joint between them (mimic joints
        locked), registered under ``name`` (default "BASE_to_TIP") for ``chain(name)``."""
        name = f"{base}_to_{tip}" if name is None else name
        spec = ChainSpec(name, base, tip, description=f"{base} to {tip}, joints found between them")
        known = self.chains.get(name)
        if known is not None and (known.base_frame, known.tip_frame) != (base, tip):
            raise RobotDescriptionError(f"robot {self.name!r} already has a chain {name!r} from "
                                        f"{known.base_frame!r} to {known.tip_frame!r}; pass another name")
        if known is None:
            chain = Chain(self, spec)  # errors (unknown frames, base not upstream) before registering
            with _CHAIN_BUILD_LOCK:
                self.chains[name] = spec
                self._chains.setdefault(name, chain)
        return self.chain(name)

    def frame_placement(self, q: np.ndarray, frame: str) -> pin.SE3:
        """World placement of a frame at full configuration q."""
        frame_id = self.frame_id(frame)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[frame_id].copy()

    def center_of_mass(self, q: np.ndarray) -> np.ndarray:
        return pin.centerOfMass(self.model, self.data, q).copy()

    @property
    def mass(self) -> float:
        return float(sum(inertia.mass for inertia in self.model.inertias))


def cache_dir() -> Path:
    """``$WBIK_CACHE_DIR``, else ``$XDG_CACHE_HOME/wbik``, else ``~/.cache/wbik`` (not created here)."""
    if override := os.environ.get("WBIK_CACHE_DIR"):
        return Path(override).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg and Path(xdg).is_absolute() else Path.home() / ".cache"
    return base / "wbik"


def write_cached_urdf(name: str, text: str) -> Path:
    """URDF text written once to a content-addressed file in ``cache_dir()/urdf`` (for PlaCo and the like)."""
    digest = hashlib.sha1(text.encode()).hexdigest()[:12]
    folder = cache_dir() / "urdf"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}-{digest}.urdf"
    if not path.exists():
        atomic_write_text(path, text)
    return path


def _joint_kind(joint) -> str:
    """A joint's kind in words, for messages."""
    name = joint.shortname()
    if "Unbounded" in name or name.startswith("JointModelRUB"):
        return "continuous (an unbounded revolute joint)"
    kinds = {"JointModelFreeFlyer": "a free-flyer (6-DOF) joint", "JointModelPlanar": "a planar joint",
             "JointModelSpherical": "a spherical joint"}
    return kinds.get(name, f"a {name.removeprefix('JointModel')} joint with nq={joint.nq}")


def check_model(model: pin.Model, source: str = "URDF") -> None:
    """RobotDescriptionError naming a joint with a zero axis, a NaN limit or lower above upper."""
    for joint_id in range(1, model.njoints):
        joint, name = model.joints[joint_id], model.names[joint_id]
        axis = getattr(joint.extract(), "axis", None)
        if axis is not None and not np.linalg.norm(axis) > 1e-12:
            raise RobotDescriptionError(
                f"{source}: joint {name!r} has a zero axis {np.asarray(axis).tolist()}; give it a "
                "non-zero <axis xyz=...> (e.g. 0 0 1)")
        if joint.nq != 1:
            continue
        lower = float(model.lowerPositionLimit[joint.idx_q])
        upper = float(model.upperPositionLimit[joint.idx_q])
        if np.isnan(lower) or np.isnan(upper) or lower > upper:
            raise RobotDescriptionError(
                f"{source}: joint {name!r} has lower limit {lower:g} above upper limit {upper:g}; "
                "swap them in its <limit lower=... upper=...>")


def serial_chain_spec(model: pin.Model, name: str = "default", mimic: Mapping = ()) -> ChainSpec | None:
    """The chain from the root body to the last body of a serial model; None for a tree or no 1-DOF joint."""
    root = 1 if model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer" else 0
    children = [model.parents[j] for j in range(root + 1, model.njoints) if model.names[j] not in mimic]
    if len(children) != len(set(children)):
        return None
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        if joint.nq != 1 and not (joint_id == 1 and joint.shortname() == "JointModelFreeFlyer"):
            raise RobotDescriptionError(
                f"joint {model.names[joint_id]!r} is {_joint_kind(joint)}; the automatic chain takes "
                "1-DOF joints only: lock it by passing chains=[ChainSpec(...)] without it")
    movable = [model.names[j] for j in range(1, model.njoints)
               if model.joints[j].nq == 1 and model.names[j] not in mimic]
    if not movable:  # a drone, say: a robot with no chain
        return None
    last_joint = model.getJointId(movable[-1])
    frames = [f for f in model.frames if f.parentJoint == last_joint and f.type == pin.FrameType.BODY]
    tip = frames[-1].name if frames else model.frames[-1].name
    bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == root]
    if not bodies:
        raise RobotDescriptionError("the model has no root body to start a chain from; pass "
                                    "chains=[ChainSpec(name, base_frame, tip_frame, joints)]")
    return ChainSpec(name, bodies[0], tip, tuple(movable), "root body to last link")


def robot_from_urdf_text(name: str, text: str, chains: Sequence[ChainSpec] | None = None,
                         nominal: np.ndarray | None = None, floating_base: bool = False,
                         urdf_path: Path | None = None, package_dirs: Sequence[str] = (),
                         soles: Mapping | None = None, closed_forms: Mapping | None = None,
                         facts: Any = None) -> Robot:
    """A Robot from URDF text; with no chains given, the model's single serial chain (none for a tree:
    :meth:`Robot.chain_between`). ``nominal``: one angle per continuous joint, or Pinocchio's (cos, sin)
    (an SRDF posture); ``soles``, ``closed_forms``, ``facts``: see :class:`Robot`."""
    source = str(urdf_path or name)
    parsed = parse_urdf(text, floating_base, source=source)
    model = parsed.model
    check_model(model, source=source)
    if nominal is not None:
        nominal = np.asarray(nominal, dtype=float).reshape(-1)
        if nominal.shape == (parsed.source_model.nq,) and parsed.source_model.nq != model.nq:
            nominal = angles_of(parsed.source_model, model, nominal)
        elif nominal.shape != (model.nq,):
            raise RobotDescriptionError(f"{source}: nominal has {nominal.size} values, the model has nq = "
                                        f"{model.nq}")
    else:
        nominal = pin.neutral(model)
        bounded = np.isfinite(model.lowerPositionLimit) & np.isfinite(model.upperPositionLimit)
        if floating_base:
            bounded[:7] = False
        nominal[bounded] = np.clip(nominal[bounded], model.lowerPositionLimit[bounded],
                                   model.upperPositionLimit[bounded])
    specs = list(chains) if chains else [serial_chain_spec(model, mimic=parsed.mimic)]
    return Robot(name, model, text, {spec.name: spec for spec in specs if spec is not None}, nominal,
                 urdf_path=urdf_path, package_dirs=list(package_dirs), soles={} if soles is None else soles,
                 closed_forms={} if closed_forms is None else closed_forms, facts=facts,
                 continuous_joints=parsed.continuous, mimic=parsed.mimic, renamed_frames=parsed.renamed)
