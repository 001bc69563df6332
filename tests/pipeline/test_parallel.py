"""Objects spread over worker processes (rail_mj.pipeline.parallel): the same results as one process, crashes and kills.

Cheap convex objects (no CoACD) whose "bathtub" dimension check fails keep most runs to loading and stable
poses; the physics of a cup is checked with the thread counts instead.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import trimesh
from eval_procs import CRASHER, GUARD_S, REPO, start_eval, wait_until

from rail_mj import llm
from rail_mj.core.errors import ConfigError
from rail_mj.core.paths import CACHE_ENV
from rail_mj.eval import cli as eval_cli
from rail_mj.eval import run as rail_eval
from rail_mj.eval.run import cases_without_timings as _cases
from rail_mj.imagination import ImaginationConfig, get_backend, imagine
from rail_mj.imagination.config import THREADS_ENV
from rail_mj.imagination.inputs import agent_setup, trajectory_array
from rail_mj.mesh import load_object
from rail_mj.pipeline.chain import classify, object_task
from rail_mj.pipeline.config import ObjectInput, RunConfig
from rail_mj.pipeline.parallel import run_tasks
from rail_mj.pipeline.tasks import largest_first, plan_workers
from rail_mj.stable_poses import StablePoseConfig, find_stable_poses

CLASSES, PER_CLASS, AFFORDANCE = ["solid_box", "cone", "solid_cylinder"], 4, "bathtub"
N_CASES = len(CLASSES) * PER_CLASS
ARGS = ["--classes", ",".join(CLASSES), "--per-class", str(PER_CLASS), "--affordances", AFFORDANCE,
        "--provider", "offline", "--backend", "native", "--drops", "8", "--no-render", "--no-progress"]
#: what may differ between two runs of the same cases: how long they took and where they ran
RUN_ONLY = {"timing", "wall_s_this_run", "execution", "merged_from", "missing_shards"}


def _cfg(**kw) -> rail_eval.EvalConfig:
    return rail_eval.EvalConfig(dataset={"classes": CLASSES, "per_class": PER_CLASS}, affordances=[AFFORDANCE],
                                run={"provider": "offline", "backend": "native", "stable_poses": {"n_drops": 8}},
                                render=False, **kw)


@pytest.fixture(scope="module")
def serial_run(module_cache, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("serial")
    assert rail_eval.run_eval(_cfg(), out, progress=False, workers=1)["complete"]
    return out




def _summary(out: Path) -> dict:
    summary = json.loads((out / "summary.json").read_text())
    return {k: v for k, v in summary.items() if k not in RUN_ONLY}


def test_parallel_run_equals_the_serial_one(serial_run, tmp_path):
    out = tmp_path / "par"
    summary = rail_eval.run_eval(_cfg(), out, progress=False, workers=2)
    assert summary["execution"]["workers"] == 2 and summary["execution"]["threads_per_worker"] >= 1
    assert _cases(out) == _cases(serial_run)
    assert _summary(out) == _summary(serial_run)


def test_shards_merged_equal_the_serial_run(serial_run, tmp_path):
    parts = [tmp_path / f"s{i}" for i in (1, 2, 3)]
    for i, part in enumerate(parts, 1):
        assert eval_cli.main([*ARGS, "--out", str(part), "--shard", f"{i}/3", "--workers", "1"]) == 0
    assert len(_cases(parts[0])) == N_CASES // 3
    merged = tmp_path / "merged"
    assert eval_cli.main(["merge", *map(str, parts[::-1]), "--out", str(merged), "--no-render"]) == 0
    assert _summary(merged) == _summary(serial_run)
    assert _cases(merged) == _cases(serial_run)
    # line for line in the serial run's order
    assert [json.loads(s)["key"] for s in (merged / "results.jsonl").read_text().splitlines()] == [
        json.loads(s)["key"] for s in (serial_run / "results.jsonl").read_text().splitlines()]
    # a missing shard: written, not complete, exit 1 naming it
    partial = tmp_path / "partial"
    assert eval_cli.main(["merge", str(parts[0]), str(parts[2]), "--out", str(partial), "--no-render"]) == 1
    summary = json.loads((partial / "summary.json").read_text())
    assert not summary["complete"] and summary["missing_shards"] == ["2/3"]


def test_merge_refuses_runs_of_other_settings(serial_run, tmp_path, capsys):
    other = tmp_path / "other"
    assert eval_cli.main([*ARGS[:-4], "--drops", "9", "--no-render", "--no-progress", "--out", str(other),
                           "--shard", "2/2", "--workers", "1"]) == 0
    capsys.readouterr()
    assert eval_cli.main(["merge", str(serial_run), str(other), "--out", str(tmp_path / "m")]) == 2
    err = capsys.readouterr().err
    assert "other settings" in err and "n_drops" in err
    assert eval_cli.main(["merge", str(tmp_path / "nothing"), "--out", str(tmp_path / "m")]) == 2
    assert "plan.json" in capsys.readouterr().err


@pytest.mark.parametrize("text", ["0/2", "3/2", "1", "a/b", "1/0"])
def test_bad_shard_is_a_usage_error(text, tmp_path, capsys):
    assert eval_cli.main([*ARGS, "--out", str(tmp_path / "o"), "--shard", text]) == 2
    assert "1 <= i <= n" in capsys.readouterr().err


def test_bad_worker_count_is_refused():
    with pytest.raises(ConfigError, match="workers must be a whole number >= 1"):
        plan_workers(0, 3)
    assert plan_workers(8, 3)[0] == 3  # never more processes than objects


# ---- results do not depend on what ran before, nor on threads ------------------------------------------


def _box(path: Path, size: tuple[float, float, float]) -> Path:
    trimesh.creation.box(extents=size).export(path)
    return path


def test_a_result_does_not_depend_on_the_object_before_it(module_cache, tmp_path):
    # two boxes within one profile size bin: the first one's profile was reused for the second, whose
    # dimension check then quoted (and judged) the first one's size (both far too big for a cup: nothing is
    # imagined, and the check's reason names the size)
    first, second = _box(tmp_path / "a.stl", (0.60, 0.40, 0.20)), _box(tmp_path / "b.stl", (0.58, 0.39, 0.196))
    kw = dict(progress=False, workers=1, config=RunConfig(provider="offline", stable_poses=StablePoseConfig(n_drops=8)))
    (alone,) = classify([second], ["cup"], **kw)
    after = classify([first, second], ["cup"], **kw)[1]
    assert "0.580 x 0.390 x 0.196 m" in after.analyzer_reasons[0]
    assert after.model_dump(exclude={"timings"}) == alone.model_dump(exclude={"timings"})


@pytest.fixture(scope="module")
def cup_scene(module_cache, tmp_path_factory):
    """A box under the offline cup profile's droplets: contacts and agents at rest on and around it."""
    path = _box(tmp_path_factory.mktemp("box") / "box.stl", (0.09, 0.08, 0.1))
    obj = load_object(path)
    poses = find_stable_poses(obj, n_drops=8)
    profile = llm.generate_profile("cup", obj.obb_dims, "offline")
    agents = agent_setup(profile.agent.mjcf, profile.layout)
    return obj, poses, agents, [trajectory_array(profile.trajectories.trajectories, p.half_extents) for p in poses]


def test_mujoco_threads_do_not_change_imagination(cup_scene):
    obj, poses, agents, trajectories = cup_scene
    runs = [imagine(obj, poses, agents, trajectories, backend=get_backend("native", ImaginationConfig(nthread=n)))
            for n in (1, 2)]
    for field in runs[0].__dataclass_fields__:
        a, b = getattr(runs[0], field), getattr(runs[1], field)
        assert np.array_equal(np.asarray(a), np.asarray(b)), field


def test_mujoco_threads_do_not_change_stable_poses(cup_scene, monkeypatch):
    obj = cup_scene[0]
    found = []
    for n in ("1", "2"):
        monkeypatch.setenv(THREADS_ENV, n)
        assert ImaginationConfig().nthread == int(n)
        found.append(find_stable_poses(obj, n_drops=16, seed=5, use_cache=False))
    assert found[0].n_unsettled == found[1].n_unsettled and len(found[0]) == len(found[1])
    for p, q in zip(found[0], found[1]):
        assert np.array_equal(p.quat, q.quat) and p.probability == q.probability


def test_a_torn_stable_pose_cache_entry_is_recomputed(module_cache, tmp_path):
    # a kill mid-write (or a reader on shared storage while another node writes) left half a JSON file
    obj = load_object(_box(tmp_path / "torn.stl", (0.2, 0.1, 0.05)))
    poses = find_stable_poses(obj, n_drops=8)
    entries = sorted((module_cache / "stable_poses").glob("*.json"), key=lambda p: p.stat().st_mtime)
    text = entries[-1].read_text()
    entries[-1].write_text(text[: len(text) // 2])
    again = find_stable_poses(obj, n_drops=8)
    assert [p.quat.tolist() for p in again] == [p.quat.tolist() for p in poses]
    assert entries[-1].read_text() == text


# ---- crashes, Ctrl-C and SIGKILL ------------------------------------------------------------------------


def test_a_crashed_worker_is_an_error_line_and_the_run_goes_on(module_cache, tmp_path, monkeypatch):
    (tmp_path / "crashing_mesh.py").write_text(CRASHER)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    from crashing_mesh import Crasher  # type: ignore[import-not-found]

    boxes = [_box(tmp_path / f"b{i}.stl", (0.2 + 0.1 * i, 0.1, 0.05)) for i in range(3)]
    seen = []
    results = classify([boxes[0], Crasher(), boxes[1], boxes[2]], [AFFORDANCE, "table"],
                       config=RunConfig(provider="offline", stable_poses=StablePoseConfig(n_drops=8)), workers=2,
                       progress=lambda d, t, r: seen.append((d, t)))
    assert [r.object for r in results[2:4]] == ["crasher.obj"] * 2
    for r in results[2:4]:
        assert r.error.startswith("WorkerError: the worker process") and "SIGSEGV" in r.error
        assert "while on crasher.obj" in r.error and r.dims_fit is None
    assert all(r.error is None for r in results[:2] + results[4:]), [r.error for r in results]
    assert seen == [(i, 8) for i in range(1, 9)]  # one progress count per case, crashed ones included


def test_workers_do_not_load_the_anthropic_sdk_or_jax(module_cache, tmp_path):
    path = _box(tmp_path / "b.stl", (0.2, 0.1, 0.05))
    code = (
        "import sys; from rail_mj.pipeline.chain import object_task, run_object; "
        "from rail_mj.pipeline.config import RunConfig; from rail_mj.stable_poses import StablePoseConfig; "
        f"print(run_object(object_task(0, {str(path)!r}, ['cup'], "
        "RunConfig(provider='offline', backend='native', stable_poses=StablePoseConfig(n_drops=8))))[:12]); "
        "print(sorted(m for m in ('anthropic', 'jax') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=GUARD_S, cwd=REPO)
    assert out.stdout.splitlines() == ['{"results": ', "[]"], out.stderr


def test_largest_meshes_are_dispatched_first(tmp_path):
    sizes = {"a.obj": 10, "b.obj": 300, "c.obj": 10, "d.obj": 2000}
    for name, n in sizes.items():
        (tmp_path / name).write_bytes(b"v 0 0 0\n" * n)
    items = [ObjectInput(path=str(tmp_path / n)) for n in sizes] + [str(tmp_path / "missing.obj")]
    tasks = [object_task(i, item, [AFFORDANCE], RunConfig()) for i, item in enumerate(items)]
    assert [t.index for t in largest_first(tasks)] == [3, 1, 0, 2, 4]


def test_run_tasks_checks_its_options():
    with pytest.raises(ConfigError, match="valid: local, ray"):
        run_tasks([], executor="dask")
    with pytest.raises(ConfigError, match="needs executor='ray'"):
        run_tasks([], ray_address="auto")
    task = object_task(0, "x.obj", ["cup"], RunConfig())
    assert task.label == "x.obj" and task.affordances == ("cup",)


def test_ray_missing_is_a_usage_error_before_any_work(tmp_path, monkeypatch, capsys):
    import rail_mj.pipeline.parallel as parallel

    real = parallel.importlib.util.find_spec
    monkeypatch.setattr(parallel.importlib.util, "find_spec", lambda name: None if name == "ray" else real(name))
    assert eval_cli.main([*ARGS, "--out", str(tmp_path / "o"), "--ray"]) == 2
    assert "pip install -e '.[cluster]'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()  # refused before the dataset or the lock


def _start(out: Path, *extra: str) -> subprocess.Popen:
    return start_eval(out, [*ARGS, "--workers", "2", *extra])


def _children(pid: int) -> set[int]:
    kids: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        kids |= {int(k) for k in (task / "children").read_text().split()}
    return kids


def _gone(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] in ("Z", "X")
    except (FileNotFoundError, ProcessLookupError):
        return True


def _lines(out: Path) -> list[str]:
    path = out / "results.jsonl"
    return path.read_text().splitlines() if path.exists() else []


def _stop_mid_run(out: Path, sig: signal.Signals) -> tuple[subprocess.Popen, set[int], int]:
    """Start a parallel run, send ``sig`` to the parent once a case is written; return it, its workers and the cases
    written when the signal was sent (read right after it)."""
    proc = _start(out)
    workers: set[int] = set()

    def first_case() -> bool:
        workers.update(_children(proc.pid))
        return len(_lines(out)) >= 1

    wait_until(first_case, proc, "a case was written")
    workers |= _children(proc.pid)
    proc.send_signal(sig)
    at_signal = len(_lines(out))
    proc.wait(timeout=GUARD_S)
    return proc, workers, at_signal


def _stopped_mid_run(tmp_path: Path, monkeypatch, sig: signal.Signals) -> tuple[Path, subprocess.Popen, set[int]]:
    """A run stopped by ``sig`` while cases were still to be handed out. After the first case about 1 s of work is
    left: a test process that the machine holds up past it sends the signal too late to test anything, so that
    try is made again (a signal the parent got while cases were left and ran on past is a failure)."""
    for attempt in range(3):
        out = tmp_path / f"out{attempt}"
        with monkeypatch.context() as cold:  # a cold cache: each object takes a while
            cold.setenv(CACHE_ENV, str(tmp_path / f"cold{attempt}"))
            proc, workers, at_signal = _stop_mid_run(out, sig)
        if at_signal < N_CASES - 2:  # more cases than the two workers hold were still to be handed out
            return out, proc, workers
    pytest.fail(f"three tries sent {sig.name} only after the last cases were handed out: nothing was tested")


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="finds the workers through /proc (Linux)")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_resume_after_the_parallel_parent_is_stopped(serial_run, module_cache, tmp_path, monkeypatch, sig):
    out, proc, workers = _stopped_mid_run(tmp_path, monkeypatch, sig)
    assert workers, "no worker process was seen"
    deadline = time.monotonic() + 30
    while not all(map(_gone, workers)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert all(map(_gone, workers)), "workers outlived their parent"
    finished = _lines(out)
    assert all(json.loads(s)["key"] for s in finished)  # whole lines only
    if sig == signal.SIGINT:
        assert proc.returncode == 130, proc.log.read_text()
        assert not json.loads((out / "summary.json").read_text())["complete"]
    assert len(finished) < N_CASES, "the run ended before the signal: nothing was tested"
    assert eval_cli.main([*ARGS, "--out", str(out), "--resume", "--workers", "1"]) == 0
    keys = Counter(json.loads(s)["key"] for s in _lines(out))
    assert len(keys) == N_CASES and set(keys.values()) == {1}
    assert set(finished) <= set(_lines(out))  # nothing finished was lost or rewritten
    assert _cases(out) == _cases(serial_run)
