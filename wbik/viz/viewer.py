"""``Viewer``: a robot in meshcat, with frames, IK targets, CoM and support polygon, animations.
>>> viewer = Viewer("ur5")                 # no server: the scene is kept in this process
>>> viewer.show(q)                         # full configuration, or one chain's joint values
>>> viewer.show_target(target, chain="arm")
>>> viewer.animate(times, qs, trace_frame="tcp")
>>> viewer.export_html("ur5.html")         # self-contained page, opens offline

``Viewer(robot, server=True)`` also serves meshcat on localhost (``viewer.url``; ``close()`` stops it).
"""

from __future__ import annotations

import html as html_module
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

import wbik.viz.arrows as arrows
import wbik.viz.geometry as robot_geometry
from wbik.errors import InvalidConfigurationError, UnsupportedError
from wbik.files import atomic_write_text
from wbik.models import load
from wbik.qp.kinematics import Kinematics
from wbik.qp.support_polygon import SupportPolygon, contact_points
from wbik.robot import Chain, Robot
from wbik.targets import as_target
from wbik.viz.animation import Animation, PushArrow
from wbik.viz.environment import SceneBox, robot_cell
from wbik.viz.scene import SceneRecorder, ServerWindow

ROOT = "wbik"
ROBOT_NODE = f"{ROOT}/robot"
TARGET_COLOR = 0x22AA44
REACHED_COLOR = 0x2255DD
COM_COLOR = 0xCC22CC
TRACE_COLOR = 0xEEBB00
INSIDE_COLOR = 0x22AA44
OUTSIDE_COLOR = 0xDD2222
CONTACT_COLOR = 0x2288EE
ZMP_COLOR = 0xFF7F00
COP_COLOR = 0x00CCCC  # the measured centre of pressure (physics)
PUSH_COLOR = 0xE0115F
PUSH_ARROW_RATIO = 0.5  # a push arrow's length: this fraction of the robot's extent
PUSH_GAP_RATIO = 0.15  # its tip this fraction of the extent short of the pushed frame (outside the body)
POLYGON_TOLERANCE = 0.005
"""m: a played support polygon is drawn anew when its soles change or move more than this."""


@dataclass(frozen=True)
class SupportView:
    """What ``show_com_and_polygon`` drew (m, world): CoM, polygon (k, 2) at ``ground_z``, margin."""

    com: np.ndarray
    polygon: np.ndarray
    ground_z: float
    inside: bool
    margin: float


@dataclass(frozen=True)
class AnimationView:
    """What ``play_animation`` drew: samples, the traced path (N, 3), the CoM margins (m), or None."""

    frames: int
    trace: np.ndarray | None
    com_margins: np.ndarray | None


def _translation(position) -> np.ndarray:
    """The 4 x 4 pose of a translation (world, m)."""
    return pin.SE3(np.eye(3), np.asarray(position, dtype=float)).homogeneous


def _same_polygon(previous, feet: tuple[str, ...], vertices: np.ndarray, ground_z: float,
                  tolerance: float = POLYGON_TOLERANCE) -> bool:
    """The same soles at the same places: each polygon's vertices within ``tolerance`` m of the other's."""
    old_feet, old_vertices, old_z = previous
    if old_feet != feet or abs(old_z - ground_z) > tolerance:
        return False
    old_polygon, polygon = SupportPolygon(old_vertices), SupportPolygon(vertices)
    return (all(abs(old_polygon.margin_of(v)) <= tolerance for v in vertices)
            and all(abs(polygon.margin_of(v)) <= tolerance for v in old_vertices))


class Viewer:
    """A robot scene in meshcat (see the module docstring)."""

    def __init__(self, robot: Robot | str, server: bool = False, style: str = "auto",
                 q: np.ndarray | None = None, title: str | None = None):
        import meshcat
        from pinocchio.visualize import MeshcatVisualizer

        self.robot = robot = load(robot) if isinstance(robot, str) else robot
        self.title = title or f"wbik: {robot.name}"
        self.window = ServerWindow() if server else SceneRecorder()
        self.meshcat = meshcat.Visualizer(window=self.window)
        self.geometry, self.style = robot_geometry.visual_model(robot, style)
        self.extent = robot_geometry.robot_extent(robot)
        self._pinocchio = MeshcatVisualizer(robot.model, None, self.geometry)
        self._pinocchio.initViewer(viewer=self.meshcat)
        self._pinocchio.loadViewerModel(rootNodeName=ROBOT_NODE)
        self.q = robot.nominal.copy()
        self.environment: dict[str, SceneBox] = {}
        self.show(self.q if q is None else q)
        self.show_environment(robot_cell(robot))
        self.place_grid()
        self.look_at()

    @property
    def url(self) -> str | None:
        """The meshcat server's local URL (None without a server)."""
        return getattr(self.window, "web_url", None)

    def close(self) -> None:
        """Stop the meshcat server if this viewer started one."""
        if isinstance(self.window, ServerWindow):
            self.window.close()

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _chain(self, chain: Chain | str | None) -> Chain | None:
        return chain if chain is None or isinstance(chain, Chain) else self.robot.chain(chain)

    def full_configuration(self, q: Sequence[float] | None, chain: Chain | str | None = None) -> np.ndarray:
        """Full q from a full configuration or from one chain's joint values (others as shown now)."""
        if q is None:
            return self.q.copy()
        values = np.asarray(q, dtype=float).reshape(-1)
        chain = self._chain(chain)
        if chain is None and values.shape == (self.robot.model.nq,):
            if not np.all(np.isfinite(values)):
                raise InvalidConfigurationError(f"joint values contain NaN or inf: {values.tolist()}")
            return values.copy()
        if chain is None and len(self.robot.chains) == 1 and values.size == self.robot.chain().nq:
            chain = self.robot.chain()  # the only chain's values
        if chain is not None:
            return chain.full_configuration(chain.check_q(values), reference=self.q)
        raise InvalidConfigurationError(
            f"{self.robot.name} has nq = {self.robot.model.nq} ({self.robot.model.nq} values for the full "
            f"configuration); got {values.size} values. For one chain's joints pass chain=NAME "
            f"(chains: {', '.join(self.robot.chains)})")

    def show(self, q: Sequence[float] | None = None, chain: Chain | str | None = None) -> np.ndarray:
        """Draw the robot at q (full, or a chain's joints with ``chain``); returns the full q."""
        self.q = self.full_configuration(q, chain)
        self._pinocchio.display(self.q)
        return self.q

    def frame_pose(self, frame: str, q: np.ndarray | None = None) -> pin.SE3:
        return self.robot.frame_placement(self.q if q is None else q, frame)

    def _framing(self, q: np.ndarray) -> tuple[np.ndarray, float]:
        """The middle of the frame origins at q (world, m), and 1.6 times their extent (m)."""
        data = self.robot.model.createData()
        pin.framesForwardKinematics(self.robot.model, data, q)
        points = [placement.translation.copy() for placement in data.oMf]
        low, high = np.min(points, axis=0), np.max(points, axis=0)
        return 0.5 * (low + high), 1.6 * max(float(np.linalg.norm(high - low)), 0.5 * self.extent, 1e-2)

    def look_at(self, center: np.ndarray | None = None, distance: float | None = None) -> None:
        """Point the camera at ``center`` (default: the robot at the shown q) from ``distance`` (m) away."""
        middle, far = self._framing(self.q)
        self.meshcat["/Cameras/default"].set_transform(_translation(middle if center is None else center))
        # the camera sits in a y-up frame: (x, y, z)_three = (x, z, -y)_world, looking at the target
        direction = np.array([1.0, 0.8, 0.55])
        position = (far if distance is None else distance) * direction / np.linalg.norm(direction)
        self.meshcat["/Cameras/default/rotated/<object>"].set_property(
            "position", [float(position[0]), float(position[2]), float(-position[1])])

    def show_environment(self, boxes: Sequence[SceneBox]) -> None:
        """Draw fixed boxes (a staircase's steps, a table) under ``wbik/environment``, by name."""
        import meshcat.geometry as mg

        for box in boxes:
            material = mg.MeshLambertMaterial(color=box.color, opacity=box.opacity,
                                              transparent=box.opacity < 1.0)
            node = self.meshcat[f"{ROOT}/environment/{box.name}"]
            node.set_object(mg.Box(list(box.size)), material)
            node.set_transform(box.homogeneous())
            self.environment[box.name] = box

    def ground_height(self, q: np.ndarray | None = None) -> float:
        """The floor's height (m): the lowest sole point at q, else the lowest box's bottom, else 0."""
        if self.robot.soles:
            kinematics = Kinematics(self.robot.model, self.q if q is None else q)
            return float(contact_points(kinematics, self.robot.soles, list(self.robot.soles))[:, 2].min())
        if self.environment:
            return float(min(box.corners()[:, 2].min() for box in self.environment.values()))
        return 0.0

    def place_grid(self, height: float | None = None) -> float:
        """Put meshcat's floor grid at ``height`` (m; default :meth:`ground_height`); returns it."""
        height = self.ground_height() if height is None else float(height)
        transform = np.diag([self.grid_scale, self.grid_scale, self.grid_scale, 1.0])
        transform[2, 3] = height - 1e-4  # (just under the soles: they are not hidden by the grid)
        self.meshcat["/Grid"].set_transform(transform)
        return height

    @property
    def grid_scale(self) -> float:
        """The scale of meshcat's 0.5 m cells: half the robot's extent (m), within [0.05, 1]."""
        return float(min(1.0, max(0.05, 0.5 * self.extent)))

    def _triad(self, path: str, placement: pin.SE3, scale: float) -> None:
        """Three cylinders along the frame's x (red), y (green), z (blue) axes."""
        import meshcat.geometry as mg

        node = self.meshcat[path]
        # meshcat cylinders run along their local y axis; rotate it onto each frame axis
        for index, (axis, rotation, color) in enumerate((("x", (0.0, 0.0, -np.pi / 2), 0xDD2222),
                                                         ("y", (0.0, 0.0, 0.0), 0x22BB22),
                                                         ("z", (np.pi / 2, 0.0, 0.0), 0x2244DD))):
            transform = pin.SE3(pin.rpy.rpyToMatrix(*rotation), 0.5 * scale * np.eye(3)[index]).homogeneous
            node[axis].set_object(mg.Cylinder(scale, 0.06 * scale), mg.MeshLambertMaterial(color=color))
            node[axis].set_transform(transform)
        node.set_transform(placement.homogeneous)

    def _sphere(self, path: str, position: np.ndarray, radius: float, color: int,
                opacity: float = 1.0) -> None:
        import meshcat.geometry as mg

        material = mg.MeshLambertMaterial(color=color, opacity=opacity, transparent=opacity < 1.0)
        self.meshcat[path].set_object(mg.Sphere(radius), material)
        self.meshcat[path].set_transform(_translation(position))

    def _line(self, path: str, points: np.ndarray, color: int, loop: bool = False) -> None:
        import meshcat.geometry as mg

        geometry = mg.PointsGeometry(np.asarray(points, dtype=np.float32).T)
        material = mg.LineBasicMaterial(color=color, linewidth=3)
        line = mg.LineLoop(geometry, material) if loop else mg.Line(geometry, material)
        self.meshcat[path].set_object(line)

    def _outline(self, path: str, vertices: np.ndarray, ground_z: float, color: int) -> None:
        self._line(path, np.column_stack([vertices, np.full(len(vertices), ground_z + 1e-4)]), color,
                   loop=True)

    def _support_polygon(self, kinematics: Kinematics, feet: Sequence[str]) -> tuple[SupportPolygon, float]:
        """The support polygon of the soles ``feet`` and its height (m, their contact points' mean)."""
        corners = contact_points(kinematics, self.robot.soles, feet)
        return SupportPolygon(corners[:, :2]), float(np.mean(corners[:, 2]))

    def clear(self, name: str) -> str:
        """Remove a marker group ("frames", "target", "reached", "support", "trace"); its node path."""
        path = f"{ROOT}/{name}"
        self.meshcat[path].delete()
        return path

    def show_frames(self, chain: Chain | str | None = None, frames: Sequence[str] = (),
                    scale: float | None = None) -> list[str]:
        """Axes of a chain's base, joint and tip frames (and any ``frames``) at the shown q."""
        chain = self._chain(chain) if chain is not None or len(self.robot.chains) != 1 else self.robot.chain()
        names = list(dict.fromkeys([chain.base_frame, *chain.joint_names, chain.tip_frame, *frames]
                                   if chain is not None else frames))
        scale = 0.12 * self.extent if scale is None else scale
        self.clear("frames")
        for name in names:
            self._triad(f"{ROOT}/frames/{name}", self.frame_pose(name), scale)
        return names

    def show_target(self, target, chain: Chain | str | None = None, name: str = "target",
                    color: int = TARGET_COLOR) -> pin.SE3:
        """An IK target (in ``chain``'s base frame): a sphere, with axes for a pose; its world pose."""
        target = as_target(target)
        placement = target.se3()
        chain = self._chain(chain)
        if chain is not None:
            placement = self.frame_pose(chain.base_frame) * placement
        path = self.clear(name)
        self._sphere(f"{path}/point", placement.translation, 0.035 * self.extent, color, opacity=0.6)
        if target.is_pose:
            self._triad(f"{path}/axes", placement, 0.15 * self.extent)
        return placement

    def show_ik_result(self, result, target, chain: Chain | str) -> None:
        """A solver's answer: the robot at ``result.q``, the target and the chain's reached tip pose."""
        chain = self._chain(chain)
        if result.q is not None:
            self.show(result.q, chain)
        self.show_target(target, chain)
        if result.q is not None:  # the reached pose, in blue
            reached = chain.fk(np.asarray(result.q, dtype=float))
            self.show_target(reached if as_target(target).is_pose else reached.translation, chain, "reached",
                             REACHED_COLOR)

    def show_com_and_polygon(self, q: Sequence[float] | None = None,
                             feet: Sequence[str] | None = None) -> SupportView:
        """The CoM, its ground projection and the support polygon of ``feet`` (green: the CoM inside)."""
        soles = self.robot.soles
        if not soles:
            raise UnsupportedError(f"{self.robot.name} declares no sole rectangles (robot.soles); "
                                   "a support polygon needs feet: try the bioloid")
        feet = list(soles) if feet is None else list(feet)
        if unknown := [foot for foot in feet if foot not in soles]:
            raise UnsupportedError(f"no sole rectangle for {unknown}; known soles: {list(soles)}")
        if q is not None:
            self.show(q)
        support, ground_z = self._support_polygon(Kinematics(self.robot.model, self.q), feet)
        com = self.robot.center_of_mass(self.q)
        margin = support.margin_of(com[:2])
        color = INSIDE_COLOR if margin >= 0.0 else OUTSIDE_COLOR
        path = self.clear("support")
        radius = 0.025 * self.extent
        self._sphere(f"{path}/com", com, radius, COM_COLOR)
        ground_point = np.array([com[0], com[1], ground_z])
        self._sphere(f"{path}/com_ground", ground_point, 0.6 * radius, color)
        self._line(f"{path}/plumb", np.array([com, ground_point]), COM_COLOR)
        self._outline(f"{path}/polygon", support.vertices, ground_z, color)
        return SupportView(com, support.vertices, ground_z, bool(margin >= 0.0), float(margin))

    def animate(self, times: Sequence[float], qs: Sequence[Sequence[float]],
                chain: Chain | str | None = None, trace_frame: str | None = None, fps: float = 30.0,
                repetitions: int = 1, play: bool = True) -> np.ndarray | None:
        """Play q rows (full, or of ``chain``) at their times (s); the path of ``trace_frame`` (N, 3)."""
        rows = [self.full_configuration(q, chain) for q in qs]
        checked = Animation(self.robot, times, rows, name="animate")  # one row per time, times increasing
        clip, _, trace = self._robot_keyframes(checked.times, list(checked.configurations), trace_frame, fps)
        self.meshcat.set_animation(clip, play=play, repetitions=repetitions)
        return trace

    def _robot_keyframes(self, times: np.ndarray, rows: Sequence[np.ndarray], trace_frame: str | None,
                         fps: float):
        """A meshcat Animation moving every robot geometry (and the trace marker), its keys, the trace."""
        import meshcat.animation

        model, data = self.robot.model, self.robot.model.createData()
        geometry_data = self.geometry.createData()
        trace_id = self.robot.frame_id(trace_frame) if trace_frame else None
        clip = meshcat.animation.Animation(default_framerate=fps)
        nodes = [(geometry_id, self._pinocchio.getViewerNodeName(geometry_object, pin.GeometryType.VISUAL),
                  np.diag([*geometry_object.meshScale, 1.0]))
                 for geometry_id, geometry_object in enumerate(self.geometry.geometryObjects)]
        keys = [float(time * fps) for time in times - times[0]]
        trace = []
        for key, q in zip(keys, rows, strict=True):
            pin.forwardKinematics(model, data, q)
            pin.updateGeometryPlacements(model, data, self.geometry, geometry_data)
            with clip.at_frame(self.meshcat, key) as frame:
                for geometry_id, node, scale in nodes:
                    frame[node].set_transform(geometry_data.oMg[geometry_id].homogeneous @ scale)
            if trace_id is not None:
                pin.updateFramePlacement(model, data, trace_id)
                trace.append(data.oMf[trace_id].translation.copy())
        self.show(rows[0])
        if trace_id is None:
            return clip, keys, None
        self._track(clip, keys, f"{ROOT}/trace/marker", trace)
        path = np.array(trace)
        self._line(f"{ROOT}/trace/path", path, TRACE_COLOR)
        self._sphere(f"{ROOT}/trace/marker", path[0], 0.02 * self.extent, TRACE_COLOR)
        return clip, keys, path

    def _track(self, clip, keys: Sequence[float], path: str, positions) -> None:
        """``path`` keyed at each position (world, m) or 4 x 4 pose."""
        for key, position in zip(keys, positions, strict=True):
            with clip.at_frame(self.meshcat, key) as frame:
                pose = position if np.shape(position) == (4, 4) else _translation(position)
                frame[path].set_transform(pose)

    def _visibility(self, clip, path: str, keys: list[float], visible: Sequence[bool]) -> None:
        """``path`` shown as ``visible[0]``, then keyed where ``visible`` changes (three.js holds it)."""
        self.meshcat[path].set_property("visible", bool(visible[0]))
        for index, (key, value) in enumerate(zip(keys, visible, strict=True)):
            if index == 0 or value != visible[index - 1] or index == len(keys) - 1:
                with clip.at_frame(self.meshcat[path], key) as frame:
                    frame.set_property("visible", "boolean", bool(value))

    def play_animation(self, animation, fps: float = 30.0, repetitions: int = 1,
                       play: bool = True) -> AnimationView:
        """Play a :class:`wbik.viz.animation.Animation` with its overlays (one sample: still)."""
        if animation.robot.model.nq != self.robot.model.nq:
            raise InvalidConfigurationError(
                f"the animation is of {animation.robot.name} (nq = {animation.robot.model.nq}); this "
                f"viewer shows {self.robot.name} (nq = {self.robot.model.nq})")
        overlays, still = animation.overlays, animation.frames == 1
        repeat = 2 if still else 1  # a still picture: two equal samples
        rows = list(animation.configurations) * repeat
        times = np.array([0.0, 1.0 / fps]) if still else animation.times
        clip, keys, trace = self._robot_keyframes(times, rows, overlays.trace_frame, fps)
        self.show_environment(animation.environment)
        self.place_grid(self.ground_height(rows[0]))
        self._camera_keyframes(clip, keys, rows, times)
        for name, points, color in (("zmp", overlays.zmp, ZMP_COLOR), ("cop", overlays.cop, COP_COLOR)):
            if points is not None:
                self._point_keyframes(clip, keys, np.vstack([points] * repeat), name, color)
        if overlays.pushes:
            self._push_keyframes(clip, keys, rows, times, overlays.pushes)
        margins = None
        if overlays.support is not None and self.robot.soles:
            margins = self._support_keyframes(clip, keys, rows, overlays.support * repeat)
        if overlays.contacts is not None:
            self._contact_keyframes(clip, keys, rows, overlays.contacts * repeat)
        self.show(rows[0])
        self.meshcat.set_animation(clip, play=play and not still, repetitions=repetitions)
        return AnimationView(animation.frames, trace, margins)

    def _camera_keyframes(self, clip, keys: list[float], rows: list[np.ndarray], times: np.ndarray) -> None:
        """The camera follows the robot's middle, averaged over about half a second."""
        self.look_at(*self._framing(rows[0]))
        centres = np.array([self._framing(q)[0] for q in rows])
        spacing = float(times[-1] - times[0]) / (len(times) - 1)
        width = max(1, int(round(0.25 / max(spacing, 1e-9))))
        padded = np.pad(centres, ((width, width), (0, 0)), mode="edge")
        kernel = np.ones(2 * width + 1) / (2 * width + 1)
        smooth = np.column_stack([np.convolve(padded[:, axis], kernel, mode="valid") for axis in range(3)])
        self._track(clip, keys, "/Cameras/default", smooth)

    def _point_keyframes(self, clip, keys: list[float], points: np.ndarray, name: str, color: int) -> None:
        """A marker of a point per sample (the ZMP, the CoP; hidden where there is none) and its path."""
        path = self.clear(name)
        finite = np.all(np.isfinite(points), axis=1)
        if not finite.any():
            return
        self._sphere(f"{path}/marker", points[int(np.argmax(finite))], 0.015 * self.extent, color)
        self._line(f"{path}/path", points[finite] + [0.0, 0.0, 2e-4], color)
        self._track(clip, [key for key, ok in zip(keys, finite, strict=True) if ok], f"{path}/marker",
                    points[finite])
        self._visibility(clip, f"{path}/marker", keys, [bool(v) for v in finite])

    def _push_keyframes(self, clip, keys: list[float], rows: list[np.ndarray], times: np.ndarray,
                        pushes: Sequence[PushArrow]) -> None:
        """Each push an arrow ending on its frame, shown from its start to its end."""
        import meshcat.geometry as mg

        path = self.clear("pushes")
        for index, push in enumerate(pushes):
            node = self.meshcat[f"{path}/{index}"]
            for part, geometry, pose in arrows.arrow_parts(PUSH_ARROW_RATIO * self.extent):
                node[part].set_object(geometry, mg.MeshLambertMaterial(color=PUSH_COLOR))
                node[part].set_transform(pose)
            poses = [arrows.arrow_pose(self.frame_pose(push.frame, q).translation, push.force_n,
                                       PUSH_GAP_RATIO * self.extent) for q in rows]
            node.set_transform(poses[0])
            self._track(clip, keys, f"{path}/{index}", poses)
            during = (times - times[0] >= push.start_s - 1e-9) & (times - times[0] <= push.end_s + 1e-9)
            self._visibility(clip, f"{path}/{index}", keys, [bool(v) for v in during])

    def _support_keyframes(self, clip, keys: list[float], rows: list[np.ndarray],
                           support: Sequence[tuple[str, ...]]) -> np.ndarray:
        """CoM, its ground point and a polygon per stretch on the same soles; CoM margins (m, NaN: in air)."""
        kinematics = Kinematics(self.robot.model)
        path = self.clear("support")
        radius = 0.025 * self.extent
        stretches, stretch_of, margins, coms, grounds = [], [], [], [], []
        for q, feet in zip(rows, support, strict=True):
            kinematics.update(q)
            coms.append(kinematics.com().copy())
            feet = [foot for foot in feet if foot in self.robot.soles]
            if not feet:
                stretch_of.append(-1)
                margins.append(np.nan)
                grounds.append(grounds[-1] if grounds else 0.0)
                continue
            polygon, ground_z = self._support_polygon(kinematics, feet)
            if not stretches or not _same_polygon(stretches[-1], tuple(feet), polygon.vertices, ground_z):
                stretches.append((tuple(feet), polygon.vertices, ground_z))
            margins.append(polygon.margin_of(coms[-1][:2]))
            stretch_of.append(len(stretches) - 1)
            grounds.append(ground_z)
        margins = np.array(margins, dtype=float)
        inside = [bool(m >= 0.0) for m in margins]  # NaN (no sole down) counts as outside
        first = next((i for i, s in enumerate(stretch_of) if s >= 0), 0)
        grounded = [[com[0], com[1], ground_z] for com, ground_z in zip(coms, grounds, strict=True)]
        self._sphere(f"{path}/com", coms[0], radius, COM_COLOR)
        self._track(clip, keys, f"{path}/com", coms)
        for name, color, shown in (("com_ground_inside", INSIDE_COLOR, inside),
                                   ("com_ground_outside", OUTSIDE_COLOR, [not v for v in inside])):
            self._sphere(f"{path}/{name}", grounded[first], 0.6 * radius, color)
            self._track(clip, keys, f"{path}/{name}", grounded)
            self._visibility(clip, f"{path}/{name}", keys, shown)
        for index, (_, vertices, ground_z) in enumerate(stretches):
            node, shown = f"{path}/polygon_{index}", [s == index for s in stretch_of]
            held = min(margins[shown]) >= 0.0
            self._outline(node, vertices, ground_z, INSIDE_COLOR if held else OUTSIDE_COLOR)
            self._visibility(clip, node, keys, shown)
        return margins

    def _contact_keyframes(self, clip, keys: list[float], rows: list[np.ndarray],
                           contacts: Sequence[tuple[str, ...]]) -> None:
        """A marker on each frame while it is held in contact."""
        path = self.clear("contacts")
        for name in dict.fromkeys(name for held in contacts for name in held):
            node, positions = f"{path}/{name}", [self.frame_pose(name, q).translation for q in rows]
            self._sphere(node, positions[0], 0.02 * self.extent, CONTACT_COLOR, opacity=0.8)
            self._track(clip, keys, node, positions)
            self._visibility(clip, node, keys, [name in held for held in contacts])

    def play(self, trajectory, trace_frame: str | None = None, fps: float = 30.0,
             repetitions: int = 1) -> np.ndarray | None:
        """Animate anything with ``times`` and joint rows (``positions``, ``qs`` or ``q``; of its ``chain`` if
        it names one), its ``tip_frame`` traced unless told otherwise."""
        times = getattr(trajectory, "times", None)
        rows = next((getattr(trajectory, name) for name in ("positions", "qs", "q")
                     if getattr(trajectory, name, None) is not None), None)
        if times is None or rows is None:
            raise UnsupportedError(f"cannot play a {type(trajectory).__name__}: it needs 'times' and joint "
                                   "rows ('positions', 'qs' or 'q')")
        rows = np.asarray(rows, dtype=float)
        chain = getattr(trajectory, "chain", None)
        if rows.ndim != 2 or rows.shape[1] == self.robot.model.nq or (isinstance(chain, str)
                                                                     and chain not in self.robot.chains):
            chain = None
        trace = trace_frame if trace_frame is not None else getattr(trajectory, "tip_frame", None)
        return self.animate(times, rows, chain=chain, trace_frame=trace, fps=fps, repetitions=repetitions)

    def html(self) -> str:
        """The scene (and animation) as one self-contained HTML page."""
        return self.window.html(self.title)

    def export_html(self, path: str | Path) -> Path:
        """Write the self-contained page to ``path`` (folders created); returns the path."""
        atomic_write_text(Path(path), self.html())
        return Path(path)

    def _repr_html_(self) -> str:
        source = html_module.escape(self.html(), quote=True)
        return f'<iframe srcdoc="{source}" style="width: 100%; height: 480px; border: none"></iframe>'


def animation_viewer(animation: Animation, server: bool = False, style: str = "auto",
                     title: str | None = None) -> Viewer:
    """A Viewer playing ``animation`` (with a meshcat server when ``server``)."""
    viewer = Viewer(animation.robot, server=server, style=style,
                    title=title or f"wbik: {animation.name or animation.robot.name}")
    viewer.play_animation(animation)
    return viewer
