"""Pictures of results, for people: the object in a pose with the agents where the imagination left them.

* :func:`render_result` draws one picture: the result's evidence pose (its functional pose when it has one)
  with the agents' final positions, and a caption under it (object, affordance, verdict, pose index and
  probability, plan and score, and what the object is drawn as).
* :func:`render_contact_sheet` draws every stable pose with its best-scoring plan as one grid image; it
  re-runs those rollouts (one batched call) because a result keeps the final agents of one rollout only.
* :func:`nothing_to_draw` says why a result has no picture (a failed case, a failed dimension check).
* :func:`write_image` and :func:`write_frames` write PNGs (Pillow) and mp4 videos (imageio + its bundled
  ffmpeg); nothing in rail_mj writes image files by hand.

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
from pathlib import Path

import numpy as np

from rail_mj.core.errors import ConfigError, RailError
from rail_mj.core.geometry import quat_mul, quat_rotate
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import AgentSetup, RailObject

__all__ = [
    "AGENT_RGBA",
    "GROUND_SQUARE_M",
    "ContactSheet",
    "caption",
    "with_caption",
    "fit_camera",
    "nothing_to_draw",
    "render_result",
    "render_contact_sheet",
    "write_image",
    "write_frames",
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
_CAPTION_BG = (250, 250, 247)
_CAPTION_FG = (20, 20, 20)
_FUNCTIONAL_RGB = (30, 150, 60)


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


@dataclass(frozen=True)
class ContactSheet:
    """A written contact sheet: one tile per stable pose, row-major, each with its best-scoring plan."""

    path: Path
    tiles: tuple[tuple[int, int], ...]  # (stable pose index, plan index) per tile
    columns: int
    tile_size: tuple[int, int]  # (width, height) of a tile's picture, caption excluded


# ---------------------------------------------------------------- files


def write_image(path: str | Path, rgb: np.ndarray) -> Path:
    """Write an (H, W, 3) uint8 image; the format follows the suffix (PNG, JPEG, ...), by Pillow."""
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(path)
    except (ValueError, KeyError) as exc:  # Pillow's errors for an unknown suffix
        raise ConfigError(f"cannot write {path}: {exc}; give a .png or .jpg path") from exc
    return path


def write_frames(frames: Sequence[np.ndarray], path: str | Path, *, fps: int = 25) -> Path:
    """Write (H, W, 3) uint8 frames: an H.264 mp4 when ``path`` ends in .mp4 (imageio's bundled ffmpeg),
    else numbered PNGs ``frame_00000.png`` ... in the folder ``path``."""
    if not frames:
        raise RailError(f"no frames to write to {path}")
    path = Path(path)
    if path.suffix.lower() == ".mp4":
        import imageio.v2 as imageio

        path.parent.mkdir(parents=True, exist_ok=True)
        h, w = frames[0].shape[:2]
        # H.264 with yuv420p needs even sides: crop the last row/column of an odd frame
        even = [np.ascontiguousarray(f[: h - h % 2, : w - w % 2]) for f in frames]
        with imageio.get_writer(path, fps=fps, codec="libx264", pixelformat="yuv420p", macro_block_size=1) as writer:
            for frame in even:
                writer.append_data(frame)
        return path
    path.mkdir(parents=True, exist_ok=True)
    for i, frame in enumerate(frames):
        write_image(path / f"frame_{i:05d}.png", frame)
    return path


# ---------------------------------------------------------------- what can be drawn


def nothing_to_draw(result: AffordanceResult) -> str | None:
    """Why ``result`` has no picture, in plain words; None when it has one."""
    head = f"{result.object} / {result.requested}: nothing to draw"
    if result.error:
        return f"{head}: the case failed ({result.error})"
    if result.dims_fit is False:
        reason = "; ".join(result.analyzer_reasons) or "the object's size is outside the affordance's range"
        return f"{head}: the dimension check failed, so no interaction was imagined ({reason})"
    if result.evidence_pose is None or not result.stable_poses:
        return f"{head}: the result holds no imagined rollout"
    return None


def _load(obj: RailObject | str | Path, units: float, up: str) -> RailObject:
    if isinstance(obj, RailObject):
        return obj
    from rail_mj.mesh.objects import load_object

    return load_object(Path(obj), units=units, up=up)


def _best_plan(result: AffordanceResult, pose: int) -> int:
    """The plan of the result's kept rollout for ``pose`` (its best plan when that is the functional pose)."""
    if result.best_plan is not None and result.functional_pose is not None and pose == result.functional_pose.index:
        return result.best_plan.index
    return int(np.argmax(result.scores[pose])) if result.scores else 0


# ---------------------------------------------------------------- scene


def _scene(obj: RailObject, fragment: str, state: _State, *, draw_mesh: bool, width: int, height: int):
    """(model, data, object body id, agent body ids) of a drawing scene: the object fixed in ``state``,
    the agents at their positions, a checker ground, a light; colours set for reading."""
    import mujoco

    from rail_mj.mjcf import build_scene
    from rail_mj.mjcf.scene import GROUND_GEOM, OBJECT_BODY, agent_body_name, agent_prefix

    agents = None
    if fragment and len(state.agent_pos):
        agents = AgentSetup(fragment=fragment, offsets=state.agent_pos, collide_agents=True)
    spec = build_scene(obj, object_pos=state.object_pos, object_quat=state.object_quat, object_free=False,
                       agents=agents)
    spec.visual.global_.offwidth = max(width, 640)
    spec.visual.global_.offheight = max(height, 480)
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]
    spec.visual.headlight.diffuse = [0.35, 0.35, 0.35]
    spec.add_texture(name="rail_sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
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
    n = len(state.agent_pos) if agents is not None else 0
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
        data.geom_xpos[g] + (model.geom_aabb[g, :3] + signs * model.geom_aabb[g, 3:]) @ data.geom_xmat[g].reshape(3, 3).T
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
    import mujoco

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
    import mujoco

    if samples.size == 0:
        return 1.0, 0
    geomid = np.zeros(1, dtype=np.int32)
    seen = np.zeros(len(samples))
    for i, (bid, pts) in enumerate(zip(agent_bodies, samples)):
        for p in pts:
            vec = camera - p
            dist = float(np.linalg.norm(vec))
            hit = mujoco.mj_ray(model, data, p, vec / dist, _VISIBLE_GROUPS, 1, bid, geomid)
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


def _draw(model, data, object_body: int, agent_bodies: Sequence[int], width: int, height: int) -> tuple[np.ndarray, _View]:
    import mujoco

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


# ---------------------------------------------------------------- captions


def _font(size: int):
    from PIL import ImageFont

    return ImageFont.load_default(size=size)


def _wrap(text: str, font, width: int) -> list[str]:
    words, lines, line = text.split(), [], ""
    for w in words:
        trial = f"{line} {w}".strip()
        if line and font.getlength(trial) > width:
            lines.append(line)
            line = w
        else:
            line = trial
    return lines + ([line] if line else [])


def with_caption(pixels: np.ndarray, lines: Sequence[tuple[str, tuple[int, int, int]]], size: int) -> np.ndarray:
    """The picture with a caption band under it; each line wraps to the picture's width."""
    from PIL import Image, ImageDraw

    font = _font(size)
    h, w = pixels.shape[:2]
    pad, step = max(4, size // 2), int(size * 1.3)
    rows = [(part, colour) for text, colour in lines for part in _wrap(text, font, w - 2 * pad)]
    band = 2 * pad + step * len(rows)
    img = Image.new("RGB", (w, h + band), _CAPTION_BG)
    img.paste(Image.fromarray(pixels), (0, 0))
    draw = ImageDraw.Draw(img)
    for k, (text, colour) in enumerate(rows):
        draw.text((pad, h + pad + k * step), text, fill=colour, font=font)
    return np.asarray(img)


def _drawn_as(obj: RailObject, draw_mesh: bool) -> str:
    if draw_mesh:
        return f"object drawn as its original mesh ({len(obj.mesh.faces)} faces)"
    return f"object drawn as its {len(obj.hulls)} CoACD convex hulls (one shade per hull)"


def _verdict(result: AffordanceResult) -> str:
    asked = "" if result.requested == result.affordance else f" (asked: {result.requested!r})"
    return (f"{result.object} - affordance {result.affordance!r}{asked} - "
            f"{'FUNCTIONAL' if result.functional else 'NOT FUNCTIONAL'}")


def _pose_line(result: AffordanceResult, pose: int, plan: int) -> str:
    p = result.stable_poses[pose]
    score = result.scores[pose][plan] if result.scores else float("nan")
    name = result.plans[plan] if plan < len(result.plans) else "?"
    return f"pose #{p.index} (p = {p.probability:.2f}, of {len(result.stable_poses)}) - plan {name!r} - score {score:.2f}"


def _notes(view: _View, n_agents: int) -> str:
    notes = [f"agents in blue ({n_agents})", f"ground squares {100 * GROUND_SQUARE_M:.0f} cm"]
    if view.translucent:
        notes.append(f"object drawn translucent: {view.hidden} agents are behind it in every good view")
    return "; ".join(notes)


def caption(result: AffordanceResult, obj: RailObject, *, draw_mesh: bool = False) -> list[str]:
    """The caption lines of :func:`render_result`'s picture (before the view's notes): object, affordance and
    verdict; the pose drawn, its probability, its plan and score; what the object is drawn as."""
    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    pose = int(result.evidence_pose)
    kept = "functional pose" if result.functional else "best-scoring rollout (no functional pose)"
    return [_verdict(result), f"{kept}: {_pose_line(result, pose, _best_plan(result, pose))}", _drawn_as(obj, draw_mesh)]


# ---------------------------------------------------------------- pictures


def _placement_state(result: AffordanceResult, pose: int, agent_pos: np.ndarray, agent_quat: np.ndarray | None,
                     object_move: tuple[np.ndarray, np.ndarray] | None = None) -> _State:
    """World state from task-frame agents; ``object_move`` = (displacement of the task-frame origin,
    rotation relative to placement) puts the object and the frame where the rollout left them."""
    info = result.stable_poses[pose]
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


def render_result(
    obj: RailObject | str | Path,
    result: AffordanceResult,
    path: str | Path,
    *,
    units: float = 1.0,
    up: str = "z",
    draw_mesh: bool = False,
    width: int = 640,
    height: int = 480,
) -> Path:
    """Write a picture of the result's evidence pose (its functional pose when it has one) with the final
    agents of that rollout, and a caption. ``obj`` is the loaded object or its mesh file (read with ``units``
    and ``up``, as it was classified). Raises RailError, with :func:`nothing_to_draw`'s words, when the result
    holds no rollout."""
    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    obj = _load(obj, units, up)
    text = caption(result, obj, draw_mesh=draw_mesh)
    state = _placement_state(result, int(result.evidence_pose), np.asarray(result.evidence_agent_pos), None)
    model, data, body, agents = _scene(obj, result.agent_fragment, state, draw_mesh=draw_mesh, width=width,
                                       height=height)
    pixels, view = _draw(model, data, body, agents, width, height)
    lines = [(text[0], _FUNCTIONAL_RGB if result.functional else _CAPTION_FG), (text[1], _CAPTION_FG),
             (f"{text[2]}; {_notes(view, len(agents))}", _CAPTION_FG)]
    return write_image(path, with_caption(pixels, lines, size=max(12, width // 40)))


def _columns(n: int) -> int:
    return max(1, min(4, math.ceil(math.sqrt(n))))


def render_contact_sheet(
    obj: RailObject | str | Path,
    result: AffordanceResult,
    path: str | Path,
    *,
    units: float = 1.0,
    up: str = "z",
    draw_mesh: bool = False,
    profile=None,
    tile: tuple[int, int] = (360, 270),
) -> ContactSheet:
    """Write one grid image: every stable pose of the result with its best-scoring plan, the agents where
    that rollout left them (re-imagined in one batched call on the result's backend), each tile captioned,
    the functional pose framed in green, and the result's caption on top.

    ``profile`` is the :class:`~rail_mj.llm.ImaginationProfile` the result was imagined with; by default it
    is asked again of the result's provider (the offline library, or the LLM answer cache). A profile whose
    agent or plans differ from the result's is refused (RailError)."""
    from PIL import Image, ImageDraw

    from rail_mj import llm
    from rail_mj.imagination import imagine
    from rail_mj.imagination.inputs import agent_setup, trajectory_array

    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    obj = _load(obj, units, up)
    if profile is None:
        profile = llm.generate_profile(result.requested, [float(d) for d in obj.obb_dims], result.provider or "offline")
    if profile.agent.mjcf != result.agent_fragment or [p.name for p in profile.plans.plans] != result.plans:
        raise RailError(
            f"{result.object} / {result.requested}: the profile's agent or plans are not the ones the result was "
            "imagined with (another provider, model or cache); pass the profile the result came from"
        )
    n = len(result.stable_poses)
    plans = [_best_plan(result, i) for i in range(n)]
    poses = [p.to_pose() for p in result.stable_poses]
    trajectories = [[trajectory_array(profile.trajectories.trajectories, p.half_extents, p.basin)[j]]
                    for p, j in zip(poses, plans)]
    outcomes = imagine(obj, poses, agent_setup(profile.agent.mjcf, profile.layout), trajectories,
                       backend=result.backend or "native")

    tw, th = tile
    size = max(11, tw // 30)
    functional = result.functional_pose.index if result.functional_pose is not None else None
    tiles = []
    for i, j in enumerate(plans):
        state = _placement_state(result, i, outcomes.agent_pos[i], outcomes.agent_quat[i],
                                 (outcomes.object_pos[i], outcomes.object_quat[i]))
        model, data, body, agents = _scene(obj, result.agent_fragment, state, draw_mesh=draw_mesh, width=tw, height=th)
        pixels, view = _draw(model, data, body, agents, tw, th)
        mark = " - FUNCTIONAL POSE" if i == functional else ""
        lines = [(f"pose #{i} (p = {result.stable_poses[i].probability:.2f}){mark}",
                  _FUNCTIONAL_RGB if i == functional else _CAPTION_FG),
                 (f"plan {result.plans[j]!r} - score {result.scores[i][j]:.2f}", _CAPTION_FG)]
        if view.translucent:
            lines.append((f"object translucent ({view.hidden} of {len(agents)} agents hidden)", _CAPTION_FG))
        tiles.append(with_caption(pixels, lines, size))
    cols = _columns(n)
    rows = math.ceil(n / cols)
    cell_h = max(t.shape[0] for t in tiles)
    gap = 6
    sheet_w = cols * tw + (cols + 1) * gap
    head = with_caption(np.zeros((0, sheet_w, 3), dtype=np.uint8), [
        (_verdict(result), _FUNCTIONAL_RGB if result.functional else _CAPTION_FG),
        (f"every stable pose (most probable first) with its best-scoring plan; "
         f"{_drawn_as(obj, draw_mesh)}; agents in blue; ground squares {100 * GROUND_SQUARE_M:.0f} cm", _CAPTION_FG),
    ], size=max(13, size + 2))
    sheet = Image.new("RGB", (sheet_w, head.shape[0] + rows * (cell_h + gap) + gap), _CAPTION_BG)
    sheet.paste(Image.fromarray(head), (0, 0))
    draw = ImageDraw.Draw(sheet)
    for k, t in enumerate(tiles):
        x, y = gap + (k % cols) * (tw + gap), head.shape[0] + gap + (k // cols) * (cell_h + gap)
        sheet.paste(Image.fromarray(t), (x, y))
        if k == functional:
            draw.rectangle([x - 3, y - 3, x + tw + 2, y + t.shape[0] + 2], outline=_FUNCTIONAL_RGB, width=3)
    out = write_image(path, np.asarray(sheet))
    return ContactSheet(path=out, tiles=tuple((i, j) for i, j in enumerate(plans)), columns=cols, tile_size=tile)
