"""The riveting cell (numbers in tasks/ur5_riveting.yaml, repeated by DEFAULT_SCENE): a UR5 at the world
origin on a table (top z = 0), a box workpiece with holes h0..h32 in rows on its top and side faces. A hole
frame: origin at the opening, z into the (blind) hole, x -z (world) on the sides and -x on the top."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.validation import finite_vector

FACE_NORMALS = {"top": np.array([0.0, 0.0, 1.0]), "right": np.array([0.0, -1.0, 0.0]),  # outward, world
                "left": np.array([0.0, 1.0, 0.0])}
FACE_X_AXES = {"top": np.array([-1.0, 0.0, 0.0]), "right": np.array([0.0, 0.0, -1.0]),  # of the hole frames
               "left": np.array([0.0, 0.0, -1.0])}
EDGE_MARGIN = 0.015  # m between a hole's axis and the face's edges (room for the hole model)

DEFAULT_SCENE = {
    "table": {"top_z": 0.0, "center": [0.3, 0.0], "size": [1.4, 1.2, 0.05]},
    "workpiece": {"center": [0.50, 0.0], "size": [0.26, 0.30, 0.30]},
    "hole_diameter": 0.006,
    "hole_depth": 0.010,
    # rows of holes per face: (row coordinate, [positions along the row]); 6 + 5 staggered = 11
    "faces": {
        "top": {"rows": [{"y": -0.05, "x": [0.40, 0.44, 0.48, 0.52, 0.56, 0.60]},
                         {"y": 0.05, "x": [0.42, 0.46, 0.50, 0.54, 0.58]}]},
        "right": {"rows": [{"z": 0.24, "x": [0.40, 0.44, 0.48, 0.52, 0.56, 0.60]},
                           {"z": 0.16, "x": [0.42, 0.46, 0.50, 0.54, 0.58]}]},
        "left": {"rows": [{"z": 0.24, "x": [0.40, 0.44, 0.48, 0.52, 0.56, 0.60]},
                          {"z": 0.16, "x": [0.42, 0.46, 0.50, 0.54, 0.58]}]},
    },
    # tcp pose to return to each cycle: 0.25 m above the top face, tool pointing down
    "rivet_home": {"position": [0.45, 0.0, 0.55], "rpy": [np.pi, 0.0, np.pi]},
}


@dataclass(frozen=True)
class Hole:
    """One hole: its name, face and frame (world; z into the hole, origin at the opening)."""

    index: int
    name: str
    face: str
    placement: pin.SE3

    @property
    def position(self) -> np.ndarray:
        return self.placement.translation

    @property
    def axis(self) -> np.ndarray:
        """Unit vector into the hole (the frame's z axis)."""
        return self.placement.rotation[:, 2]

    def point_at_depth(self, depth: float) -> np.ndarray:
        """The point on the hole axis ``depth`` metres inside the opening (negative: outside)."""
        return self.position + depth * self.axis


@dataclass
class Scene:
    """Geometry of the cell (no robot): table, workpiece box, holes, rivet_home."""

    table_top_z: float
    table_center: np.ndarray  # (2,) x, y
    table_size: np.ndarray  # (3,)
    workpiece_center: np.ndarray  # (3,) centre of the box
    workpiece_size: np.ndarray  # (3,)
    hole_diameter: float
    hole_depth: float
    holes: list[Hole]
    rivet_home: pin.SE3

    @property
    def workpiece_half(self) -> np.ndarray:
        return 0.5 * self.workpiece_size

    @property
    def table_box_center(self) -> np.ndarray:
        """Centre (m) of the table's box, its top at ``table_top_z``."""
        return np.array([*self.table_center, self.table_top_z - 0.5 * self.table_size[2]])

    def hole(self, name: str) -> Hole:
        found = next((hole for hole in self.holes if hole.name == name), None)
        if found is None:
            raise InvalidConfigurationError(f"no hole {name!r}; holes are h0..h{len(self.holes) - 1}")
        return found

    def faces(self) -> list[str]:
        return list(dict.fromkeys(hole.face for hole in self.holes))

    def holes_of(self, face: str) -> list[Hole]:
        return [hole for hole in self.holes if hole.face == face]

    def nearest_hole(self, position: np.ndarray) -> Hole:
        """The hole whose opening is nearest to ``position`` (the thesis's identification, position only)."""
        gaps = np.array([hole.position for hole in self.holes]) - position  # vecdot: np.linalg.norm's dot
        return self.holes[int(np.argmin(np.sqrt(np.vecdot(gaps, gaps))))]

    def minimum_hole_spacing(self) -> float:
        points = np.array([hole.position for hole in self.holes])
        gaps = np.linalg.norm(points[:, None] - points[None], axis=-1)
        return float(np.min(gaps[np.triu_indices(len(points), 1)]))


def _vector(value, size: int, what: str) -> np.ndarray:
    return finite_vector(value, size, f"scene: {what}", InvalidConfigurationError)


def _merged(spec: dict | None) -> dict:
    """DEFAULT_SCENE updated by ``spec``, one level deep (but ``faces``, which is replaced whole)."""
    merged = dict(DEFAULT_SCENE)
    for key, value in (spec or {}).items():
        if key not in DEFAULT_SCENE:
            raise InvalidConfigurationError(f"scene: unknown key {key!r}; known: {sorted(DEFAULT_SCENE)}")
        nested = isinstance(value, dict) and isinstance(merged[key], dict) and key != "faces"
        merged[key] = {**merged[key], **value} if nested else value
    return merged


def hole_frame(face: str, position: np.ndarray) -> pin.SE3:
    """Frame of a hole on ``face`` whose opening centre is ``position``."""
    z_axis, x_axis = -FACE_NORMALS[face], FACE_X_AXES[face]
    return pin.SE3(np.column_stack((x_axis, np.cross(z_axis, x_axis), z_axis)), np.asarray(position, float))


def build_scene(spec: dict | None = None) -> Scene:
    """The scene from a (partial) ``scene`` mapping of a task file; missing keys take DEFAULT_SCENE."""
    merged = _merged(spec)
    table, workpiece = merged["table"], merged["workpiece"]
    table_top = float(table["top_z"])
    size = _vector(workpiece["size"], 3, "workpiece.size")
    if np.any(size <= 0):
        raise InvalidConfigurationError(f"scene: workpiece.size must be positive, got {size.tolist()}")
    center = np.array([*_vector(workpiece["center"], 2, "workpiece.center"), table_top + 0.5 * size[2]])
    half = 0.5 * size
    holes: list[Hole] = []
    for face, layout in merged["faces"].items():
        if face not in FACE_NORMALS:
            raise InvalidConfigurationError(f"scene: unknown face {face!r}; faces: {sorted(FACE_NORMALS)}")
        normal = FACE_NORMALS[face]
        level = center + normal * (half @ np.abs(normal))  # a point of the face plane
        for row in layout["rows"]:
            row_axis = "y" if face == "top" else "z"
            if row_axis not in row or "x" not in row:
                raise InvalidConfigurationError(f"scene: rows of face {face!r} need '{row_axis}' and 'x'")
            for x in row["x"]:
                position = level.copy()
                position[0], position["yz".index(row_axis) + 1] = float(x), float(row[row_axis])
                holes.append(Hole(len(holes), f"h{len(holes)}", face, hole_frame(face, position)))
    home = merged["rivet_home"]
    rivet_home = pin.SE3(pin.rpy.rpyToMatrix(*_vector(home["rpy"], 3, "rivet_home.rpy")),
                         _vector(home["position"], 3, "rivet_home.position"))
    scene = Scene(table_top, _vector(table["center"], 2, "table.center"),
                  _vector(table["size"], 3, "table.size"), center, size, float(merged["hole_diameter"]),
                  float(merged["hole_depth"]), holes, rivet_home)
    _check_holes(scene)
    return scene


def _check_holes(scene: Scene) -> None:
    half = scene.workpiece_half
    for hole in scene.holes:
        local = hole.position - scene.workpiece_center
        in_face = np.abs(FACE_NORMALS[hole.face]) < 0.5
        if np.any(np.abs(local[in_face]) > half[in_face] - EDGE_MARGIN):
            raise InvalidConfigurationError(
                f"scene: hole {hole.name} at {hole.position.round(4).tolist()} is within "
                f"{EDGE_MARGIN * 1e3:g} mm of the edge of face {hole.face!r} (or outside it)")
    if scene.hole_depth <= 0 or scene.hole_diameter <= 0:
        raise InvalidConfigurationError("scene: hole_diameter and hole_depth must be positive")
    if len(scene.holes) > 1 and scene.minimum_hole_spacing() < 0.03:
        raise InvalidConfigurationError(
            f"scene: holes closer than 30 mm ({scene.minimum_hole_spacing() * 1e3:.1f} mm); the hole model "
            "needs room around each hole")
