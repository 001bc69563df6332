"""Closing the fused scan into a closed volume: the volume closing, the fan closing, the closed manifold.

The volume closing meshes the space no view saw through by marching cubes; the fan closing fans the bottom outline
and the holes and has manifold3d repair them; either ends in a closed manifold simplified to ``max_faces``.

The scan is made a closed volume: the space no view saw through, on a voxel grid over the object's box (so a cavity
a view saw into stays open and a wall stays solid), meshed by marching cubes (scikit-image), standing on the table,
decimated to at most ``ScanConfig.max_faces`` faces. An open mesh would be remeshed by CoACD (which thickened a
scanned cup's walls and left gaps that leaked). Where that fails, the fused mesh's outline on the table and its
holes are fanned and manifold3d repairs it (``ScanConfig.closing``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
import trimesh
from scipy.spatial import cKDTree  # pyright: ignore[reportAttributeAccessIssue]  # compiled, no stub

from rail_mj.robot.scan.config import ScanConfig, load_open3d
from rail_mj.robot.scan.views import ScanView

__all__ = [
    "cap_bottom",
    "watertight",
    "solid_closing",
    "off_surface",
]

#: Closed pieces of the scan under this fraction of the largest piece's volume are specks, dropped.
_MIN_PIECE_VOLUME = 0.002
#: How far apart two touching sheets of the watertight scan are moved, m (far above vertex-merge tolerances).
_TOUCH_SEPARATION = 1e-5
#: How far (grid steps) the volume closing's surface reaches round a grid point the fused surface passes through:
#: enough to keep a wall thinner than the grid, little enough not to thicken the walls the grid resolves.
_WALL_FILL = 0.1


def cap_bottom(mesh: trimesh.Trimesh, table_z: float, band: float) -> trimesh.Trimesh:
    """Close the mesh's lowest open outline down to the table: the object stands there.

    Its underside is never seen. The boundary loops within ``band`` of the lowest boundary vertex are the
    bottom outline: near the table their vertices are snapped onto it; higher up (an overhang hid the base)
    a skirt goes straight down to the table, the unseen space under the outline counted as the object's.
    Each loop is then closed with a fan from its centroid, wound against the adjacent faces so the normals
    stay consistent.
    """
    boundary = _boundary_edges(mesh)
    if len(boundary) < 3:
        return mesh
    vertices = np.asarray(mesh.vertices).copy()
    lowest = float(vertices[boundary, 2].min())
    boundary = boundary[(vertices[boundary, 2] < lowest + band).all(axis=1)]
    if len(boundary) < 3:
        return mesh
    faces = [np.asarray(mesh.faces)]
    ring = np.unique(boundary)
    if lowest < table_z + band:
        vertices[ring, 2] = table_z
    else:
        # a copy of each outline vertex on the table, and two triangles per outline edge down to it
        below = np.full(len(vertices), -1)
        below[ring] = np.arange(len(vertices), len(vertices) + len(ring))
        vertices = np.vstack([vertices, np.column_stack([vertices[ring, :2], np.full(len(ring), table_z)])])
        a, b = boundary[:, 0], boundary[:, 1]
        faces += [np.column_stack([b, a, below[a]]), np.column_stack([b, below[a], below[b]])]
        boundary = np.column_stack([below[a], below[b]])
    vertices, fans = _fan_fill(vertices, boundary)
    return trimesh.Trimesh(vertices, np.vstack(faces + fans), process=True)


def _boundary_edges(mesh: trimesh.Trimesh) -> np.ndarray:
    """The edges used by one face only, directed as in that face: (E, 2)."""
    edges = mesh.edges  # (3F, 2) directed, in face order
    key = edges.min(axis=1).astype(np.int64) * len(mesh.vertices) + edges.max(axis=1)  # one integer per edge
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    return edges[counts[inverse] == 1]


def _fan_fill(vertices: np.ndarray, boundary: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Close each loop of ``boundary`` (directed edges) with a fan from its centroid, wound against the faces
    beside it so the normals stay consistent: the new vertices and the new faces."""
    faces = []
    for component in trimesh.graph.connected_components(boundary, min_len=3):
        loop = boundary[np.isin(boundary, component).all(axis=1)]
        centre = len(vertices)
        vertices = np.vstack([vertices, vertices[np.unique(loop)].mean(axis=0)])
        faces.append(np.column_stack([loop[:, 1], loop[:, 0], np.full(len(loop), centre)]))
    return vertices, faces


def watertight(mesh: trimesh.Trimesh, config: ScanConfig) -> tuple[trimesh.Trimesh, list[str]]:
    """Every remaining hole closed, then a closed manifold simplified to at most ``config.max_faces`` faces.

    The fallback of the volume closing (``closing="fans"``, or where that fails). The holes left after the
    bottom closure are small (a rim thinner than the TSDF's truncation, carved edges): a fan closes each.
    manifold3d then repairs what the fans leave non-manifold and simplifies (:func:`_simplified`). A mesh
    manifold3d refuses is returned as it came (open: what a fan would add is not on the object), and a note
    says so.
    """
    import manifold3d  # noqa: PLC0415 - a core dependency (trimesh's boolean engine), only needed here

    vertices, faces = _fan_fill(np.asarray(mesh.vertices), _boundary_edges(mesh))
    closed = trimesh.Trimesh(vertices, np.vstack([np.asarray(mesh.faces), *faces]), process=True)
    try:
        solid = manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(closed.vertices, dtype=np.float32),
                                                    tri_verts=np.asarray(closed.faces, dtype=np.uint32)))
    except (RuntimeError, ValueError) as exc:
        return mesh, [f"the scanned mesh could not be made a closed manifold ({exc}); its holes are left open"]
    if solid.status() != manifold3d.Error.NoError:
        return mesh, [f"the scanned mesh could not be made a closed manifold ({solid.status().name}); holes "
                        "left open"]
    result, notes = _simplified(solid, config)
    if result is None:
        return mesh, notes + ["holes left open"]
    # a fan across a large outline can make the wrong piece the kept one: the result must lie on the scan
    samples = trimesh.sample.sample_surface(closed, 4000, seed=config.seed)[0]
    # unsigned: the sign (ray tests, ~70% of signed_distance's time) plays no part in the mean distance
    off = float(np.mean(trimesh.proximity.closest_point(result, samples)[1]))
    if off > config.voxel_size:
        return mesh, [f"the watertight scan strays {1000 * off:.1f} mm (mean) from the fused surface; holes "
                        "left open"]
    return result, notes


def _simplified(solid, config: ScanConfig, simplify: bool = True) -> tuple[trimesh.Trimesh | None, list[str]]:
    """A closed manifold (manifold3d) simplified to at most ``config.max_faces`` faces, specks dropped, as a
    mesh that stays closed through the loader's vertex merge; ``None`` with a note when it does not.

    The tolerance bounds how far any surface moves, so a wall thicker than twice the tolerance keeps its
    cavity (quadric decimation has no such bound). It starts at ``simplify_tolerance`` voxels and grows by
    25% while the faces are over ``max_faces``, up to 2 voxels.
    """
    import manifold3d  # noqa: PLC0415

    tolerance = config.simplify_tolerance * config.voxel_size
    if simplify and tolerance > 0:
        solid = solid.simplify(tolerance)
    while solid.num_tri() > config.max_faces and tolerance < 2 * config.voxel_size:
        tolerance = max(1.25 * tolerance, 0.05 * config.voxel_size)
        solid = solid.simplify(tolerance)
    # pieces wound inside out (a fan across a sliver) or too small to matter (a speck the crop kept) go
    pieces = solid.decompose()
    largest = max((piece.volume() for piece in pieces), default=0.0)
    kept = [piece for piece in pieces if piece.volume() > _MIN_PIECE_VOLUME * largest]
    if largest <= 0.0 or not kept:  # simplified away, or every piece inside out
        return None, ["the simplified scan keeps no piece with a volume"]
    solid = manifold3d.Manifold.batch_boolean(kept, manifold3d.OpType.Add) if len(kept) > 1 else kept[0]
    out = solid.to_mesh()
    vertices = _separate_touching(np.asarray(out.vert_properties[:, :3], dtype=np.float64),
                                  np.asarray(out.tri_verts, dtype=np.int64))
    result = trimesh.Trimesh(vertices, np.asarray(out.tri_verts, dtype=np.int64), process=False)
    notes = []
    if len(kept) < len(pieces):
        notes.append(f"{len(pieces) - len(kept)} of {len(pieces)} closed pieces dropped (inside out, or under "
                     f"{_MIN_PIECE_VOLUME:.1%} of the largest's volume)")
    if len(result.faces) > config.max_faces:
        notes.append(f"the watertight scan has {len(result.faces):,} faces, over max_faces {config.max_faces:,} "
                     f"at the largest simplification tolerance ({1000 * tolerance:.2f} mm)")
    # the loader merges vertices by position and drops degenerate faces: what it gets must still be closed
    check = result.copy()
    check.merge_vertices()
    check.update_faces(check.nondegenerate_faces() & check.unique_faces())
    if not check.is_volume:
        return None, ["the simplified scan is not a closed volume once its vertices are merged"]
    return result, notes


def solid_closing(fused: trimesh.Trimesh, depths: list[np.ndarray], views: list[ScanView], config: ScanConfig,
                   lo: np.ndarray, hi: np.ndarray, table_z: float) -> tuple[trimesh.Trimesh | None, list[str]]:
    """The scan as the boundary of the space no view saw through: a closed manifold by construction.

    On a grid of ``solid_voxel`` × the voxel size over the object's box (from the crop's floor above the
    table), each point's free-ness is the largest, over the views, of how far in front of the seen surface it
    lies along that view's ray (its pixel's return; a lost pixel tells nothing). Space some view saw through
    is outside; everything else - the walls, and the inside no view reached - is solid, so an open cavity a
    view saw into stays open and a hole no view saw through is closed. The surface lies ``solid_offset``
    grid steps outside the free space; a wall thinner than the grid (its points all just in front of one
    face or the other) is kept by making the grid points the fused surface passes through solid
    (:data:`_WALL_FILL`). Solid pieces the fused surface does not touch (unseen pockets in the box) go; the
    grid is padded with free space, so marching cubes closes it, and the base is put on the table. ``None``
    with a note when the mesh is not a closed manifold.
    """
    import manifold3d  # noqa: PLC0415 - a core dependency (trimesh's boolean engine), only needed here
    from scipy.ndimage import label  # noqa: PLC0415
    from skimage.measure import marching_cubes  # noqa: PLC0415 - part of the [scan] extra

    floor = table_z + config.plane_distance
    origin = np.array([lo[0], lo[1], floor])
    box = np.asarray(hi) - origin
    step = max(config.solid_voxel * config.voxel_size, float(np.prod(box) / config.solid_max_points) ** (1 / 3))
    shape = tuple(int(n) for n in np.ceil(box / step).astype(int) + 1)
    axes = [(origin[i] + step * np.arange(shape[i])).astype(np.float32) for i in range(3)]
    clip = np.float32(2 * step)  # only the band near the surface matters to marching cubes
    free = np.full(shape, -clip, dtype=np.float32)
    fx, fy, cx, cy = config.intrinsics()
    for depth, view in zip(depths, views, strict=True):
        world_to_cam = np.linalg.inv(view.cam_to_world).astype(np.float32)
        rot, shift = world_to_cam[:3, :3], world_to_cam[:3, 3]
        # camera coordinates of the grid points, by broadcasting the axes (no (N, 3) array of points)
        pc = [rot[r, 0] * axes[0][:, None, None] + rot[r, 1] * axes[1][None, :, None]
              + rot[r, 2] * axes[2][None, None, :] + shift[r] for r in range(3)]
        z = np.maximum(pc[2], 1e-6)
        u = np.rint(fx * pc[0] / z + cx).astype(np.int32)
        v = np.rint(fy * pc[1] / z + cy).astype(np.int32)
        inside = (pc[2] > 1e-6) & (u >= 0) & (u < config.width) & (v >= 0) & (v < config.height)
        ui, vi = u[inside], v[inside]
        ahead = np.where(depth[vi, ui] > 0, depth[vi, ui] - z[inside] - 2 * config.depth_noise * z[inside], -clip)
        free[inside] = np.maximum(free[inside], np.clip(ahead, -clip, clip))
    solid = np.float32(config.solid_offset * step) - free  # > 0: solid
    samples, _ = trimesh.sample.sample_surface_even(fused, max(1000, int(4 * fused.area / step ** 2)),
                                                    seed=config.seed)
    index = np.rint((np.asarray(samples) - origin) / step).astype(int)
    index = index[np.all((index >= 0) & (index < shape), axis=1)]
    flat = np.ravel_multi_index(index.T, shape)
    solid.flat[flat] = np.maximum(solid.flat[flat], np.float32(_WALL_FILL * step))
    pieces, n_pieces = cast(tuple[np.ndarray, int], label(solid > 0))  # without output=: (labels, count)
    touched = np.bincount(pieces.flat[flat], minlength=n_pieces + 1) > 0
    sizes = np.bincount(pieces.ravel(), minlength=n_pieces + 1)
    touched[0] = False
    keep = touched & (sizes >= _MIN_PIECE_VOLUME * sizes[touched].max(initial=0))
    if not keep.any():
        return None, ["the volume closing found no solid on the fused surface"]
    solid[~keep[pieces]] = -clip
    vertices, faces, _, _ = marching_cubes(np.pad(solid, 1, constant_values=-clip), level=0.0,
                                           spacing=(step, step, step))
    vertices = vertices + (origin - step)
    # the base: the padding under the crop's floor closed the footprint there; it stands on the table
    vertices[vertices[:, 2] < floor, 2] = table_z
    if trimesh.Trimesh(vertices, faces, process=False).volume < 0:
        faces = faces[:, ::-1]  # marching cubes winds by the field's gradient: outward normals wanted
    # the grid's staircase is fine and flat: quadrics decimate it (manifold3d's simplification leaves
    # collinear slivers there, which the loader drops, opening the mesh); manifold3d then checks it is closed
    o3d = load_open3d()
    dense = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(faces))
    coarse = dense.simplify_quadric_decimation(config.max_faces)
    coarse.remove_degenerate_triangles()
    coarse.remove_unreferenced_vertices()
    vertices, faces = np.asarray(coarse.vertices), np.asarray(coarse.triangles)
    try:
        closed = manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(vertices, dtype=np.float32),
                                                     tri_verts=np.asarray(faces, dtype=np.uint32)))
    except (RuntimeError, ValueError) as exc:
        return None, [f"the volume closing's mesh is not a manifold ({exc})"]
    if closed.status() != manifold3d.Error.NoError:
        return None, [f"the volume closing's mesh is not a manifold ({closed.status().name})"]
    return _simplified(closed, config, simplify=False)


def _separate_touching(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Move apart the vertices manifold3d keeps distinct at one position (where two sheets touch).

    A loader that merges vertices by position (``rail_mj.mesh.repair_mesh``) would join them again into a
    non-manifold edge or vertex, and the mesh would no longer be closed. Each copy moves
    :data:`_TOUCH_SEPARATION` towards the centroid of its own neighbours, which lie on its own sheet.
    """
    _, inverse, counts = np.unique(np.round(vertices, 8), axis=0, return_inverse=True, return_counts=True)
    shared = np.flatnonzero(counts[inverse.ravel()] > 1)
    if len(shared) == 0:
        return vertices
    edges = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    total = np.zeros_like(vertices)
    np.add.at(total, edges[:, 0], vertices[edges[:, 1]])
    degree = np.bincount(edges[:, 0], minlength=len(vertices))
    out = vertices.copy()
    step = total[shared] / np.maximum(degree[shared], 1)[:, None] - vertices[shared]
    norm = np.linalg.norm(step, axis=1, keepdims=True)
    out[shared] += _TOUCH_SEPARATION * step / np.maximum(norm, 1e-12)
    return out


def off_surface(meshes: Sequence[trimesh.Trimesh], fused: trimesh.Trimesh, config: ScanConfig) -> list[float]:
    """Mean distance from each mesh's surface to the fused surface, m: what a closing added away from the scan."""
    target = trimesh.sample.sample_surface(fused, 20000, seed=config.seed)[0]
    tree = cKDTree(np.asarray(target))
    return [float(tree.query(np.asarray(trimesh.sample.sample_surface(m, 4000, seed=config.seed + 1)[0]))[0].mean())
            for m in meshes]
