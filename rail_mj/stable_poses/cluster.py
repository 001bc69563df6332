"""Clustering of resting ups into poses, and merging the clusters that are one pose rolled about a symmetry axis."""

from __future__ import annotations

import numpy as np

from rail_mj.core.types import RailObject

__all__ = ["CONGRUENT", "cluster_ups", "merge_symmetric"]

#: two resting shapes match when their height signatures differ by less than this fraction of the object size
CONGRUENT = 0.02


def cluster_ups(ups: np.ndarray, tol: float) -> list[np.ndarray]:
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


def merge_symmetric(obj: RailObject, reps: list[np.ndarray], tol: float) -> list[list[int]]:
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
