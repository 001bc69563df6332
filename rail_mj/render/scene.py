"""The drawing scene of a picture and its camera: the object and the agents in MuJoCo, and the view that shows them.

The object is drawn as its CoACD hulls (the shapes the physics used), one shade per hull, or, with
``draw_mesh``, as the original mesh. Agents are always drawn in :data:`AGENT_RGBA`, whatever colour their
fragment gives them, so they stand out from the object. The camera is chosen per picture: of a set of
views around and above the scene, the one that sees most of the agents past the object (rays cast from
points on each agent towards the camera), nearest a three-quarter view from above among equals; a cup's
droplets are seen through its opening. When the chosen view still has an agent behind the object, the
object is drawn translucent and the caption says so. The view is fitted to the object and the agents.

Headless: ``import rail_mj`` sets ``MUJOCO_GL=egl`` unless it is set (MuJoCo reads it at import).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import mujoco
import numpy as np

from rail_mj.core.errors import RailError
from rail_mj.core.geometry import quat_mul, quat_rotate
from rail_mj.core.results import AffordanceResult, PoseInfo
from rail_mj.core.types import AgentSetup, RailObject, StablePose
from rail_mj.mjcf import build_scene
from rail_mj.mjcf.scene import GROUND_GEOM, OBJECT_BODY, agent_body_name, agent_prefix

__all__ = [
    "AGENT_RGBA",
    "GROUND_SQUARE_M",
    "fit_camera",
]

#: Colour every agent is drawn in (RGBA, 0-1): a saturated blue no hull shade comes near.
AGENT_RGBA = (0.05, 0.35, 1.0, 1.0)
#: Side of one ground checker square, m (the caption states it, so sizes can be read off the picture).
GROUND_SQUARE_M = 0.1

_HULL_SHADES = ((0.80, 0.58, 0.36), (0.66, 0.46, 0.28), (0.86, 0.68, 0.46), (0.58, 0.40, 0.26))
_MESH_RGB = (0.76, 0.57, 0.38)
_TRANSLUCENT_ALPHA = 0.35
_HIDDEN_GROUP = 3  # a geom group the default visual options do not draw
_VISIBLE_GROUPS = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)  # MuJoCo's default drawn groups
_AZIMUTHS = tuple(range(0, 360, 45))
_ELEVATIONS = (-20.0, -35.0, -50.0, -60.0, -70.0, -78.0, -85.0, -89.0)  # denser where a deep opening needs it
_PREFERRED_VIEW = (135.0, -35.0)  # a three-quarter view from above: the elevation first, then the azimuth
#: A view may score this much less than the best view (see _visible) to be nearer the preferred view.
_VIEW_SLACK = 0.03
_FILL = 0.85  # the framed points span this fraction of the picture
_NEAR_RADII = 4.0  # agents farther than this many object radii (e.g. rolled away) are not framed


@dataclass(frozen=True)
class _State:
    """What one picture shows, world frame: the object's mesh-frame pose and the agents."""

    object_pos: np.ndarray  # (3,)
    object_quat: np.ndarray  # (4,) wxyz
    agent_pos: np.ndarray  # (N, 3) agent centres
    agent_quat: np.ndarray  # (N, 4) wxyz


@dataclass(frozen=True)
class _View:
    azimuth: float
    elevation: float
    distance: float
    lookat: np.ndarray
    visible: float  # how well the agents are seen past the object, 0-1 (see _visible)
    hidden: int  # agents of which the object hides most
    translucent: bool


def _placement_state(result: AffordanceResult, pose: int, agent_pos: np.ndarray, agent_quat: np.ndarray | None,
                     object_move: tuple[np.ndarray, np.ndarray] | None = None) -> _State:
    """World state from task-frame agents; ``object_move`` = (displacement of the task-frame origin,
    rotation relative to placement) puts the object and the frame where the rollout left them."""
    return placed_state(result.stable_poses[pose], agent_pos, agent_quat, object_move)


def placed_state(info: StablePose | PoseInfo, agent_pos: np.ndarray, agent_quat: np.ndarray | None,
                 object_move: tuple[np.ndarray, np.ndarray] | None = None) -> _State:
    """:func:`_placement_state` for a pose (``pos``, ``quat``, ``half_extents``) given directly."""
    origin0 = np.array([0.0, 0.0, info.half_extents[2]])  # the task frame at placement (rail_mj.core.types)
    obj_pos, obj_quat = np.asarray(info.pos, dtype=np.float64), np.asarray(info.quat, dtype=np.float64)
    agent_pos = np.asarray(agent_pos, dtype=np.float64).reshape(-1, 3)
    quats = np.tile([1.0, 0.0, 0.0, 0.0], (len(agent_pos), 1)) if agent_quat is None else np.asarray(agent_quat)
    if object_move is None:
        return _State(obj_pos, obj_quat, origin0 + agent_pos, quats)
    shift, rot = np.asarray(object_move[0], dtype=np.float64), np.asarray(object_move[1], dtype=np.float64)
    origin = origin0 + shift
    return _State(
        object_pos=origin + quat_rotate(rot, obj_pos - origin0),
        object_quat=quat_mul(rot, obj_quat),
        agent_pos=origin + quat_rotate(rot, agent_pos),
        agent_quat=quat_mul(rot, np.asarray(quats, dtype=np.float64)),
    )


def _drawing_spec(obj: RailObject, fragment: str, state: _State, *, draw_mesh: bool, width: int, height: int,
                  object_free: bool = False) -> tuple[mujoco.MjSpec, list[str], int]:
    """(spec, the object's hull geom names, number of agents) of a drawing scene before its colours: the
    object in ``state`` (fixed, or with its free joint when ``object_free``), the agents at their positions,
    a checker ground, a sky, a light; with ``draw_mesh`` the original mesh as a massless, non-colliding geom
    ``rail_render_mesh`` (its mesh asset of the same name)."""
    agents = None
    if fragment and len(state.agent_pos):
        agents = AgentSetup(fragment=fragment, offsets=state.agent_pos, collide_agents=True)
    spec = build_scene(obj, object_pos=cast(Sequence[float], state.object_pos),  # 1-d arrays
                       object_quat=cast(Sequence[float], state.object_quat), object_free=object_free, agents=agents)
    spec.visual.global_.offwidth = max(width, 640)
    spec.visual.global_.offheight = max(height, 480)
    # the generated stubs type these as arrays; MuJoCo's setter takes any 3 numbers
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]  # pyright: ignore[reportAttributeAccessIssue]
    spec.visual.headlight.diffuse = [0.35, 0.35, 0.35]  # pyright: ignore[reportAttributeAccessIssue]
    spec.add_texture(name="rail_sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.93, 0.95, 0.98], rgb2=[0.70, 0.74, 0.80], width=64, height=384)
    spec.add_texture(name="rail_grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.80, 0.80, 0.78], rgb2=[0.62, 0.62, 0.60], width=64, height=64)
    # one checker square per repeat (measured); no specular, so a top-down view is not washed out
    grid = spec.add_material(name="rail_grid", texuniform=True, texrepeat=[1.0 / GROUND_SQUARE_M] * 2,
                             specular=0.0, shininess=0.0, reflectance=0.0)
    grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "rail_grid"
    spec.geom(GROUND_GEOM).material = "rail_grid"
    spec.worldbody.add_light(name="rail_sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=[0.3, 0.5, -1.0],
                             diffuse=[0.4, 0.4, 0.4], castshadow=True)
    body = spec.body(OBJECT_BODY)
    hull_geoms = [g.name for g in body.geoms]
    if draw_mesh:
        mesh = spec.add_mesh(name="rail_render_mesh")
        mesh.uservert = np.asarray(obj.mesh.vertices, dtype=np.float64).ravel().tolist()
        mesh.userface = np.asarray(obj.mesh.faces, dtype=np.int32).ravel().tolist()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # a drawing only: any surface will do
        g = body.add_geom(name="rail_render_mesh", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="rail_render_mesh",
                          contype=0, conaffinity=0, rgba=[*_MESH_RGB, 1.0])
        g.mass = 0.0
    return spec, hull_geoms, len(state.agent_pos) if agents is not None else 0


def _scene(obj: RailObject, fragment: str, state: _State, *, draw_mesh: bool, width: int, height: int):
    """(model, data, object body id, agent body ids) of a drawing scene: the object fixed in ``state``,
    the agents at their positions, a checker ground, a light; colours set for reading."""
    spec, hull_geoms, n = _drawing_spec(obj, fragment, state, draw_mesh=draw_mesh, width=width, height=height)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise RailError(f"the drawing scene for {obj.name!r} does not compile: {exc}") from exc
    for k, name in enumerate(hull_geoms):
        gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        model.geom_rgba[gid] = [*_HULL_SHADES[k % len(_HULL_SHADES)], 1.0]
        if draw_mesh:
            model.geom_group[gid] = _HIDDEN_GROUP
    agent_bodies = []
    data = mujoco.MjData(model)
    for i in range(n):
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, agent_body_name(fragment, i))
        agent_bodies.append(bid)
        mine = model.geom_bodyid == bid
        model.geom_rgba[mine] = AGENT_RGBA
        model.geom_matid[mine] = -1
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, agent_prefix(i) + "free")
        a = model.jnt_qposadr[jid]
        data.qpos[a:a + 3] = state.agent_pos[i]
        data.qpos[a + 3:a + 7] = state.agent_quat[i] / np.linalg.norm(state.agent_quat[i])
    mujoco.mj_forward(model, data)
    return model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY), agent_bodies


# ---------------------------------------------------------------- camera


def _axes(azimuth: float, elevation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, right, up) of MuJoCo's free camera at these angles (degrees)."""
    a, e = math.radians(azimuth), math.radians(elevation)
    forward = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    up = np.array([-math.sin(e) * math.cos(a), -math.sin(e) * math.sin(a), math.cos(e)])
    return forward, np.cross(forward, up), up


def _world_box(model, data, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of the world-aligned box around these geoms."""
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    corners = np.concatenate([
        data.geom_xpos[g]
        + (model.geom_aabb[g, :3] + signs * model.geom_aabb[g, 3:]) @ data.geom_xmat[g].reshape(3, 3).T
        for g in geoms
    ])
    return corners.min(axis=0), corners.max(axis=0)


_AXES6 = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], dtype=np.float64)


def _frame_points(model, data, object_body: int, agent_bodies: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """(points the view must hold (P, 3), sample points on each agent for visibility (N, 6, 3))."""
    drawn = (model.geom_bodyid == object_body) & (model.geom_group != _HIDDEN_GROUP)
    lo, hi = _world_box(model, data, np.flatnonzero(drawn))
    centre, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo) / 2)
    signs = np.array(np.meshgrid([0, 1], [0, 1], [0, 1])).reshape(3, -1).T
    frame, samples = [lo + signs * (hi - lo)], []
    for bid in agent_bodies:
        a_lo, a_hi = _world_box(model, data, np.flatnonzero(model.geom_bodyid == bid))
        mid, half = (a_lo + a_hi) / 2, (a_hi - a_lo) / 2
        samples.append(mid + 0.6 * half * _AXES6)  # inside the agent, clear of a surface it rests on
        if np.linalg.norm(mid - centre) <= _NEAR_RADII * radius:
            frame.append(a_lo + signs * (a_hi - a_lo))
    return np.concatenate(frame), (np.array(samples) if samples else np.zeros((0, 6, 3)))


def _fit(points: np.ndarray, azimuth: float, elevation: float, fovy: float, aspect: float) -> tuple[np.ndarray, float]:
    """(lookat, distance) so the points fill ``_FILL`` of the picture seen from these angles."""
    forward, right, up = _axes(azimuth, elevation)
    lookat = (points.min(axis=0) + points.max(axis=0)) / 2
    rel = points - lookat
    toward = rel @ -forward  # how much nearer the camera each point is than the look-at point
    tan_v = math.tan(math.radians(fovy) / 2) * _FILL
    need = np.maximum(np.abs(rel @ up) / tan_v, np.abs(rel @ right) / (tan_v * aspect)) + toward
    return lookat, float(max(need.max(), 1e-3) * 1.02)


def fit_camera(points: np.ndarray, azimuth: float, elevation: float, *, fovy: float = 45.0, aspect: float = 4 / 3):
    """A free ``mujoco.MjvCamera`` at these angles (degrees) whose picture holds every point (P, 3) with a
    margin; ``fovy`` is the model's ``vis.global_.fovy`` and ``aspect`` the picture's width / height."""
    lookat, distance = _fit(np.asarray(points, dtype=np.float64).reshape(-1, 3), azimuth, elevation, fovy, aspect)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = lookat
    cam.distance, cam.azimuth, cam.elevation = distance, azimuth, elevation
    return cam


def _visible(model, data, samples: np.ndarray, agent_bodies: Sequence[int], object_body: int,
             camera: np.ndarray) -> tuple[float, int]:
    """(score, hidden) for a camera position: each agent scores the fraction of its sample points from which
    the straight line to the camera meets no object geom, full marks from half of them; the score is the
    mean over agents, and ``hidden`` counts the agents with fewer than a third of their points in sight."""
    if samples.size == 0:
        return 1.0, 0
    geomid = np.zeros(1, dtype=np.int32)
    seen = np.zeros(len(samples))
    for i, (bid, pts) in enumerate(zip(agent_bodies, samples)):
        for p in pts:
            vec = camera - p
            dist = float(np.linalg.norm(vec))
            hit = mujoco.mj_ray(model, data, p, vec / dist, _VISIBLE_GROUPS, True, bid, geomid)
            seen[i] += not (0 <= hit < dist and model.geom_bodyid[geomid[0]] == object_body)
    n = samples.shape[1]
    return float(np.mean(np.minimum(1.0, seen / (n / 2)))), int(np.sum(seen < n / 3))


def _choose_view(model, data, object_body: int, agent_bodies: Sequence[int], aspect: float) -> _View:
    points, samples = _frame_points(model, data, object_body, agent_bodies)
    fovy = float(model.vis.global_.fovy)
    views = []
    for el in _ELEVATIONS:
        for az in _AZIMUTHS:
            lookat, distance = _fit(points, az, el, fovy, aspect)
            camera = lookat - distance * _axes(az, el)[0]
            vis, hidden = _visible(model, data, samples, agent_bodies, object_body, camera)
            turn = abs((az - _PREFERRED_VIEW[0] + 180.0) % 360.0 - 180.0)
            views.append((abs(el - _PREFERRED_VIEW[1]) + 0.02 * turn,  # the shallowest view, then the azimuth
                          _View(az, el, distance, lookat, vis, hidden, translucent=hidden > 0)))
    top = max(v.visible for _, v in views)
    _, k = min((cost, k) for k, (cost, v) in enumerate(views) if v.visible >= top - _VIEW_SLACK)
    return views[k][1]


def _draw(
    model, data, object_body: int, agent_bodies: Sequence[int], width: int, height: int
) -> tuple[np.ndarray, _View]:
    view = _choose_view(model, data, object_body, agent_bodies, width / height)
    if view.translucent:
        mine = model.geom_bodyid == object_body
        model.geom_rgba[mine, 3] = _TRANSLUCENT_ALPHA
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # MuJoCo raises plain exceptions when no GL context can be made
        raise RailError(f"cannot create an offscreen renderer ({exc}); set MUJOCO_GL=egl or osmesa") from exc
    try:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = view.lookat
        cam.distance, cam.azimuth, cam.elevation = view.distance, view.azimuth, view.elevation
        renderer.update_scene(data, camera=cam)
        pixels = renderer.render().copy()
    finally:
        renderer.close()
    return pixels, view
