"""A result's imagined scene as MJCF files to open in MuJoCo: ``DIR/scene.xml``, ``DIR/meshes/``, ``DIR/README.txt``.

:func:`save_scene` writes the scene of the pose :func:`~rail_mj.render.images.render_result` draws (the
functional pose, else the best-scoring rollout's pose) and of that pose's plan (the best plan, else the
best-scoring one), built by the drawing scene's own path (:mod:`rail_mj.render.scene`):

* body ``object`` with its free joint ``object``, placed in the pose; its CoACD hulls ``object/hull{i}``
  are the collision geoms (geom group 3, hidden by default; the shapes the physics uses) and the original
  mesh ``rail_render_mesh`` is the visual geom (massless, colliding with nothing). A mesh MuJoCo refuses
  (a degenerate scan) is left out and the hulls are drawn instead; README.txt says so.
* the agents ``agent{i}/<fragment body>``, each with its free joint ``agent{i}/free``, drawn in blue, at
  the start of the plan: its first via-pose plus each agent's offset in the layout.
* the plan's via-poses of the layout centre as sites ``via{k}`` (their frame is the via-pose's orientation)
  and as keyframes ``via{k}`` (the agents at via-pose k, the object in its pose), plus ``imagined_end``: the
  agents where the kept rollout left them (as the picture draws them). ``qpos0`` is keyframe ``via0``.
* the ground plane ``ground``, a checker texture, a sky and the light ``rail_sun``.

The object's meshes are written as OBJ files in ``DIR/meshes`` and referenced by relative ``file=`` paths
(``<compiler meshdir="meshes"/>``); agent meshes a fragment gives inline stay inline. Gravity is on and
nothing drives the agents: played, they fall and the object settles, as after the imagination releases them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import mujoco
import numpy as np
import trimesh

from rail_mj.core.errors import ConfigError, RailError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.imagination.inputs import trajectory_array
from rail_mj.mjcf.scene import GROUND_GEOM, OBJECT_BODY, agent_body_name, agent_prefix
from rail_mj.render.captions import _best_plan, _verdict, nothing_to_draw
from rail_mj.render.images import _load, result_profile
from rail_mj.render.scene import _HIDDEN_GROUP, _HULL_SHADES, AGENT_RGBA, _drawing_spec, _placement_state, _State

__all__ = ["SCENE_FILE", "MESH_DIR", "README_FILE", "SavedScene", "check_scene_dir", "save_scene"]

SCENE_FILE = "scene.xml"
MESH_DIR = "meshes"
README_FILE = "README.txt"
_MESH_GEOM = "rail_render_mesh"  # the visual mesh's geom and asset (rail_mj.render.scene)
_VIA_RGBA = [1.0, 0.55, 0.0, 0.8]


@dataclass(frozen=True)
class SavedScene:
    """What :func:`save_scene` wrote and chose."""

    path: Path  # DIR/scene.xml
    meshes: tuple[Path, ...]  # DIR/meshes/*.obj
    readme: Path
    pose: int  # index of the stable pose the object is in
    plan: int  # index of the plan whose via-poses and start are shown
    plan_name: str
    functional: bool  # the pose is the functional pose (else the best-scoring rollout's)
    n_agents: int
    via_sites: tuple[str, ...]
    keyframes: tuple[str, ...]
    mesh_drawn: bool  # the original mesh is in the scene (else only the hulls, drawn)
    overwrote: bool  # DIR held a previous scene, now replaced


def check_scene_dir(out_dir: str | Path) -> bool:
    """Whether ``out_dir`` holds a previous scene that :func:`save_scene` will overwrite; False when it is
    missing or empty. ConfigError when it is a file or a non-empty directory without a ``scene.xml``."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"cannot save the scene in {out}: it is a file, not a directory")
    if not out.is_dir() or not any(out.iterdir()):
        return False
    if not (out / SCENE_FILE).is_file():
        raise ConfigError(f"cannot save the scene in {out}: the directory is not empty and holds no previous "
                          f"{SCENE_FILE}; give a new or empty directory")
    return True


def _via_poses(obj: RailObject, result: AffordanceResult, pose: int, plan: int, profile) -> np.ndarray:
    """(K, 7) task-frame via-poses of the shown plan: the best plan's own, else rebuilt from the profile."""
    if result.best_plan is not None and result.functional_pose is not None and pose == result.functional_pose.index:
        return np.asarray(result.best_plan.via_poses, dtype=np.float64).reshape(-1, 7)
    profile = result_profile(obj, result, profile)
    p = result.stable_poses[pose].to_pose()
    return trajectory_array(profile.trajectories.trajectories, p.half_extents, p.basin)[plan]


def _at(result: AffordanceResult, pose: int, offsets: np.ndarray, via: np.ndarray) -> _State:
    """The world state with the layout centre at one task-frame via-pose (7,)."""
    return _placement_state(result, pose, via[:3] + offsets, np.tile(via[3:], (len(offsets), 1)))


def _build(obj: RailObject, fragment: str, state: _State, *, draw_mesh: bool) -> tuple[mujoco.MjSpec, int]:
    """(spec, number of agents): the drawing spec with a free object and the colours set in the spec."""
    spec, hull_geoms, n = _drawing_spec(obj, fragment, state, draw_mesh=draw_mesh, width=640, height=480,
                                        object_free=True)
    for k, name in enumerate(hull_geoms):
        g = spec.geom(name)
        g.rgba = [*_HULL_SHADES[k % len(_HULL_SHADES)], 1.0]  # pyright: ignore[reportAttributeAccessIssue]
        if draw_mesh:
            g.group = _HIDDEN_GROUP
    for i in range(n):
        body = spec.body(agent_body_name(fragment, i))
        q = state.agent_quat[i]
        body.quat = (q / np.linalg.norm(q)).tolist()
        for g in body.geoms:
            g.rgba = list(AGENT_RGBA)  # pyright: ignore[reportAttributeAccessIssue]
            g.material = ""
    return spec, n


def _file_name(mesh_name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", mesh_name) + ".obj"


def _object_meshes(spec: mujoco.MjSpec) -> dict[str, trimesh.Trimesh]:
    """The object's inline mesh assets (hulls and the visual mesh) as triangle meshes, by asset name; a hull
    given by vertices alone becomes its convex hull, as MuJoCo makes it."""
    out = {}
    for mesh in spec.meshes:
        if not (mesh.name.startswith(OBJECT_BODY + "/") or mesh.name == _MESH_GEOM):
            continue
        vertices = np.asarray(mesh.uservert, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(mesh.userface, dtype=np.int64).reshape(-1, 3)
        out[mesh.name] = (trimesh.Trimesh(vertices, faces, process=False) if len(faces)
                          else trimesh.convex.convex_hull(vertices))
    return out


def _keyframes(spec: mujoco.MjSpec, model: mujoco.MjModel, n: int, states: dict[str, _State]) -> None:
    """Add one keyframe per named state: the object at qpos0, the agents where the state puts them."""
    for name, state in states.items():
        qpos = model.qpos0.copy()
        for i in range(n):
            a = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, agent_prefix(i) + "free")]
            q = state.agent_quat[i]
            qpos[a:a + 7] = [*state.agent_pos[i], *(q / np.linalg.norm(q))]
        spec.add_key(name=name, qpos=qpos.tolist())


def _comment(readme: str) -> str:
    """The README as the XML's comment, less its lines with ``--`` (not allowed in an XML comment)."""
    return " " + "\n".join(line for line in readme.strip().splitlines() if "--" not in line) + "\n"


def _readme(result: AffordanceResult, obj: RailObject, saved: SavedScene, via: np.ndarray) -> str:
    p = result.stable_poses[saved.pose]
    score = result.scores[saved.pose][saved.plan] if result.scores else float("nan")
    why = ("the functional pose" if saved.functional
           else "the pose of the best-scoring rollout (the result has no functional pose)")
    plan_why = "the best plan" if saved.functional else "the best-scoring plan in that pose"
    lines = [
        f"{_verdict(result)}",
        "",
        f"Pose: stable pose #{p.index} (p = {p.probability:.2f}, of {len(result.stable_poses)}), {why};",
        f"  object mesh frame at pos {[round(v, 4) for v in p.pos]}, quat (wxyz) {[round(v, 4) for v in p.quat]}.",
        f"Plan: {saved.plan_name!r} (plan {saved.plan} of {len(result.plans)}), {plan_why}, score {score:.2f};",
        f"  {len(via)} via-poses of the layout centre.",
        "",
        "Open it: python -m mujoco.viewer --mjcf scene.xml",
        "",
        "What is in scene.xml:",
        f"* body '{OBJECT_BODY}' (free joint '{OBJECT_BODY}'): the object, placed in the pose above.",
        f"  geoms '{OBJECT_BODY}/hull0'..'{OBJECT_BODY}/hull{len(obj.hulls) - 1}': its {len(obj.hulls)} CoACD convex "
        "hulls, the collision geoms (meshes/object_hull*.obj)"
        + (", geom group 3: hidden by default, shown with the viewer's geom group 3 toggle" if saved.mesh_drawn
           else "; drawn, one shade per hull") + ".",
        (f"  geom '{_MESH_GEOM}': the original mesh (meshes/{_MESH_GEOM}.obj), visual only: massless, "
         "colliding with nothing." if saved.mesh_drawn else
         "  the original mesh is left out: MuJoCo's mesh compiler refused it."),
        f"* bodies 'agent0/...'..'agent{saved.n_agents - 1}/...' (free joints 'agent{{i}}/free'): the "
        f"{saved.n_agents} agents, in blue, at the start of the plan (its first via-pose plus each agent's layout "
        "offset).",
        f"* sites 'via0'..'via{len(via) - 1}' (orange): the plan's via-poses of the layout centre, in order; each "
        "site's frame is the via-pose's orientation.",
        f"* keyframes {', '.join(repr(k) for k in saved.keyframes)}: the agents at each via-pose"
        + (" and, last, where the imagined rollout left them" if "imagined_end" in saved.keyframes else "")
        + "; the object in its pose. qpos0 is 'via0'.",
        f"* geom '{GROUND_GEOM}': the ground plane (checker squares 10 cm); light 'rail_sun'.",
        "",
        "Gravity is on and nothing drives the agents: played, they fall and the object settles, as after the "
        "imagination releases them.",
    ]
    return "\n".join(lines) + "\n"


def save_scene(
    obj: RailObject | str | Path,
    result: AffordanceResult,
    out_dir: str | Path,
    *,
    units: float = 1.0,
    up: Literal["z", "y"] = "z",
    profile=None,
) -> SavedScene:
    """Write the imagined scene of ``result`` to ``out_dir`` (see the module docstring): ``scene.xml``, its
    meshes in ``meshes/`` and ``README.txt``. ``obj`` is the loaded object or its mesh file (read with
    ``units`` and ``up``, as it was classified); ``profile`` is needed only for a result without a functional
    pose (its plan's via-poses are rebuilt from it; by default it is asked again of the result's provider).

    Raises RailError, with :func:`~rail_mj.render.captions.nothing_to_draw`'s words, when the result holds no
    rollout; ConfigError when ``out_dir`` is a file or a non-empty directory without a previous scene.xml (a
    previous scene is overwritten: :attr:`SavedScene.overwrote`)."""
    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    assert result.evidence_pose is not None  # nothing_to_draw says so
    out = Path(out_dir)
    overwrote = check_scene_dir(out)
    obj = _load(obj, units, up)
    pose = int(result.evidence_pose)
    plan = _best_plan(result, pose)
    via = _via_poses(obj, result, pose, plan, profile)
    offsets = np.asarray(result.agent_offsets, dtype=np.float64).reshape(-1, 3)
    start = _at(result, pose, offsets, via[0])
    mesh_drawn = True
    try:
        spec, n = _build(obj, result.agent_fragment, start, draw_mesh=True)
        model = spec.compile()
    except (ValueError, RailError):
        mesh_drawn = False
        spec, n = _build(obj, result.agent_fragment, start, draw_mesh=False)
        try:
            model = spec.compile()
        except ValueError as exc:
            raise RailError(f"the scene for {obj.name!r} does not compile: {exc}") from exc

    sites = tuple(f"via{k}" for k in range(len(via)))
    world = _placement_state(result, pose, via[:, :3], via[:, 3:])
    size = float(np.clip(0.04 * max(result.stable_poses[pose].half_extents), 0.003, 0.02))
    for name, pos, quat in zip(sites, world.agent_pos, world.agent_quat):
        spec.worldbody.add_site(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[size, 0.0, 0.0],
                                pos=pos.tolist(), quat=(quat / np.linalg.norm(quat)).tolist(), rgba=_VIA_RGBA)
    states = {name: _at(result, pose, offsets, v) for name, v in zip(sites, via)}
    end = np.asarray(result.evidence_agent_pos, dtype=np.float64).reshape(-1, 3)
    if n and len(end) == n:
        states["imagined_end"] = _placement_state(result, pose, end, None)
    _keyframes(spec, model, n, states)
    half = np.asarray(result.stable_poses[pose].half_extents, dtype=np.float64)
    spec.stat.center = [0.0, 0.0, float(half[2])]  # pyright: ignore[reportAttributeAccessIssue]
    spec.stat.extent = float(max(2.5 * np.linalg.norm(half), 0.1))

    meshes = _object_meshes(spec)
    mesh_dir = out / MESH_DIR
    files = tuple(mesh_dir / _file_name(name) for name in meshes)
    saved = SavedScene(path=out / SCENE_FILE, meshes=files, readme=out / README_FILE, pose=pose, plan=plan,
                       plan_name=result.plans[plan] if plan < len(result.plans) else "?",
                       functional=result.functional_pose is not None and result.functional_pose.index == pose,
                       n_agents=n, via_sites=sites, keyframes=tuple(states), mesh_drawn=mesh_drawn,
                       overwrote=overwrote)
    readme = _readme(result, obj, saved, via)
    spec.comment = _comment(readme)

    out.mkdir(parents=True, exist_ok=True)
    mesh_dir.mkdir(exist_ok=True)
    for old in mesh_dir.glob("*.obj"):  # a previous scene's meshes
        old.unlink()
    for (name, tm), path in zip(meshes.items(), files):
        tm.export(path, file_type="obj")
        m = spec.mesh(name)
        m.uservert, m.userface = [], []
        m.file = path.name
    spec.meshdir = MESH_DIR
    spec.modelfiledir = str(out.resolve())
    try:
        xml = spec.to_xml()
    except ValueError as exc:
        raise RailError(f"the scene for {obj.name!r} does not compile from its mesh files: {exc}") from exc
    saved.path.write_text(xml)
    saved.readme.write_text(readme)
    return saved
