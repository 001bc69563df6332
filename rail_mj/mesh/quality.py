"""Hull quality: how well convex hulls stand for their mesh, and the guard that chooses between decompositions.

Every object's hulls pass the quality guard (:func:`hull_quality`: volume ratio, cavities kept open,
surface covered); hulls from :func:`~rail_mj.mesh.decomposition.decomposition_for`'s faster settings
that fail it are made again with the defaults (:data:`~rail_mj.mesh.decomposition.GUARD_DECOMPOSITION`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from rail_mj.core.errors import DecompositionTimeout
from rail_mj.mesh.decomposition import GUARD_DECOMPOSITION, DecompositionConfig, decompose, decomposition_for

__all__ = ["MAX_EXCESS", "MAX_MISSING", "HullQuality", "hull_quality"]

#: The quality guard (:func:`object_from_mesh`): most of :attr:`HullQuality.excess` and
#: :attr:`HullQuality.missing` that hulls may have. The procedural dataset's default hulls reach
#: 0.04 and 0.23 (a sphere's 64-vertex hull); one hull of a cup gives 0.73 excess.
MAX_EXCESS = 0.25
MAX_MISSING = 0.3


# Probe rays per side of the grid :func:`hull_quality` casts from each of the six axis directions.
_PROBE_GRID = 32
# Surface points :func:`hull_quality` checks for a hull near them, and how near (fraction of the
# mesh's largest extent) counts as covered.
_SURFACE_SAMPLES = 2048
_COVER_TOL = 0.02
_MIN_FREE = 0.02


@dataclass(frozen=True)
class HullQuality:
    """How well the convex hulls stand for the mesh they were made from (:func:`hull_quality`).

    ``excess`` and ``missing`` need no closed surface, so they stand in for ``volume_ratio`` on
    open meshes.
    """

    n_hulls: int
    #: Volume of the union of the hulls over the mesh's volume; None when the mesh is not closed.
    volume_ratio: float | None
    #: The worst of six axis views (probe rays on a grid over the bounding box): the part of the free
    #: space in front of the mesh that hulls fill. ~1 when hulls fill a cup seen from above; ~0 when
    #: every cavity stays open.
    excess: float
    #: The fraction of the mesh's surface (area-weighted samples) farther than 2% of its largest
    #: extent from every hull: parts the hulls lost.
    missing: float


def _hull_intervals(
    hulls: tuple[np.ndarray, ...], equations: list[np.ndarray], origins: np.ndarray, axis: int, sign: float
) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit ray parameters (H, R) of the rays ``origins + t * sign * e_axis`` through each hull
    (inf where a ray misses it); only the rays over a hull's bounding box are tested against it."""
    enter = np.full((len(equations), len(origins)), np.inf)
    leave = np.full((len(equations), len(origins)), np.inf)
    across = [k for k in range(3) if k != axis]
    for i, (points, eq) in enumerate(zip(hulls, equations, strict=True)):
        lo, hi = points[:, across].min(axis=0), points[:, across].max(axis=0)
        rays = np.flatnonzero(((origins[:, across] >= lo) & (origins[:, across] <= hi)).all(axis=1))
        if len(rays) == 0:
            continue
        num = -(origins[rays] @ eq[:, :3].T + eq[:, 3])  # (R, P): a point is inside where n.p + d <= 0
        den = sign * eq[:, axis]  # (P,)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = num / den
        first = np.where(den < 0, t, -np.inf).max(axis=1)
        last = np.where(den > 0, t, np.inf).min(axis=1)
        outside = ((den == 0) & (num < 0)).any(axis=1)
        hit = (first <= last) & ~outside & (last >= 0)
        enter[i, rays[hit]] = np.maximum(first[hit], 0.0)
        leave[i, rays[hit]] = last[hit]
    return enter, leave


def _probe_origins(bounds: np.ndarray, axis: int, sign: float, n: int, margin: float) -> tuple:
    """Ray origins (n*n, 3) on a grid ``margin`` outside the bounding box, and the direction, for one view."""
    lo, hi = bounds
    a, b = [k for k in range(3) if k != axis]
    ua = lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n
    ub = lo[b] + (np.arange(n) + 0.5) * (hi[b] - lo[b]) / n
    ga, gb = np.meshgrid(ua, ub, indexing="ij")
    origins = np.empty((n * n, 3))
    origins[:, a], origins[:, b] = ga.ravel(), gb.ravel()
    origins[:, axis] = lo[axis] - margin if sign > 0 else hi[axis] + margin
    direction = np.zeros(3)
    direction[axis] = sign
    return origins, direction


def _union_length(enter: np.ndarray, leave: np.ndarray) -> np.ndarray:
    """Per ray, the length of the union of the [enter, leave] intervals (inputs (H, R), inf where missed)."""
    order = np.argsort(enter, axis=0)
    start = np.take_along_axis(enter, order, axis=0)
    end = np.take_along_axis(leave, order, axis=0)
    hit = np.isfinite(start) & (end > start)
    start, end = np.where(hit, start, 0.0), np.where(hit, end, 0.0)
    reach = np.maximum.accumulate(end, axis=0)
    before = np.vstack([np.full((1, start.shape[1]), -np.inf), reach[:-1]])
    return np.maximum(0.0, end - np.maximum(start, before)).sum(axis=0)


def _axis_depths(mesh: trimesh.Trimesh, bounds: np.ndarray, axis: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nearest and farthest mesh coordinate along ``axis`` on the rays of the n x n grid of
    :func:`_probe_origins` (NaN where a ray misses), by rasterising the triangles onto the grid."""
    a, b = [k for k in range(3) if k != axis]
    lo, hi = bounds
    step = np.array([(hi[a] - lo[a]) / n, (hi[b] - lo[b]) / n])
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    uv = (tri[:, :, [a, b]] - np.array([lo[a], lo[b]])) / step - 0.5  # grid units: cell i is centred at i
    first = np.clip(np.ceil(uv.min(axis=1)), 0, n - 1).astype(np.int64)
    last = np.clip(np.floor(uv.max(axis=1)), 0, n - 1).astype(np.int64)
    span = np.maximum(last - first + 1, 0)
    span[(uv.max(axis=1) < 0).any(axis=1) | (uv.min(axis=1) > n - 1).any(axis=1)] = 0
    count = span[:, 0] * span[:, 1]
    near = np.full(n * n, np.inf)
    far = np.full(n * n, -np.inf)
    chunk = np.cumsum(count) // 2_000_000  # bounded memory for meshes of large triangles
    for c in np.unique(chunk):
        sel = np.flatnonzero((chunk == c) & (count > 0))
        t = np.repeat(sel, count[sel])
        k = np.arange(len(t)) - np.repeat(np.cumsum(count[sel]) - count[sel], count[sel])
        i = first[t, 0] + k // span[t, 1]
        j = first[t, 1] + k % span[t, 1]
        p0, p1, p2 = uv[t, 0], uv[t, 1], uv[t, 2]
        e1, e2 = p1 - p0, p2 - p0
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        q = np.column_stack([i, j]) - p0
        flat = det == 0  # a triangle seen edge-on covers no cell
        det[flat] = 1.0
        w1 = (q[:, 0] * e2[:, 1] - q[:, 1] * e2[:, 0]) / det
        w2 = (e1[:, 0] * q[:, 1] - e1[:, 1] * q[:, 0]) / det
        inside = ~flat & (w1 >= -1e-9) & (w2 >= -1e-9) & (w1 + w2 <= 1 + 1e-9)
        z = tri[t, 0, axis] + w1 * (tri[t, 1, axis] - tri[t, 0, axis]) + w2 * (tri[t, 2, axis] - tri[t, 0, axis])
        cell = (i * n + j)[inside]
        np.minimum.at(near, cell, z[inside])
        np.maximum.at(far, cell, z[inside])
    missed = ~np.isfinite(near)
    near[missed], far[missed] = np.nan, np.nan
    return near, far


def hull_quality(mesh: trimesh.Trimesh, hulls: tuple[np.ndarray, ...]) -> HullQuality:
    """Volume ratio, excess (filled cavities) and missing surface of ``hulls`` against ``mesh``
    (:class:`HullQuality`)."""
    equations = [ConvexHull(h).equations for h in hulls]
    bounds = np.asarray(mesh.bounds, dtype=np.float64)
    extents = np.ptp(bounds, axis=0)
    margin = 0.01 * float(extents.max())
    excess = 0.0
    for axis in range(3):
        near, far = _axis_depths(mesh, bounds, axis, _PROBE_GRID)
        length = margin + float(extents[axis])
        for sign, depth in ((1.0, near - (bounds[0, axis] - margin)), (-1.0, (bounds[1, axis] + margin) - far)):
            t_mesh = np.where(np.isnan(depth), length, np.minimum(depth, length))
            # a view the mesh fills (a box seen face-on) has next to no free space: a sliver of hull
            # in it is no filled cavity, so the free space counts as at least 2% of the view's box
            free = max(float((t_mesh - margin).sum()), _MIN_FREE * len(t_mesh) * float(extents[axis]))
            origins, _ = _probe_origins(bounds, axis, sign, _PROBE_GRID, margin)
            enter, leave = _hull_intervals(hulls, equations, origins, axis, sign)
            front = _union_length(np.clip(enter, margin, t_mesh), np.clip(leave, margin, t_mesh))
            excess = max(excess, float(front.sum()) / free)
    points = trimesh.sample.sample_surface(mesh, _SURFACE_SAMPLES, seed=0)[0]
    outside = np.full(len(points), np.inf)
    for eq in equations:
        outside = np.minimum(outside, (points @ eq[:, :3].T + eq[:, 3]).max(axis=1))
    missing = float((outside > _COVER_TOL * float(extents.max())).mean())
    volume_ratio = None
    if mesh.is_volume:
        n = 2 * _PROBE_GRID
        origins, _ = _probe_origins(bounds, 2, 1.0, n, margin)
        enter, leave = _hull_intervals(hulls, equations, origins, 2, 1.0)
        cell = float(extents[0] * extents[1]) / (n * n)
        volume_ratio = float(_union_length(enter, leave).sum() * cell / mesh.volume)
    return HullQuality(n_hulls=len(hulls), volume_ratio=volume_ratio, excess=excess, missing=missing)


def _guard_score(quality: HullQuality) -> float:
    """How far the worse of excess and missing is toward its limit (> 1: the guard fails)."""
    return max(quality.excess / MAX_EXCESS, quality.missing / MAX_MISSING)


def _guarded_hulls(
    mesh: trimesh.Trimesh, decomposition: DecompositionConfig | None
) -> tuple[tuple[np.ndarray, ...], list[str]]:
    """Hulls of ``mesh`` and notes on their quality.

    Hulls made with :func:`decomposition_for`'s faster settings that fail the guard (more than
    :data:`MAX_EXCESS` excess or :data:`MAX_MISSING` missing, :class:`HullQuality`) are made again
    with the defaults on at most :data:`~rail_mj.mesh.decomposition.DENSE_FACES` faces
    (:data:`~rail_mj.mesh.decomposition.GUARD_DECOMPOSITION`), and the better set is kept; hulls that still fail are
    noted.
    """
    config = decomposition or decomposition_for(mesh)
    hulls = decompose(mesh, config)
    quality = hull_quality(mesh, hulls)
    notes = []
    if _guard_score(quality) > 1.0 and decomposition is None and config != DecompositionConfig():
        try:
            again = decompose(mesh, GUARD_DECOMPOSITION)
        except DecompositionTimeout as late:  # the faster settings' hulls are kept, with why
            notes.append(f"hulls not made again with the default settings: {late}")
        else:
            again_quality = hull_quality(mesh, again)
            if _guard_score(again_quality) < _guard_score(quality):
                notes.append(
                    f"hulls made again with the default settings on at most {GUARD_DECOMPOSITION.max_faces:,} faces: "
                    f"the faster ones' excess {quality.excess:.2f}, missing {quality.missing:.2f}"
                )
                hulls, quality = again, again_quality
    if _guard_score(quality) > 1.0:
        notes.append(
            f"hull quality below the guard ({quality.n_hulls} hulls): they fill {quality.excess:.0%} of the free space "
            f"seen along an axis (limit {MAX_EXCESS:.0%}: a cavity may be closed) and leave {quality.missing:.0%} "
            f"of the surface uncovered (limit {MAX_MISSING:.0%}); pass a DecompositionConfig with a lower threshold"
        )
    return hulls, notes
