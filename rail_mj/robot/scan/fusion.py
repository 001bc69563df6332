"""Fusion of the depth images into the object's mesh: TSDF, table plane, largest cluster, crop, carving.

The depth images are fused into a TSDF (Open3D), the table plane (RANSAC) is removed, the largest cluster
(DBSCAN) is the object, the TSDF mesh is cropped to it, and the result is closed
(:mod:`rail_mj.robot.scan.closing`).

After fusion, surface that some view saw through is carved away (the projective TSDF fattens convex edges). The top
view counts for the closings (what views saw through), not for the TSDF or the carving.
"""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree  # pyright: ignore[reportAttributeAccessIssue]  # compiled, no stub

from rail_mj.robot.scan.closing import cap_bottom, off_surface, solid_closing, watertight
from rail_mj.robot.scan.config import ScanConfig, ScanError, load_open3d
from rail_mj.robot.scan.views import ScanView

__all__ = [
    "fuse_views",
    "extract",
]

#: Voxels per block edge of the TSDF grid; the fused box reaches this far below the table top, m.
_BLOCK_RESOLUTION = 8
_BELOW_TABLE = 0.05
#: A fan-closed scan is weighed against the volume closing when more than this fraction of its surface lies more
#: than _FAN_MARGIN voxels in front of what some view saw (its own surface never does: carving removed that).
_FAN_SEEN_THROUGH = 0.03
_FAN_MARGIN = 2.0


def fuse_views(depths: list[np.ndarray], views: list[ScanView], config: ScanConfig, workspace_centre: np.ndarray):
    """Integrate the depth images into a TSDF voxel-block grid (Open3D's ``VoxelBlockGrid``); returns the grid.

    Pixels whose points fall outside the workspace box are dropped first: the fused region is where objects
    are put down, not the whole room, and its size bounds the grid's blocks.
    """
    o3d = load_open3d()
    o3c = o3d.core
    fx, fy, cx, cy = config.intrinsics()
    # Open3D's integration truncates the projected pixel coordinate (static_cast<int>) instead of rounding it:
    # half a pixel on the principal point makes that the nearest pixel (without it the table fuses 0.5 mm low)
    intrinsic = o3c.Tensor(np.array([[fx, 0, cx + 0.5], [0, fy, cy + 0.5], [0, 0, 1]]), o3c.float64)
    half = np.asarray(config.workspace_half, dtype=float)
    lo = workspace_centre + np.array([-half[0], -half[1], -_BELOW_TABLE])
    hi = workspace_centre + half
    block = _BLOCK_RESOLUTION * config.voxel_size
    blocks = int(np.prod(np.ceil((hi - lo) / block) + 2))
    grid = o3d.t.geometry.VoxelBlockGrid(
        attr_names=("tsdf", "weight"), attr_dtypes=(o3c.float32, o3c.float32), attr_channels=((1), (1)),
        voxel_size=config.voxel_size, block_resolution=_BLOCK_RESOLUTION, block_count=blocks,
        device=o3c.Device("CPU:0"))
    u, v = np.meshgrid(np.arange(config.width), np.arange(config.height))
    rays = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones(u.shape)], axis=-1)
    for depth, view in zip(depths, views, strict=True):
        pts = (rays * depth[..., None]) @ view.cam_to_world[:3, :3].T + view.cam_to_world[:3, 3]
        inside = np.all((pts >= lo) & (pts <= hi), axis=-1)
        image = o3d.t.geometry.Image(o3c.Tensor(np.where(inside, depth, 0.0).astype(np.float32)))
        extrinsic = o3c.Tensor(np.linalg.inv(view.cam_to_world), o3c.float64)
        coords = grid.compute_unique_block_coordinates(image, intrinsic, extrinsic, 1.0, config.depth_max,
                                                       config.sdf_trunc)
        grid.integrate(coords, image, intrinsic, extrinsic, 1.0, config.depth_max, config.sdf_trunc)
    return grid


def _seen_through(points: np.ndarray, depths: list[np.ndarray], views: list[ScanView], config: ScanConfig,
                  margin_voxels: float) -> np.ndarray:
    """(N,) bool: some view has a return at the point's pixel, and every valid return in the 3 × 3
    neighbourhood (so a silhouette's pixel steps never count) lies beyond it by more than the margin:
    ``margin_voxels`` voxels plus two noise deviations. Such a point is in space a camera saw through."""
    from scipy.ndimage import minimum_filter  # noqa: PLC0415 - scipy's image module, only here

    fx, fy, cx, cy = config.intrinsics()
    free = np.zeros(len(points), dtype=bool)
    for depth, view in zip(depths, views, strict=True):
        world_to_cam = np.linalg.inv(view.cam_to_world)
        pc = points @ world_to_cam[:3, :3].T + world_to_cam[:3, 3]
        z = pc[:, 2]
        ahead = z > 1e-6
        u = np.full(len(z), -1)
        v = np.full(len(z), -1)
        u[ahead] = np.rint(fx * pc[ahead, 0] / z[ahead] + cx).astype(int)
        v[ahead] = np.rint(fy * pc[ahead, 1] / z[ahead] + cy).astype(int)
        inside = ahead & (u >= 0) & (u < config.width) & (v >= 0) & (v < config.height)
        # lost pixels (0) are unknown, not far: the neighbourhood's nearest valid return decides
        seen = minimum_filter(np.where(depth > 0, depth, np.inf), size=3, mode="nearest")
        ui, vi, zi = u[inside], v[inside], z[inside]
        margin = margin_voxels * config.voxel_size + 2 * config.depth_noise * zi
        through = (depth[vi, ui] > 0) & (seen[vi, ui] > zi + margin)
        free[np.flatnonzero(inside)[through]] = True
    return free


def _carve(mesh: trimesh.Trimesh, depths: list[np.ndarray], views: list[ScanView], config: ScanConfig
           ) -> tuple[trimesh.Trimesh, int]:
    """Remove surface that some view saw through: free-space carving of the TSDF's edge artefacts.

    The projective TSDF fattens convex edges: voxels just past an edge, hidden behind the top face from one
    side, are fused as inside. A camera on the other side sees the table behind them. A vertex goes when
    :func:`_seen_through` with a margin of half a voxel.
    """
    free = _seen_through(np.asarray(mesh.vertices), depths, views, config, 0.5)
    if not free.any():
        return mesh, 0
    keep = ~free[np.asarray(mesh.faces)].any(axis=1)
    if not keep.any():
        return mesh, 0
    carved = trimesh.Trimesh(mesh.vertices, np.asarray(mesh.faces)[keep], process=False)
    carved.remove_unreferenced_vertices()
    return carved, int(free.sum())


def _sorted_rows(points: np.ndarray) -> np.ndarray:
    """The points in lexicographic (x, y, z) order.

    Open3D's voxel-block grid hands out its surface in the order its threads fill a hash map, which changes
    from run to run; the voxel averaging, the RANSAC's draws and every later step depend on that order.
    """
    return points[np.lexsort(points.T[::-1])]


def _ransac_plane(points: np.ndarray, distance: float, iterations: int, rng: np.random.Generator
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The plane (a, b, c, d) with the most points within ``distance`` over ``iterations`` random triples, refitted
    by least squares to them, and its inliers' indices.

    Open3D's ``segment_plane`` runs its iterations on threads that share one generator, so which triples it
    tries, and the table height, change from run to run even with its seed set.
    """
    triples = points[rng.integers(0, len(points), size=(iterations, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    length = np.linalg.norm(normals, axis=1)
    normals = normals[length > 1e-12] / length[length > 1e-12, None]  # collinear triples define no plane
    offsets = -np.einsum("ij,ij->i", normals, triples[length > 1e-12, 0])
    counts = (np.abs(points @ normals.T + offsets) < distance).sum(axis=0)
    best = int(np.argmax(counts))
    near = points[np.abs(points @ normals[best] + offsets[best]) < distance]
    centre = near.mean(axis=0)
    normal = np.linalg.svd(near - centre, full_matrices=False)[2][-1]
    inliers = np.flatnonzero(np.abs((points - centre) @ normal) < distance)
    return np.append(normal, -normal @ centre), inliers


def _canonical_mesh(o3d: ModuleType, mesh):
    """The TSDF's triangle mesh (a tensor mesh) as a legacy mesh in an order that does not depend on threads:
    vertices sorted as :func:`_sorted_rows`, each triangle started at its smallest index (winding kept), the
    triangles sorted."""
    vertices = mesh.vertex.positions.numpy().astype(np.float64)
    triangles = mesh.triangle.indices.numpy().astype(np.int64)
    order = np.lexsort(vertices.T[::-1])
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    triangles = rank[triangles]
    first = np.argmin(triangles, axis=1)
    triangles = np.take_along_axis(triangles, (first[:, None] + np.arange(3)) % 3, axis=1)
    triangles = triangles[np.lexsort(triangles.T[::-1])]
    return o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices[order]),
                                     o3d.utility.Vector3iVector(triangles.astype(np.int32)))


def extract(volume, depths: list[np.ndarray], views: list[ScanView], config: ScanConfig, table_top: float,
             workspace_centre: np.ndarray, n_fused: int | None = None) -> tuple[trimesh.Trimesh, float, list[str]]:
    """Table plane (RANSAC; a level plane above the table's known height is a dish's floor, and the known height is
    used) out, largest cluster (DBSCAN) in, the TSDF mesh cropped to the cluster's box.

    Open3D keeps voxels whose weight (views fused) is strictly above its threshold: hence ``- 0.5``. The first
    ``n_fused`` views (default all) are the TSDF's and carve it; the rest (the top view) count for the closings
    only: carving with a view straight down on a box's top opened holes at its edges that the fans could not close,
    and the volume closing came out a voxel wider on each side (noisy test box: 5.2 mm instead of 3.3 mm).
    """
    o3d = load_open3d()
    notes: list[str] = []
    points = _sorted_rows(volume.extract_point_cloud(weight_threshold=config.min_observations - 0.5).point.positions
                          .numpy().astype(np.float64))
    if len(points) < 50:
        raise ScanError(f"the scan saw nothing: {len(points)} surface points in the workspace "
                        f"(half size {config.workspace_half} m at {np.round(workspace_centre, 3).tolist()})")
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)).voxel_down_sample(2 * config.voxel_size)
    pts = _sorted_rows(np.asarray(cloud.points))
    cloud.points = o3d.utility.Vector3dVector(pts)
    plane, inliers = _ransac_plane(pts, config.plane_distance, 200, np.random.default_rng(config.seed))
    a, b, c, d = plane
    table_z = table_top
    x, y = workspace_centre[:2]
    level = abs(c) > 0.95 * math.sqrt(a * a + b * b + c * c)
    plane_z = float(-(a * x + b * y + d) / c) if level else math.nan  # its height under the workspace centre
    if level and plane_z > table_top + config.plane_distance / 2:
        # the largest flat face in view can be a dish's floor standing on the table (a 40 cm tray's, against the
        # strip of table the workspace shows beside it); the table's own plane lies within 0.1 mm of its height
        notes.append(f"the largest level plane lies {1000 * (plane_z - table_top):.1f} mm above the table's known "
                     f"height: it is on the table (a dish's floor); the table is taken at its known height")
        inliers = []  # the height cut below takes the table's points out
    elif level:
        table_z = plane_z  # the table
    else:
        notes.append(f"the largest plane is not horizontal (normal {np.round(plane[:3], 3).tolist()}); "
                     f"the table is taken at its known height {table_top:.3f} m")
        inliers = []
    keep = np.ones(len(pts), dtype=bool)
    keep[np.asarray(inliers, dtype=int)] = False
    keep &= pts[:, 2] > table_z + config.plane_distance
    rest = cloud.select_by_index(np.flatnonzero(keep).tolist())
    if len(rest.points) < 20:
        raise ScanError(f"the scan saw only the table: {len(rest.points)} points above the plane at "
                        f"z = {table_z:.3f} m; is the object in the workspace at "
                        f"{np.round(workspace_centre[:2], 3).tolist()}?")
    labels = np.asarray(rest.cluster_dbscan(eps=config.cluster_eps, min_points=10))
    if labels.max() < 0:
        raise ScanError(f"no cluster of at least 10 points within {config.cluster_eps} m above the table")
    sizes = np.bincount(labels[labels >= 0])
    largest = int(np.argmax(sizes))
    obj_pts = np.asarray(rest.points)[labels == largest]
    if len(sizes) > 1:
        notes.append(f"{len(sizes)} clusters above the table; kept the largest ({sizes[largest]} of "
                     f"{int(sizes.sum())} points)")
    margin = 2 * config.voxel_size
    lo = obj_pts.min(axis=0) - margin
    hi = obj_pts.max(axis=0) + margin
    lo[2] = table_z + config.plane_distance
    half = np.asarray(config.workspace_half)
    ws_lo = workspace_centre[:2] - half[:2] + margin
    ws_hi = workspace_centre[:2] + half[:2] - margin
    if np.any(lo[:2] < ws_lo) or np.any(hi[:2] > ws_hi) or hi[2] > table_z + half[2] - margin:
        notes.append("the object reaches the edge of the fused workspace: it may be cut off")
    o3d_mesh = _canonical_mesh(o3d, volume.extract_triangle_mesh(weight_threshold=config.min_observations - 0.5))
    o3d_mesh = o3d_mesh.crop(o3d.geometry.AxisAlignedBoundingBox(lo, hi))
    if len(o3d_mesh.triangles) == 0:
        raise ScanError("the TSDF holds no surface inside the object's cluster box")
    # TSDF fragments (a stray speck of noise, a sliver of table) go: keep the pieces near the cluster's points
    triangles = np.asarray(o3d_mesh.triangles)
    n_vertices = len(o3d_mesh.vertices)
    # pieces = connected components of the vertex graph (scipy's is ~100x faster than Open3D's triangle clusters)
    graph = coo_matrix((np.ones(3 * len(triangles)), (triangles.ravel(), np.roll(triangles, 1, axis=1).ravel())),
                       shape=(n_vertices, n_vertices))
    _, vertex_label = connected_components(graph, directed=False)
    labels = vertex_label[triangles[:, 0]]
    vertex_dist, _ = cKDTree(obj_pts).query(np.asarray(o3d_mesh.vertices))
    face_dist = vertex_dist[triangles].mean(axis=1)
    mean_dist = np.bincount(labels, face_dist) / np.bincount(labels)
    near = mean_dist < config.cluster_eps
    if not near.any():
        near[np.argmax(np.bincount(labels))] = True
    o3d_mesh.remove_triangles_by_mask(~near[labels])
    o3d_mesh.remove_unreferenced_vertices()
    mesh = trimesh.Trimesh(np.asarray(o3d_mesh.vertices), np.asarray(o3d_mesh.triangles), process=True)
    if config.carve:
        mesh, _ = _carve(mesh, depths[:n_fused], views[:n_fused], config)
    fused = mesh
    if config.watertight and config.closing == "volume":
        solid, more = solid_closing(fused, depths, views, config, lo, hi, table_z)
        if solid is not None:
            return solid, table_z, notes + more
        notes += [f"{note}; the fused mesh's holes are fanned instead" for note in more]
    if config.close_bottom:
        mesh = cap_bottom(mesh, table_z, config.plane_distance + 2 * config.voxel_size)
    if config.watertight:
        capped = mesh
        mesh, more = watertight(capped, config)
        if mesh is not capped and config.closing == "auto":
            # a fan across a wide outline (a plate's rim, its well's surface lost) lies where views saw through;
            # then the closing that adds less surface away from what was fused wins
            samples = trimesh.sample.sample_surface(mesh, 4000, seed=config.seed)[0]
            through = float(np.mean(_seen_through(np.asarray(samples), depths, views, config, _FAN_MARGIN)))
            if through > _FAN_SEEN_THROUGH:
                solid, also = solid_closing(fused, depths, views, config, lo, hi, table_z)
                if solid is not None:
                    off_solid, off_fans = off_surface([solid, mesh], fused, config)
                    if off_solid < off_fans:
                        return solid, table_z, notes + more + [
                            f"{through:.0%} of the fan-closed surface lies where views saw through; the volume "
                            "closing strays less from the fused surface and is used instead"] + also
        if mesh is capped and config.closing == "auto":
            # the fans left it open: the volume closing is closed by construction (unseen space counts as solid)
            solid, also = solid_closing(fused, depths, views, config, lo, hi, table_z)
            if solid is not None:
                return solid, table_z, notes + [f"{note}; the volume closing is used instead" for note in more] + also
            more += also
        notes += more
    return mesh, table_z, notes
