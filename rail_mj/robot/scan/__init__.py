"""The simulated wrist-camera scan of an object on the robot's table: views, fusion, closing, the mesh.

A simulated wrist-camera scan: the Panda moves a hand-mounted depth camera around the object, the depth
images are fused into a TSDF (Open3D), the table plane is removed, the largest cluster is the object, and
its surface is extracted as a mesh in the world frame (metres, z up), resting where the object stands.

This is the paper's real-robot perception (12 wrist-camera poses, TSDF fusion, the object cropped from the
scene cloud). The scene is the executor's (``rail_mj.robot.scene.build_robot_scene``): the object stands in a
stable pose on the table at ``RobotConfig.object_xy``. The camera sees the object's true mesh (a render-only
geom); the robot's links are rendered too (they can occlude) and masked out with a segmentation render.

After fusion, surface that some view saw through is carved away (the projective TSDF fattens convex edges),
and the scan is made a closed volume: the space no view saw through, on a voxel grid over the object's box
(so a cavity a view saw into stays open and a wall stays solid), meshed by marching cubes (scikit-image),
standing on the table, decimated to at most ``ScanConfig.max_faces`` faces. An open mesh would be remeshed
by CoACD (which thickened a scanned cup's walls and left gaps that leaked). Where that fails, the fused
mesh's outline on the table and its holes are fanned and manifold3d repairs it (``ScanConfig.closing``).

The view plan knows only the workspace (where objects are put down in front of the robot), not the object:
look-at targets sit above the workspace centre on two rings, so an unseen object is scanned the same way. One
more view then looks straight down onto the top of what the rings fused (``ScanConfig.top_view``): it sees the
bottom of a deep cavity, and counts for the closings (what views saw through), not for the TSDF or the carving.
Each view is reached by IK (``rail_mj.robot.control.solve_ik``) for a site at the camera; the arm is placed at
the solution and the camera pose used for fusion is read from the model. An unreachable view, or one where
the arm would touch the table or the object, is skipped and named in ``ScanResult.skipped``.

Open3D is the optional extra ``[scan]`` (``pip install -e '.[scan]'``); it is imported only when a scan runs.

The package: :mod:`~rail_mj.robot.scan.config` (ScanConfig, ScanError, loading open3d),
:mod:`~rail_mj.robot.scan.views` (the camera, the view plan, IK, depth and segmentation renders),
:mod:`~rail_mj.robot.scan.fusion` (TSDF fusion, table plane, cluster, crop, carving),
:mod:`~rail_mj.robot.scan.closing` (volume and fan closings, the closed manifold) and
:mod:`~rail_mj.robot.scan.run` (scan_object, ScanResult, save_scan).
"""

from __future__ import annotations

from rail_mj.robot.scan.config import INSTALL_HINT, ScanConfig, ScanError, load_open3d
from rail_mj.robot.scan.fusion import fuse_views
from rail_mj.robot.scan.run import MESH_FORMATS, ScanResult, chamfer_distance, save_scan, scan_object
from rail_mj.robot.scan.views import (
    CAMERA_NAME,
    CAMERA_POS_IN_HAND,
    CAMERA_SITE,
    PlannedView,
    ScanScene,
    ScanView,
    build_scan_scene,
    noisy_depth,
    plan_top_view,
    plan_views,
    render_views,
    true_mesh_world,
)

__all__ = [
    "CAMERA_NAME",
    "CAMERA_SITE",
    "CAMERA_POS_IN_HAND",
    "INSTALL_HINT",
    "MESH_FORMATS",
    "ScanError",
    "ScanConfig",
    "PlannedView",
    "ScanView",
    "ScanResult",
    "ScanScene",
    "build_scan_scene",
    "plan_views",
    "plan_top_view",
    "render_views",
    "noisy_depth",
    "fuse_views",
    "scan_object",
    "load_open3d",
    "chamfer_distance",
    "save_scan",
    "true_mesh_world",
]
