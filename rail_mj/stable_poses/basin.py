"""The spill basin of a resting pose: where water poured into the object stands, from surface samples."""

from __future__ import annotations

import heapq

import numpy as np
import scipy.ndimage
import trimesh

from rail_mj.core.types import Basin, RailObject

__all__ = ["surface_samples", "spill_basin"]

#: Points sampled on the mesh surface for :func:`spill_basin` (fixed seed: the same poses give the same level).
_SAMPLES = 60000
#: Cells across the larger side of the height map of :func:`spill_basin` (a cell holds a dozen samples of a flat top).
_GRID = 48
#: A basin is at least this deep (fraction of the object's height) where it is deepest.
_MIN_BASIN = 0.1


def surface_samples(obj: RailObject) -> np.ndarray:
    # trimesh types the result as a union over its sample_color flag; without it there are 2 items
    points, _ = trimesh.sample.sample_surface(obj.mesh, _SAMPLES, seed=0)  # pyright: ignore[reportAssignmentType]
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
    # scipy's stub types label's result as an int or a tuple; without an output array it is (labels, count)
    wet, _ = scipy.ndimage.label(depth >= 0.5 * depth[deepest])  # pyright: ignore[reportGeneralTypeIssues]
    cells = np.argwhere(wet == wet[deepest])
    centre = lo[:2] + (cells.mean(axis=0) - 0.5) * cell
    # the water surface at the spill level, where it stands over 5% of the deepest: a divider as high as the
    # walls (to a sample's noise) parts two basins
    surface, _ = scipy.ndimage.label(depth > 0.05 * depth[deepest])  # pyright: ignore[reportGeneralTypeIssues]
    span = np.ptp(np.argwhere(surface == surface[deepest]), axis=0) + 1
    return Basin(rim=float(level[deepest]), opening=centre, length=float(span.max() * cell),
                 floor=float(height[deepest]))
