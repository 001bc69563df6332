"""The paper's real-robot experiment, simulated end to end: a sentence, a wrist-camera scan, imagination in the
placed pose, and the Panda doing the task.

Each task is one object standing on the robot's table and one request ("put the doll on the stool"):

1. ``parse_request`` -> the agent and the affordance (the agent sets the scale: a doll's stool);
2. scan: the wrist camera's TSDF model of the object (:func:`rail_mj.robot.scan.scan_object`), or, with
   ``scan=False`` or without open3d, the true mesh (the result says which);
3. imagine, in the pose the object stands in (``classify(..., pose="as_placed")``), on the scanned mesh AND on
   the true mesh: the scan verdict, the true verdict;
4. execute the scan's best plan with the Panda on the real (true) object (:func:`rail_mj.robot.executor.execute`);
5. judge with the plan's own scoring code.

Every task is one line of a JSONL file, written as it finishes, so a killed run resumes where it stopped.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from rail_mj.affordances import PAPER_AFFORDANCES, request_scale
from rail_mj.core.errors import ConfigError, RailError
from rail_mj.core.geometry import quat_conj, quat_mul, quat_rotate, task_origin
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.core.types import RailObject, StablePose
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import as_placed_pose, classify
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.demo import case_from_result, make_object
from rail_mj.robot.executor import execute
from rail_mj.robot.request import parse_request

__all__ = ["Task", "TASKS", "task_object", "scan_available", "plan_in_true_frame", "run_task", "run_experiment",
           "summarize", "format_table"]


@dataclass(frozen=True)
class Task:
    """One experiment task: an object to build and the request a person makes of it."""

    name: str  # unique: the JSONL key
    builder: str  # "demo:KIND" (rail_mj.robot.demo.make_object) or "shapes:BUILDER" (rail_mj.dataset.shapes)
    seed: int
    request: str
    scale: float = 1.0  # for shapes builders: their real-world mesh scaled to the robot's table


#: 25 objects, 22 affordances (14 beyond the paper's eight: every other row of the registry).
TASKS: tuple[Task, ...] = (
    Task("mug", "shapes:cup", 1, "pour the water into the mug"),
    Task("cup", "demo:cup", 2, "put the water in the cup"),
    Task("bowl", "shapes:bowl", 1, "put the apple in the bowl"),
    Task("small_bowl", "demo:bowl", 3, "put the water in the bowl"),
    Task("vase", "demo:vase", 1, "put the water in the vase"),
    Task("basket", "demo:basket", 1, "put the apple in the basket"),
    Task("doll_bathtub", "demo:bathtub", 1, "put the doll in the bathtub"),
    Task("plate", "shapes:plate", 1, "put the food on the plate"),
    Task("doll_table", "demo:table", 1, "put the doll on the table"),
    Task("doll_chair", "demo:chair", 1, "put the doll on the chair"),
    Task("doll_stool", "demo:stool", 1, "put the doll on the stool"),
    Task("teddy_stool", "demo:stool", 2, "put the teddy on the stool"),
    Task("doll_bench", "demo:bench", 1, "put the dolls on the bench"),
    Task("doll_bed", "demo:bed", 1, "put the doll on the bed"),
    Task("doll_shelf", "demo:shelf", 1, "put the doll on the shelf"),
    Task("doll_cupboard", "demo:cupboard", 1, "put the doll in the cupboard"),
    Task("tray", "demo:tray", 1, "put the food on the tray"),
    Task("pot", "demo:pot", 1, "put the soil in the pot"),
    Task("trash_bin", "demo:trash_bin", 1, "put the paper in the trash bin"),
    Task("pen_holder", "demo:pen_holder", 1, "put the pen in the pen holder"),
    Task("bucket", "demo:bucket", 1, "pour the water into the bucket"),
    Task("jar", "demo:jar", 1, "put the water in the jar"),
    Task("saucer", "demo:saucer", 1, "put the cup on the saucer"),
    Task("doll_nightstand", "demo:nightstand", 1, "put the doll on the nightstand"),
    Task("cutting_board", "demo:cutting_board", 1, "put the bread on the cutting board"),
)


def task_object(task: Task) -> RailObject:
    """The task's true object (mesh frame: upright, base at z = 0)."""
    source, kind = task.builder.split(":", 1)
    if source == "demo":
        obj = make_object(kind, task.seed)
        return RailObject(name=task.name, mesh=obj.mesh, hulls=obj.hulls, mesh_hash=obj.mesh_hash,
                          obb_dims=obj.obb_dims, com=obj.com, mass=obj.mass, density=obj.density)
    from rail_mj.dataset import shapes

    mesh = shapes.GENERATORS[kind](np.random.default_rng(task.seed)).mesh.copy()
    mesh.apply_scale(task.scale)
    mesh.apply_translation([0.0, 0.0, -float(mesh.bounds[0][2])])
    return object_from_mesh(mesh, name=task.name)


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
    its mesh frame's origin lies in the real object's task frame (for :func:`plan_in_true_frame`)."""
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


def _verdict(result) -> dict[str, Any]:
    return {"functional": bool(result.functional), "dims_fit": result.dims_fit, "error": result.error,
            "plan": result.best_plan.name if result.best_plan is not None else None,
            "reason": (result.analyzer_reasons or [""])[-1][:300],
            "seconds": float(sum(v for k, v in result.timings.items() if k != "load"))}


def run_task(task: Task, *, scan: bool = True, config: RobotConfig | None = None,
             video: Path | None = None) -> dict[str, Any]:
    """Request -> scan -> imagine (scan and true mesh, as placed) -> execute -> judge: one JSON-ready row."""
    cfg = config or RobotConfig()
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    req = parse_request(task.request)
    times["parse"] = time.perf_counter() - t0
    row: dict[str, Any] = {"task": task.name, "request": task.request, "agent": req.agent,
                           "affordance": req.affordance, "preposition": req.preposition,
                           "scale": request_scale(req.agent, req.owner), "paper": req.affordance in PAPER_AFFORDANCES}
    obj = task_object(task)
    pose = as_placed_pose(obj)[0]
    row["dims"] = [round(float(d), 4) for d in obj.obb_dims]

    def imagine(o: RailObject):
        return classify([o], [req.affordance], provider="offline", progress=False, workers=1, pose="as_placed",
                        agent=req.agent, owner=req.owner)[0]

    t0 = time.perf_counter()
    true = imagine(obj)
    times["imagine_true"] = time.perf_counter() - t0
    row["true"] = _verdict(true)
    plan_from = true
    row["scan"] = None
    if scan:
        t0 = time.perf_counter()
        try:
            scanned, info, scan_base = _scanned(obj, pose)
        except RailError as exc:
            row["scan"] = {"error": f"{type(exc).__name__}: {exc}"[:400], "functional": None}
            times["scan"] = time.perf_counter() - t0
        else:
            times["scan"] = info["seconds"]
            times["scan_decompose"] = info["decompose_seconds"]
            t0 = time.perf_counter()
            scan_result = imagine(scanned)
            times["imagine_scan"] = time.perf_counter() - t0
            row["scan"] = {**_verdict(scan_result), **info}
            plan_from = scan_result
    row["used"] = "scan" if scan and row["scan"] is not None and "chamfer_m" in row["scan"] else "true mesh"
    row["agree"] = None if row["scan"] is None else row["scan"]["functional"] == row["true"]["functional"]

    case = case_from_result(plan_from)
    row["executed"] = case is not None
    if case is None:
        row.update(success=False, score=None, peak_force=0.0, force_limit=cfg.force_limit, force_events=0,
                   message=f"the {row['used']} imagination found no functional plan")
    else:
        t0 = time.perf_counter()
        render = Path(video) / f"{task.name}.mp4" if video is not None else None
        via_poses = case.via_poses if plan_from is true else plan_in_true_frame(case.via_poses, case.pose, scan_base)
        # the plan imagined on the model, carried out on the real object standing where it stands
        res = execute(obj, pose, case.agent_fragment, via_poses, case.scoring, config=cfg, render=render,
                      affordance=row["affordance"])
        times["execute"] = time.perf_counter() - t0
        assert plan_from.best_plan is not None  # case_from_result gave a case, so there is a best plan
        row.update(success=bool(res.success), score=float(res.score) if np.isfinite(res.score) else None,
                   peak_force=float(res.peak_force), force_limit=float(res.force_limit),
                   force_events=len(res.force_events), message=res.message, plan=plan_from.best_plan.name)
    row["seconds"] = times
    return row


def _read_rows(path: Path) -> dict[str, dict]:
    rows: dict[str, dict] = {}
    if path.exists():
        for line in path.read_text().splitlines():
            try:
                row = json.loads(line)
            except ValueError:
                continue  # a line torn by a kill: that task runs again
            if isinstance(row, dict) and "task" in row:
                rows[row["task"]] = row
    return rows


def _append(path: Path, row: dict) -> None:
    # a line torn by a kill has no newline: end it, so this row starts a line of its own
    torn = path.exists() and path.stat().st_size > 0 and not path.read_bytes().endswith(b"\n")
    with path.open("a") as f:
        f.write(("\n" if torn else "") + json.dumps(row) + "\n")
        f.flush()
        os.fsync(f.fileno())


def summarize(rows: list[dict], *, scan: bool, scan_note: str | None) -> dict[str, Any]:
    """The experiment's figures over its rows."""
    n = len(rows)
    compared = [r for r in rows if r.get("agree") is not None]
    stage_keys = sorted({k for r in rows for k in r["seconds"]})
    per_stage = {k: float(np.mean([r["seconds"][k] for r in rows if k in r["seconds"]])) for k in stage_keys}
    scans = [r["scan"]["seconds"] for r in rows if r.get("scan") and "seconds" in r["scan"]]
    chamfers = [r["scan"]["chamfer_m"] for r in rows if r.get("scan") and "chamfer_m" in r["scan"]]
    affordances = sorted({r["affordance"] for r in rows})
    limit = max((r["force_limit"] for r in rows), default=RobotConfig().force_limit)
    peak = max((r["peak_force"] for r in rows), default=0.0)
    return {
        "n_tasks": n,
        "n_affordances": len(affordances),
        "n_beyond_paper": sum(a not in PAPER_AFFORDANCES for a in affordances),
        "affordances": affordances,
        "scan": scan,
        "scan_note": scan_note,
        "success_rate": sum(r["success"] for r in rows) / max(1, n),
        "n_success": sum(r["success"] for r in rows),
        "verdict_agreement": (sum(r["agree"] for r in compared) / len(compared)) if compared else None,
        "n_compared": len(compared),
        "true_functional_rate": sum(r["true"]["functional"] for r in rows) / max(1, n),
        "max_peak_force": peak,
        "force_limit": limit,
        "peak_over_limit": peak / limit,
        "n_force_events": sum(r["force_events"] for r in rows),
        "scan_seconds_mean": float(np.mean(scans)) if scans else None,
        "scan_seconds_max": float(np.max(scans)) if scans else None,
        "chamfer_mm_mean": 1000 * float(np.mean(chamfers)) if chamfers else None,
        "seconds_per_stage": per_stage,
        "targets": {"success_rate": 0.95, "verdict_agreement": 0.95, "peak_over_limit": 1.2, "scan_seconds": 10.0},
    }


def format_table(rows: list[dict]) -> str:
    """The paper-style table: one line per task."""
    def yn(v) -> str:
        return "-" if v is None else ("yes" if v else "no")

    head = (f"{'object':15s} {'request':34s} {'affordance':13s} {'scan':5s} {'true':5s} {'exec':5s} "
            f"{'success':7s} {'peak/limit N':>13s}")
    lines = [head, "-" * len(head)]
    for r in rows:
        scan = r["scan"]["functional"] if r.get("scan") else None
        lines.append(f"{r['task']:15s} {r['request'][:34]:34s} {r['affordance']:13s} {yn(scan):5s} "
                     f"{yn(r['true']['functional']):5s} {yn(r['executed']):5s} {yn(r['success']):7s} "
                     f"{r['peak_force']:6.1f}/{r['force_limit']:<6.1f}")
    return "\n".join(lines)


def run_experiment(*, tasks: tuple[Task, ...] = TASKS, scan: bool = True, json_path: Path | None = None,
                   video: Path | None = None, config: RobotConfig | None = None,
                   progress: Callable[[str], None] | None = print) -> dict[str, Any]:
    """Run (or resume) every task; return and write the summary with its rows.

    Rows go to ``json_path`` with the suffix ``.jsonl`` (default ``runs/experiment/trials.jsonl``) as each task
    ends; a rerun keeps the rows already there and runs the rest. Without open3d (or ``rail_mj.robot.scan``),
    ``scan=True`` is refused with the install hint; ``scan=False`` imagines on the true mesh and says so.
    """
    note = scan_available()
    if scan and note is not None:
        raise ConfigError(f"{note}; or run with --no-scan to imagine on the true meshes")
    if not scan:
        note = "no scan (--no-scan): the scan verdict is not measured, imagination used the true mesh"
    json_path = Path(json_path) if json_path is not None else Path("runs/experiment/summary.json")
    jsonl = json_path.with_suffix(".jsonl")
    jsonl.parent.mkdir(parents=True, exist_ok=True)
    if video is not None:
        Path(video).mkdir(parents=True, exist_ok=True)
    done = _read_rows(jsonl)
    # a row from a run with the other scan setting does not count
    done = {k: r for k, r in done.items() if (r.get("scan") is not None) == scan}
    rows = []
    for task in tasks:
        if task.name in done:
            rows.append(done[task.name])
            continue
        row = run_task(task, scan=scan, config=config, video=video)
        _append(jsonl, row)
        rows.append(row)
        if progress:
            scan_v = row["scan"]["functional"] if row.get("scan") else None
            progress(f"{task.name:14s} {row['affordance']:10s} scan={scan_v!s:5s} "
                     f"true={row['true']['functional']!s:5s} "
                     f"success={row['success']!s:5s} peak={row['peak_force']:5.1f} N {row['message']}")
    summary = {**summarize(rows, scan=scan, scan_note=note), "rows": rows}
    atomic_write_text(json_path, json.dumps(summary, indent=2))
    return summary
