"""Scan-like corruption: what a scanner or an exporter does to a built mesh (noise, holes, open seams, a warped base).

Each takes a mesh in its build frame and a generator of its own (so one corruption does the same to an
object alone or with others) and returns the corrupted mesh and what was done. None of them changes what
the object affords: they model what a scanner or an exporter does to the file, not the object.
"""

from __future__ import annotations

from typing import Callable, cast

import numpy as np
import trimesh

from rail_mj.dataset.shapes.parts import _cm, _u

__all__ = [
    "DENSE_FACES",
    "densify",
    "add_noise",
    "punch_holes",
    "open_seams",
    "uneven_bottom",
    "GEOMETRIC_CORRUPTIONS",
]


#: Face count :func:`densify` aims under (the dataset's cap keeps CoACD fast).
DENSE_FACES = 4500
_ALREADY_DENSE = 2500


def densify(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The same surface split into smaller triangles (<= :data:`DENSE_FACES`), as a scan's would be, so
    noise, holes and seams are local; meshes of over 2,500 faces (revolved ones) are returned as they are."""
    if len(mesh.faces) >= _ALREADY_DENSE:
        return mesh.copy()
    edge = float(np.sqrt(4 * mesh.area / (np.sqrt(3) * 1000)))
    for _ in range(12):
        # trimesh types the result as a union over its return_index flag; without it there are 2 items
        v, f = trimesh.remesh.subdivide_to_size(  # pyright: ignore[reportAssignmentType]
            mesh.vertices, mesh.faces, max_edge=edge, max_iter=20)
        if len(f) <= DENSE_FACES:
            return trimesh.Trimesh(vertices=v, faces=f, process=True)
        edge *= 1.05 * float(np.sqrt(len(f) / (0.9 * DENSE_FACES)))
    return mesh.copy()


def _scan_scale(mesh: trimesh.Trimesh) -> float:
    """Scanner error grows with the object: 1 below 30 cm, proportional above."""
    return max(1.0, float(np.max(mesh.extents)) / 0.3)


def add_noise(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """Vertices moved along their normals by Gaussian noise clipped at 2 sigma (sigma 0.1-0.25 mm below 30 cm)."""
    sigma = _u(rng, 0.0001, 0.00025) * _scan_scale(mesh)
    step = np.clip(rng.normal(0.0, sigma, len(mesh.vertices)), -2 * sigma, 2 * sigma)
    out = trimesh.Trimesh(vertices=mesh.vertices + step[:, None] * mesh.vertex_normals, faces=mesh.faces, process=False)
    return out, f"noise: vertices moved along their normals, sigma {1000 * sigma:.2f} mm"


def punch_holes(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """2-4 missing patches of the surface (Ø 2-5 % of the largest extent), each on one side of a wall only:
    a patch takes the faces near its seed facing the same way, never the opposite face of a thin wall."""
    centres, normals = mesh.triangles_center, mesh.face_normals
    n = int(rng.integers(2, 5))
    radius = _u(rng, 0.01, 0.025) * float(np.max(mesh.extents))
    seeds = rng.choice(len(mesh.faces), size=n, replace=False, p=mesh.area_faces / mesh.area)
    drop = np.zeros(len(mesh.faces), dtype=bool)
    for s in seeds:
        near = np.linalg.norm(centres - centres[s], axis=1) <= radius
        drop |= near & (normals @ normals[s] > 0.5)
        drop[s] = True
    out = trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces[~drop], process=False)
    out.remove_unreferenced_vertices()
    return out, (f"holes: {n} missing surface patches of Ø {_cm(2 * radius)} ({int(drop.sum())} faces), "
                 "none through a wall")


def open_seams(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """The surface cut into 2-4 unwelded shells (the faces nearest each of random seed points), each shifted
    0.2-0.5 mm (more on large objects, at most 1.5 mm), so the seams are open cracks: not watertight."""
    k = int(rng.integers(2, 5))
    centres = mesh.triangles_center
    seeds = centres[rng.choice(len(centres), size=k, replace=False)]
    group = np.argmin(np.linalg.norm(centres[:, None] - seeds[None], axis=-1), axis=1)
    shells, widest = [], 0.0
    for g in range(k):
        faces = mesh.faces[group == g]
        if len(faces) == 0:
            continue
        used, inv = np.unique(faces, return_inverse=True)
        direction = rng.normal(size=3)
        size = min(_u(rng, 0.0002, 0.0005) * _scan_scale(mesh), 0.0015)
        widest = max(widest, size)
        shells.append(trimesh.Trimesh(vertices=mesh.vertices[used] + size * direction / np.linalg.norm(direction),
                                      faces=inv.reshape(-1, 3), process=False))
    out = cast(trimesh.Trimesh, trimesh.util.concatenate(shells))
    return out, f"open shell: {len(shells)} unwelded shells, seams open by up to {1000 * 2 * widest:.1f} mm"


def uneven_bottom(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """The base warped by up to ``a`` (1.5-3 mm below 50 cm, 4-8 mm above: legs of different lengths):
    a tilt plus a dome or dish, fading out over the lowest ``4 a`` (at least 1 cm), so the object rocks."""
    large = float(np.max(mesh.extents)) >= 0.5
    a = _u(rng, 0.004, 0.008) if large else _u(rng, 0.0015, 0.003)
    band = max(4 * a, 0.01)
    v = np.array(mesh.vertices, dtype=np.float64)
    z0 = v[:, 2].min()
    low = v[:, 2] - z0 < band
    centre = v[low, :2].mean(axis=0)
    rel = v[:, :2] - centre
    reach = float(np.max(np.linalg.norm(rel[low], axis=1)))
    phi = _u(rng, 0.0, 2 * np.pi)
    tilt = _u(rng, -1.0, 1.0)
    dome = (1.0 - abs(tilt)) * (1.0 if rng.random() < 0.5 else -1.0)
    f = (tilt * (rel @ np.array([np.cos(phi), np.sin(phi)])) / reach
         + dome * (1.0 - 2.0 * np.sum(rel**2, axis=1) / reach**2))
    fade = np.clip(1.0 - (v[:, 2] - z0) / band, 0.0, 1.0)
    v[:, 2] += a * np.clip(f, -1.0, 1.0) * fade
    out = trimesh.Trimesh(vertices=v, faces=mesh.faces, process=False)
    shape = "dome" if dome > 0 else "dish"
    return out, f"uneven bottom: base warped by up to {1000 * a:.1f} mm (tilt {tilt:+.2f}, {shape} {abs(dome):.2f})"


#: The corruptions that change the mesh, in the order they are applied.
GEOMETRIC_CORRUPTIONS: dict[str, Callable[[trimesh.Trimesh, np.random.Generator], tuple[trimesh.Trimesh, str]]] = {
    "uneven_bottom": uneven_bottom,
    "noise": add_noise,
    "holes": punch_holes,
    "open_shell": open_seams,
}
