"""What one pose shows of an object's shape, in words a model can weigh: which faces of its box its cavity opens
through, how much of the box the cavity is, and whether it is the pose the object came in.

Stage 7's model judges numbers from the rollouts; without these it cannot tell a basket standing as built from a
shelf box lying on its back (both hold what is dropped in). A point of the box is in the object's cavity when it is
outside the object's solid (its convex parts) and the object bounds it on at least :data:`ENCLOSED` of the six
sides (rays along ±x, ±y, ±z meet the mesh); the cavity opens through a face when most of its points see out
through that face. The pose the object came in is its mesh's own up (the file's, or the one the user named).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from rail_mj.core.profile import PoseShape
from rail_mj.core.types import RailObject, StablePose

__all__ = ["FACES", "ENCLOSED", "GRID", "AS_IT_CAME_DEG", "tilt_from_up", "tilt_from_came", "pose_shape",
           "came_in_shape", "ObjectShapes"]

#: The faces of a pose's box, by the task frame's directions (front = +x, left = +y).
FACES: dict[str, tuple[float, float, float]] = {
    "top": (0.0, 0.0, 1.0), "bottom": (0.0, 0.0, -1.0), "front": (1.0, 0.0, 0.0), "back": (-1.0, 0.0, 0.0),
    "left": (0.0, 1.0, 0.0), "right": (0.0, -1.0, 0.0)}
#: A point bounded on at least four of six sides is inside a cavity: a vessel is open on one side, a shelf's
#: compartment or an open-ended sleeve on two; a point bounded on three or fewer (beside a wall, under a seat, in
#: a corner) is only near the object.
ENCLOSED = 4
#: Points per axis of the grid the box is sampled on (9^3 = 729): a cavity a ninth of the box across is seen.
GRID = 9
#: A pose is the one the object came in when its up is within this of the mesh's own up: the eval's tolerance for
#: a pose's up (rail_mj.eval.summary.POSE_TOLERANCE_DEG), the spread of one stable pose's settled ups.
AS_IT_CAME_DEG = 20.0


def _solid(points: np.ndarray, hulls: list[ConvexHull]) -> np.ndarray:
    """Whether each point lies inside one of the convex parts."""
    inside = np.zeros(len(points), dtype=bool)
    for hull in hulls:
        eq = hull.equations
        inside |= np.all(points @ eq[:, :3].T + eq[:, 3] <= 1e-9, axis=1)
    return inside


def _shape(mesh: trimesh.Trimesh, hulls: list[np.ndarray], as_it_came: bool) -> PoseShape:
    """The shape facts of ``mesh`` as it stands (world frame, z up) with its convex parts ``hulls`` (same frame)."""
    lo, hi = np.asarray(mesh.bounds)
    steps = [(np.arange(GRID) + 0.5) / GRID for _ in range(3)]
    grid = np.stack(np.meshgrid(*steps, indexing="ij"), axis=-1).reshape(-1, 3)
    points = lo + grid * (hi - lo)
    parts = [ConvexHull(h) for h in hulls if len(h) >= 4]
    empty = points[~_solid(points, parts)] if parts else points
    if len(empty) == 0:
        return PoseShape(open_faces=[], cavity=0.0, as_it_came=as_it_came)
    names = list(FACES)
    hits = np.zeros((len(empty), len(names)), dtype=bool)
    for k, name in enumerate(names):
        direction = np.broadcast_to(np.asarray(FACES[name]), empty.shape)
        hits[:, k] = mesh.ray.intersects_any(ray_origins=empty, ray_directions=direction)
    cavity = hits.sum(axis=1) >= ENCLOSED
    if not cavity.any():
        return PoseShape(open_faces=[], cavity=0.0, as_it_came=as_it_came)
    seen = ~hits[cavity]
    open_faces = [name for k, name in enumerate(names) if seen[:, k].mean() > 0.5]
    return PoseShape(open_faces=open_faces, cavity=round(float(cavity.mean() * len(empty) / len(points)), 3),
                     as_it_came=as_it_came)


def _placed(obj: RailObject, rotation: np.ndarray) -> tuple[trimesh.Trimesh, list[np.ndarray]]:
    mesh = obj.mesh.copy()
    transform = np.eye(4)
    transform[:3, :3] = rotation
    mesh.apply_transform(transform)
    return mesh, [np.asarray(h) @ rotation.T for h in obj.hulls]


def tilt_from_up(up: np.ndarray | Sequence[float]) -> float:
    """Degrees between the unit ``up`` (mesh frame) and the up the object came in (its mesh frame's +z)."""
    return math.degrees(math.acos(float(np.clip(up[2], -1.0, 1.0))))


def tilt_from_came(pose: StablePose) -> float:
    """Degrees between ``pose``'s up and the up the object came in (its mesh frame's +z)."""
    return tilt_from_up(pose.up_in_mesh_frame)


def pose_shape(obj: RailObject, pose: StablePose) -> PoseShape:
    """The shape facts of ``obj`` in ``pose``."""
    came = obj.oriented and tilt_from_came(pose) <= AS_IT_CAME_DEG
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, np.asarray(pose.quat, dtype=np.float64))
    return _shape(*_placed(obj, rotation.reshape(3, 3)), came)


def came_in_shape(obj: RailObject) -> PoseShape:
    """The shape facts of ``obj`` as it came: its mesh frame's z up."""
    return _shape(*_placed(obj, np.eye(3)), True)


class ObjectShapes:
    """One object's shape facts, each measured when first asked for: per stable pose, and as it came."""

    def __init__(self, obj: RailObject, poses: Sequence[StablePose]) -> None:
        self.obj, self._poses = obj, poses
        self._of: dict[int, PoseShape] = {}
        self._came_in: PoseShape | None = None

    def pose(self, index: int) -> PoseShape:
        if index not in self._of:
            self._of[index] = pose_shape(self.obj, self._poses[index])
        return self._of[index]

    @property
    def came_in(self) -> PoseShape:
        if self._came_in is None:
            self._came_in = came_in_shape(self.obj)
        return self._came_in
