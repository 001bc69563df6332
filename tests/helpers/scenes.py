"""Small generated scenes the imagination tests share: a cup of 13 boxes, a table, droplets, pour plans."""

import numpy as np
import trimesh

from rail_mj.core.types import RailObject
from rail_mj.imagination import ImaginationConfig

DROPLET = ('<mujoco><worldbody><body name="drop"><geom type="sphere" size="0.006" mass="0.001"/></body>'
           '</worldbody></mujoco>')
BLOCK = ('<mujoco><worldbody><body name="block"><geom type="box" size="{s} {s} {s}" mass="{m}"/></body>'
         '</worldbody></mujoco>')
FAST = ImaginationConfig(settle_time=1.5)


def _object(name: str, hulls: list[np.ndarray], density: float = 500.0) -> RailObject:
    mesh = trimesh.util.concatenate([trimesh.convex.convex_hull(h) for h in hulls])
    return RailObject(name=name, mesh=mesh, hulls=tuple(np.asarray(h) for h in hulls), mesh_hash=f"test-{name}",
                      obb_dims=np.sort(mesh.extents)[::-1], com=mesh.center_mass, mass=float(mesh.volume * density),
                      density=density)


def _box(lo, hi) -> np.ndarray:
    return trimesh.creation.box(bounds=[lo, hi]).vertices


def _cup(r: float = 0.04, h: float = 0.08, t: float = 0.004, n: int = 12) -> RailObject:
    hulls = [_box([-r, -r, 0], [r, r, t])]
    for i in range(n):
        wall = trimesh.creation.box(extents=[t, 2 * np.pi * r / n + t, h])
        wall.apply_translation([r - t / 2, 0, h / 2])
        wall.apply_transform(trimesh.transformations.rotation_matrix(2 * np.pi * i / n, [0, 0, 1]))
        hulls.append(wall.vertices)
    return _object(f"cup{r}", hulls)


def _table() -> RailObject:
    legs = [_box([x - 0.01, y - 0.01, 0], [x + 0.01, y + 0.01, 0.1]) for x in (-0.08, 0.08) for y in (-0.08, 0.08)]
    return _object("table", [_box([-0.1, -0.1, 0.1], [0.1, 0.1, 0.12]), *legs])


def _grid(n: int, spacing: float) -> np.ndarray:
    g = (np.arange(n) - (n - 1) / 2) * spacing
    return np.array([[x, y, z] for x in g for y in g for z in g])


def _inside(out) -> np.ndarray:
    return (np.abs(out.agent_pos) <= out.object_half_extents[:, None, :] + 1e-3).all(-1)


def _pour_plans(cup_poses):
    above = cup_poses[0].half_extents[2] + 0.04
    return [np.array([[0, 0, above, 1, 0, 0, 0]]),
            np.array([[0, 0, above + 0.05, 1, 0, 0, 0], [0, 0, above, 1, 0, 0, 0]])]
