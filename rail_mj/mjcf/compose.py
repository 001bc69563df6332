"""The one scene composer: ground + object hulls + agent fragments, with the physics every scene shares.

The imagination, the stable-pose drops and the robot all build their object body and agents here, with
the same contact constants (``FRICTION``, solref time constant ``SOLREF_TIMECONST_FACTOR`` × timestep),
the object's mass split over its hulls by volume, and every agent fragment through ``check_fragment``.

Collision filtering uses contype/conaffinity bits (a pair collides when
``(contype1 & conaffinity2) or (contype2 & conaffinity1)``):

=========  =============  ==========================================
geom       contype        conaffinity
=========  =============  ==========================================
ground     GROUND_BIT     0
object     OBJECT_BIT     GROUND_BIT | AGENT_BIT
agent      AGENT_BIT      GROUND_BIT | OBJECT_BIT (| AGENT_BIT when agents collide)
=========  =============  ==========================================

Filtering agent pairs this way removes them before compile at no accuracy cost
(design.md); agent geoms the fragment marks visual-only (contype = conaffinity
= 0) stay visual.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import mujoco
import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from rail_mj.core.errors import SceneError
from rail_mj.core.types import AgentSetup, RailObject
from rail_mj.mjcf.body import BEARING_PROBES, REACH_PROBES
from rail_mj.mjcf.scene import (
    AGENT_BIT,
    FRICTION,
    GROUND_BIT,
    GROUND_GEOM,
    OBJECT_BIT,
    OBJECT_BODY,
    OBJECT_JOINT,
    SOLREF_TIMECONST_FACTOR,
    agent_body_name,
    agent_prefix,
    check_fragment,
    hull_geom_name,
)
from rail_mj.mjcf.surface import OwnSurface, surface_data, surface_model

__all__ = [
    "OWNER_GROUND",
    "OWNER_OBJECT",
    "OWNER_OTHER",
    "ScenePhysics",
    "Scene",
    "settled_bodies",
    "compose_scene",
    "build_scene",
    "add_object",
    "add_agent",
    "count_contacts",
    "segment_state",
]

#: geom owner codes in Scene.geom_owner (agents are 0..N-1); OTHER (a robot's links) is never counted
OWNER_GROUND = -1
OWNER_OBJECT = -2
OWNER_OTHER = -3
_SCENE_NAME = "rail_scene"  # one name for every object: MJX keeps names static, so one compile per bucket


@dataclass(frozen=True)
class ScenePhysics:
    """Contact and solver settings of a composed scene. ``None`` keeps MuJoCo's own solver default."""

    timestep: float = 0.005
    solref_factor: float = SOLREF_TIMECONST_FACTOR  # contact time constant as a multiple of the timestep
    friction: float = FRICTION[0]  # sliding friction of the ground and the object (agents keep their own)
    iterations: int | None = None
    ls_iterations: int | None = None
    speculative: bool = False  # speculative contacts: fast small agents do not tunnel through thin walls
    max_hull_vertices: int | None = None  # MuJoCo simplifies each hull mesh to at most this many vertices

    def __post_init__(self) -> None:
        if not (np.isfinite(self.timestep) and self.timestep > 0):
            raise SceneError(f"timestep must be a positive number of seconds, got {self.timestep}")
        if not (np.isfinite(self.solref_factor) and self.solref_factor > 0 and self.friction > 0):
            raise SceneError(
                f"solref_factor and friction must be positive, got {self.solref_factor} and {self.friction}"
            )

    @property
    def solref(self) -> list[float]:
        """Contact solref of every collidable geom: time constant, damping ratio."""
        return [self.solref_factor * self.timestep, 1.0]

    @property
    def friction3(self) -> list[float]:
        """Sliding, torsional, rolling friction of the ground and the object."""
        return [self.friction, FRICTION[1], FRICTION[2]]


@dataclass(frozen=True)
class Scene:
    """A compiled scene (object with a free joint, agents with free joints, ground) and its ids."""

    model: mujoco.MjModel
    n_agents: int
    object_qpos: int  # qpos address of the object's free joint
    object_dof: int
    agent_qpos: np.ndarray  # (N,) qpos address of each agent's free joint
    agent_dof: np.ndarray  # (N,)
    geom_owner: np.ndarray  # (ngeom,) agent index, OWNER_GROUND or OWNER_OBJECT
    #: the object's own surface in its frame, for ray probes (:func:`surface_model`); None in a scene without
    #: agents
    surface: mujoco.MjModel | None = None
    #: dof addresses of the agents' hinge joints (an articulated agent's; empty when every agent is one body)
    hinge_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: reach (m) of what each hinge turns, about the hinge: the lever of its speed bound in :meth:`at_rest`
    hinge_radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: (N, S) body ids of each agent's bodies (segments), the root first; S = 1 for one-body agents
    agent_bodies: np.ndarray = field(default_factory=lambda: np.zeros((0, 1), dtype=np.int64))

    # the free bodies' addresses and radii are read at every settle check: computed once per scene
    @cached_property
    def free_dofs(self) -> np.ndarray:
        """dof addresses of every free joint (object first), (1 + N,)."""
        return np.concatenate([[self.object_dof], self.agent_dof]).astype(np.int64)

    @cached_property
    def free_radius(self) -> np.ndarray:
        """Bounding radius of each free body (object first) and the bodies it carries, about its frame origin,
        (1 + N,)."""
        m = self.model
        return np.array([_reach(m, int(b)) for b in m.dof_bodyid[self.free_dofs]])

    @property
    def articulated(self) -> bool:
        """Whether an agent has hinge joints (its segments move against each other)."""
        return len(self.hinge_dofs) > 0

    @property
    def segment_names(self) -> tuple[str, ...]:
        """The names of an agent's bodies (segments) as its fragment names them, the root first."""
        if self.agent_bodies.shape[0] == 0:
            return ()
        prefix = agent_prefix(0)
        return tuple(self.model.body(int(b)).name.removeprefix(prefix) for b in self.agent_bodies[0])

    @cached_property
    def surface_data(self) -> mujoco.MjData | None:
        """The data of :attr:`surface` that its rays read (static: made once per scene); None without a surface."""
        return None if self.surface is None else surface_data(self.surface)

    @cached_property
    def free_qpos(self) -> np.ndarray:
        """qpos addresses of every free joint (object first), (1 + N,)."""
        return np.concatenate([[self.object_qpos], self.agent_qpos]).astype(np.int64)

    def at_rest(self, qpos: np.ndarray, qvel: np.ndarray, settle_speed: float) -> np.ndarray:
        """Whether every free body of each world has settled (:func:`settled_bodies`); qpos (..., nq), qvel (..., nv)
        → (...)."""
        pos = np.stack([qpos[..., a : a + 3] for a in self.free_qpos], axis=-2)
        lin = np.stack([qvel[..., d : d + 3] for d in self.free_dofs], axis=-2)
        ang = np.stack([qvel[..., d + 3 : d + 6] for d in self.free_dofs], axis=-2)
        rest = np.all(settled_bodies(np, pos, lin, ang, self.free_radius, settle_speed), axis=-1)
        if self.articulated:  # a limb swinging about its joint moves as fast as its far end
            rest &= np.all(np.abs(qvel[..., self.hinge_dofs]) * self.hinge_radius < settle_speed, axis=-1)
        return rest


def settled_bodies(xp, pos, lin, ang, radius, settle_speed: float):
    """Whether each free body (the object first, then the agents) has settled, (..., 1 + N), from their positions,
    linear and angular velocities (..., 1 + N, 3) and bounding radii (1 + N,); ``xp`` is numpy or jax.numpy, so both
    backends judge rest alike.

    A body has settled when no point of it moves faster than ``settle_speed``: its speed bound is |v| + |w| r, so a
    rolling droplet and a spinning cup count alike. An agent has also settled once it has rolled clear: its centre
    within its radius of the ground (low enough to touch it), farther across from the object's centre than the two
    radii (out of the object's reach) and moving away across the ground. Where it ends is decided (off the object), and
    nothing but another agent turns it back; a ball rolling on the floor, which nothing in the scene slows, would
    otherwise keep its world running to the time limit.
    """
    speed = xp.linalg.norm(lin, axis=-1) + xp.linalg.norm(ang, axis=-1) * radius
    still = speed < settle_speed
    away = pos[..., 1:, :2] - pos[..., :1, :2]
    clear = ((pos[..., 1:, 2] <= radius[1:])
             & (xp.linalg.norm(away, axis=-1) > radius[0] + radius[1:])
             & (xp.sum(away * lin[..., 1:, :2], axis=-1) >= 0.0))
    return xp.concatenate([still[..., :1], still[..., 1:] | clear], axis=-1)


def _reach(m: mujoco.MjModel, body: int) -> float:
    """How far (m) the geoms of ``body`` and of the bodies it carries reach from its origin, at most."""
    own = np.linalg.norm(m.geom_pos[m.geom_bodyid == body], axis=1) + m.geom_rbound[m.geom_bodyid == body]
    children = np.nonzero((m.body_parentid == body) & (np.arange(m.nbody) != body))[0]
    return max([0.0, *own.tolist(), *(float(np.linalg.norm(m.body_pos[c])) + _reach(m, int(c)) for c in children)])


def count_contacts(geom_owner: np.ndarray, geom_pairs: np.ndarray, n_agents: int) -> np.ndarray:
    """Contact points per agent, split (object, other agents, ground): (N, 3) from (ncon, 2) geom ids."""
    out = np.zeros((n_agents, 3), dtype=np.int64)
    if len(geom_pairs) == 0:
        return out
    a, b = geom_owner[geom_pairs[:, 0]], geom_owner[geom_pairs[:, 1]]
    for x, y in ((a, b), (b, a)):
        kind = np.where(y == OWNER_OBJECT, 0, np.where(y == OWNER_GROUND, 2, np.where(y >= 0, 1, -1)))
        counted = (x >= 0) & (kind >= 0)
        np.add.at(out, (x[counted], kind[counted]), 1)
    return out


def segment_state(scene: Scene, data: mujoco.MjData, geom_pairs: np.ndarray, model: mujoco.MjModel | None = None,
                  scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where each agent's segments ended, from ``data.qpos`` and the (ncon, 2) contact geom pairs: (N, S) height
    (m) of each segment's origin above the ground, (N, S) ``up`` (the cosine of the angle between its own z axis
    and the vertical), (N, S, 3) its contact points with (object, other agents, ground) and (N, S) whether a foot
    or a thigh touching nothing reaches the object: a foot by bending its knee, a thigh over a seat pan it rose off
    (:func:`rail_mj.mjcf.body.toes_reach`, :func:`rail_mj.mjcf.body.seat_under`), and whether a pelvis touching the
    object has both sitting bones over it, on its hulls and its own surface (:func:`rail_mj.mjcf.body.sit_bones`);
    False for every other segment. ``model``: the rollout's own model when it is not ``scene.model`` (a perturbed
    world's, the same layout); ``scale``: that world's mesh scale (the surface is the nominal mesh)."""
    m = scene.model if model is None else model
    mujoco.mj_kinematics(m, data)
    bodies = scene.agent_bodies
    n, s = bodies.shape
    height = data.xpos[bodies, 2]
    up = data.xmat[bodies, 8]
    segment = np.full(m.nbody, -1, dtype=np.int64)
    for row in bodies:
        segment[row] = np.arange(s)
    contacts = np.zeros((n, s, 3), dtype=np.int64)
    if len(geom_pairs):
        owner = scene.geom_owner[geom_pairs]
        seg = segment[m.geom_bodyid[geom_pairs]]
        for x, y in ((0, 1), (1, 0)):
            kind = np.where(owner[:, y] == OWNER_OBJECT, 0, np.where(owner[:, y] == OWNER_GROUND, 2,
                                                                      np.where(owner[:, y] >= 0, 1, -1)))
            counted = (owner[:, x] >= 0) & (kind >= 0)
            np.add.at(contacts, (owner[counted, x], seg[counted, x], kind[counted]), 1)
    reach = np.zeros((n, s), dtype=bool)
    probes = [(k, REACH_PROBES[name], False) for k, name in enumerate(scene.segment_names) if name in REACH_PROBES]
    probes += [(k, BEARING_PROBES[name], True) for k, name in enumerate(scene.segment_names) if name in BEARING_PROBES]
    if probes:
        geoms = np.nonzero(scene.geom_owner == OWNER_OBJECT)[0]
        body = int(m.geom_bodyid[geoms[0]])
        own = None if scene.surface is None or scene.surface_data is None else OwnSurface(
            scene.surface, scene.surface_data, data.xpos[body].copy(), data.xmat[body].reshape(3, 3).copy(), scale)
        for i in range(n):
            for k, probe, touching in probes:
                if touching and contacts[i, k, 0]:
                    reach[i, k] = probe(m, data, int(bodies[i, k]), geoms, own)
                elif not touching and not contacts[i, k].any():
                    reach[i, k] = probe(m, data, int(bodies[i, k]), geoms)
    return height, up, contacts, reach


def _contact(geom: mujoco.MjsGeom, solref: list[float], contype: int, conaffinity: int) -> None:
    geom.contype = contype
    geom.conaffinity = conaffinity
    geom.solref = solref  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works


def _mesh_inertia(obj: RailObject, physics: ScenePhysics) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """(mass, ipos, inertia diagonal, iquat) MuJoCo computes for the object's hull meshes."""
    spec = mujoco.MjSpec()
    add_object(spec, obj, physics=physics)
    try:
        m = spec.compile()
    except ValueError as exc:
        raise SceneError(f"the hulls of {obj.name!r} do not compile: {exc}") from exc
    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
    return float(m.body_mass[b]), m.body_ipos[b].copy(), m.body_inertia[b].copy(), m.body_iquat[b].copy()


def add_object(
    spec: mujoco.MjSpec,
    obj: RailObject,
    *,
    pos: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    quat: Sequence[float] | np.ndarray = (1.0, 0.0, 0.0, 0.0),
    free: bool = True,
    physics: ScenePhysics = ScenePhysics(),
    hull_boxes: int = 0,
) -> mujoco.MjsBody:
    """Add the object body ``object`` (one geom per hull, its mass split by hull volume) to ``spec``.

    With ``free`` it gets the free joint ``object``. ``hull_boxes`` > 0 replaces each hull by its oriented box
    and pads the object to that many geoms (the MJX-JAX shape buckets).
    """
    if not obj.hulls:
        raise SceneError(f"object {obj.name!r} has no hulls; build it with rail_mj.mesh")
    if hull_boxes and len(obj.hulls) > hull_boxes:
        raise SceneError(f"object {obj.name!r} has {len(obj.hulls)} hulls, more than the bucket of {hull_boxes}")
    solref = physics.solref
    body = spec.worldbody.add_body(
        name=OBJECT_BODY,
        pos=np.asarray(pos, dtype=np.float64).tolist(),
        quat=np.asarray(quat, dtype=np.float64).tolist(),
    )
    if free:
        body.add_freejoint(name=OBJECT_JOINT)
    volumes = np.array([ConvexHull(h).volume for h in obj.hulls])
    shares = volumes / volumes.sum()
    for i, (hull, share) in enumerate(zip(obj.hulls, shares, strict=True)):
        if hull_boxes:
            # MJX-JAX collides spheres with general hulls wrongly (design.md): one oriented box per hull
            to_origin, extents = trimesh.bounds.oriented_bounds(np.asarray(hull))
            frame = np.linalg.inv(to_origin)
            box_quat = np.zeros(4)
            mujoco.mju_mat2Quat(box_quat, np.ascontiguousarray(frame[:3, :3], dtype=np.float64).ravel())
            geom = body.add_geom(name=hull_geom_name(i), type=mujoco.mjtGeom.mjGEOM_BOX,
                                 size=np.maximum(extents / 2, 1e-4),
                                 pos=frame[:3, 3], quat=box_quat)  # pyright: ignore[reportArgumentType]  # stub: arrays work
        else:
            mesh = spec.add_mesh(name=hull_geom_name(i))
            mesh.uservert = np.asarray(hull, dtype=np.float64).ravel().tolist()
            if physics.max_hull_vertices is not None:
                mesh.maxhullvert = physics.max_hull_vertices
            # MuJoCo recentres mesh assets on their inertial frame and moves the geom frame to
            # compensate, so a geom at the body origin shows the vertices exactly where they are.
            geom = body.add_geom(name=hull_geom_name(i), type=mujoco.mjtGeom.mjGEOM_MESH, meshname=hull_geom_name(i))
        geom.mass = float(obj.mass * share)  # hulls may overlap: split the object's mass by hull volume
        geom.rgba = [0.8, 0.6, 0.4, 1.0]  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works
        geom.friction = physics.friction3  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works
        _contact(geom, solref, OBJECT_BIT, GROUND_BIT | AGENT_BIT)
    # pad to the bucket's geom count with tiny massless boxes hidden inside the first hull, so a new
    # object of the same bucket has the same shapes (MJX compiles once per bucket)
    inner = np.asarray(obj.hulls[0]).mean(axis=0)
    for i in range(len(obj.hulls), hull_boxes):
        geom = body.add_geom(name=f"{OBJECT_BODY}/pad{i}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[1e-5] * 3, pos=inner)
        geom.mass = 0.0
        geom.friction = physics.friction3  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works
        _contact(geom, solref, OBJECT_BIT, GROUND_BIT | AGENT_BIT)
    return body


def add_agent(
    spec: mujoco.MjSpec,
    fragment: mujoco.MjSpec,
    i: int,
    *,
    pos: Sequence[float] | np.ndarray,
    quat: Sequence[float] | np.ndarray,
    physics: ScenePhysics = ScenePhysics(),
    collide_agents: bool = True,
) -> mujoco.MjsBody:
    """Attach agent ``i``: the body of a checked fragment spec (``check_fragment``; attaching consumes it).

    The body is named ``agent{i}/<its name>``, gets the free joint ``agent{i}/free`` and is placed at
    ``pos``/``quat`` (the fragment body's own pos/quat are replaced). Its collidable geoms get the scene's
    contact bits and solref; their friction stays the fragment's own.
    """
    conaffinity = GROUND_BIT | OBJECT_BIT | (AGENT_BIT if collide_agents else 0)
    name = agent_body_name(fragment, i)
    body = spec.worldbody.add_frame().attach_body(fragment.worldbody.first_body(), agent_prefix(i), "")
    body.name = name
    body.pos = np.asarray(pos, dtype=np.float64).tolist()
    body.quat = np.asarray(quat, dtype=np.float64).tolist()
    body.add_freejoint(name=agent_prefix(i) + "free")
    for geom in body.find_all(mujoco.mjtObj.mjOBJ_GEOM):
        if geom.contype or geom.conaffinity:
            _contact(geom, physics.solref, AGENT_BIT, conaffinity)
    return body


def _add_agents(
    spec: mujoco.MjSpec, agents: AgentSetup, pos: np.ndarray, quat: np.ndarray, physics: ScenePhysics
) -> None:
    offsets = np.asarray(agents.offsets, dtype=np.float64)
    if offsets.ndim != 2 or offsets.shape[1] != 3 or len(offsets) == 0 or not np.isfinite(offsets).all():
        raise SceneError(f"agents.offsets must be a finite (N, 3) array with N >= 1, got shape {offsets.shape}")
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    centres = pos + offsets @ rot.reshape(3, 3).T
    check_fragment(agents.fragment)
    for i, centre in enumerate(centres):
        # a fresh spec per agent: attaching moves its elements; the fragment passed the check above
        add_agent(spec, mujoco.MjSpec.from_string(agents.fragment), i, pos=centre, quat=quat, physics=physics,
                  collide_agents=agents.collide_agents)


def _pose(label: str, value: Sequence[float] | np.ndarray, n: int) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (n,) or not np.isfinite(arr).all() or (n == 4 and np.linalg.norm(arr) < 1e-9):
        raise SceneError(f"{label} must be {n} finite numbers (a quaternion non-zero, wxyz), got {value!r}")
    return arr / np.linalg.norm(arr) if n == 4 else arr


def _spec(
    obj: RailObject,
    *,
    object_pos: Sequence[float] | np.ndarray,
    object_quat: Sequence[float] | np.ndarray,
    object_free: bool,
    agents: AgentSetup | None,
    agents_pos: Sequence[float] | np.ndarray,
    agents_quat: Sequence[float] | np.ndarray,
    physics: ScenePhysics,
    ground: bool,
    hull_boxes: int,
) -> mujoco.MjSpec:
    object_pos, object_quat = _pose("object_pos", object_pos, 3), _pose("object_quat", object_quat, 4)
    agents_pos, agents_quat = _pose("agents_pos", agents_pos, 3), _pose("agents_quat", agents_quat, 4)
    if not obj.hulls:
        raise SceneError(f"object {obj.name!r} has no hulls; build it with rail_mj.mesh")
    spec = mujoco.MjSpec()
    spec.modelname = f"rail_{obj.name}"
    spec.option.timestep = physics.timestep
    if physics.iterations is not None:
        spec.option.iterations = physics.iterations
    if physics.ls_iterations is not None:
        spec.option.ls_iterations = physics.ls_iterations
    if physics.speculative:
        spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SPECULATIVE
    if ground:
        plane = spec.worldbody.add_geom(name=GROUND_GEOM, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 0.05])
        plane.friction = physics.friction3  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works
        _contact(plane, physics.solref, GROUND_BIT, 0)
    add_object(spec, obj, pos=object_pos, quat=object_quat, free=object_free, physics=physics, hull_boxes=hull_boxes)
    if agents is not None:
        _add_agents(spec, agents, agents_pos, agents_quat, physics)
    return spec


def build_scene(
    obj: RailObject,
    *,
    object_pos: Sequence[float] = (0.0, 0.0, 0.0),
    object_quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    object_free: bool = True,
    agents: AgentSetup | None = None,
    agents_pos: Sequence[float] = (0.0, 0.0, 0.0),
    agents_quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    timestep: float = 0.005,
    ground: bool = True,
    hull_boxes: int = 0,
    max_hull_vertices: int | None = None,
) -> mujoco.MjSpec:
    """Compose ground, object and agents into one editable spec (compiled once here to check it).

    The object body ``object`` holds one mesh geom per hull; with ``object_free``
    it has a free joint ``object``, else it is fixed at ``object_pos/quat``.
    Agent ``i`` is the fragment's body, prefixed ``agent{i}/``, with a free joint
    ``agent{i}/free``, at ``agents_pos + R(agents_quat) @ offsets[i]`` with
    orientation ``agents_quat`` (the fragment body's own pos/quat are replaced).
    ``hull_boxes`` > 0 replaces each hull by its oriented box and pads the object to
    that many geoms (the MJX-JAX shape buckets). ``max_hull_vertices`` lets MuJoCo
    simplify each hull mesh further (collision cost grows with hull vertices).
    """
    physics = ScenePhysics(timestep=timestep, max_hull_vertices=max_hull_vertices)
    spec = _spec(obj, object_pos=object_pos, object_quat=object_quat, object_free=object_free, agents=agents,
                 agents_pos=agents_pos, agents_quat=agents_quat, physics=physics, ground=ground, hull_boxes=hull_boxes)
    try:
        spec.compile()
    except Exception as exc:  # compile errors come as ValueError with MuJoCo's message
        raise SceneError(f"scene for {obj.name!r} does not compile: {exc}") from exc
    return spec


def compose_scene(
    obj: RailObject,
    agents: AgentSetup | None = None,
    physics: ScenePhysics = ScenePhysics(),
    *,
    hull_boxes: int = 0,
    joint_damping: float = 0.0,
    rolling_friction: float = 0.0,
) -> Scene:
    """The compiled one-world scene: ground, the free object at the origin, free agents; one compile.

    ``hull_boxes`` > 0 gives the box bucket scene; its object keeps the inertia of the hull meshes, so box and
    mesh scenes weigh the same. ``joint_damping`` and ``rolling_friction`` > 0 damp the object's free joint
    and give its geoms rolling friction (round objects come to rest in a stable-pose drop).
    """
    spec = _spec(obj, object_pos=(0.0, 0.0, 0.0), object_quat=(1.0, 0.0, 0.0, 0.0), object_free=True, agents=agents,
                 agents_pos=(0.0, 0.0, 0.0), agents_quat=(1.0, 0.0, 0.0, 0.0), physics=physics, ground=True,
                 hull_boxes=hull_boxes)
    spec.modelname = _SCENE_NAME
    body = spec.body(OBJECT_BODY)
    if hull_boxes:
        mass, ipos, inertia, iquat = _mesh_inertia(obj, physics)
        body.explicitinertial = True
        body.mass, body.ipos, body.inertia, body.iquat = mass, ipos, inertia, iquat
    if joint_damping or rolling_friction:
        spec.joint(OBJECT_JOINT).damping = [joint_damping, 0.0, 0.0]  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works
        for g in body.geoms:
            g.condim = 6
            g.friction = [physics.friction, rolling_friction, rolling_friction]
    try:
        model = spec.compile()
    except ValueError as exc:
        raise SceneError(f"the scene for {obj.name!r} does not compile: {exc}") from exc
    n_agents = 0 if agents is None else len(agents.offsets)
    owner = np.full(model.ngeom, OWNER_OBJECT, dtype=np.int64)
    owner[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, GROUND_GEOM)] = OWNER_GROUND
    agent_qpos = np.zeros(n_agents, dtype=np.int64)
    agent_dof = np.zeros(n_agents, dtype=np.int64)
    bodies = []
    for i in range(n_agents):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, agent_prefix(i) + "free")
        agent_qpos[i], agent_dof[i] = model.jnt_qposadr[jid], model.jnt_dofadr[jid]
        root = model.jnt_bodyid[jid]
        owner[model.body_rootid[model.geom_bodyid] == root] = i  # every segment's geoms are the agent's
        bodies.append(np.nonzero(model.body_rootid == root)[0])
    hinges = np.nonzero(np.isin(model.jnt_bodyid, np.concatenate(bodies) if bodies else [])
                        & (model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE))[0]
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, OBJECT_JOINT)
    return Scene(model=model, n_agents=n_agents, object_qpos=int(model.jnt_qposadr[jid]),
                 object_dof=int(model.jnt_dofadr[jid]), agent_qpos=agent_qpos, agent_dof=agent_dof, geom_owner=owner,
                 surface=None if agents is None else surface_model(obj),
                 hinge_dofs=model.jnt_dofadr[hinges].astype(np.int64),
                 hinge_radius=np.array([_reach(model, int(model.jnt_bodyid[int(j)])) for j in hinges]),
                 agent_bodies=np.stack(bodies).astype(np.int64) if bodies else np.zeros((0, 1), dtype=np.int64))
