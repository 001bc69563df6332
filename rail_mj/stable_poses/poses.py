"""Stable poses G_s: drop the object from many orientations in one batched simulation and cluster where it rests.

Each settled drop gives the mesh-frame direction that ends up pointing to world +z ("up"). Ups closer than
``tolerance_deg`` form one pose; its orientation is snapped to the nearest quasi-static pose from trimesh (an
exact face/rim contact) when one lies within the tolerance, and its yaw puts the footprint's smallest bounding
rectangle on the world axes. Drops that never stop (round objects rolling) are counted, not clustered.

Random drops miss poses with small basins: a chair or a legged table falls over before it can land on its
feet, a bulbous vase rolls off its base. So every quasi-static pose no drop found is also placed at rest on
the ground and simulated for a short while, and kept when it stays put. A pose's probability averages the two
estimates of its basin: the fraction of drops that ended in it and trimesh's quasi-static probability.
"""

from __future__ import annotations

import dataclasses
import hashlib
import heapq
import json
from pathlib import Path

import mujoco
import mujoco.batch
import numpy as np
import scipy.ndimage
import scipy.spatial
import trimesh

from rail_mj.core.errors import ConfigError, StablePoseError
from rail_mj.core.geometry import rotation_to_z, up_in_mesh_frame
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.mjcf import compose_scene
from rail_mj.core.paths import cache_dir
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.core.results import PoseInfo
from rail_mj.core.types import Basin, RailObject, StablePose, StablePoses

__all__ = ["find_stable_poses", "pose_from_up", "spill_basin"]

#: bump when the algorithm changes, so old cache entries are ignored (4: poses carry their spill level, 6: and
#: where their basin opens, and how long it is)
_CACHE_VERSION = 7
#: two resting shapes match when their height signatures differ by less than this fraction of the object size
_CONGRUENT = 0.02
#: quasi-static poses are checked by setting the object down this much off the pose and simulating this long (s)
_VERIFY_TILT_DEG = 3.0
_VERIFY_TIME = 1.5


def _uniform_quats(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


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
    ``samples``: the object's :func:`_surface_samples` for its spill level, when the caller has them already.
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
    samples = _surface_samples(obj) if samples is None else samples
    basin = spill_basin(samples @ rot.reshape(3, 3).T - lo)
    half = (hi - lo) / 2
    if basin is not None:  # its opening from the box centre, as the task frame has it
        basin = dataclasses.replace(basin, opening=basin.opening - half[:2])
    return StablePose(pos=pos, quat=quat, probability=probability, half_extents=half, basin=basin)


#: Points sampled on the mesh surface for :func:`spill_basin` (fixed seed: the same poses give the same level).
_SAMPLES = 60000
#: Cells across the larger side of the height map of :func:`spill_basin` (a cell holds a dozen samples of a flat top).
_GRID = 48
#: A basin is at least this deep (fraction of the object's height) where it is deepest.
_MIN_BASIN = 0.1


def _surface_samples(obj: RailObject) -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(obj.mesh, _SAMPLES, seed=0)
    return np.asarray(points, dtype=np.float64)


def spill_basin(points: np.ndarray) -> Basin | None:
    """The deepest basin of an object seen from above: the height (above the lowest point) at which water poured
    into it spills over (the lowest point of the rim that surrounds it), and where its water stands. A handle
    rising above the rim or reaching out beside it plays no part, nor do holes in the walls (unseen from above).
    None without a basin at least :data:`_MIN_BASIN` of the height deep (a closed box, a slatted crate open to the
    floor). The basin's ``opening`` is in the frame of the points given.

    ``points``: surface samples in a pose's frame (z up, lowest point at 0). The height map keeps the highest
    sample per cell (empty cells are the floor); water floods in from the border over the lowest passes first
    (priority flood), so each cell's water level is the lowest rim it spills over on its way out.
    """
    lo, hi = points.min(axis=0), points.max(axis=0)
    cell = float(max(hi[0] - lo[0], hi[1] - lo[1])) / _GRID
    if cell <= 0 or hi[2] <= 0:
        return None
    ij = np.floor((points[:, :2] - lo[:2]) / cell).astype(int) + 1  # one floor cell of margin all round
    shape = tuple(int(v) for v in ij.max(axis=0) + 2)
    height = np.zeros(shape)
    np.maximum.at(height, (ij[:, 0], ij[:, 1]), points[:, 2])
    # a cell no sample fell in is no pit: it takes its neighbours' height (walls grow by a cell, rims keep theirs)
    height = scipy.ndimage.maximum_filter(height, size=3, mode="constant")
    level = np.full(shape, np.inf)
    heap = []
    for i in range(shape[0]):
        for j in range(shape[1]):
            if i in (0, shape[0] - 1) or j in (0, shape[1] - 1):
                level[i, j] = height[i, j]
                heap.append((height[i, j], i, j))
    heapq.heapify(heap)
    while heap:
        h, i, j = heapq.heappop(heap)
        for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
            if 0 <= a < shape[0] and 0 <= b < shape[1] and level[a, b] == np.inf:
                level[a, b] = max(height[a, b], h)
                heapq.heappush(heap, (level[a, b], a, b))
    depth = level - height
    deepest = np.unravel_index(int(np.argmax(depth)), shape)
    if depth[deepest] < _MIN_BASIN * hi[2]:
        return None
    # where water stands at least half as deep as the deepest point: the opening a pour aims at (a saucepan's
    # pan, not its box's centre over the handle's root)
    wet, _ = scipy.ndimage.label(depth >= 0.5 * depth[deepest])
    cells = np.argwhere(wet == wet[deepest])
    centre = lo[:2] + (cells.mean(axis=0) - 0.5) * cell
    # the water surface at the spill level, where it stands over 5% of the deepest: a divider as high as the
    # walls (to a sample's noise) parts two basins
    surface, _ = scipy.ndimage.label(depth > 0.05 * depth[deepest])
    span = np.ptp(np.argwhere(surface == surface[deepest]), axis=0) + 1
    return Basin(rim=float(level[deepest]), opening=centre, length=float(span.max() * cell))


def _cluster(ups: np.ndarray, tol: float) -> list[np.ndarray]:
    """Greedy clustering: the up with most unassigned neighbours within ``tol`` (rad) seeds the next cluster."""
    close = ups @ ups.T > np.cos(tol)
    free = np.ones(len(ups), dtype=bool)
    clusters = []
    while free.any():
        counts = (close & free[None, :]).sum(axis=1) * free
        seed = int(np.argmax(counts))
        members = np.nonzero(close[seed] & free)[0]
        clusters.append(members)
        free[members] = False
    return clusters


def _signature(obj: RailObject, up: np.ndarray) -> np.ndarray:
    """Yaw-invariant shape of a resting pose: centre-of-mass height and area-weighted surface height quantiles."""
    mesh = obj.mesh
    heights = np.asarray(mesh.triangles_center) @ up
    order = np.argsort(heights)
    cdf = np.cumsum(np.asarray(mesh.area_faces)[order])
    quantiles = heights[order][np.searchsorted(cdf, cdf[-1] * np.linspace(0.05, 0.95, 10))]
    base = np.asarray(mesh.vertices) @ up
    return np.concatenate([[float(obj.com @ up) - base.min()], quantiles - base.min()])


def _merge_symmetric(obj: RailObject, reps: list[np.ndarray], tol: float) -> list[list[int]]:
    """Groups of clusters that are one pose rolled about a symmetry axis (a cup on its side at any angle).

    Two clusters join when their resting shapes match and their ups are less than 100° apart, so chains of
    neighbours along a round side merge, while opposite faces (a box's top and bottom) stay apart.
    """
    size = float(np.max(obj.extents))
    sigs = [_signature(obj, u) for u in reps]
    parent = list(range(len(reps)))

    def find(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for i in range(len(reps)):
        for j in range(i + 1, len(reps)):
            if reps[i] @ reps[j] > np.cos(np.deg2rad(100)) and np.max(np.abs(sigs[i] - sigs[j])) < tol * size:
                parent[find(j)] = find(i)
    groups: dict[int, list[int]] = {}
    for i in range(len(reps)):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def _quasi_static(obj: RailObject) -> tuple[np.ndarray, np.ndarray]:
    """Mesh-frame ups (n, 3) and probabilities (n,) of trimesh's quasi-static poses (symmetric copies apart)."""
    transforms, probs = trimesh.poses.compute_stable_poses(obj.mesh, center_mass=obj.com)
    return np.array([t[2, :3] for t in transforms]).reshape(-1, 3), np.asarray(probs, dtype=np.float64).reshape(-1)


def _drop(
    obj: RailObject, quats: np.ndarray, settle_time: float, drop_height: float, min_time: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Drop the object from each orientation ``quats`` (n, 4) in one batch; return the final orientations (n, 4)
    and whether each settled (n,). Rest before ``min_time`` does not count: an object set down on an unstable
    balance point starts at rest and needs a moment to fall."""
    cfg = ImaginationConfig(settle_speed=0.005)  # the imagination's physics, a stricter rest
    size = float(np.max(obj.extents))
    mass_scale = max(obj.mass, 1e-3)
    n_drops = len(quats)
    # damping and rolling friction let round objects (a cup on its side) come to rest within the settle time
    scene = compose_scene(obj, None, cfg.physics, joint_damping=0.05 * mass_scale, rolling_friction=0.01 * size)
    verts = np.concatenate([np.asarray(h) for h in obj.hulls])
    o = scene.object_qpos
    qpos0 = np.tile(scene.model.qpos0, (n_drops, 1))
    for i, q in enumerate(quats):
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, q)
        qpos0[i, o + 2] = drop_height - (verts @ rot.reshape(3, 3).T)[:, 2].min()
    qpos0[:, o + 3 : o + 7] = quats
    batch = mujoco.batch.Batch(scene.model, n_drops, nthread=cfg.nthread)
    qpos, qvel = batch.bind("qpos"), batch.bind("qvel")
    batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
    qpos[:] = qpos0
    qvel[:] = 0.0
    batch.forward()
    settled = np.zeros(n_drops, dtype=bool)
    quiet = np.zeros(n_drops, dtype=bool)
    steps, limit = 0, int(np.ceil(settle_time / cfg.timestep))
    first_check = int(np.ceil(min_time / cfg.timestep))
    while steps < limit:
        running = np.nonzero(~settled)[0]
        if len(running) == 0:
            break
        batch.step(ids=running, nstep=cfg.check_every)
        steps += cfg.check_every
        rest = scene.at_rest(qvel, cfg.settle_speed) & (steps >= first_check)
        settled |= rest & quiet
        quiet = rest
    final = np.array(qpos[:, o + 3 : o + 7])
    return final / np.linalg.norm(final, axis=1, keepdims=True), settled


def _verified(
    obj: RailObject, ups: np.ndarray, probs: np.ndarray, tol: float, rng: np.random.Generator
) -> list[tuple[np.ndarray, float]]:
    """Quasi-static poses (mesh-frame ups, probabilities) that hold in physics: each cluster of ups within ``tol``
    is set on the ground tilted by ``_VERIFY_TILT_DEG`` about a random horizontal axis, and kept when its up is
    back within ``tol`` after ``_VERIFY_TIME`` (an unstable balance falls well past ``tol`` in that time).
    Returns (up, summed probability) per kept cluster."""
    if len(ups) == 0:
        return []
    clusters = _cluster(ups, tol)
    seeds = [ups[m[np.argmax(probs[m])]] for m in clusters]
    quats = []
    for up in seeds:
        angle = rng.uniform(0, 2 * np.pi)
        half = np.deg2rad(_VERIFY_TILT_DEG) / 2
        tilt = np.array([np.cos(half), np.sin(half) * np.cos(angle), np.sin(half) * np.sin(angle), 0.0])
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, tilt, rotation_to_z(up))
        quats.append(q)
    # judged by where it ends, not by coming to rest: a legged table rocks on its hulls' corners for a while
    final, _ = _drop(obj, np.array(quats), _VERIFY_TIME, 0.002, min_time=_VERIFY_TIME)
    kept = np.einsum("ij,ij->i", up_in_mesh_frame(final), np.array(seeds)) > np.cos(tol)
    return [(seeds[i], float(probs[clusters[i]].sum())) for i in np.nonzero(kept)[0]]


def _cache_path(obj: RailObject, params: dict) -> Path:
    # the poses come from the hulls, which change with the decomposition settings under an unchanged mesh
    hulls = hashlib.sha256(b"".join(np.ascontiguousarray(h, dtype=np.float64).tobytes() for h in obj.hulls))
    key = json.dumps({"mesh": obj.mesh_hash, "hulls": hulls.hexdigest(), "version": _CACHE_VERSION, **params},
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


def find_stable_poses(
    obj: RailObject,
    *,
    n_drops: int = 128,
    seed: int = 0,
    settle_time: float = 3.0,
    drop_height: float = 0.01,
    tolerance_deg: float = 10.0,
    min_probability: float = 0.0,
    use_cache: bool = True,
) -> StablePoses:
    """Stable poses of ``obj``, most probable first; poses rarer than ``min_probability`` are dropped."""
    if n_drops < 1 or settle_time <= 0 or not 0 < tolerance_deg < 90 or drop_height < 0:
        raise ConfigError(
            f"need n_drops >= 1, settle_time > 0, 0 < tolerance_deg < 90, drop_height >= 0; got {n_drops}, "
            f"{settle_time}, {tolerance_deg}, {drop_height}"
        )
    params = dict(n_drops=n_drops, seed=seed, settle_time=settle_time, drop_height=drop_height,
                  tolerance_deg=tolerance_deg, min_probability=min_probability)
    path = _cache_path(obj, params)
    if use_cache and path.exists():
        try:
            return _from_json(path.read_text())
        except (ValueError, KeyError, TypeError):
            path.unlink(missing_ok=True)  # a torn entry (a writer killed before the atomic writes) is recomputed
    quats, settled = _drop(obj, _uniform_quats(np.random.default_rng(seed), n_drops), settle_time, drop_height)
    if not settled.any():
        raise StablePoseError(
            f"none of {n_drops} drops of {obj.name!r} came to rest within {settle_time} s; raise settle_time"
        )
    tol = np.deg2rad(tolerance_deg)
    ups = up_in_mesh_frame(quats[settled])
    exact, exact_p = _quasi_static(obj)
    reps, counts = [], []
    for members in _cluster(ups, tol):
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
    for up, p in _verified(obj, exact[missed], exact_p[missed], tol, np.random.default_rng(seed + 1)):
        reps.append(up)
        counts.append(0)
        quasi.append(p)
    poses = []
    samples = _surface_samples(obj)  # one set for every pose's spill level
    for group in _merge_symmetric(obj, reps, _CONGRUENT):
        best = max(group, key=lambda i: (counts[i], quasi[i]))
        probability = 0.5 * sum(counts[i] / n_drops + quasi[i] for i in group)
        if probability >= min_probability:
            poses.append(pose_from_up(obj, reps[best], probability, samples))
    poses.sort(key=lambda p: -p.probability)
    result = StablePoses(poses=tuple(poses), n_drops=n_drops, n_unsettled=int((~settled).sum()))
    if use_cache:  # atomic: a concurrent reader (another worker, a node on shared storage) never sees half a file
        atomic_write_text(path, _to_json(result))
    return result
