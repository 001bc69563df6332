"""A simulated wrist-camera scan: the Panda moves a hand-mounted depth camera around the object, the depth
images are fused into a TSDF (Open3D), the table plane is removed, the largest cluster is the object, and
its surface is extracted as a mesh in the world frame (metres, z up), resting where the object stands.

This is the paper's real-robot perception (12 wrist-camera poses, TSDF fusion, the object cropped from the
scene cloud). The scene is the executor's (``rail_mj.robot.executor.build_scene``): the object stands in a
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
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Literal

import mujoco
import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from rail_mj.core.errors import ConfigError, RobotError
from rail_mj.core.types import RailObject, StablePose
from rail_mj.robot.arm import HOME_QPOS, ArmIndex
from rail_mj.robot.control import RobotConfig, solve_ik
from rail_mj.robot.model import load_panda_spec

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

#: The wrist camera (an MJCF camera on the hand body) and the IK site at the same frame.
CAMERA_NAME = "wrist_camera"
CAMERA_SITE = "wrist_camera_site"
#: Where the camera sits on the hand, hand frame: beside the hand (off the fingers' slide axis y), a little
#: behind the fingertips, looking along the gripper (+z of the hand), like a depth camera on a Panda mount.
CAMERA_POS_IN_HAND = (0.07, 0.0, 0.04)
#: MuJoCo cameras look along their -z with +y up: this turns the camera's -z onto the hand's +z.
_CAMERA_QUAT_IN_HAND = (0.0, 1.0, 0.0, 0.0)
INSTALL_HINT = "pip install -e '.[scan]'  (installs open3d-cpu)"
#: Mesh formats :func:`save_scan` writes; all are formats :func:`rail_mj.mesh.objects.load_mesh` reads.
MESH_FORMATS = (".obj", ".ply", ".stl", ".off", ".glb")
_ROBOT_ROOT = "link0"
#: Voxels per block edge of the TSDF grid; the fused box reaches this far below the table top, m.
_BLOCK_RESOLUTION = 8
_BELOW_TABLE = 0.05
#: A fan-closed scan is weighed against the volume closing when more than this fraction of its surface lies more
#: than _FAN_MARGIN voxels in front of what some view saw (its own surface never does: carving removed that).
_FAN_SEEN_THROUGH = 0.03
_FAN_MARGIN = 2.0
#: Closed pieces of the scan under this fraction of the largest piece's volume are specks, dropped.
_MIN_PIECE_VOLUME = 0.002
#: How far apart two touching sheets of the watertight scan are moved, m (far above vertex-merge tolerances).
_TOUCH_SEPARATION = 1e-5
#: How far (grid steps) the volume closing's surface reaches round a grid point the fused surface passes through:
#: enough to keep a wall thinner than the grid, little enough not to thicken the walls the grid resolves.
_WALL_FILL = 0.1


class ScanError(RobotError):
    """A scan could not be made: open3d missing, too few reachable views, or nothing seen."""


class ScanConfig(BaseModel):
    """How the wrist-camera scan is made and fused (SI units, angles in degrees)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    n_views: int = Field(12, ge=1, le=64, description="planned camera poses")
    min_views: int = Field(6, ge=1, description="fewest reachable views a scan needs")
    width: int = Field(320, ge=16, le=2048, description="depth image width, px")
    height: int = Field(240, ge=16, le=2048, description="depth image height, px")
    fovy: float = Field(58.0, gt=5, lt=150, description="vertical field of view (a RealSense D435's depth: 58)")
    distance: float = Field(0.33, gt=0.05, le=1.5, description="camera to look-at target, m")
    elevations: tuple[float, ...] = Field((35.0, 60.0), min_length=1,
                                          description="view elevations above the table, cycled over the views")
    top_view: bool = Field(True, description="after the planned views, one more straight down onto the top of "
                           "what they fused: the only view that sees the bottom of a deep, narrow cavity")
    elevation_step: float = Field(10.0, ge=0, description="fallback: how much steeper to try an unreachable view")
    fallback_distance: float = Field(0.8, gt=0.3, le=1.0,
                                     description="fallback: the closer distance tried last, × distance")
    arm_clearance: float = Field(0.01, ge=0, description="closest the arm may come to the object at a view, m")
    target_height: float = Field(0.07, ge=0, description="look-at target above the table top, m")
    workspace_half: tuple[float, float, float] = Field(
        (0.2, 0.2, 0.35), description="the fused region: half x, half y and height above the table, m")
    depth_min: float = Field(0.07, gt=0, description="the sensor's nearest valid depth, m")
    depth_max: float = Field(1.2, gt=0, description="farthest depth fused, m")
    voxel_size: float = Field(0.0025, ge=0.0005, le=0.02, description="TSDF voxel edge, m")
    sdf_trunc: float = Field(4.0, ge=1.0, le=10.0, description="TSDF truncation, in voxels")
    min_observations: int = Field(1, ge=1, description="fewest views that must have fused a voxel of the surface")
    depth_noise: float = Field(0.0, ge=0, le=0.05,
                               description="Gaussian depth noise, standard deviation per metre of depth")
    dropout: float = Field(0.0, ge=0, lt=1, description="fraction of valid pixels lost at random")
    edge_dropout: float = Field(0.0, ge=0, le=1,
                                description="chance a pixel next to a depth discontinuity is lost")
    edge_jump: float = Field(0.01, gt=0, description="depth step between neighbours counted as an edge, m")
    plane_distance: float = Field(0.004, gt=0, description="RANSAC inlier distance for the table plane, m")
    cluster_eps: float = Field(0.01, gt=0, description="DBSCAN neighbourhood radius, m")
    carve: bool = Field(True, description="remove surface a view saw through (the TSDF's fattened edges)")
    close_bottom: bool = Field(True, description="cap the open outline where the object meets the table")
    watertight: bool = Field(True, description="close every other hole and make the mesh a closed manifold "
                             "(manifold3d), simplified within simplify_tolerance")
    simplify_tolerance: float = Field(0.3, ge=0, le=2.0,
                                      description="surface the simplification may move, in voxels; it grows "
                                      "(up to 2 voxels) only while the mesh has over max_faces faces")
    max_faces: int = Field(5_000, ge=500, le=20_000, description="most faces of the watertight mesh")
    closing: Literal["auto", "volume", "fans"] = Field(
        "auto", description="how the watertight step closes the scan: 'fans' fans the fused mesh's holes and "
        "repairs it (may stay open); 'volume' meshes the space no view saw through (always closed, but unseen "
        "space - a deep cavity's bottom, under a table top - comes out solid); 'auto': fans, else volume")
    solid_voxel: float = Field(1.0, ge=0.25, le=1.0, description="the volume closing's grid step, × voxel_size")
    solid_max_points: int = Field(600_000, ge=10_000, description="the volume closing's grid has at most this "
                                  "many points: past it the step grows. Marching cubes' faces grow with the grid, "
                                  "and their quadric decimation (Open3D, which holds the GIL) took 5 of the 0.35 m "
                                  "trash bin's 10 s at 0.9M points")
    solid_offset: float = Field(0.0, ge=0.0, le=1.0,
                                description="how far the volume closing's surface lies outside the free space, "
                                "in grid steps")
    chamfer_points: int = Field(20000, ge=100, description="points sampled on each mesh for the Chamfer distance")
    seed: int = 0
    robot: RobotConfig = Field(default_factory=RobotConfig, description="table and object placement")

    @model_validator(mode="after")
    def _check(self) -> "ScanConfig":
        if self.min_views > self.n_views:
            raise ValueError(f"min_views ({self.min_views}) must be at most n_views ({self.n_views})")
        if self.depth_min >= self.depth_max:
            raise ValueError(f"depth_min ({self.depth_min}) must be below depth_max ({self.depth_max})")
        if any(not 5.0 <= e <= 90.0 for e in self.elevations):
            raise ValueError(f"elevations must lie in [5, 90] degrees, got {self.elevations}")
        return self

    @property
    def fovx(self) -> float:
        """Horizontal field of view, degrees (square pixels)."""
        return math.degrees(2 * math.atan(math.tan(math.radians(self.fovy) / 2) * self.width / self.height))

    def intrinsics(self) -> tuple[float, float, float, float]:
        """Pinhole (fx, fy, cx, cy) of the rendered images, px."""
        f = self.height / 2 / math.tan(math.radians(self.fovy) / 2)
        return f, f, (self.width - 1) / 2, (self.height - 1) / 2


@dataclass(frozen=True)
class ScanView:
    """One planned camera pose and, once reached, the pose the model puts the camera in."""

    index: int
    eye: np.ndarray  # (3,) planned camera position, world
    target: np.ndarray  # (3,) look-at point, world
    cam_to_world: np.ndarray  # (4, 4) camera pose read from the model (OpenCV axes: x right, y down, z forward)
    qpos: np.ndarray  # (7,) arm joints


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


@dataclass(frozen=True)
class ScanScene:
    """The compiled scan scene: Panda with the wrist camera, table, floor and the object's true mesh."""

    model: mujoco.MjModel
    arm: ArmIndex
    camera: int
    robot_geoms: np.ndarray  # (ngeom,) bool: geoms of the Panda (masked out of the depth)
    table_top: float  # m
    workspace_centre: np.ndarray  # (3,) on the table top, m


def _preload_libusb() -> bool:
    """Load the libusb that the ``libusb-package`` wheel ships; whether there was one to load.

    open3d-cpu's library links ``libusb-1.0.so.0`` (for RealSense cameras), which a bare machine lacks; once a
    library with that soname is loaded, the dynamic loader uses it for open3d too, so no system package is needed.
    """
    import ctypes  # noqa: PLC0415

    try:
        import libusb_package  # noqa: PLC0415 - part of the [scan] extra
    except ImportError:
        return False
    path = libusb_package.get_library_path()
    if path is None:
        return False
    ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)
    return True


def load_open3d() -> ModuleType:
    """The open3d module, or :class:`ScanError` naming the extra to install."""
    try:
        import open3d  # noqa: PLC0415 - an optional extra, imported only when a scan runs
    except (ImportError, OSError) as first:
        if "libusb" not in str(first) or not _preload_libusb():
            raise ScanError(f"the scan needs open3d, an optional extra: {INSTALL_HINT} ({first})") from first
        for name in [m for m in sys.modules if m == "open3d" or m.startswith("open3d.")]:
            del sys.modules[name]  # the failed import left half-initialised modules behind
        try:
            import open3d  # noqa: PLC0415
        except (ImportError, OSError) as exc:
            raise ScanError(f"the scan needs open3d, an optional extra: {INSTALL_HINT} ({exc})") from exc
    return open3d


def true_mesh_world(obj: RailObject, pose: StablePose, robot: RobotConfig | None = None) -> trimesh.Trimesh:
    """The object's mesh placed as the robot scene places it: stable pose, shifted onto the table."""
    robot = robot or RobotConfig()
    transform = np.eye(4)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(pose.quat, dtype=np.float64))
    transform[:3, :3] = rot.reshape(3, 3)
    transform[:3, 3] = np.asarray(pose.pos, dtype=float) + np.array([*robot.object_xy, robot.table_height])
    mesh = trimesh.Trimesh(np.asarray(obj.mesh.vertices, dtype=np.float64), np.asarray(obj.mesh.faces), process=False)
    mesh.apply_transform(transform)
    return mesh


def build_scan_scene(obj: RailObject, pose: StablePose, config: ScanConfig) -> ScanScene:
    """Compile the Panda (collision meshes as its visible body) with the wrist camera, the table and the object.

    The table and floor are the executor's (same size and place); the object is its true mesh, render-only,
    placed like the executor places it (stable pose + the table's offset).
    """
    robot = config.robot
    spec = load_panda_spec(visual=False)
    hand = spec.body("hand")
    hand.add_camera(name=CAMERA_NAME, pos=list(CAMERA_POS_IN_HAND), quat=list(_CAMERA_QUAT_IN_HAND),
                    fovy=config.fovy)
    hand.add_site(name=CAMERA_SITE, pos=list(CAMERA_POS_IN_HAND), quat=list(_CAMERA_QUAT_IN_HAND))
    tx, ty = robot.object_xy
    th = robot.table_height
    sx, sy = robot.table_half_size
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05])
    spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx, sy, th / 2], pos=[tx, ty, th / 2])
    world = true_mesh_world(obj, pose, robot)
    mesh = spec.add_mesh(name="scan_object")
    mesh.uservert = np.asarray(world.vertices, dtype=np.float64).ravel().tolist()
    mesh.userface = np.asarray(world.faces, dtype=np.int32).ravel().tolist()
    # the shell inertia is defined for open and thin meshes too; a static render-only geom needs no volume
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    spec.worldbody.add_geom(name="scan_object", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="scan_object",
                            contype=0, conaffinity=0, group=0)
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, config.width)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, config.height)
    try:
        model = spec.compile()
    except Exception as exc:  # MuJoCo compile errors (ValueError or mujoco.FatalError)
        raise ScanError(f"scan scene for {obj.name!r} does not compile: {exc}") from exc
    # the object mesh is render-only; collisions of the arm are checked against it separately
    root = model.body_rootid[model.geom_bodyid]
    robot_geoms = root == model.body(_ROBOT_ROOT).id
    # near and far clip in metres (MuJoCo scales them by the model's extent)
    model.vis.map.znear = 0.01 / model.stat.extent
    model.vis.map.zfar = 2 * config.depth_max / model.stat.extent
    return ScanScene(
        model=model,
        arm=ArmIndex.of(model, CAMERA_SITE),
        camera=model.camera(CAMERA_NAME).id,
        robot_geoms=robot_geoms,
        table_top=th,
        workspace_centre=np.array([tx, ty, th]),
    )


def _look_at_quat(eye: np.ndarray, target: np.ndarray, roll: float) -> np.ndarray:
    """MuJoCo camera orientation (looks along -z, +y up) at ``eye`` facing ``target``, rolled about the view axis."""
    forward = target - eye
    forward = forward / np.linalg.norm(forward)
    helper = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    right = np.cross(forward, helper)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    c, s = math.cos(roll), math.sin(roll)
    right, up = c * right + s * up, -s * right + c * up
    mat = np.stack([right, up, -forward], axis=1)  # columns: camera x, y, z in the world
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, mat.ravel())
    return quat


@dataclass(frozen=True)
class PlannedView:
    """One planned view: the look-at target and the camera directions to try, first choice first."""

    index: int
    target: np.ndarray  # (3,) world
    eyes: tuple[np.ndarray, ...]  # (3,) camera positions, world: the planned one, then the fallbacks


def _eye(target: np.ndarray, distance: float, azimuth: float, elevation: float) -> np.ndarray:
    return target + distance * np.array([math.cos(elevation) * math.cos(azimuth),
                                         math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])


def plan_views(config: ScanConfig, workspace_centre: np.ndarray) -> list[PlannedView]:
    """The views: azimuths evenly spaced round the workspace centre, elevations cycled, one target.

    The first view faces the object from the robot's side; the order goes round the object so the arm
    moves between neighbouring poses. The far side is at the edge of the Panda's reach, so each view
    carries fallbacks: steeper (``elevation_step`` at a time, up to 85 degrees), then closer
    (``fallback_distance`` × the distance) at the same elevations.
    """
    target = np.asarray(workspace_centre, dtype=float) + np.array([0.0, 0.0, config.target_height])
    views = []
    for k in range(config.n_views):
        azimuth = math.pi + 2 * math.pi * k / config.n_views  # pi: between the robot base and the object
        elevation = config.elevations[k % len(config.elevations)]
        steps = [elevation + config.elevation_step * i
                 for i in range(int((85.0 - elevation) // config.elevation_step) + 1)] if config.elevation_step else [elevation]
        eyes = [_eye(target, d, azimuth, math.radians(e))
                for d in (config.distance, config.fallback_distance * config.distance) for e in steps]
        views.append(PlannedView(index=k, target=target, eyes=tuple(eyes)))
    return views


def plan_top_view(volume, config: ScanConfig, table_top: float, index: int) -> PlannedView | None:
    """A view straight down onto the centre of what the fused views saw above the table, ``distance`` above its
    top (then the fallback distance); None when they saw nothing there.

    The ring views look in at 35-60 degrees: the bottom of a deep cavity (a waste-paper bin's) stays unseen, and
    the volume closing fills what no view saw through. Only a camera above the opening sees down into it. The view
    is not fused into the TSDF: looking straight down on a thin board (a doll's table top), the projective TSDF
    counts a truncation's depth behind it as inside and thickens it (Chamfer 2.4 -> 2.7 mm); what it adds is the
    space it sees through.
    """
    points = volume.extract_point_cloud(weight_threshold=config.min_observations - 0.5).point.positions.numpy()
    points = points[points[:, 2] > table_top + 2 * config.plane_distance]
    if len(points) < 50:
        return None
    lo, hi = np.percentile(points, [1.0, 99.0], axis=0)  # a speck of noise does not move the view
    target = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, float(points[:, 2].max())])
    eyes = tuple(target + np.array([0.0, 0.0, d])
                 for d in (config.distance, config.fallback_distance * config.distance))
    return PlannedView(index=index, target=target, eyes=eyes)


#: Rolls about the viewing axis tried in turn until the IK reaches the pose: the image's roll is free.
_ROLLS = (0.0, math.pi / 2, -math.pi / 2, math.pi)


def _touches_scene(scene: ScanScene, data: mujoco.MjData, surface: np.ndarray, tree: cKDTree,
                   clearance: float) -> str:
    """Why the arm at ``data.qpos`` may not be there ('' if it may): a contact with the table or floor, or a
    robot geom within ``clearance`` of the object's surface (sampled)."""
    model = scene.model
    mujoco.mj_forward(model, data)
    for i in range(data.ncon):
        g1, g2 = data.contact.geom[i]
        if scene.robot_geoms[g1] != scene.robot_geoms[g2]:
            other = g2 if scene.robot_geoms[g1] else g1
            return f"the arm touches {model.geom(other).name or 'the scene'}"
    # the object is render-only, so test the robot's geoms' bounding spheres against its surface points
    robot = np.flatnonzero(scene.robot_geoms)
    centres = data.geom_xpos[robot]
    radii = model.geom_rbound[robot]
    dist, _ = tree.query(centres)
    close = dist < radii + clearance
    if close.any():
        # bounding spheres are loose: check the close geoms' oriented boxes point-wise
        for g in robot[close]:
            idx = tree.query_ball_point(data.geom_xpos[g], model.geom_rbound[g] + clearance)
            if not idx:
                continue
            pts = surface[idx] - data.geom_xpos[g]
            local = pts @ data.geom_xmat[g].reshape(3, 3)
            aabb = model.geom_aabb[g]
            if np.any(np.all(np.abs(local - aabb[:3]) <= aabb[3:] + clearance, axis=1)):
                return "the arm would touch the object"
    return ""


def _reach_views(scene: ScanScene, planned: list[PlannedView], surface: np.ndarray, config: ScanConfig
                 ) -> tuple[list[ScanView], list[str], list[str]]:
    """Reach each planned view by IK (its fallbacks in turn); returns the views, the skipped and the moved ones."""
    model = scene.model
    data = mujoco.MjData(model)
    tree = cKDTree(surface)
    robot = config.robot
    views: list[ScanView] = []
    skipped: list[str] = []
    moved: list[str] = []
    q_prev = HOME_QPOS.copy()
    for plan in planned:
        why = "the IK did not reach it"
        best = math.inf
        reached = None
        for n_eye, eye in enumerate(plan.eyes):
            for roll in _ROLLS:
                quat = _look_at_quat(eye, plan.target, roll)
                # from the last view's joints first: the arm moves to a neighbouring pose
                for q0 in (q_prev, HOME_QPOS):
                    q, res_p, res_r = solve_ik(model, data, scene.arm, eye, quat, q0)
                    best = min(best, res_p)
                    if res_p > robot.ik_pos_tol or res_r > robot.ik_rot_tol:
                        continue
                    data.qpos[:] = 0
                    data.qpos[scene.arm.qpos] = q
                    blocked = _touches_scene(scene, data, surface, tree, config.arm_clearance)
                    if blocked:
                        why = blocked
                        continue
                    reached = q
                    break
                if reached is not None:
                    break
            if reached is not None:
                if n_eye:
                    moved.append(f"view {plan.index} moved to its fallback {n_eye} "
                                 f"(eye {np.round(eye, 3).tolist()}): the planned pose is out of reach")
                break
        if reached is None:
            skipped.append(f"view {plan.index} (eye {np.round(plan.eyes[0], 3).tolist()}, {len(plan.eyes)} "
                           f"poses tried): {why}"
                           + (f" (best position residual {1000 * best:.0f} mm)" if why.startswith("the IK") else ""))
            continue
        # the arm is placed at the solution; the camera pose is the model's, not the planned one
        data.qpos[:] = 0
        data.qpos[scene.arm.qpos] = reached
        mujoco.mj_kinematics(model, data)
        cam = np.eye(4)
        cam[:3, :3] = data.cam_xmat[scene.camera].reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])  # MuJoCo -> OpenCV
        cam[:3, 3] = data.cam_xpos[scene.camera]
        views.append(ScanView(index=plan.index, eye=eye, target=plan.target, cam_to_world=cam, qpos=reached.copy()))
        q_prev = reached
    return views, skipped, moved


def render_views(scene: ScanScene, views: list[ScanView], config: ScanConfig) -> list[np.ndarray]:
    """Depth images (m, 0 = no return) from the wrist camera at each view, the robot's own pixels masked out."""
    model = scene.model
    data = mujoco.MjData(model)
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[0] = option.geomgroup[3] = 1  # the scene, and the Panda's collision meshes
    depths = []
    # software GL: shadows and multisampling cost time and change no depth
    model.light_castshadow[:] = False
    model.vis.quality.offsamples = 0
    try:
        renderer = mujoco.Renderer(model, config.height, config.width)
    except Exception as exc:  # no GL context (set MUJOCO_GL=egl or osmesa headless)
        raise ScanError(f"cannot open a MuJoCo renderer ({exc}); headless, set MUJOCO_GL=egl") from exc
    with renderer:
        # one pass per mode over all views: switching modes costs more than the render itself in software GL
        for mode in ("depth", "segmentation"):
            getattr(renderer, f"enable_{mode}_rendering")()
            for i, view in enumerate(views):
                data.qpos[:] = 0
                data.qpos[scene.arm.qpos] = view.qpos
                mujoco.mj_kinematics(model, data)
                mujoco.mj_camlight(model, data)
                renderer.update_scene(data, camera=scene.camera, scene_option=option)
                image = renderer.render()
                if mode == "depth":
                    depths.append(image.astype(np.float32))
                    continue
                geom, kind = image[..., 0], image[..., 1]
                is_geom = kind == int(mujoco.mjtObj.mjOBJ_GEOM)  # an int: comparing to the enum goes element by element in Python
                robot = np.zeros(geom.shape, dtype=bool)
                robot[is_geom] = scene.robot_geoms[geom[is_geom]]
                depth = depths[i]
                depth[robot | ~is_geom] = 0.0
                depth[(depth < config.depth_min) | (depth > config.depth_max)] = 0.0
            getattr(renderer, f"disable_{mode}_rendering")()
    return depths


def noisy_depth(depth: np.ndarray, config: ScanConfig, rng: np.random.Generator) -> np.ndarray:
    """The sensor model: distance-proportional Gaussian noise, random pixel dropout, dropout at depth edges."""
    out = depth.astype(np.float32).copy()
    valid = out > 0
    if config.edge_dropout > 0:
        # a step to a neighbour (or to a missing return) larger than edge_jump marks both pixels as an edge
        pad = np.pad(out, 1, mode="edge")
        edge = np.zeros(out.shape, dtype=bool)
        for dy, dx in ((0, 1), (2, 1), (1, 0), (1, 2)):
            edge |= np.abs(pad[dy:dy + out.shape[0], dx:dx + out.shape[1]] - out) > config.edge_jump
        out[valid & edge & (rng.random(out.shape) < config.edge_dropout)] = 0.0
    if config.dropout > 0:
        out[rng.random(out.shape) < config.dropout] = 0.0
    if config.depth_noise > 0:
        keep = out > 0
        out[keep] += (rng.standard_normal(int(keep.sum())) * config.depth_noise * out[keep]).astype(np.float32)
    return out


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


def _cap_bottom(mesh: trimesh.Trimesh, table_z: float, band: float) -> trimesh.Trimesh:
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


def _watertight(mesh: trimesh.Trimesh, config: ScanConfig) -> tuple[trimesh.Trimesh, list[str]]:
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
    samples, _ = trimesh.sample.sample_surface(closed, 4000, seed=config.seed)
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


def _solid_closing(fused: trimesh.Trimesh, depths: list[np.ndarray], views: list[ScanView], config: ScanConfig,
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
    pieces, n_pieces = label(solid > 0)
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

    A loader that merges vertices by position (``rail_mj.mesh.objects.repair_mesh``) would join them again into a
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


def _off_surface(meshes: Sequence[trimesh.Trimesh], fused: trimesh.Trimesh, config: ScanConfig) -> list[float]:
    """Mean distance from each mesh's surface to the fused surface, m: what a closing added away from the scan."""
    target, _ = trimesh.sample.sample_surface(fused, 20000, seed=config.seed)
    tree = cKDTree(np.asarray(target))
    return [float(tree.query(np.asarray(trimesh.sample.sample_surface(m, 4000, seed=config.seed + 1)[0]))[0].mean())
            for m in meshes]


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


def _extract(volume, depths: list[np.ndarray], views: list[ScanView], config: ScanConfig, table_top: float,
             workspace_centre: np.ndarray, n_fused: int | None = None) -> tuple[trimesh.Trimesh, float, list[str]]:
    """Table plane (RANSAC) out, largest cluster (DBSCAN) in, the TSDF mesh cropped to the cluster's box.

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
    cloud.points = o3d.utility.Vector3dVector(_sorted_rows(np.asarray(cloud.points)))
    plane, inliers = _ransac_plane(np.asarray(cloud.points), config.plane_distance, 200,
                                   np.random.default_rng(config.seed))
    a, b, c, d = plane
    table_z = table_top
    if abs(c) > 0.95 * math.sqrt(a * a + b * b + c * c):
        # a horizontal plane: the table; its height under the workspace centre
        x, y = workspace_centre[:2]
        table_z = float(-(a * x + b * y + d) / c)
    else:
        notes.append(f"the largest plane is not horizontal (normal {np.round(plane[:3], 3).tolist()}); "
                     f"the table is taken at its known height {table_top:.3f} m")
        inliers = []
    pts = np.asarray(cloud.points)
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
        solid, more = _solid_closing(fused, depths, views, config, lo, hi, table_z)
        if solid is not None:
            return solid, table_z, notes + more
        notes += [f"{note}; the fused mesh's holes are fanned instead" for note in more]
    if config.close_bottom:
        mesh = _cap_bottom(mesh, table_z, config.plane_distance + 2 * config.voxel_size)
    if config.watertight:
        capped = mesh
        mesh, more = _watertight(capped, config)
        if mesh is not capped and config.closing == "auto":
            # a fan across a wide outline (a plate's rim, its well's surface lost) lies where views saw through;
            # then the closing that adds less surface away from what was fused wins
            samples, _ = trimesh.sample.sample_surface(mesh, 4000, seed=config.seed)
            through = float(np.mean(_seen_through(np.asarray(samples), depths, views, config, _FAN_MARGIN)))
            if through > _FAN_SEEN_THROUGH:
                solid, also = _solid_closing(fused, depths, views, config, lo, hi, table_z)
                if solid is not None:
                    off_solid, off_fans = _off_surface([solid, mesh], fused, config)
                    if off_solid < off_fans:
                        return solid, table_z, notes + more + [
                            f"{through:.0%} of the fan-closed surface lies where views saw through; the volume "
                            "closing strays less from the fused surface and is used instead"] + also
        if mesh is capped and config.closing == "auto":
            # the fans left it open: the volume closing is closed by construction (unseen space counts as solid)
            solid, also = _solid_closing(fused, depths, views, config, lo, hi, table_z)
            if solid is not None:
                return solid, table_z, notes + [f"{note}; the volume closing is used instead" for note in more] + also
            more += also
        notes += more
    return mesh, table_z, notes


def chamfer_distance(a: trimesh.Trimesh, b: trimesh.Trimesh, n: int = 20000, seed: int = 0) -> float:
    """Symmetric Chamfer distance: the mean of (a→b mean nearest distance) and (b→a), surface samples, m."""
    pa, _ = trimesh.sample.sample_surface(a, n, seed=seed)
    pb, _ = trimesh.sample.sample_surface(b, n, seed=seed + 1)
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
    surface, _ = trimesh.sample.sample_surface(world, 4000, seed=config.seed)
    views, skipped, moved = _reach_views(scene, plan_views(config, scene.workspace_centre), np.asarray(surface),
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
        more, not_reached, fallback = _reach_views(scene, [top], np.asarray(surface), config)
        skipped, moved = skipped + not_reached, moved + fallback
        seconds["plan"] += time.perf_counter() - t0
        if more:  # for the closings only (plan_top_view and _extract say why)
            t0 = time.perf_counter()
            depths = depths + [noisy_depth(d, config, rng) for d in render_views(scene, more, config)]
            views = views + more
            seconds["render"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    mesh, table_z, notes = _extract(volume, depths, views, config, scene.table_top, scene.workspace_centre, n_fused)
    seconds["extract"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    chamfer = chamfer_distance(mesh, world, config.chamfer_points, config.seed)
    seconds["chamfer"] = time.perf_counter() - t0
    return ScanResult(mesh=mesh, chamfer_m=chamfer, seconds=seconds, n_views=len(views), skipped=tuple(skipped),
                      table_z=table_z, views=tuple(views), notes=tuple(moved + notes))


def save_scan(result: ScanResult | trimesh.Trimesh, path: str | Path) -> Path:
    """Write the scanned mesh (metres, z up, world frame) where ``rail_mj.mesh.objects.load_object(path)`` reads it."""
    path = Path(path)
    if path.suffix.lower() not in MESH_FORMATS:
        raise ConfigError(f"cannot save a scan as {path.suffix or 'no suffix'!r}; use one of {', '.join(MESH_FORMATS)}")
    mesh = result.mesh if isinstance(result, ScanResult) else result
    if len(mesh.faces) == 0:
        raise ScanError(f"the scanned mesh is empty; nothing written to {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)
    return path
