"""Data that crosses stage boundaries: objects, stable poses, rollout inputs and outcomes.

Frames (used everywhere in rail_mj)
-----------------------------------
* **mesh frame** — the object's own frame after units and up-axis conversion
  (metres, z up). Hull vertices, ``com`` and ``functional_up`` labels live here.
* **world** — z up, ground plane at z = 0.
* **stable pose** ``(pos, quat)`` — places the mesh frame in the world so that
  the object rests on the ground: its world-aligned bounding box is centred at
  x = y = 0 and its lowest point touches z = 0.
* **task frame** — the frame agents, trajectories and scoring work in. Its
  origin is the centre of the object's world-aligned bounding box in the stable
  pose, its axes are the world axes at placement, and it is rigidly attached to
  the object (if the object tips over, the frame tips with it). In the task
  frame the object occupies ``[-h, h]`` per axis, where
  ``h = Outcomes.object_half_extents``; "up" is +z; the object's top is at
  ``z = h[2]`` and the ground at ``z = -h[2]``.

Quaternions are MuJoCo's ``(w, x, y, z)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rail_mj.core.geometry import up_in_mesh_frame

__all__ = [
    "RailObject",
    "Basin",
    "StablePose",
    "StablePoses",
    "AgentSetup",
    "Outcomes",
    "SCORING_ARGS",
]


@dataclass(frozen=True, eq=False)
class RailObject:
    """A loaded, repaired, convex-decomposed object (mesh frame, metres)."""

    name: str
    mesh: Any  # trimesh.Trimesh, kept untyped to avoid importing trimesh here
    hulls: tuple[np.ndarray, ...]  # each (V, 3) float64 convex-hull vertices, mesh frame
    mesh_hash: str  # SHA-256 of the source bytes (or of the mesh arrays)
    obb_dims: np.ndarray  # (3,) oriented-bounding-box extents, metres, sorted descending
    com: np.ndarray  # (3,) centre of mass, mesh frame
    mass: float  # kg, from the density
    density: float  # kg / m^3
    source: str = ""  # the file it came from, if any
    #: its mesh frame's +z is the up it came in (a file's up, the table a scan stood on), evidence of the pose it
    #: was made to stand in (rail_mj.stable_poses.came_in); False: it came in an arbitrary orientation
    oriented: bool = True

    @property
    def extents(self) -> np.ndarray:
        """Axis-aligned extents of the mesh in the mesh frame, (3,)."""
        lo, hi = np.asarray(self.mesh.bounds)
        return hi - lo


@dataclass(frozen=True)
class Basin:
    """Where water poured into an object's deepest basin stands, in one pose (seen from above)."""

    #: height (m) above the lowest point at which the water spills over: the lowest point of the rim, unlike the
    #: box a handle may raise
    rim: float
    #: (2,) x, y (m) of the middle of the water surface: from the box centre in a pose's task frame (where a pour
    #: aims; a long handle moves the box centre off it)
    opening: np.ndarray
    #: (m) the water surface's longer side along x or y at the spill level
    length: float
    #: height (m) above the lowest point of the basin's floor where it is deepest: a mug's base, a wine glass's stem
    floor: float = 0.0


@dataclass(frozen=True)
class StablePose:
    """One stable resting pose of an object on the ground."""

    pos: np.ndarray  # (3,) world position of the mesh-frame origin
    quat: np.ndarray  # (4,) wxyz world orientation of the mesh frame
    probability: float  # fraction of drops that ended in this pose
    half_extents: np.ndarray  # (3,) half-sizes of the world-aligned bounding box in this pose
    basin: Basin | None = None  # the pose's deepest basin; None without one
    toe_room: float | None = None  # the widest foot (m) that gets under its middle at toe height; None: not mapped

    @property
    def up_in_mesh_frame(self) -> np.ndarray:
        """The mesh-frame unit vector that points to world +z in this pose."""
        return up_in_mesh_frame(np.asarray(self.quat, dtype=np.float64))


@dataclass(frozen=True)
class StablePoses:
    """The set G_s of stable poses of one object, most probable first."""

    poses: tuple[StablePose, ...]
    n_drops: int  # how many drops were simulated
    n_unsettled: int  # drops that were still moving at the time limit

    def __len__(self) -> int:
        return len(self.poses)

    def __iter__(self):
        return iter(self.poses)

    def __getitem__(self, i: int) -> StablePose:
        return self.poses[i]


@dataclass(frozen=True)
class AgentSetup:
    """What the imagination needs to know about the agents of one profile.

    ``fragment`` is an MJCF ``<mujoco>`` document whose ``<worldbody>`` holds
    exactly one body (the agent; no joints, the scene adds a free joint).
    ``offsets`` are the agents' positions relative to the layout centre (task
    frame axes); every agent has the same orientation as the layout centre.
    """

    fragment: str
    offsets: np.ndarray  # (N, 3)
    collide_agents: bool = True  # agent-agent contacts (droplets pile up; a lone agent does not care)


#: Parameter names, in order, of a generated scoring function
#: ``def score(agent_pos, agent_quat, ...) -> array of shape (B,)``.
SCORING_ARGS: tuple[str, ...] = (
    "agent_pos",
    "agent_quat",
    "agent_vel",
    "contacts_object",
    "contacts_agents",
    "contacts_ground",
    "object_pos",
    "object_tilt",
    "object_half_extents",
)


@dataclass(frozen=True)
class Outcomes:
    """Resultant configurations of a batch of imagination rollouts.

    Leading axis B = stable poses × plans, pose-major: rollout ``b`` is pose
    ``pose_index[b]`` and plan ``plan_index[b]``. N = number of agents.
    Positions and orientations are in the task frame (see the module doc) at
    the end of the rollout.
    """

    pose_index: np.ndarray  # (B,) int
    plan_index: np.ndarray  # (B,) int
    agent_pos: np.ndarray  # (B, N, 3) float, agent centres in the task frame
    agent_quat: np.ndarray  # (B, N, 4) float, agent orientation in the task frame, wxyz
    agent_vel: np.ndarray  # (B, N, 3) float, linear velocity, world frame, m/s
    contacts_object: np.ndarray  # (B, N) int, contact points agent–object
    contacts_agents: np.ndarray  # (B, N) int, contact points agent–other agents
    contacts_ground: np.ndarray  # (B, N) int, contact points agent–ground
    released_early: np.ndarray  # (B, N) bool, released on collision before the trajectory ended
    object_pos: np.ndarray  # (B, 3) float, displacement of the task-frame origin in the world, m
    object_quat: np.ndarray  # (B, 4) float, final object orientation relative to placement, wxyz
    object_tilt: np.ndarray  # (B,) float, angle between task-frame +z and world +z at the end, rad
    object_half_extents: np.ndarray  # (B, 3) float, the object's half-sizes in the task frame
    settled: np.ndarray  # (B,) bool, every body slower than the settle threshold at the end
    # (B, N) int, the most consecutive of the enclosure probe's horizontal directions in which a ray from the agent's
    # centre leaves without meeting the object (0: walled all round); None where no probe ran (e.g. the robot)
    agent_open_sector: np.ndarray | None = None
    # (B,) int, the perturbed world of each rollout (rail_mj.imagination.perturb; 0: nominal); None: all nominal
    world: np.ndarray | None = None
    # (B,) bool, the rollout blew up: a non-finite state or a MuJoCo instability warning; None: none checked
    unstable: np.ndarray | None = None
    # An articulated agent's segments (S of them, the root first; names in ``segment_names``), None for one-body
    # agents: (B, N, S) height of each segment's origin above the ground, m; (B, N, S) cosine of the angle between
    # its own z axis and the vertical; (B, N, S, 3) its contact points with (object, other agents, ground); (B, N, S)
    # bool, a foot or a thigh touching nothing that reaches the object (rail_mj.mjcf.body.toes_reach, seat_under)
    segment_height: np.ndarray | None = None
    segment_up: np.ndarray | None = None
    segment_contacts: np.ndarray | None = None
    segment_reach: np.ndarray | None = None
    segment_names: tuple[str, ...] | None = None

    @property
    def batch(self) -> int:
        return int(self.pose_index.shape[0])

    @property
    def n_agents(self) -> int:
        return int(self.agent_pos.shape[1])

    def scoring_kwargs(self) -> dict[str, np.ndarray]:
        """The arrays a generated scoring function receives, by name."""
        return {name: getattr(self, name) for name in SCORING_ARGS}
