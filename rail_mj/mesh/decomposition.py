"""Convex decomposition: CoACD settings, its runs in child processes with their limits, the hulls and their cache.

A mesh of separate bodies is decomposed body by body; meshes over :data:`DENSE_FACES` faces get
faster CoACD settings (:func:`decomposition_for`). Hulls are cached under ``cache_dir("hulls")``,
keyed by :func:`mesh_hash` and the settings.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from typing import Any, Literal

import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from scipy.spatial import ConvexHull, QhullError

from rail_mj.core.config import config_error
from rail_mj.core.errors import DecompositionError
from rail_mj.core.paths import cache_dir
from rail_mj.core.runfiles import atomic_write_bytes
from rail_mj.mesh.coacd_run import CoacdCrash, coacd_child
from rail_mj.mesh.repair import _body_labels, _decimate

__all__ = [
    "MJX_MAX_HULL_VERTICES",
    "DENSE_FACES",
    "DENSE_DECOMPOSITION",
    "GUARD_DECOMPOSITION",
    "DecompositionConfig",
    "decomposition_for",
    "second_decomposition",
    "mesh_hash",
    "decompose",
    "reduce_hull",
]

#: MJX's convex collision caps hull vertices at 64.
MJX_MAX_HULL_VERTICES = 64
#: Meshes with more faces are dense (scans, CAD exports): :func:`decomposition_for` gives them faster
#: settings. The procedural dataset stays at or under it (``rail_mj.dataset.procedural.MAX_FACES``), so its hulls
#: and their cache keys are those of the defaults.
DENSE_FACES = 5_000
# Fewest faces DecompositionConfig.max_faces may ask for: below it decimation erases whole features.
_MIN_COACD_FACES = 500
# Hulls with less volume than this (m^3) are slivers MuJoCo cannot give inertia.
_MIN_HULL_VOLUME = 1e-12


class DecompositionConfig(BaseModel):
    """CoACD parameters and the hull vertex cap.

    The defaults decompose a ~5.9k-face mug with a handle in ~7 s of CPU into
    25 hulls that leave its cavity free (``benchmarks/coacd_time.py``);
    CoACD's own defaults (resolution 2000, 150 MCTS iterations, remeshing)
    took ~2 minutes here. ``mcts_max_depth=1`` is a trap: worse cuts and a
    ~50x slower merge. A bad value is a ConfigError naming the field's declared range.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    # concavity tolerance; larger = fewer, coarser hulls (0.08 let hulls into a cup)
    threshold: float = Field(default=0.05, gt=0.0, le=1.0)
    max_convex_hull: int = Field(default=32, ge=1)  # hull cap (CoACD merges down to it)
    max_hull_vertices: int = Field(default=MJX_MAX_HULL_VERTICES, ge=4, le=MJX_MAX_HULL_VERTICES)  # the MJX limit
    # "auto": remesh (CoACD's manifold preprocessing) only when the repaired mesh is not a closed
    # volume — remeshing at low resolution thickens thin walls into the cavity and triples the time
    preprocess_mode: Literal["auto", "on", "off"] = "auto"
    preprocess_resolution: int = Field(default=30, ge=1)
    resolution: int = Field(default=500, ge=1)  # surface samples per cut evaluation
    mcts_nodes: int = Field(default=10, ge=1)
    mcts_iterations: int = Field(default=30, ge=1)
    mcts_max_depth: int = Field(default=2, ge=1)
    seed: int = 0
    convex_shortcut: bool = True  # a convex mesh is its own (reduced) hull, no CoACD call
    # CoACD sees at most this many faces: the mesh is decimated for it alone (the object keeps the
    # repaired mesh); None: CoACD sees the mesh as repaired (<= FACE_BUDGET faces)
    max_faces: int | None = Field(default=None, ge=_MIN_COACD_FACES)
    # CPU seconds one CoACD run may take before it is stopped with a DecompositionTimeout: a 10k-piece
    # triangle soup ran for minutes per run. The worst real mesh here took 26 s of wall time cold.
    time_limit_s: float = Field(default=150.0, gt=0.0, allow_inf_nan=False)

    def __init__(self, **data: Any) -> None:
        try:
            super().__init__(**data)
        except ValidationError as exc:
            raise config_error(type(self), exc) from None


#: :func:`decomposition_for` meshes of more than :data:`DENSE_FACES` faces.
DENSE_DECOMPOSITION = DecompositionConfig(threshold=0.07, mcts_iterations=15, max_faces=3_000)
#: The quality guard's second try on a dense mesh whose :data:`DENSE_DECOMPOSITION` hulls fail it: the defaults, on
#: the mesh cut to the most faces the defaults are otherwise given (:data:`DENSE_FACES`). On the whole mesh (up to
#: the 20,000-face budget) the defaults took 1.4-1.9x as long on six of the real set's dense meshes (libero's basket
#: 46.6 s against 26.6 s of CPU), for hulls no better: probe excess within 0.03 on four, the bowl drainer's 0.21
#: against 0.26 and the kiva pod's 0.35 against 0.18.
GUARD_DECOMPOSITION = DecompositionConfig(max_faces=DENSE_FACES)


def mesh_hash(mesh: trimesh.Trimesh) -> str:
    """SHA-256 of the vertex (float64) and face (int64) arrays."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def reduce_hull(points: np.ndarray, max_vertices: int) -> np.ndarray:
    """Convex-hull vertices of ``points``, reduced to at most ``max_vertices``.

    Greedy farthest-point insertion: start from the 6 axis extremes, then add
    the point lying farthest outside the current hull until the cap, so the
    reduced hull is inscribed and its worst-case gap is minimised step by step.
    """
    points = np.asarray(points, dtype=np.float64)
    try:
        hull_pts = points[ConvexHull(points).vertices]
    except (QhullError, ValueError) as exc:
        raise DecompositionError(f"hull of {len(points)} points is degenerate (flat or too few points)") from exc
    if len(hull_pts) <= max_vertices:
        return hull_pts
    chosen = list(dict.fromkeys(int(i) for i in np.concatenate([hull_pts.argmin(0), hull_pts.argmax(0)])))
    while len(chosen) < 4:  # extremes coincide on tiny hulls: add the farthest from the centroid
        d = np.linalg.norm(hull_pts - hull_pts[chosen].mean(0), axis=1)
        d[chosen] = -1.0
        chosen.append(int(d.argmax()))
    while len(chosen) < max_vertices:
        try:
            eq = ConvexHull(hull_pts[chosen]).equations
        except QhullError:  # the seed points are coplanar: add the point farthest off their plane
            c = hull_pts[chosen]
            normal = np.linalg.svd(c - c.mean(0))[2][-1]
            dist = np.abs((hull_pts - c.mean(0)) @ normal)
        else:
            dist = (hull_pts @ eq[:, :3].T + eq[:, 3]).max(axis=1)
        dist[chosen] = -np.inf
        best = int(dist.argmax())
        if dist[best] <= 0.0:
            break
        chosen.append(best)
    return hull_pts[np.sort(chosen)]


def _cache_key(digest: str, config: DecompositionConfig, n_bodies: int) -> str:
    # Options left at None and a single body are left out of the key, so the meshes and configs that
    # existed before those options and the split into bodies keep their cache entries; the time limit
    # does not change the hulls it lets through.
    fields = {k: v for k, v in config.model_dump().items() if v is not None and k != "time_limit_s"}
    payload = {"mesh": digest, "config": fields}
    if n_bodies > 1:
        payload["bodies"] = n_bodies
        payload["shares"] = 3  # version of _decompose_bodies: bodies without volume take no hull (2), thresholds
        # in the whole object's scale (3)
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _preprocess_mode(mesh: trimesh.Trimesh, config: DecompositionConfig) -> str:
    if config.preprocess_mode != "auto":
        return config.preprocess_mode
    return "off" if mesh.is_volume else "on"


def _run_coacd(mesh: trimesh.Trimesh, config: DecompositionConfig) -> list[np.ndarray]:
    options = dict(
        threshold=config.threshold,
        max_convex_hull=config.max_convex_hull,
        preprocess_mode=_preprocess_mode(mesh, config),
        preprocess_resolution=config.preprocess_resolution,
        resolution=config.resolution,
        mcts_nodes=config.mcts_nodes,
        mcts_iterations=config.mcts_iterations,
        mcts_max_depth=config.mcts_max_depth,
        decimate=True,
        max_ch_vertex=max(config.max_hull_vertices, 8),
        seed=config.seed,
    )
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int32)
    try:
        return coacd_child(vertices, faces, options, config.time_limit_s)
    except CoacdCrash as crash:
        if options["preprocess_mode"] == "on":
            raise DecompositionError(f"CoACD crashed on this mesh ({crash}); repair or simplify the mesh") from None
        # the crashes seen come from CoACD's cutting of the mesh as given; its own remeshing avoids them
        try:
            return coacd_child(vertices, faces, {**options, "preprocess_mode": "on"}, config.time_limit_s)
        except CoacdCrash as again:
            raise DecompositionError(f"CoACD crashed on this mesh ({crash}), and again with its own remeshing "
                                     f"({again}); repair or simplify the mesh") from None


def _bodies(mesh: trimesh.Trimesh, labels: np.ndarray) -> list[trimesh.Trimesh]:
    """The mesh's connected pieces, in the order of their first face.

    Each piece keeps only its own vertices, gathered in one pass: copying every vertex into each piece
    and pruning made a 10k-piece triangle soup quadratic (minutes).
    """
    _, first = np.unique(labels, return_index=True)
    pieces = []
    for label in labels[np.sort(first)]:
        faces = mesh.faces[labels == label]
        used, local = np.unique(faces, return_inverse=True)
        pieces.append(trimesh.Trimesh(mesh.vertices[used], local.reshape(faces.shape), process=False))
    return pieces


def _point_hull_volume(points: np.ndarray) -> float:
    try:
        return float(ConvexHull(points).volume)
    except (QhullError, ValueError):
        return 0.0


def _hull_caps(weights: list[float], convex: list[bool], cap: int) -> list[int]:
    """Each body's share of the hull cap: 0 for a body with no volume (a stray triangle of an open seam, a flat
    patch: dropped as a sliver, so it takes no hull), 1 for a convex one, and the rest shared by the concave bodies
    in proportion to their hull volume, by largest remainder, so no hull of the cap is lost to rounding."""
    solid = [w >= _MIN_HULL_VOLUME for w in weights]
    caps = [int(s) for s in solid]
    concave = [i for i, (s, c) in enumerate(zip(solid, convex, strict=True)) if s and not c]
    total = sum(weights[i] for i in concave)
    spare = cap - sum(caps)
    if not concave or total <= 0 or spare <= 0:
        return caps
    share = {i: spare * weights[i] / total for i in concave}
    for i in concave:
        caps[i] += int(share[i])
    left = spare - sum(int(v) for v in share.values())
    for i in sorted(concave, key=lambda i: share[i] - int(share[i]), reverse=True)[:left]:
        caps[i] += 1
    return caps


def _decompose_bodies(bodies: list[trimesh.Trimesh], config: DecompositionConfig) -> list[np.ndarray]:
    """Raw parts of a mesh made of separate bodies, each body decomposed on its own.

    CoACD given the bodies together treats them as one surface: on overlapping closed bodies
    (a teddy made of 15 convex pieces, a tray of 5 boxes) it ran for minutes or exhausted memory.
    A convex body is its own hull; the concave ones share what the hull cap leaves (:func:`_hull_caps`). A
    scan's or an exporter's open seams leave stray triangles as bodies of their own: when each took a hull of the
    cap, a bar chair of 4 pieces and 20 such triangles had its seat and back made one hull, a wedge that filled
    the seat.
    """
    convex = [config.convex_shortcut and body.is_convex for body in bodies]
    weights = [_point_hull_volume(np.asarray(body.vertices)) for body in bodies]
    whole = float(np.ptp(np.vstack([body.bounds for body in bodies]), axis=0).max())
    raw: list[np.ndarray] = []
    for body, is_convex, cap in zip(bodies, convex, _hull_caps(weights, convex, config.max_convex_hull), strict=True):
        if cap == 0:
            continue
        if cap == 1 or is_convex:
            raw.append(np.asarray(body.vertices, dtype=np.float64))
            continue
        # CoACD measures concavity in a box scaled to the mesh it is given: a body a third of the object's size
        # held to the object's threshold in its own box was cut three times finer than the object as one mesh
        # would be. Its threshold in the object's scale keeps every body to the same tolerance in metres.
        threshold = min(1.0, config.threshold * whole / float(body.extents.max()))
        raw.extend(_run_coacd(body, config.model_copy(update={"max_convex_hull": cap, "threshold": threshold})))
    return raw


def decompose(mesh: trimesh.Trimesh, config: DecompositionConfig | None = None) -> tuple[np.ndarray, ...]:
    """Convex hulls of ``mesh`` (mesh frame), each with <= ``config.max_hull_vertices`` vertices.

    A mesh of separate bodies (no more than ``config.max_convex_hull``) is decomposed body by body.
    Cached as .npz under ``cache_dir("hulls")``, keyed by the mesh arrays and the config.
    """
    config = config or DecompositionConfig()
    labels = _body_labels(mesh)
    path = cache_dir("hulls") / f"{_cache_key(mesh_hash(mesh), config, len(np.unique(labels)))}.npz"
    if path.exists():
        try:
            with np.load(path) as data:
                return tuple(data[f"hull{i}"] for i in range(len(data.files)))
        except (OSError, ValueError, KeyError, zipfile.BadZipFile):
            path.unlink(missing_ok=True)  # a damaged cache entry is recomputed, not trusted
    if config.convex_shortcut and mesh.is_convex:
        raw = [np.asarray(mesh.vertices, dtype=np.float64)]
    else:
        target = mesh
        if config.max_faces is not None and len(mesh.faces) > config.max_faces:
            target = _decimate(mesh, "mesh", config.max_faces, strict=False)
            labels = _body_labels(target)
        if 1 < len(np.unique(labels)) <= config.max_convex_hull:
            raw = _decompose_bodies(_bodies(target, labels), config)
        else:
            raw = _run_coacd(target, config)
    hulls = []
    for points in raw:
        if len(points) < 4:
            continue
        try:
            if ConvexHull(points).volume < _MIN_HULL_VOLUME:
                continue
        except QhullError:
            continue  # a flat sliver: no volume, no contact surface worth keeping
        hulls.append(reduce_hull(points, config.max_hull_vertices))
    if not hulls:
        raise DecompositionError(
            f"decomposition gave no usable hull ({len(raw)} raw parts, all flat or tiny); "
            "check the mesh has volume or lower DecompositionConfig.threshold"
        )
    data = io.BytesIO()
    np.savez(data, **{f"hull{i}": h for i, h in enumerate(hulls)})
    # atomic and fsynced: a concurrent reader, another worker or a node on shared storage writing the same key,
    # a power cut: none sees or leaves half a file
    atomic_write_bytes(path, data.getvalue())
    return tuple(hulls)


def decomposition_for(mesh: trimesh.Trimesh) -> DecompositionConfig:
    """The decomposition settings :func:`object_from_mesh` uses for ``mesh`` when given none.

    Meshes of at most :data:`DENSE_FACES` faces get the defaults. Denser ones (scans, CAD
    exports) get :data:`DENSE_DECOMPOSITION`: CoACD sees them cut to 3,000 faces, with a coarser
    concavity threshold (0.07) and half the MCTS iterations (15). On the real-mesh set's eight
    dense closed meshes (8k-66k faces) that took CoACD from 5-60 s of CPU to 2.4-10 s, with the
    same hull count (22-32 of 32), volume ratio within 6% and excess within 0.02
    (``benchmarks/coacd_time.py``). Fewer hulls (16) were slower (more merging) and filled more
    of the cavities (excess +0.03-0.07); CoACD's ``resolution`` at 250 changed neither time nor
    hulls. CoACD scales every mesh to a unit box, so an object's size in metres changes neither.
    The quality guard of :func:`object_from_mesh` redoes hulls from these settings with the
    defaults, on at most :data:`DENSE_FACES` faces (:data:`GUARD_DECOMPOSITION`), where they fail it.
    """
    return DecompositionConfig() if len(mesh.faces) <= DENSE_FACES else DENSE_DECOMPOSITION


def second_decomposition(mesh: trimesh.Trimesh) -> DecompositionConfig:
    """The decomposition perturbation's settings for ``mesh``: the other of the two concavity thresholds the
    project uses (the defaults' 0.05 and :data:`DENSE_DECOMPOSITION`'s 0.07) than :func:`decomposition_for`
    gives it, at the dense settings' speed (3,000 faces, 15 MCTS iterations). A standard mesh's second
    decomposition is the coarser one, whose hulls reach further into a cavity; a dense mesh's is the finer one.
    """
    first, fine, coarse = decomposition_for(mesh), DecompositionConfig().threshold, DENSE_DECOMPOSITION.threshold
    return DENSE_DECOMPOSITION.model_copy(update={"threshold": fine if first.threshold == coarse else coarse})
