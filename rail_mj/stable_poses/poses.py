"""Stable poses G_s: drop the object from many orientations in one batched simulation and cluster where it rests.

Each settled drop gives the mesh-frame direction that ends up pointing to world +z ("up"). Ups closer than
``tolerance_deg`` form one pose; its orientation is snapped to the nearest quasi-static pose from trimesh (an
exact face/rim contact) when one lies within the tolerance, and its yaw puts the footprint's smallest bounding
rectangle on the world axes. Drops that never stop (round objects rolling) are counted, not clustered.

Random drops miss poses with small basins: a chair or a legged table falls over before it can land on its
feet, a bulbous vase rolls off its base. So every quasi-static pose no drop found is also placed at rest on
the ground and simulated for a short while, and kept when it stays put. A pose's probability averages the two
estimates of its basin: the fraction of drops that ended in it and trimesh's quasi-static probability.

This module is the entry: :func:`find_stable_poses` (cached on disk) and :func:`pose_from_up`. The drops are
in :mod:`rail_mj.stable_poses.drop`, the clustering in :mod:`rail_mj.stable_poses.cluster`, the spill basin in
:mod:`rail_mj.stable_poses.basin`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import scipy.spatial
from pydantic import ValidationError

from rail_mj.core.config import config_error
from rail_mj.core.errors import StablePoseError
from rail_mj.core.geometry import rotation_to_z, up_in_mesh_frame
from rail_mj.core.paths import cache_dir
from rail_mj.core.results import PoseInfo
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.core.types import RailObject, StablePose, StablePoses
from rail_mj.stable_poses.basin import spill_basin, surface_samples
from rail_mj.stable_poses.cluster import CONGRUENT, cluster_ups, merge_symmetric
from rail_mj.stable_poses.config import StablePoseConfig, drop_physics
from rail_mj.stable_poses.drop import drop, quasi_static, uniform_quats, verified
from rail_mj.stable_poses.legroom import toe_room
from rail_mj.stable_poses.shape import AS_IT_CAME_DEG, tilt_from_up

__all__ = ["find_stable_poses", "pose_from_up"]

#: bump when the algorithm changes, so old cache entries are ignored (4: poses carry their spill level, 6: and
#: where their basin opens, and how long it is, 8: how wide a foot gets under them, 9: how high the basin's floor is,
#: 10: of congruent poses, the one an oriented object came in stands for them)
_CACHE_VERSION = 10


def _footprint_yaw(xy: np.ndarray) -> float:
    """Yaw (rad) that turns the points' smallest-area bounding rectangle onto the x/y axes, its long side on x."""
    hull = xy[scipy.spatial.ConvexHull(xy).vertices] if len(xy) >= 3 else xy
    best = (np.inf, 0.0, 0.0)
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        theta = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
        c, s = np.cos(theta), np.sin(theta)
        p = hull @ np.array([[c, -s], [s, c]])  # rotated by -theta
        ext = p.max(axis=0) - p.min(axis=0)
        if ext[0] * ext[1] < best[0] - 1e-12:
            best = (ext[0] * ext[1], -theta, ext[1] - ext[0])
    _, yaw, longer_y = best
    return yaw + np.pi / 2 if longer_y > 1e-9 else yaw


def pose_from_up(obj: RailObject, up: np.ndarray, probability: float,
                 samples: np.ndarray | None = None) -> StablePose:
    """The stable pose whose mesh-frame ``up`` points to world +z, AABB centred, bottom at z = 0.

    Its yaw puts the footprint's smallest bounding rectangle on the world axes, long side along x, so the
    task-frame box is the object's own box: a table set diagonally would have placements off its corners.
    ``samples``: the object's :func:`~rail_mj.stable_poses.basin.surface_samples` for its spill level, when the
    caller has them already.
    """
    tilt = rotation_to_z(np.asarray(up, dtype=np.float64))
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, tilt)
    verts = np.asarray(obj.mesh.vertices) @ rot.reshape(3, 3).T
    yaw = _footprint_yaw(verts[:, :2])
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]), tilt)
    mujoco.mju_quat2Mat(rot, quat)
    verts = np.asarray(obj.mesh.vertices) @ rot.reshape(3, 3).T
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    centre = (lo + hi) / 2
    pos = np.array([-centre[0], -centre[1], -lo[2]])
    samples = surface_samples(obj) if samples is None else samples
    basin = spill_basin(samples @ rot.reshape(3, 3).T - lo)
    half = (hi - lo) / 2
    room = toe_room(samples @ rot.reshape(3, 3).T - lo, half)
    if basin is not None:  # its opening from the box centre, as the task frame has it
        basin = dataclasses.replace(basin, opening=basin.opening - half[:2])
    return StablePose(pos=pos, quat=quat, probability=probability, half_extents=half, basin=basin,
                      toe_room=room)


def _cache_path(obj: RailObject, params: dict) -> Path:
    # the poses come from the hulls, which change with the decomposition settings under an unchanged mesh
    hulls = hashlib.sha256(b"".join(np.ascontiguousarray(h, dtype=np.float64).tobytes() for h in obj.hulls))
    key = json.dumps({"mesh": obj.mesh_hash, "hulls": hulls.hexdigest(), "version": _CACHE_VERSION,
                      "oriented": obj.oriented, **params},
                     sort_keys=True)
    return cache_dir("stable_poses") / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


def _to_json(poses: StablePoses) -> str:
    return json.dumps({
        "n_drops": poses.n_drops,
        "n_unsettled": poses.n_unsettled,
        "poses": [PoseInfo.from_pose(i, p).model_dump(mode="json") for i, p in enumerate(poses)],
    })


def _from_json(text: str) -> StablePoses:
    raw = json.loads(text)
    poses = tuple(PoseInfo.model_validate(p).to_pose() for p in raw["poses"])
    return StablePoses(poses=poses, n_drops=int(raw["n_drops"]), n_unsettled=int(raw["n_unsettled"]))


def _with_settings(config: StablePoseConfig, settings: dict[str, Any]) -> StablePoseConfig:
    """``config`` with the fields named in ``settings`` replaced, checked against their declared ranges
    (ConfigError naming the range)."""
    unknown = sorted(set(settings) - set(StablePoseConfig.model_fields))
    if unknown:
        raise TypeError(f"find_stable_poses() got unexpected settings {unknown}; valid: "
                        f"{', '.join(StablePoseConfig.model_fields)}")
    if not settings:
        return config
    try:
        return StablePoseConfig.model_validate({**dict(config), **settings})
    except ValidationError as exc:
        raise config_error(StablePoseConfig, exc) from None


def find_stable_poses(
    obj: RailObject, config: StablePoseConfig | None = None, *, use_cache: bool = True, **settings: Any
) -> StablePoses:
    """Stable poses of ``obj``, most probable first; poses rarer than ``min_probability`` are dropped.

    ``config``: the search's settings (default :class:`StablePoseConfig`); ``settings``: some of its fields
    changed for this call (``n_drops=16, seed=3``).
    """
    config = _with_settings(config or StablePoseConfig(), settings)
    n_drops, seed, settle_time = config.n_drops, config.seed, config.settle_time
    drop_height, tolerance_deg, min_probability = config.drop_height, config.tolerance_deg, config.min_probability
    params: dict[str, Any] = dict(n_drops=n_drops, seed=seed, settle_time=settle_time, drop_height=drop_height,
                                  tolerance_deg=tolerance_deg, min_probability=min_probability)
    physics = config.physics.model_dump(exclude={"nthread"})  # threads do not change a drop's outcome
    if physics != drop_physics().model_dump(exclude={"nthread"}):  # the default's entries keep their keys
        params["physics"] = physics
    path = _cache_path(obj, params)
    if use_cache and path.exists():
        try:
            return _from_json(path.read_text())
        except (ValueError, KeyError, TypeError):
            path.unlink(missing_ok=True)  # a torn entry (a writer killed before the atomic writes) is recomputed
    quats, settled = drop(
        obj, uniform_quats(np.random.default_rng(seed), n_drops), settle_time, drop_height, config.physics
    )
    if not settled.any():
        raise StablePoseError(
            f"none of {n_drops} drops of {obj.name!r} came to rest within {settle_time} s; raise settle_time"
        )
    tol = np.deg2rad(tolerance_deg)
    ups = up_in_mesh_frame(quats[settled])
    exact, exact_p = quasi_static(obj)
    reps, counts = [], []
    for members in cluster_ups(ups, tol):
        mean = ups[members].mean(axis=0)
        up = ups[members[np.argmax(ups[members] @ mean)]]
        if len(exact):
            nearest = exact[np.argmax(exact @ up)]
            up = nearest if nearest @ up > np.cos(tol) else up
        reps.append(up)
        counts.append(len(members))
    # each quasi-static pose adds its probability to the drop cluster it lies in; the rest are verified
    similarity = exact @ np.array(reps).T
    missed = similarity.max(axis=1, initial=-1.0) <= np.cos(tol)
    quasi = np.zeros(len(reps))
    np.add.at(quasi, similarity.argmax(axis=1)[~missed], exact_p[~missed])
    quasi = quasi.tolist()
    for up, p in verified(
        obj, exact[missed], exact_p[missed], tol, np.random.default_rng(seed + 1), config.physics
    ):
        reps.append(up)
        counts.append(0)
        quasi.append(p)
    poses = []
    samples = surface_samples(obj)  # one set for every pose's spill level
    # of congruent poses (one pose rolled about a symmetry axis: a nearly square open-fronted cubby upright, on a side
    # or upside down), the one the object came in stands for them, so that the pose it came in is found
    for group in merge_symmetric(obj, reps, CONGRUENT):
        best = max(group, key=lambda i: (obj.oriented and tilt_from_up(reps[i]) <= AS_IT_CAME_DEG, counts[i], quasi[i]))
        probability = 0.5 * sum(counts[i] / n_drops + quasi[i] for i in group)
        if probability >= min_probability:
            poses.append(pose_from_up(obj, reps[best], probability, samples))
    poses.sort(key=lambda p: -p.probability)
    result = StablePoses(poses=tuple(poses), n_drops=n_drops, n_unsettled=int((~settled).sum()))
    if use_cache:  # atomic: a concurrent reader (another worker, a node on shared storage) never sees half a file
        atomic_write_text(path, _to_json(result))
    return result
