"""The scan's views: the wrist camera, the view plan, each view reached by IK, depth and segmentation renders.

The camera sits on the Panda's hand; at each view the depth image is rendered and the robot's own pixels are
masked out by a segmentation render.

The view plan knows only the workspace (where objects are put down in front of the robot), not the object:
look-at targets sit above the workspace centre on two rings, so an unseen object is scanned the same way. One
more view then looks straight down onto the top of what the rings fused (``ScanConfig.top_view``). Each view is
reached by IK (``rail_mj.robot.control.solve_ik``) for a site at the camera; the arm is placed at the solution and
the camera pose used for fusion is read from the model. An unreachable view, or one where the arm would touch the
table or the object, is skipped and named in ``ScanResult.skipped``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh
from scipy.spatial import cKDTree  # pyright: ignore[reportAttributeAccessIssue]  # compiled, no stub

from rail_mj.core.types import RailObject, StablePose
from rail_mj.robot.arm import HOME_QPOS, ArmIndex
from rail_mj.robot.control import RobotConfig, solve_ik
from rail_mj.robot.model import load_panda_spec
from rail_mj.robot.scan.config import ScanConfig, ScanError

__all__ = [
    "CAMERA_NAME",
    "CAMERA_SITE",
    "CAMERA_POS_IN_HAND",
    "ScanView",
    "ScanScene",
    "PlannedView",
    "true_mesh_world",
    "build_scan_scene",
    "plan_views",
    "plan_top_view",
    "reach_views",
    "render_views",
    "noisy_depth",
]

#: The wrist camera (an MJCF camera on the hand body) and the IK site at the same frame.
CAMERA_NAME = "wrist_camera"
CAMERA_SITE = "wrist_camera_site"
#: Where the camera sits on the hand, hand frame: beside the hand (off the fingers' slide axis y), a little
#: behind the fingertips, looking along the gripper (+z of the hand), like a depth camera on a Panda mount.
CAMERA_POS_IN_HAND = (0.07, 0.0, 0.04)
#: MuJoCo cameras look along their -z with +y up: this turns the camera's -z onto the hand's +z.
_CAMERA_QUAT_IN_HAND = (0.0, 1.0, 0.0, 0.0)
_ROBOT_ROOT = "link0"


@dataclass(frozen=True)
class ScanView:
    """One planned camera pose and, once reached, the pose the model puts the camera in."""

    index: int
    eye: np.ndarray  # (3,) planned camera position, world
    target: np.ndarray  # (3,) look-at point, world
    cam_to_world: np.ndarray  # (4, 4) camera pose read from the model (OpenCV axes: x right, y down, z forward)
    qpos: np.ndarray  # (7,) arm joints


@dataclass(frozen=True)
class ScanScene:
    """The compiled scan scene: Panda with the wrist camera, table, floor and the object's true mesh."""

    model: mujoco.MjModel
    arm: ArmIndex
    camera: int
    robot_geoms: np.ndarray  # (ngeom,) bool: geoms of the Panda (masked out of the depth)
    table_top: float  # m
    workspace_centre: np.ndarray  # (3,) on the table top, m


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
        steps = ([elevation + config.elevation_step * i
                  for i in range(int((85.0 - elevation) // config.elevation_step) + 1)]
                 if config.elevation_step else [elevation])
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


def reach_views(scene: ScanScene, planned: list[PlannedView], surface: np.ndarray, config: ScanConfig
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
                # an int: comparing to the enum goes element by element in Python
                is_geom = kind == int(mujoco.mjtObj.mjOBJ_GEOM)
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
