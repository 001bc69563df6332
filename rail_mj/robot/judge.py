"""The experiment's own judge: did the item end where the request put it? A physical check of the end state,
written apart from every plan's scoring code.

Per preposition and agent:

- ``in``: each item rests (moves under :data:`REST_SPEED` over a :data:`WINDOW` of 1 s) inside the object's
  footprint, its centre below the object's rim, off the table (touching neither the table nor the floor, and
  not over the table: straight below its centre lies the object). The place checks hold at both ends of the
  window. Water counts droplets: at least half of them retained.
- ``on``: each item rests touching the object, off the table, its centre over the object's footprint, tipped no
  more than :data:`MAX_TIP` from the orientation it was set down in. A figure (doll, teddy, person) must have its
  pelvis carried by the object: straight down from its centre the first thing is the object (the seat), not the
  table or nothing; its feet may touch the table, as a sitter's stand on the floor.

In both cases the object must still stand (tipped no more than :data:`MAX_TIP`). :func:`observe` reads the end
state out of a MuJoCo simulation; :func:`judge` decides from an :class:`EndState` alone, so hand-built end states
test it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

from rail_mj.core.errors import ConfigError
from rail_mj.mjcf import OWNER_GROUND, OWNER_OBJECT, geom_bottom

__all__ = ["WINDOW", "REST_SPEED", "MAX_TIP", "MIN_RETAINED", "Support", "EndState", "Judgement", "judge", "footprint",
           "observe"]

#: How long the item must rest where it ended, s (the issue's definition of "rests").
WINDOW = 1.0
#: An item whose centre moves slower than this on average over the window rests, m/s: twice the robot's
#: instantaneous settle speed (RobotConfig.settle_speed, 1 cm/s), as a ball rocking in a bowl's well averages more.
REST_SPEED = 0.02
#: Most tilt of an item set on something, and of the object, that still counts as standing, rad (15°: the issue's).
MAX_TIP = np.deg2rad(15.0)
#: Least fraction of the droplets a container must retain for "water in" (more than it spills).
MIN_RETAINED = 0.5

Support = Literal["object", "table", "other", "none"]


@dataclass(frozen=True)
class EndState:
    """What the judge looks at, in world coordinates: N items (droplets, or one item) and the object."""

    preposition: Literal["in", "on"]
    figure: bool  # the agent is a figure with a pelvis (doll, teddy, person)
    water: bool  # the agent is water: droplets are counted
    items: np.ndarray  # (N, 3) item centres at the end
    items_before: np.ndarray  # (N, 3) the same WINDOW seconds earlier
    item_bottom: np.ndarray  # (N,) lowest z of each item (reported: soft contacts sink a thin bottom below it)
    item_tilt: np.ndarray  # (N,) rad, each item's tilt from the orientation it was released in
    touches_object: np.ndarray  # (N,) bool
    touches_table: np.ndarray  # (N,) bool: the table or the floor
    support: tuple[Support, ...]  # (N,) what lies first straight below each item's centre
    footprint: np.ndarray  # (M, 2) the object's footprint polygon (convex, counter-clockwise)
    rim_z: float  # the object's top
    table_z: float  # the table top
    object_tilt: float  # rad
    window: float = WINDOW


@dataclass(frozen=True)
class Judgement:
    """The judge's verdict: success, the checks per item, and a sentence saying why."""

    success: bool
    reason: str
    retained: int  # items that passed every check
    n_items: int
    checks: dict[str, list[bool]] = field(default_factory=dict)
    measured: dict[str, object] = field(default_factory=dict)  # the end state's numbers the checks read

    def to_dict(self) -> dict:
        return {"success": self.success, "reason": self.reason, "retained": self.retained, "n_items": self.n_items,
                "checks": self.checks, "measured": self.measured}


def footprint(world_vertices: np.ndarray) -> np.ndarray:
    """The convex footprint (counter-clockwise polygon) of points ``(K, 3)`` seen from above."""
    xy = np.asarray(world_vertices, dtype=float)[:, :2]
    return xy[ConvexHull(xy).vertices]


def _inside(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Which ``(N, 2)`` points lie inside the convex counter-clockwise ``polygon``."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    rel = points[:, None, :] - polygon[None]
    cross = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]
    return np.all(cross >= 0, axis=1)


def judge(state: EndState) -> Judgement:
    """Success of the end state by the rules of the module docstring."""
    if state.preposition not in ("in", "on"):
        raise ConfigError(f"the judge knows the prepositions 'in' and 'on', got {state.preposition!r}")
    n = len(state.items)
    moved = np.linalg.norm(state.items - state.items_before, axis=1)
    checks: dict[str, np.ndarray] = {
        "rests": moved < REST_SPEED * state.window,
        "over_footprint": (_inside(state.items[:, :2], state.footprint)
                           & _inside(state.items_before[:, :2], state.footprint)),
    }
    off = np.array([s != "table" for s in state.support], dtype=bool)
    # a figure's feet may stand on the table, as a sitter's stand on the floor: its pelvis is what must be off it
    checks["off_table"] = off if state.figure else off & ~state.touches_table
    if state.preposition == "in":
        checks["below_rim"] = (state.items[:, 2] < state.rim_z) & (state.items_before[:, 2] < state.rim_z)
    else:
        checks["touches_object"] = state.touches_object
        checks["upright"] = state.item_tilt <= MAX_TIP
        if state.figure:
            checks["pelvis_on_object"] = np.array([s == "object" for s in state.support])
    ok = np.all(np.stack(list(checks.values())), axis=0) if n else np.zeros(0, bool)
    retained = int(ok.sum())
    standing = state.object_tilt <= MAX_TIP
    need = int(np.ceil(MIN_RETAINED * n)) if state.water else n
    success = bool(n > 0 and standing and retained >= max(1, need))
    if success:
        what = f"{retained} of {n} droplets retained" if state.water else "every check holds"
        reason = f"{state.preposition!r}: {what}"
    elif not standing:
        reason = f"the object tipped {np.rad2deg(state.object_tilt):.0f} deg (most {np.rad2deg(MAX_TIP):.0f})"
    else:
        failed = sorted({k for k, v in checks.items() for i in range(n) if not v[i]})
        reason = (f"{state.preposition!r}: {retained} of {n} items pass (need {max(1, need)}); failed: "
                  f"{', '.join(failed)}")
    measured = {"moved_m": np.round(moved, 4).tolist(), "item_z": np.round(state.items[:, 2], 4).tolist(),
                "item_bottom": np.round(state.item_bottom, 4).tolist(), "rim_z": round(state.rim_z, 4),
                "table_z": round(state.table_z, 4), "touches_table": [bool(x) for x in state.touches_table],
                "support": list(state.support), "item_tilt_deg": np.round(np.rad2deg(state.item_tilt), 1).tolist(),
                "object_tilt_deg": round(float(np.rad2deg(state.object_tilt)), 1)}
    return Judgement(success, reason, retained, n, {k: [bool(x) for x in v] for k, v in checks.items()}, measured)


def _tilt(quat_now: np.ndarray, quat_then: np.ndarray) -> float:
    """Angle between a body's z axis now and then, rad."""
    z = []
    for q in (quat_now, quat_then):
        m = np.empty(9)
        mujoco.mju_quat2Mat(m, np.asarray(q, dtype=np.float64))
        z.append(m.reshape(3, 3)[:, 2])
    return float(np.arccos(np.clip(z[0] @ z[1], -1.0, 1.0)))


def observe(model: mujoco.MjModel, data: mujoco.MjData, *, item_body: int, object_body: int,
            object_hulls: tuple[np.ndarray, ...], object_quat0: np.ndarray, item_quat0: np.ndarray,
            item_before: np.ndarray, geom_owner: np.ndarray, table_z: float, preposition: Literal["in", "on"],
            figure: bool, water: bool, window: float = WINDOW) -> EndState:
    """The end state of one carried item (its free body ``item_body``) and the object, read from ``data``.

    ``geom_owner`` holds the rail_mj.mjcf owner codes (agent 0, object, ground); ``item_quat0``: the item's
    orientation when it was released; ``item_before``: its centre ``window`` seconds ago."""
    rot = data.xmat[object_body].reshape(3, 3)
    world = np.vstack([np.asarray(h, dtype=float) @ rot.T + data.xpos[object_body] for h in object_hulls])
    item_geoms = np.flatnonzero(model.body_rootid[model.geom_bodyid] == item_body)
    bottom = min(geom_bottom(model, data, int(g)) for g in item_geoms)
    touch_obj = touch_table = False
    for c in data.contact[: data.ncon]:
        g1, g2 = int(c.geom[0]), int(c.geom[1])
        for mine, other in ((g1, g2), (g2, g1)):
            root = model.body_rootid[model.geom_bodyid]
            if root[mine] == item_body and root[other] != item_body:
                touch_obj |= bool(geom_owner[other] == OWNER_OBJECT)
                touch_table |= bool(geom_owner[other] == OWNER_GROUND)
    hit = np.array([-1], dtype=np.int32)
    centre = data.xpos[item_body].copy()
    mujoco.mj_ray(model, data, centre, np.array([0.0, 0.0, -1.0]), None, True, item_body, hit)
    owner = geom_owner[hit[0]] if hit[0] >= 0 else None
    support: Support = ("none" if owner is None else "object" if owner == OWNER_OBJECT
                        else "table" if owner == OWNER_GROUND else "other")
    return EndState(
        preposition=preposition, figure=figure, water=water, items=centre[None],
        items_before=np.asarray(item_before, dtype=float)[None], item_bottom=np.array([bottom]),
        item_tilt=np.array([_tilt(data.xquat[item_body], item_quat0)]),
        touches_object=np.array([touch_obj]), touches_table=np.array([touch_table]), support=(support,),
        footprint=footprint(world), rim_z=float(world[:, 2].max()), table_z=table_z,
        object_tilt=_tilt(data.xquat[object_body], object_quat0), window=window)
