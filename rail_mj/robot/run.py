"""One request on one table: objects stand side by side, each is scanned and imagined as placed, the robot
executes the best plan on the object that affords the request best, or declines saying why; the independent
judge (:mod:`rail_mj.robot.judge`) says whether it worked.

:func:`run_request` is the API of ``python -m rail_mj.robot --request TEXT --object MESH ...``, and each task of
the experiment (:mod:`rail_mj.robot.experiment`) runs through :func:`run_table`.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Literal, Sequence

import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field

from rail_mj.affordances import PAPER_AFFORDANCES, request_scale
from rail_mj.core.errors import ConfigError, RailError
from rail_mj.core.geometry import quat_conj, quat_mul, quat_rotate, task_origin
from rail_mj.core.types import RailObject, StablePose
from rail_mj.llm.schemas import Request
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import Pipeline, classify, define_uses, provider_for
from rail_mj.pipeline.config import RunConfig
from rail_mj.pipeline.saved_profiles import save_profiles
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.demo import case_from_result
from rail_mj.robot.executor import execute
from rail_mj.robot.request import parse_request
from rail_mj.robot.scene import Neighbour
from rail_mj.robot.table import Placed, layout, load_user_object, table_centre

__all__ = ["ObjectSpec", "LIQUIDS", "scan_available", "plan_in_true_frame", "decline_text", "verdict_row", "run_table",
           "run_request"]

#: Agents that are poured, not carried: the judge counts their droplets.
LIQUIDS = frozenset({"water", "milk", "juice", "tea", "coffee", "soup", "wine", "oil", "liquid"})


class ObjectSpec(BaseModel):
    """A mesh file to stand on the table, as the user gives it."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    path: Path
    units: float = Field(default=1.0, gt=0, description="metres per mesh unit")
    up: Literal["z", "y"] = "z"
    yaw: float = Field(default=0.0, description="turn about the vertical, degrees")
    xy: tuple[float, float] | None = Field(default=None, description="where it stands (world m); None: laid out")
    name: str | None = None


def scan_available() -> str | None:
    """Why the wrist-camera scan cannot run here (None when it can)."""
    try:
        from rail_mj.robot.scan import load_open3d
    except ImportError as exc:
        return f"no scan: {exc} (pip install -e '.[scan]')"
    try:
        load_open3d()  # preloads the wheel's libusb where the machine has none; a bare import would fail there
    except RailError as exc:
        return f"no scan: {exc}"
    return None


def _scanned(obj: RailObject, pose: StablePose) -> tuple[RailObject, dict[str, Any], np.ndarray]:
    """The scanned model as an object (mesh frame: z up, base at z = 0), with what the scan measured, and where
    its mesh frame's origin lies in the real object's task frame (for :func:`plan_in_true_frame`). The object is
    scanned standing alone at the scan station (``RobotConfig.object_xy``)."""
    from rail_mj.robot.scan import ScanConfig, scan_object

    config = ScanConfig()
    t0 = time.perf_counter()
    result = scan_object(obj, pose, config)
    seconds = time.perf_counter() - t0
    mesh = trimesh.Trimesh(np.asarray(result.mesh.vertices), np.asarray(result.mesh.faces), process=False)
    # the model stands on the table in the world: bring its base to z = 0 (the pose it stands in is kept)
    base = np.array([0.0, 0.0, float(mesh.bounds[0][2])])
    mesh.apply_translation(-base)
    robot = config.robot
    true_origin = np.array([*robot.object_xy, robot.table_height]) + task_origin(pose.half_extents)
    t0 = time.perf_counter()
    scanned = object_from_mesh(mesh, name=f"{obj.name}_scan")
    info = {"chamfer_m": float(result.chamfer_m), "n_views": int(result.n_views), "seconds": seconds,
            "stages": {k: float(v) for k, v in result.seconds.items()},
            "decompose_seconds": time.perf_counter() - t0, "faces": int(len(mesh.faces)),
            "watertight": bool(mesh.is_volume), "hulls": len(scanned.hulls),
            # what the scan noted beyond the views' fallbacks: cut off at the workspace edge, holes left open
            "notes": [n[:200] for n in result.notes if not n.startswith("view ")]}
    return scanned, info, base - true_origin


def plan_in_true_frame(via_poses: np.ndarray, scan_pose: StablePose, scan_base: np.ndarray) -> np.ndarray:
    """Via-poses ``(K, 7)`` imagined in the scanned model's task frame, in the real object's task frame, where the
    executor carries them out; ``scan_base``: the scanned mesh frame's origin in that frame.

    Each model gets its own task frame: its box centre, turned so its footprint's box lies on the axes
    (``as_placed_pose``). Which way round is free: the doll shelf's scan came out turned half a turn, and its
    plan "left" (the open front, on the scan) was pushed into the real shelf's back wall.
    """
    via = np.asarray(via_poses, dtype=float)
    turn = np.asarray(scan_pose.quat, dtype=float)
    # scan task frame -> scan mesh frame (the inverse of its pose) -> the real object's task frame
    local = via[:, :3] + task_origin(scan_pose.half_extents) - np.asarray(scan_pose.pos, dtype=float)
    pos = quat_rotate(quat_conj(turn), local) + scan_base
    quat = quat_mul(np.broadcast_to(quat_conj(turn), via[:, 3:].shape), via[:, 3:])
    return np.hstack([pos, quat / np.linalg.norm(quat, axis=1, keepdims=True)])


def _reason(result) -> str:
    """Why the verdict is what it is: the analyser's last reason, or, where the physics succeeded and the size prior
    kept the probability below 0.5, that prior's factors."""
    if not result.functional and result.prior and any(v.physics > 0 for v in result.pose_verdicts):
        return f"the imagined use works, but its size is unusual for it: {result.prior}"
    return (result.analyzer_reasons or [""])[-1]


def verdict_row(result) -> dict[str, Any]:
    """One object's verdict for a request as JSON: functional, probability, plan, score, the reason, seconds."""
    best = result.best_plan
    return {"functional": bool(result.functional), "probability": float(result.probability),
            "dims_fit": result.dims_fit, "error": result.error, "plan": best.name if best is not None else None,
            "score": float(best.score) if best is not None and np.isfinite(best.score) else None,
            "reason": _reason(result)[:300],
            "seconds": float(sum(v for k, v in result.timings.items() if k != "load"))}


def decline_text(name: str, affordance: str, verdict: dict[str, Any]) -> str:
    """Why one object does not afford the request as it stands: its probability and the analyser's reason (or the
    error)."""
    why = verdict.get("error") or verdict.get("reason") or "no imagined plan succeeded"
    odds = f"probability {verdict['probability']:.2f} < 0.5"
    return f"as it stands, {name!r} does not afford {affordance!r} ({odds}): {why}"


def _rank(candidate: dict[str, Any]) -> tuple[float, float]:
    """Higher is better: the probability, then the best plan's score."""
    v = candidate["verdict"]
    return v["probability"], v["score"] if v["score"] is not None else 0.0


def run_table(req: Request, placed: Sequence[Placed], *, scan: bool = True, config: RobotConfig | None = None,
              video: Path | None = None, label: str = "request", run: RunConfig | None = None,
              save_profile: Path | None = None) -> dict[str, Any]:
    """Scan and imagine every placed object for the request, execute on the best, judge: one JSON-ready dict.
    ``run``: the imagination's settings (provider, model, ...; default the offline provider), imagined as placed
    at the request's scale. ``save_profile``: write the profile the chosen object was imagined with there
    (:func:`rail_mj.pipeline.saved_profiles.save_profiles`)."""
    imagination = (run or RunConfig(provider="offline")).model_copy(
        update={"pose": "as_placed", "agent": req.agent, "owner": req.owner})
    cfg = config or RobotConfig()
    times: dict[str, float] = {}
    scale = request_scale(req.agent, req.owner)
    out: dict[str, Any] = {"request": req.text, "agent": req.agent, "affordance": req.affordance,
                           "preposition": req.preposition, "scale": scale,
                           "paper": req.affordance in PAPER_AFFORDANCES}

    # a use outside the registry is defined (and proven) once for the table, not once per object
    imagination, _ = define_uses([req.affordance], Pipeline(imagination), imagination)

    def imagine(o: RailObject):
        return classify([o], [req.affordance], config=imagination, progress=False, workers=1)[0]

    candidates: list[dict[str, Any]] = []
    for p in placed:
        entry: dict[str, Any] = {"name": p.obj.name, "xy": [round(v, 4) for v in p.xy],
                                 "dims": [round(float(d), 4) for d in p.obj.obb_dims]}
        t0 = time.perf_counter()
        true = imagine(p.obj)
        imagined_dims = p.obj.obb_dims
        times["imagine_true"] = times.get("imagine_true", 0.0) + time.perf_counter() - t0
        true_v: dict[str, Any] = verdict_row(true)
        scan_v: dict[str, Any] | None = None
        plan_from, scan_base = true, None
        if scan:
            t0 = time.perf_counter()
            try:
                scanned, info, scan_base = _scanned(p.obj, p.pose)
            except RailError as exc:
                scan_v = {"error": f"{type(exc).__name__}: {exc}"[:400], "functional": None}
                times["scan"] = times.get("scan", 0.0) + time.perf_counter() - t0
            else:
                times["scan"] = times.get("scan", 0.0) + info["seconds"]
                t0 = time.perf_counter()
                scan_result = imagine(scanned)
                times["imagine_scan"] = times.get("imagine_scan", 0.0) + time.perf_counter() - t0
                scan_v = {**verdict_row(scan_result), **info}
                plan_from, imagined_dims = scan_result, scanned.obb_dims
        verdict = scan_v if plan_from is not true and scan_v is not None else true_v
        entry.update(true=true_v, scan=scan_v, used="scan" if plan_from is not true else "true mesh",
                     verdict=verdict, agree=None if scan_v is None else scan_v["functional"] == true_v["functional"],
                     functional=bool(verdict["functional"]), probability=verdict["probability"])
        candidates.append({**entry, "_result": plan_from, "_base": scan_base, "_placed": p, "_dims": imagined_dims})
    out["objects"] = [{k: v for k, v in c.items() if not k.startswith("_")} for c in candidates]
    able = [c for c in candidates if c["functional"] and case_from_result(c["_result"]) is not None]
    out.update(chosen=None, executed=False, declined=False, reason=None, success=False, plan_success=None,
               plan_score=None, agree_judge=None, peak_force=0.0, force_limit=cfg.force_limit, force_events=0,
               judge=None, plan=None)
    if not able:
        reasons = [decline_text(c["name"], req.affordance, c["verdict"]) for c in candidates]
        out.update(declined=True, reason="; ".join(reasons) if len(reasons) > 1 else reasons[0],
                   message="declined: nothing executed")
        out["seconds"] = times
        return out
    best = max(able, key=_rank)
    if save_profile is not None:
        save_profiles(save_profile, [(best["_result"], best["_dims"])], imagination)
    p: Placed = best["_placed"]
    case = case_from_result(best["_result"])
    assert case is not None  # every able candidate has a case
    via = case.via_poses if best["_base"] is None else plan_in_true_frame(case.via_poses, case.pose, best["_base"])
    others = tuple(Neighbour(q.obj, q.pose, q.xy) for q in placed if q is not p)
    run_cfg = cfg.model_copy(update={"object_xy": p.xy, "table_xy": tuple(table_centre(cfg))})
    render = Path(video) / f"{label}.mp4" if video is not None else None
    t0 = time.perf_counter()
    res = execute(p.obj, p.pose, case.agent_fragment, via, case.scoring, config=run_cfg, render=render,
                  affordance=req.affordance, others=others, preposition=req.preposition,
                  figure=scale != 1.0, water=req.agent.lower() in LIQUIDS)
    times["execute"] = time.perf_counter() - t0
    judged = res.judgement
    plan_ok = bool(res.success) if np.isfinite(res.score) else None
    out.update(chosen=best["name"], executed=res.reachable, plan=best["verdict"]["plan"],
               success=bool(judged.success) if judged is not None else False,
               plan_success=plan_ok, plan_score=float(res.score) if np.isfinite(res.score) else None,
               agree_judge=None if judged is None or plan_ok is None else judged.success == plan_ok,
               judge=judged.to_dict() if judged is not None else None, peak_force=float(res.peak_force),
               force_limit=float(res.force_limit), force_events=len(res.force_events), message=res.message)
    out["seconds"] = times
    return out


def run_request(text: str, objects: Sequence[ObjectSpec | RailObject | str | Path], *, scan: bool = True,
                config: RobotConfig | None = None, video: Path | None = None, run: RunConfig | None = None,
                save_profile: Path | None = None) -> dict[str, Any]:
    """Put ``objects`` on the table (mesh files as :class:`ObjectSpec`, paths, or built objects), read the
    request ``text``, and execute it on the object that affords it best, or decline saying why.

    Raises (nothing executes): UnknownAffordanceError for a sentence with no known use, MeshError for a file
    that does not load, ConfigError for an object off the table, out of reach, or overlapping another.
    The result: ``chosen`` (name or None), ``executed``, ``declined`` and ``reason``, ``success`` (the judge's),
    ``plan_success`` / ``plan_score`` (the plan's own scoring code), and per object its verdict and probability.
    ``run`` sets the provider (and its model, timeout, repairs) that reads the request and imagines (default: the
    offline provider). ``save_profile``: write the chosen object's profile there (``--save-profile``).
    """
    cfg = config or RobotConfig()
    if scan:
        note = scan_available()
        if note is not None:
            raise ConfigError(f"{note}; or run with --no-scan to imagine on the true meshes")
    run = run or RunConfig(provider="offline")
    req = parse_request(text, provider_for(run))
    objs, xys = [], []
    for item in objects:
        if isinstance(item, RailObject):
            objs.append(item)
            xys.append(None)
            continue
        spec = item if isinstance(item, ObjectSpec) else ObjectSpec(path=Path(item))
        obj = load_user_object(spec.path, units=spec.units, up=spec.up, yaw=spec.yaw, name=spec.name)
        objs.append(obj)
        xys.append(spec.xy)
    names = [o.name for o in objs]
    if len(set(names)) != len(names):
        raise ConfigError(f"two objects share a name in {names}; give each a name of its own")
    placed = layout(objs, cfg, xys)
    return run_table(req, placed, scan=scan, config=cfg, video=video, run=run, save_profile=save_profile)
