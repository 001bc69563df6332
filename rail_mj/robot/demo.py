"""The robot demo: table-top objects × affordances, imagined, executed by the Panda and judged.

By default each trial runs the whole chain: ``rail_mj.pipeline.chain.classify``
(stable poses → offline profile → batched imagination → scoring → functional
pose) on an object built here from convex parts, sized for the Panda's
table-top workspace, then executes the best imagined plan in the functional
pose and judges it with the profile's own scoring code. ``planner="scripted"``
swaps the imagination for :func:`plan_offline` (upright pose, a hand-written
plan) to check the controller alone.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from rail_mj.affordances import get
from rail_mj.core.errors import ConfigError
from rail_mj.core.types import Outcomes, RailObject, StablePose
from rail_mj.mesh import object_from_parts
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.executor import ExecutionResult, ScoringFunction, execute
from rail_mj.robot.request import parse_request

__all__ = ["OBJECT_KINDS", "DEMO_AFFORDANCES", "DEMO_REQUESTS", "DemoCase", "make_object", "object_from_parts",
           "upright_pose", "plan_offline", "case_from_result", "imagined_case", "run_demo"]

_BALL = ('<mujoco><worldbody><body name="ball"><geom type="sphere" size="{r}" density="{rho}" '
         'rgba="0.2 0.4 0.9 1"/></body></worldbody></mujoco>')
_BLOCK = ('<mujoco><worldbody><body name="block"><geom type="box" size="{a} {a} {b}" density="{rho}" '
          'rgba="0.2 0.7 0.3 1"/></body></worldbody></mujoco>')


def _box_hull(lo, hi) -> np.ndarray:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    return lo + corners * (hi - lo)


def _disk_hull(r: float, z0: float, z1: float, n: int = 24) -> np.ndarray:
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.stack([r * np.cos(a), r * np.sin(a)], 1)
    return np.vstack([np.c_[ring, np.full(n, z0)], np.c_[ring, np.full(n, z1)]])


def _ring_walls(r_in: float, wall: float, z0: float, z1: float, n: int = 16) -> list[np.ndarray]:
    """A round wall as n boxes tangent to the circle of radius r_in (no gaps: they overlap slightly)."""
    hulls = []
    half = (r_in + wall) * np.tan(np.pi / n) * 1.05
    for k in range(n):
        a = 2 * np.pi * k / n
        box = _box_hull([r_in, -half, z0], [r_in + wall, half, z1])
        c, s = np.cos(a), np.sin(a)
        hulls.append(box @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]))
    return hulls


def _square_walls(hx: float, hy: float, wall: float, z0: float, z1: float) -> list[np.ndarray]:
    return [_box_hull([-hx, -hy, z0], [-hx + wall, hy, z1]), _box_hull([hx - wall, -hy, z0], [hx, hy, z1]),
            _box_hull([-hx, -hy, z0], [hx, -hy + wall, z1]), _box_hull([-hx, hy - wall, z0], [hx, hy, z1])]


def _legged(top_hx: float, top_hy: float, height: float, top_t: float, leg: float) -> list[np.ndarray]:
    hulls = [_box_hull([-top_hx, -top_hy, height - top_t], [top_hx, top_hy, height])]
    for sx in (-1, 1):
        for sy in (-1, 1):
            x, y = sx * (top_hx - leg), sy * (top_hy - leg)
            hulls.append(_box_hull([x - leg / 2, y - leg / 2, 0], [x + leg / 2, y + leg / 2, height - top_t]))
    return hulls


#: A builder draws its sizes with ``u(lo, hi)`` (uniform, from the object's seed) and returns the convex parts.
_Builder = Callable[[str, Callable[[float, float], float]], list[np.ndarray]]


def _round_vessel(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # real-world sizes (the imagination's dimension check knows them), within the Panda's reach
    r, h = {"cup": (u(0.035, 0.045), u(0.08, 0.11)), "vase": (u(0.04, 0.05), u(0.2, 0.24)),
            "pen_holder": (u(0.03, 0.035), u(0.10, 0.12)), "pot": (u(0.085, 0.1), u(0.12, 0.15)),
            "bowl": (u(0.06, 0.08), u(0.045, 0.06))}[kind]
    return [_disk_hull(r + 0.005, 0, 0.006)] + _ring_walls(r, 0.005, 0, h)


def _bucket(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a small one: a real bucket, short enough for the hand to reach over its rim
    r, h = u(0.09, 0.1), u(0.18, 0.21)
    return [_disk_hull(r + 0.006, 0, 0.008)] + _ring_walls(r, 0.006, 0, h)


def _jar(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a body, a shoulder and a wide mouth (the neck's opening is 0.8 of the body's)
    r, h = u(0.04, 0.045), u(0.12, 0.14)
    neck, wall, body = 0.8 * r, 0.004, h - 0.02
    return ([_disk_hull(r + wall, 0, 0.006)] + _ring_walls(r, wall, 0, body)
            + _ring_walls(neck, r - neck + wall, body - 0.005, body) + _ring_walls(neck, wall, body, h))


def _saucer(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a small plate: a flat well inside a low rim
    r = u(0.065, 0.075)
    return [_disk_hull(r, 0, 0.006)] + _ring_walls(r - 0.005, 0.005, 0, u(0.014, 0.018), n=24)


def _cutting_board(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a rimless slab on the counter
    return [_box_hull([-u(0.13, 0.15), -u(0.09, 0.1), 0], [u(0.13, 0.15), u(0.09, 0.1), u(0.015, 0.02)])]


def _open_box(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    hx, hy, h = (u(0.1, 0.12), u(0.08, 0.1), u(0.08, 0.12)) if kind == "basket" else \
        (u(0.09, 0.11), u(0.07, 0.09), u(0.02, 0.03))
    return [_box_hull([-hx, -hy, 0], [hx, hy, 0.006])] + _square_walls(hx, hy, 0.006, 0, h)


def _plate(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    r = u(0.08, 0.1)
    return [_disk_hull(r, 0, 0.008)] + _ring_walls(r - 0.004, 0.004, 0, 0.018, n=24)


# furniture at a doll's scale (0.3 m: rail_mj.affordances.FIGURE_HEIGHTS), for requests whose agent is a doll
def _table(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    return _legged(u(0.08, 0.1), u(0.07, 0.09), u(0.11, 0.14), 0.01, 0.012)


def _stool(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    return _legged(u(0.05, 0.06), u(0.05, 0.06), u(0.07, 0.09), 0.01, 0.01)


def _chair(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    parts = _legged(u(0.05, 0.06), u(0.05, 0.06), u(0.075, 0.09), 0.01, 0.01)
    seat = parts[0]
    hx, top = float(seat[:, 0].max()), float(seat[:, 2].max())
    hy = float(seat[:, 1].max())
    return parts + [_box_hull([-hx, hy - 0.01, top], [hx, hy, top + u(0.06, 0.08)])]


def _trash_bin(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a real waste-paper bin, the tallest object the wrist camera's workspace takes
    r, h = u(0.1, 0.115), u(0.3, 0.32)
    return [_disk_hull(r + 0.006, 0, 0.008)] + _ring_walls(r, 0.006, 0, h)


def _bathtub(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a doll's
    hx, hy, h = u(0.12, 0.14), u(0.06, 0.07), u(0.07, 0.09)
    return [_box_hull([-hx, -hy, 0], [hx, hy, 0.008])] + _square_walls(hx, hy, 0.008, 0, h)


def _bench(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a doll's
    return _legged(u(0.1, 0.12), u(0.035, 0.045), u(0.075, 0.09), 0.01, 0.01)


def _nightstand(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a doll's: a closed cabinet on four short legs under a top board
    hx, hy, h, foot, t = u(0.045, 0.05), u(0.035, 0.04), u(0.09, 0.11), 0.012, 0.008
    legs = _legged(hx, hy, foot + 0.001, 0.001, 0.008)[1:]
    return legs + [_box_hull([-hx + 0.003, -hy + 0.003, foot], [hx - 0.003, hy - 0.003, h - t]),
                    _box_hull([-hx, -hy, h - t], [hx, hy, h])]


def _bed(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a doll's: a mattress on four legs and a headboard
    hx, hy = u(0.15, 0.17), u(0.07, 0.08)
    parts = _legged(hx, hy, u(0.05, 0.06), 0.02, 0.015)
    return parts + [_box_hull([-hx, -hy, 0], [-hx + 0.012, hy, u(0.1, 0.12)])]


def _shelf(kind: str, u: Callable[[float, float], float]) -> list[np.ndarray]:
    # a doll's, open at the front (-y), a board at a third of the height. The hand holds the item from above,
    # so the shelf is open at the top. The cupboard stays under the hand's home pose (0.36 m above the table),
    # too low for the hand and wrist over the item (13 cm and more above its centre, pushed in at 0.575 of the
    # height) to pass under its top: the hand catches the top board and tips it over backwards
    hx, hy, t = u(0.1, 0.12), u(0.05, 0.06), 0.008
    h = u(0.18, 0.22) if kind == "shelf" else u(0.32, 0.34)
    parts = [_box_hull([-hx, -hy, 0], [hx, hy, t]), _box_hull([-hx, hy - t, 0], [hx, hy, h]),
             _box_hull([-hx, -hy, 0], [-hx + t, hy, h]), _box_hull([hx - t, -hy, 0], [hx, hy, h]),
             _box_hull([-hx, -hy, h / 3 - t / 2], [hx, hy, h / 3 + t / 2])]
    return parts if kind == "shelf" else parts + [_box_hull([-hx, -hy, h - t], [hx, hy, h])]


#: The builder of each object :func:`make_object` builds: table-top objects at real size, furniture at a doll's.
_BUILDERS: dict[str, _Builder] = {
    "cup": _round_vessel, "bowl": _round_vessel, "vase": _round_vessel, "pen_holder": _round_vessel,
    "pot": _round_vessel, "basket": _open_box, "tray": _open_box, "plate": _plate, "trash_bin": _trash_bin,
    "bucket": _bucket, "jar": _jar, "saucer": _saucer, "cutting_board": _cutting_board, "table": _table,
    "stool": _stool, "chair": _chair, "bench": _bench, "bed": _bed, "bathtub": _bathtub, "shelf": _shelf,
    "cupboard": _shelf, "nightstand": _nightstand,
}


def _parts(kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    def u(lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi))

    builder = _BUILDERS.get(kind)
    if builder is None:
        raise ConfigError(f"unknown demo object {kind!r}; known: {', '.join(OBJECT_KINDS)}")
    return builder(kind, u)


def make_object(kind: str, seed: int = 0, density: float = 600.0, scale: float = 1.0) -> RailObject:
    """A table-top object of ``kind`` built from convex parts (mesh frame: upright, base at z = 0), ``scale`` times
    its size (the furniture is doll-sized at 1: a table 18 cm long)."""
    parts = _parts(kind, np.random.default_rng(seed))
    name = f"{kind}_{seed}" if scale == 1.0 else f"{kind}_{seed}_x{scale:g}"
    return object_from_parts(name, [np.asarray(p, float) * scale for p in parts] if scale != 1.0 else parts, density)


def upright_pose(obj: RailObject) -> StablePose:
    """The functional (upright) stable pose: bbox centred on x = y = 0, lowest point at z = 0."""
    lo, hi = np.asarray(obj.mesh.bounds)
    centre = (lo + hi) / 2
    return StablePose(pos=np.array([-centre[0], -centre[1], -lo[2]]), quat=np.array([1.0, 0, 0, 0]),
                      probability=1.0, half_extents=(hi - lo) / 2)


def _inside(margin: float) -> ScoringFunction:
    """Containment: the agent ends within the object's footprint, below its rim, on the object, upright object."""
    def score(o: Outcomes) -> np.ndarray:
        h = o.object_half_extents[:, None, :]
        p = o.agent_pos
        inside = (np.abs(p[..., 0]) < h[..., 0] - margin) & (np.abs(p[..., 1]) < h[..., 1] - margin) \
            & (p[..., 2] < h[..., 2]) & (o.contacts_object > 0) & (o.contacts_ground == 0)
        return inside.mean(axis=1) * (o.object_tilt < 0.3) - 0.5
    return score


def _on_object(o: Outcomes) -> np.ndarray:
    """Support: the agent rests on the object within its footprint, off the ground, object upright."""
    h = o.object_half_extents[:, None, :]
    p = o.agent_pos
    on = (np.abs(p[..., 0]) < h[..., 0]) & (np.abs(p[..., 1]) < h[..., 1]) & (p[..., 2] > -h[..., 2]) \
        & (o.contacts_object > 0) & (o.contacts_ground == 0)
    return on.mean(axis=1) * (o.object_tilt < 0.3) - 0.5


def _demo(name: str) -> tuple[str, str, ScoringFunction]:
    """(object kind, agent kind, scoring) of a registered affordance: the registry's kind says whether a ball is
    dropped in (containers) or a block set down on it."""
    aff = get(name)
    if aff.kind == "container":
        return aff.key, "ball", _inside(0.0)
    return aff.key, "block", _on_object


#: What :func:`make_object` builds: table-top objects at real size, furniture at a doll's.
OBJECT_KINDS = tuple(_BUILDERS)

#: registry key -> (object kind, agent kind, scoring), for the affordances :func:`make_object` builds at table-top size
DEMO_AFFORDANCES: dict[str, tuple[str, str, ScoringFunction]] = {
    get(name).key: _demo(name)
    for name in ("cup", "bowl", "vase", "pen holder", "pot", "basket", "tray", "plate", "table", "stool", "chair")
}


#: The request each demo affordance's trials answer: its agent sets the scale (a doll's furniture).
DEMO_REQUESTS: dict[str, str] = {
    "cup": "pour the water into the cup", "bowl": "put the apple in the bowl", "vase": "put the water in the vase",
    "pen_holder": "put the pen in the pen holder", "pot": "put the soil in the pot",
    "basket": "put the apple in the basket", "tray": "put the food on the tray", "plate": "put the food on the plate",
    "table": "put the doll on the table", "stool": "put the doll on the stool", "chair": "put the doll on the chair",
}


@dataclass(frozen=True)
class DemoCase:
    """The fields of rail_mj.core.results.AffordanceResult that execution needs, for one object."""

    object: str
    affordance: str
    functional: bool
    pose: StablePose
    via_poses: np.ndarray  # (K, 7) task frame
    agent_fragment: str
    scoring: ScoringFunction | str  # a callable, or generated source for rail_mj.scoring.compile_scoring


def case_from_result(result: Any) -> DemoCase | None:
    """The executable part of a pipeline ``AffordanceResult``; None when it found no functional pose/plan."""
    if not result.functional or result.functional_pose is None or result.best_plan is None or result.error:
        return None
    return DemoCase(result.object, result.affordance, True, result.functional_pose.to_pose(),
                    np.asarray(result.best_plan.via_poses, float), result.agent_fragment, result.scoring_source)


def plan_offline(obj: RailObject, affordance: str) -> DemoCase:
    """Stand-in for classify: upright pose, a drop-in or set-down plan above the object's opening/top."""
    if affordance not in DEMO_AFFORDANCES:
        raise ConfigError(f"no demo plan for {affordance!r}; known: {', '.join(DEMO_AFFORDANCES)}")
    _, agent, scoring = DEMO_AFFORDANCES[affordance]
    pose = upright_pose(obj)
    h = pose.half_extents
    ident = [1.0, 0, 0, 0]
    if agent == "ball":
        fragment = _BALL.format(r=0.006, rho=1000)
        # from above the opening down to just under the rim, then release (the ball drops in)
        via = [[0, 0, h[2] + 0.06, *ident], [0, 0, h[2] + 0.01, *ident]]
    else:
        fragment = _BLOCK.format(a=0.02, b=0.015, rho=500)
        # seat area of a chair is in front of its back (+y side is the back)
        y = -0.01 if affordance == "chair" else 0.0
        top = h[2] if affordance != "chair" else float(obj.hulls[0][:, 2].max()) + pose.pos[2] - h[2]
        # set it down: the last via-pose lies below the surface, so the robot presses until the
        # force limit stops it, then lets go (the paper's safety rule doing the placing)
        via = [[0, y, top + 0.06, *ident], [0, y, top - 0.03, *ident]]
    return DemoCase(obj.name, affordance, True, pose, np.asarray(via, float), fragment, scoring)


def imagined_case(obj: RailObject, affordance: str, backend: str = "auto", *, agent: str | None = None
                  ) -> DemoCase | None:
    """Classify the object for the affordance with the offline provider, at the scale of the request's ``agent``;
    the executable result or None."""
    from rail_mj.pipeline.chain import classify
    from rail_mj.pipeline.config import RunConfig

    return case_from_result(classify([obj], [affordance], config=RunConfig(provider="offline", backend=backend,
                                     agent=agent), progress=False, workers=1)[0])


def run_demo(affordances: list[str] | None = None, trials: int = 4, *, config: RobotConfig | None = None,
             json_path: Path | None = None, video: Path | None = None, planner: str = "imagined",
             progress: Callable[[str], None] | None = print) -> dict:
    """Execute ``trials`` objects per affordance; return (and optionally write) the summary.

    ``video`` is a folder that gets ``AFFORDANCE_OBJECT.mp4`` of each affordance's first trial."""
    if planner not in ("imagined", "scripted"):
        raise ConfigError(f"unknown planner {planner!r}; valid: imagined, scripted")
    names = affordances or list(DEMO_AFFORDANCES)
    cfg = config or RobotConfig()
    rows = []
    for name in names:
        if name not in DEMO_AFFORDANCES:
            raise ConfigError(f"no demo plan for {name!r}; known: {', '.join(DEMO_AFFORDANCES)}")
        for seed in range(trials):
            obj = make_object(DEMO_AFFORDANCES[name][0], seed)
            t0 = time.perf_counter()
            agent = parse_request(DEMO_REQUESTS[name]).agent
            case = plan_offline(obj, name) if planner == "scripted" else imagined_case(obj, name, agent=agent)
            if case is None:
                rows.append({"object": obj.name, "affordance": name, "success": False, "score": -1.0,
                             "peak_force": 0.0, "force_events": [], "message": "imagination found no functional pose",
                             "seconds": time.perf_counter() - t0})
                if progress:
                    progress(f"{name:11s} {obj.name:14s} success=False (imagination found no functional pose)")
                continue
            render = video / f"{name}_{obj.name}.mp4" if video is not None and seed == 0 else None
            res: ExecutionResult = execute(obj, case.pose, case.agent_fragment, case.via_poses, case.scoring,
                                           config=cfg, render=render, affordance=name)
            row = {"object": obj.name, "affordance": name, **res.to_dict(), "seconds": time.perf_counter() - t0}
            rows.append(row)
            if progress:
                progress(f"{name:11s} {obj.name:14s} success={res.success!s:5s} score={res.score:+.2f} "
                         f"peak={res.peak_force:5.1f} N events={len(res.force_events)} {res.message}")
    n_ok = sum(r["success"] for r in rows)
    summary = {
        "success_rate": n_ok / max(1, len(rows)),
        "n_trials": len(rows),
        "n_affordances": len(names),
        "planner": planner,
        "force_limit": cfg.force_limit,
        "max_peak_force": max((r["peak_force"] for r in rows), default=0.0),
        "n_force_events": sum(len(r["force_events"]) for r in rows),
        "trials": rows,
    }
    if json_path is not None:
        Path(json_path).write_text(json.dumps(summary, indent=2))
    return summary
