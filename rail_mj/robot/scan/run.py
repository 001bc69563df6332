"""The scan of one object from start to end (scan_object), what it reports (ScanResult), and saving it."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import cKDTree  # pyright: ignore[reportAttributeAccessIssue]  # compiled, no stub

from rail_mj.core.errors import ConfigError
from rail_mj.core.types import RailObject, StablePose
from rail_mj.robot.scan.config import ScanConfig, ScanError, load_open3d
from rail_mj.robot.scan.fusion import extract, fuse_views
from rail_mj.robot.scan.views import (
    ScanView,
    build_scan_scene,
    noisy_depth,
    plan_top_view,
    plan_views,
    reach_views,
    render_views,
    true_mesh_world,
)

__all__ = [
    "MESH_FORMATS",
    "ScanResult",
    "scan_object",
    "chamfer_distance",
    "save_scan",
]

#: Mesh formats :func:`save_scan` writes; all are formats :func:`rail_mj.mesh.load_mesh` reads.
MESH_FORMATS = (".obj", ".ply", ".stl", ".off", ".glb")


@dataclass(frozen=True)
class ScanResult:
    """A fused, segmented scan of one object."""

    mesh: trimesh.Trimesh  # world frame, metres, z up, resting on the table
    chamfer_m: float  # symmetric Chamfer distance to the true mesh (mean of both directions), m; nan unknown
    seconds: dict[str, float]  # plan (IK), render, fuse, extract (and chamfer)
    n_views: int  # views used: fused, and the top view (free space only)
    skipped: tuple[str, ...]  # why each planned view was not used
    table_z: float  # fitted table plane height under the object, m
    views: tuple[ScanView, ...]
    notes: tuple[str, ...] = ()

    @property
    def scan_seconds(self) -> float:
        """Time of the scan itself: planning, rendering, fusion and extraction (not the Chamfer check)."""
        return sum(self.seconds.get(k, 0.0) for k in ("plan", "render", "fuse", "extract"))

    def to_dict(self) -> dict:
        """JSON-ready summary (no mesh)."""
        return {
            "chamfer_mm": None if math.isnan(self.chamfer_m) else 1000 * self.chamfer_m,
            "seconds": self.seconds,
            "scan_seconds": self.scan_seconds,
            "n_views": self.n_views,
            "skipped": list(self.skipped),
            "table_z": self.table_z,
            "faces": int(len(self.mesh.faces)),
            "extents": np.asarray(self.mesh.extents).tolist(),
            "notes": list(self.notes),
        }


def chamfer_distance(a: trimesh.Trimesh, b: trimesh.Trimesh, n: int = 20000, seed: int = 0) -> float:
    """Symmetric Chamfer distance: the mean of (a→b mean nearest distance) and (b→a), surface samples, m."""
    pa = trimesh.sample.sample_surface(a, n, seed=seed)[0]
    pb = trimesh.sample.sample_surface(b, n, seed=seed + 1)[0]
    da, _ = cKDTree(pb).query(pa)
    db, _ = cKDTree(pa).query(pb)
    return float((da.mean() + db.mean()) / 2)


def scan_object(obj: RailObject, pose: StablePose, config: ScanConfig | None = None) -> ScanResult:
    """Scan ``obj`` standing in ``pose`` on the robot's table with the wrist camera; fuse, segment, mesh.

    Raises :class:`ScanError` when open3d is missing, when fewer than ``config.min_views`` views are
    reachable, or when nothing but the table is seen.
    """
    config = config or ScanConfig()
    load_open3d()  # fail before any work when the extra is missing
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    scene = build_scan_scene(obj, pose, config)
    world = true_mesh_world(obj, pose, config.robot)
    surface = trimesh.sample.sample_surface(world, 4000, seed=config.seed)[0]
    views, skipped, moved = reach_views(scene, plan_views(config, scene.workspace_centre), np.asarray(surface),
                                         config)
    seconds["plan"] = time.perf_counter() - t0
    if len(views) < config.min_views:
        raise ScanError(f"only {len(views)} of {config.n_views} scan views are reachable (at least "
                        f"{config.min_views} needed): " + "; ".join(skipped))
    t0 = time.perf_counter()
    rng = np.random.default_rng(config.seed)
    depths = [noisy_depth(d, config, rng) for d in render_views(scene, views, config)]
    seconds["render"] = time.perf_counter() - t0
    if not any((d > 0).any() for d in depths):
        raise ScanError("the wrist camera saw nothing in any view (every pixel empty or out of range)")
    t0 = time.perf_counter()
    volume = fuse_views(depths, views, config, scene.workspace_centre)
    seconds["fuse"] = time.perf_counter() - t0
    n_fused = len(views)
    top = plan_top_view(volume, config, scene.table_top, config.n_views) if config.top_view else None
    if top is not None:
        t0 = time.perf_counter()
        more, not_reached, fallback = reach_views(scene, [top], np.asarray(surface), config)
        skipped, moved = skipped + not_reached, moved + fallback
        seconds["plan"] += time.perf_counter() - t0
        if more:  # for the closings only (plan_top_view and extract say why)
            t0 = time.perf_counter()
            depths = depths + [noisy_depth(d, config, rng) for d in render_views(scene, more, config)]
            views = views + more
            seconds["render"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    mesh, table_z, notes = extract(volume, depths, views, config, scene.table_top, scene.workspace_centre, n_fused)
    seconds["extract"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    chamfer = chamfer_distance(mesh, world, config.chamfer_points, config.seed)
    seconds["chamfer"] = time.perf_counter() - t0
    return ScanResult(mesh=mesh, chamfer_m=chamfer, seconds=seconds, n_views=len(views), skipped=tuple(skipped),
                      table_z=table_z, views=tuple(views), notes=tuple(moved + notes))


def save_scan(result: ScanResult | trimesh.Trimesh, path: str | Path) -> Path:
    """Write the scanned mesh (metres, z up, world frame) where ``rail_mj.mesh.load_object(path)`` reads it."""
    path = Path(path)
    if path.suffix.lower() not in MESH_FORMATS:
        raise ConfigError(f"cannot save a scan as {path.suffix or 'no suffix'!r}; use one of {', '.join(MESH_FORMATS)}")
    mesh = result.mesh if isinstance(result, ScanResult) else result
    if len(mesh.faces) == 0:
        raise ScanError(f"the scanned mesh is empty; nothing written to {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)
    return path
