"""Objects on the robot's table: a user's mesh made an object as given, objects laid out side by side, and the
checks that they stand on the table, apart, within the arm's reach."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Sequence

import numpy as np

from rail_mj.core.errors import ConfigError
from rail_mj.core.types import RailObject, StablePose
from rail_mj.mesh import load_mesh, object_from_mesh
from rail_mj.pipeline.chain import as_placed_pose
from rail_mj.robot.control import RobotConfig

__all__ = ["PANDA_REACH", "SHOULDER_Z", "GAP", "Placed", "load_user_object", "table_centre", "layout"]

#: Franka Emika Panda: maximum reach from the shoulder (joint 2) axis, m (Franka datasheet: 855 mm).
PANDA_REACH = 0.855
#: Height of the Panda's shoulder (joint 2) above its base, m (Menagerie panda.xml: link1 at 0.333 m).
SHOULDER_Z = 0.333
#: Free space between neighbouring footprints, m: the Panda's open fingers (8 cm apart, 2 cm pads) pass between.
GAP = 0.05


@dataclass(frozen=True)
class Placed:
    """An object standing on the table: its pose as placed and where its task frame's centre stands (world)."""

    obj: RailObject
    pose: StablePose
    xy: tuple[float, float]


def load_user_object(path: str | Path, *, units: float = 1.0, up: Literal["z", "y"] = "z", yaw: float = 0.0,
                     name: str | None = None) -> RailObject:
    """A mesh file as an object standing upright as given: ``units`` metres per unit, ``up`` its up axis, turned
    ``yaw`` degrees about the vertical, its lowest point on the table (z = 0)."""
    if not np.isfinite(yaw):
        raise ConfigError(f"yaw must be a finite number of degrees, got {yaw}")
    mesh = load_mesh(Path(path), units=units, up=up)
    a = np.deg2rad(yaw)
    turn = np.eye(4)
    turn[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    mesh.apply_transform(turn)
    mesh.apply_translation([0.0, 0.0, -float(mesh.bounds[0][2])])
    return object_from_mesh(mesh, name=name or Path(path).stem, source=str(path))


def table_centre(cfg: RobotConfig) -> np.ndarray:
    """The table's centre (world xy)."""
    return np.asarray(cfg.table_xy if cfg.table_xy is not None else cfg.object_xy, dtype=float)


def _check(placed: list[Placed], cfg: RobotConfig) -> None:
    """Each object on the table and within reach; no two footprints overlapping."""
    centre, half_table = table_centre(cfg), np.asarray(cfg.table_half_size, dtype=float)
    for p in placed:
        half = np.asarray(p.pose.half_extents, dtype=float)
        lo, hi = np.asarray(p.xy) - half[:2], np.asarray(p.xy) + half[:2]
        size = f"{2 * half[0]:.2f} x {2 * half[1]:.2f} x {2 * half[2]:.2f} m"
        if np.any(lo < centre - half_table) or np.any(hi > centre + half_table):
            raise ConfigError(
                f"object {p.obj.name!r} ({size}) standing at {np.round(p.xy, 3).tolist()} does not fit on the table "
                f"({2 * half_table[0]:.2f} x {2 * half_table[1]:.2f} m centred at {np.round(centre, 3).tolist()}); "
                f"check --units (metres per mesh unit) or give fewer objects")
        # the farthest point the hand must reach: a top corner, with the approach height above it
        far = np.abs(np.array([p.xy[0], p.xy[1]])) + half[:2]
        top = cfg.table_height + 2 * half[2] + cfg.clearance - SHOULDER_Z
        reach = float(np.hypot(np.linalg.norm(far), top))
        if reach > PANDA_REACH:
            raise ConfigError(
                f"object {p.obj.name!r} ({size}) at {np.round(p.xy, 3).tolist()} is out of the arm's reach: its far "
                f"top corner, {cfg.clearance:.2f} m above, lies {reach:.2f} m from the shoulder (the Panda reaches "
                f"{PANDA_REACH} m); check --units or give a smaller object")
    for i, a in enumerate(placed):
        for b in placed[i + 1:]:
            ha, hb = np.asarray(a.pose.half_extents)[:2], np.asarray(b.pose.half_extents)[:2]
            if np.all(np.abs(np.subtract(a.xy, b.xy)) < ha + hb):
                raise ConfigError(f"objects {a.obj.name!r} at {np.round(a.xy, 3).tolist()} and {b.obj.name!r} at "
                                  f"{np.round(b.xy, 3).tolist()} overlap on the table; give positions at least "
                                  f"their half widths apart")


def layout(objects: Sequence[RailObject], cfg: RobotConfig | None = None,
           xys: Sequence[tuple[float, float] | None] | None = None) -> list[Placed]:
    """Each object as placed (:func:`rail_mj.pipeline.chain.as_placed_pose`), side by side along the table's
    width (y), :data:`GAP` apart, centred on the table; ``xys`` gives positions (world m) instead, where not None.
    Raises ConfigError naming the object that is off the table, out of reach, or overlapping another."""
    cfg = cfg or RobotConfig()
    if not objects:
        raise ConfigError("no object to put on the table; give at least one")
    given = list(xys) if xys is not None else [None] * len(objects)
    if len(given) != len(objects):
        raise ConfigError(f"{len(given)} positions for {len(objects)} objects; give one per object or none")
    poses = [as_placed_pose(o).poses[0] for o in objects]
    widths = [2 * float(p.half_extents[1]) for p in poses]
    centre = table_centre(cfg)
    y = centre[1] - (sum(widths) + GAP * (len(widths) - 1)) / 2
    placed = []
    for obj, pose, width, xy in zip(objects, poses, widths, given):
        auto = (float(cfg.object_xy[0]), float(y + width / 2))
        placed.append(Placed(obj, pose, auto if xy is None else (float(xy[0]), float(xy[1]))))
        y += width + GAP
    _check(placed, cfg)
    return placed
