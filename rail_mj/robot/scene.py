"""The robot scene (Panda, table, placed object, held agent compiled into one model) and the grasp geometry.

How the hand holds the agent: from above or from the side, how deep, and the scale that makes the agent graspable.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rail_mj.core.errors import FragmentError, RobotError
from rail_mj.core.geometry import quat_conj, quat_rotate
from rail_mj.core.types import RailObject, StablePose
from rail_mj.mjcf import (
    OBJECT_BODY,
    OBJECT_JOINT,
    OWNER_GROUND,
    OWNER_OBJECT,
    OWNER_OTHER,
    ScenePhysics,
    add_agent,
    add_object,
    agent_prefix,
    check_fragment,
)
from rail_mj.robot.arm import HOME_QPOS, MONITORED_BODIES, ArmIndex
from rail_mj.robot.control import RobotConfig, make_torque_controlled
from rail_mj.robot.ik import ArmIK
from rail_mj.robot.model import load_panda_spec

__all__ = [
    "GRASP_QUAT",
    "GRASP_TWIN",
    "TOP_GRASPS",
    "Neighbour",
    "RobotScene",
    "build_robot_scene",
    "hand_z",
    "side_grasp",
    "side_grasps",
    "home_grip",
    "graspable_scale",
]

#: Hand z below the hand frame where the fingertips end (Menagerie finger mesh), m.
_FINGERTIP_Z = 0.1125
#: Agent frame -> hand frame: the hand points down (its z = the agent's -z).
GRASP_QUAT = np.array([0.0, 1.0, 0.0, 0.0])
#: The same grasp turned half a turn about the hand's axis: a parallel gripper holds the item alike either way round,
#: and the wrist may reach one where its joint limits refuse the other.
GRASP_TWIN = np.array([0.0, 0.0, 1.0, 0.0])
#: The grasps that hold the item from above.
TOP_GRASPS = (GRASP_QUAT, GRASP_TWIN)
#: A plan whose path runs at least this far, and more horizontally than vertically, may be held from the side, m.
_SIDE_PUSH = 0.01
_PRIMITIVES = (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CAPSULE,
               mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_ELLIPSOID)


@dataclass(frozen=True)
class Neighbour:
    """Another object standing on the table beside the one the robot works on: where, and in which pose."""

    obj: RailObject
    pose: StablePose
    xy: tuple[float, float]  # where its task frame's centre stands on the table, world m


def _add_fixed(spec: mujoco.MjSpec, other: Neighbour, table_height: float, index: int) -> None:
    """A neighbour's hulls as fixed world geoms (static: the IK's obstacles, as the table is)."""
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(other.pose.quat, dtype=np.float64))
    shift = np.asarray(other.pose.pos, dtype=float) + np.array([*other.xy, table_height])
    for i, hull in enumerate(other.obj.hulls):
        name = f"neighbour{index}_{i}"
        world = np.asarray(hull, dtype=float) @ rot.reshape(3, 3).T + shift
        spec.add_mesh(name=name, uservert=world.ravel().tolist())
        spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name,
                                rgba=[0.55, 0.45, 0.35, 1])


@dataclass(frozen=True)
class RobotScene:
    """A compiled robot + table (+ object + agent) scene and the ids used during execution."""

    model: mujoco.MjModel
    arm: ArmIndex
    agent_body: int  # -1 without agent
    weld: int  # -1 without agent
    agent_qpos: int  # qpos address of the agent's free joint
    agent_dof: int
    object_body: int  # -1 without object
    object_qpos: int
    object_dof: int
    monitored: np.ndarray  # (ngeom,) bool: hand geoms
    agent_geoms: np.ndarray  # (ngeom,) bool
    geom_owner: np.ndarray  # (ngeom,) rail_mj.mjcf owner codes: agent 0, object, ground (table, floor), other
    task_origin: np.ndarray  # (3,) world position of the task frame at placement
    half_extents: np.ndarray  # (3,)
    agent_scale: float
    agent_solref: np.ndarray  # (n_agent_geoms, 2) the composer's (the imagination's) solref, restored at release
    ik: ArmIK  # the scene's mink solver for the control site


def _agent_spec(fragment: str, scale: float) -> mujoco.MjSpec:
    """The checked fragment (``rail_mj.mjcf.check_fragment``: untrusted MJCF) scaled by ``scale``."""
    spec = check_fragment(fragment)
    for i, g in enumerate(spec.geoms):
        if g.type not in _PRIMITIVES:
            raise FragmentError(f"agent geom {i} has type {g.type.name}; the robot carries primitive agents only "
                                f"({', '.join(t.name for t in _PRIMITIVES)})")
        g.pos = np.asarray(g.pos) * scale
        g.size = np.asarray(g.size) * scale
        if not np.isnan(g.fromto[0]):
            g.fromto = np.asarray(g.fromto) * scale
        if not np.isnan(g.mass):
            g.mass = g.mass * scale**3
    top = spec.worldbody.first_body()
    # an articulated figure (the seat and lie kinds' body) is carried as one rigid piece in the posture it was
    # imagined in, as a doll's stiff joints hold it: its posture springs are set for its imagined size, and
    # scaled to a graspable size they would swing it out of the hand's weld
    for joint in _figure_joints(spec):
        spec.delete(joint)
    nested = top.find_all(mujoco.mjtObj.mjOBJ_BODY)
    for body in nested:
        body.pos = np.asarray(body.pos) * scale
    for body in [top, *nested]:
        if body.explicitinertial:
            body.mass, body.ipos = body.mass * scale**3, np.asarray(body.ipos) * scale
            body.inertia = np.asarray(body.inertia) * scale**5
    return spec


def _figure_joints(spec: mujoco.MjSpec) -> list:
    """The joints inside a fragment's agent body: those of an articulated figure, none for a rigid agent."""
    return spec.worldbody.first_body().find_all(mujoco.mjtObj.mjOBJ_JOINT)


def _agent_extent(fragment: str) -> np.ndarray:
    """Full size of the agent body's axis-aligned box in its own frame, (3,)."""
    model = check_fragment(fragment).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = 1  # the fragment's top body (0 is the world)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for g in range(model.ngeom):
        rot = data.geom_xmat[g].reshape(3, 3)
        centre = data.geom_xpos[g] + rot @ model.geom_aabb[g, :3] - data.xpos[body]
        half = np.abs(rot) @ model.geom_aabb[g, 3:]
        lo, hi = np.minimum(lo, centre - half), np.maximum(hi, centre + half)
    return hi - lo


def hand_z(grasp: np.ndarray) -> np.ndarray:
    """The hand's z axis (where the fingers point) in the agent's frame, for the grasp ``grasp``."""
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(grasp, dtype=np.float64))
    return rot.reshape(3, 3)[2]


def _grasp_depth(extent: np.ndarray, grasp: np.ndarray) -> float:
    """Half the agent's box (full size ``extent``, its own frame) along the hand's z for the grasp ``grasp``."""
    return float(np.abs(hand_z(grasp)) @ extent / 2)


def side_grasp(direction: np.ndarray, fingers_vertical: bool = False) -> np.ndarray:
    """The grasp (agent frame -> hand frame, wxyz) of a hand pointing along ``direction`` (agent frame, horizontal):
    it holds the item from behind as it pushes it, the fingers closing across it horizontally or vertically."""
    z = np.array([direction[0], direction[1], 0.0])
    z /= np.linalg.norm(z)
    y = np.array([0.0, 0.0, 1.0]) if fingers_vertical else np.array([-z[1], z[0], 0.0])
    hand_in_agent = np.column_stack([np.cross(y, z), y, z])
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, hand_in_agent.T.ravel())
    return quat


def build_robot_scene(cfg: RobotConfig, *, obj: RailObject | None = None, pose: StablePose | None = None,
                agent_fragment: str | None = None, agent_scale: float = 1.0,
                boxes: tuple[tuple[np.ndarray, np.ndarray], ...] = (), visual: bool | None = None,
                grasp: np.ndarray = GRASP_QUAT, others: tuple[Neighbour, ...] = ()) -> RobotScene:
    """Compile the torque-controlled Panda on a floor, a table, the placed object and the welded agent.

    The object and the agent come from the imagination's scene composer (``rail_mj.mjcf``), with its contact
    constants at the robot's timestep; the table and floor are the ground. ``boxes`` adds fixed boxes
    ``(centre, half_size)`` in the world (used for scripted collisions). ``grasp``: how the hand holds the agent
    (agent frame -> hand frame): from above by default, or :func:`side_grasp`. ``others``: the other objects
    standing on the table, fixed there (obstacles the IK keeps the hand off).
    """
    spec = load_panda_spec(visual=cfg.visual if visual is None else visual)
    make_torque_controlled(spec)
    spec.option.timestep = cfg.dt
    physics = ScenePhysics(timestep=cfg.dt)
    floor = spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05],
                                    rgba=[0.3, 0.35, 0.4, 1])
    tx, ty = cfg.object_xy
    th = cfg.table_height
    sx, sy = cfg.table_half_size
    cx, cy = cfg.table_xy if cfg.table_xy is not None else cfg.object_xy
    table = spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx, sy, th / 2],
                                    pos=[cx, cy, th / 2], rgba=[0.6, 0.6, 0.55, 1])
    for k, other in enumerate(others):
        _add_fixed(spec, other, th, k)
    for ground in (floor, table):
        ground.solref, ground.friction = physics.solref, physics.friction3  # pyright: ignore[reportAttributeAccessIssue]  # stub: any sequence works
    for i, (centre, half) in enumerate(boxes):
        spec.worldbody.add_geom(name=f"box{i}", type=mujoco.mjtGeom.mjGEOM_BOX, size=half,
                                pos=centre, rgba=[0.7, 0.2, 0.2, 1])  # pyright: ignore[reportArgumentType]  # stub: arrays work
    half_extents = np.zeros(3)
    shift = np.array([tx, ty, th])
    if obj is not None:
        if pose is None:
            raise RobotError("build_robot_scene: an object needs its stable pose")
        half_extents = np.asarray(pose.half_extents, dtype=float)
        add_object(spec, obj, pos=np.asarray(pose.pos, dtype=float) + shift, quat=np.asarray(pose.quat, dtype=float),
                   physics=physics)
    grip_z = _FINGERTIP_Z
    agent_name = ""
    agent_geoms: list[mujoco.MjsGeom] = []
    if agent_fragment is not None:
        agent = add_agent(spec, _agent_spec(agent_fragment, agent_scale), 0, pos=(0.0, 0.0, 0.0),
                          quat=(1.0, 0.0, 0.0, 0.0), physics=physics)
        agent_name = agent.name
        agent_geoms = agent.find_all(mujoco.mjtObj.mjOBJ_GEOM)
        grip_z += _grasp_depth(_agent_extent(agent_fragment) * agent_scale, grasp) + cfg.grip_gap
        for name in ("hand", "left_finger", "right_finger"):
            spec.add_exclude(bodyname1=name, bodyname2=agent_name)
        spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY, name="hold",
                          name1="hand", name2=agent_name,
                          data=[0, 0, 0, 0, 0, grip_z, *grasp, 1, 0])
    spec.body("hand").add_site(name="grip", pos=[0, 0, grip_z], quat=list(grasp))
    for geom in [g for g in spec.geoms if g.parent.name in MONITORED_BODIES] + agent_geoms:
        geom.solref = [cfg.compliance, 1.0]
    try:
        model = spec.compile()
    except Exception as exc:  # MuJoCo compile errors
        raise RobotError(f"robot scene does not compile: {exc}") from exc

    has_agent = agent_fragment is not None
    agent_body = model.body(agent_name).id if has_agent else -1
    agent_joint = model.joint(agent_prefix(0) + "free").id if has_agent else -1
    objb = model.body(OBJECT_BODY).id if obj is not None else -1
    object_joint = model.joint(OBJECT_JOINT).id if obj is not None else -1
    owner = np.full(model.ngeom, OWNER_OTHER, dtype=np.int64)
    owner[[model.geom("floor").id, model.geom("table").id]] = OWNER_GROUND
    root = model.body_rootid[model.geom_bodyid]
    if obj is not None:
        owner[root == objb] = OWNER_OBJECT
    if has_agent:
        owner[root == agent_body] = 0
    arm = ArmIndex.of(model, "grip")
    return RobotScene(
        model=model,
        arm=arm,
        agent_body=agent_body,
        weld=model.equality("hold").id if has_agent else -1,
        agent_qpos=int(model.jnt_qposadr[agent_joint]) if has_agent else -1,
        agent_dof=int(model.jnt_dofadr[agent_joint]) if has_agent else -1,
        object_body=objb,
        object_qpos=int(model.jnt_qposadr[object_joint]) if obj is not None else -1,
        object_dof=int(model.jnt_dofadr[object_joint]) if obj is not None else -1,
        monitored=np.isin(model.geom_bodyid, [model.body(n).id for n in MONITORED_BODIES]),
        agent_geoms=owner == 0,
        geom_owner=owner,
        task_origin=shift + np.array([0.0, 0.0, half_extents[2]]),
        half_extents=half_extents,
        agent_scale=agent_scale,
        agent_solref=np.tile(physics.solref, (int((owner == 0).sum()), 1)),
        ik=ArmIK(model, arm, min_distance=cfg.ik_clearance),
    )


def side_grasps(positions: np.ndarray, final_quat: np.ndarray) -> list[np.ndarray]:
    """The side grasps worth trying for a path ``(K, 3)`` (task frame) ending with the agent at ``final_quat``:
    a hand pointing along the push, fingers across it horizontally, then vertically; none for a path that
    does not push mostly horizontally (a drop from above, a set-down)."""
    push = positions[-1] - positions[0]
    if np.linalg.norm(push[:2]) < max(_SIDE_PUSH, abs(push[2])):
        return []
    direction = quat_rotate(quat_conj(final_quat), push)  # task frame -> the agent's frame
    return [side_grasp(direction), side_grasp(direction, fingers_vertical=True)]


def home_grip(scene: RobotScene) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(scene.model)
    data.qpos[scene.arm.qpos] = HOME_QPOS
    mujoco.mj_kinematics(scene.model, data)
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, data.site_xmat[scene.arm.site])
    return data.site_xpos[scene.arm.site].copy(), q


def graspable_scale(fragment: str, half_extents: np.ndarray, cfg: RobotConfig) -> float:
    """Scale that makes the agent graspable (cfg.agent_size) but smaller than the object's footprint. An
    articulated figure (the seat and lie kinds' body) keeps its own size, 1: it is the doll or teddy the request
    names, imagined at that size on furniture of that size, and the hand holds it by its trunk."""
    if _figure_joints(check_fragment(fragment)):
        return 1.0
    size = float(np.max(_agent_extent(fragment)))
    lo, hi = cfg.agent_size
    target = min(max(size, lo), hi, 0.5 * 2 * float(np.min(half_extents[:2])))
    return target / size
