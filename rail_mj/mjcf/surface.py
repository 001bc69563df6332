"""The object's own surface as a static model: what ray probes meet, where its convex hulls would fill or bridge."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from rail_mj.core.types import RailObject

__all__ = ["surface_model", "surface_data", "static_meshes", "OwnSurface"]


def surface_data(model: mujoco.MjModel) -> mujoco.MjData:
    """The static ``model``'s data with its kinematics done: what rays cast in it read."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return data


def surface_model(obj: RailObject) -> mujoco.MjModel:
    """The object's mesh as one static, non-colliding geom in its own frame: rays cast in it meet the surface
    itself, where the convex hulls fill a desk's 3 cm top out to 5-9 cm or bridge a basket's slots. When MuJoCo
    refuses the mesh (a scan too degenerate for its mesh compiler) the hulls, which the scene compiled, stand in."""
    try:
        return static_meshes([(obj.mesh.vertices, obj.mesh.faces)])
    except ValueError:
        return static_meshes([(hull, None) for hull in obj.hulls])


def static_meshes(meshes: Sequence[tuple[np.ndarray, np.ndarray | None]]) -> mujoco.MjModel:
    """A model of static, non-colliding mesh geoms (vertices, faces; no faces: their convex hull)."""
    spec = mujoco.MjSpec()
    for i, (vertices, faces) in enumerate(meshes):
        mesh = spec.add_mesh(name=f"surface{i}", uservert=np.asarray(vertices, dtype=np.float64).ravel().tolist(),
                             inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL)
        if faces is not None:
            mesh.userface = np.asarray(faces, dtype=np.int32).ravel().tolist()
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh.name, contype=0, conaffinity=0)
    return spec.compile()


@dataclass(frozen=True)
class OwnSurface:
    """Rays from world points into the object's own surface (:func:`surface_model` and its ``data``, whose
    kinematics are done) where the object stands in one world: its body's position ``pos`` and rotation ``mat``
    (3, 3), and the world's mesh ``scale`` (the surface is the nominal mesh)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    pos: np.ndarray
    mat: np.ndarray
    scale: float = 1.0

    def ray(self, pnt: np.ndarray, vec: np.ndarray) -> tuple[float, float]:
        """(distance (m) along the unit ``vec`` (world frame) from ``pnt`` to the surface, -1 when the ray misses it;
        the vertical part of the surface's normal where it meets it)."""
        local = self.mat.T @ (np.asarray(pnt, dtype=np.float64) - self.pos) / self.scale
        direction = self.mat.T @ np.asarray(vec, dtype=np.float64)
        normal = np.zeros(3)
        hit = mujoco.mj_ray(self.model, self.data, local, direction, None, True, -1, np.zeros(1, dtype=np.int32),
                            normal)
        return (hit * self.scale if hit >= 0.0 else -1.0), float((self.mat @ normal)[2])
