"""`python -m rail_mj.eval` killed (SIGKILL) at the moments that lost or duplicated work, then resumed.

Real processes on a tiny procedural config of cheap convex objects whose "bathtub" dimension check
fails (no imagination rollouts); the moment to kill is found by polling the output folder.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
from eval_procs import GUARD_S, output, start_eval, wait_until

from rail_mj.core.runfiles import HOLDER_FILE, STAGING_PREFIX, staging_dir
from rail_mj.eval import run as rail_eval

CLASSES, PER_CLASS, AFFORDANCE = ["solid_box", "cone", "solid_cylinder"], 8, "bathtub"
N_CASES = len(CLASSES) * PER_CLASS
ARGS = ["--classes", ",".join(CLASSES), "--per-class", str(PER_CLASS), "--affordances", AFFORDANCE,
        "--provider", "offline", "--backend", "native", "--drops", "8", "--no-render", "--no-progress"]


@pytest.fixture(scope="module")
def finished_run(module_cache, tmp_path_factory) -> Path:
    """A whole run of the config, made in this process (the same as the command line's)."""
    out = tmp_path_factory.mktemp("finished")
    cfg = rail_eval.EvalConfig(dataset={"classes": CLASSES, "per_class": PER_CLASS}, affordances=[AFFORDANCE],
                               run={"provider": "offline", "backend": "native", "stable_poses": {"n_drops": 8}},
                               render=False)
    assert rail_eval.run_eval(cfg, out, progress=False)["complete"]
    return out


def _start(out: Path, *, resume: bool) -> subprocess.Popen:
    return start_eval(out, [*ARGS, *(["--resume"] if resume else [])])


def _run(out: Path, *, resume: bool) -> tuple[int, str]:
    proc = _start(out, resume=resume)
    return proc.wait(timeout=GUARD_S), output(proc)


def _kill_when(proc: subprocess.Popen, moment: Callable[[], bool], what: str) -> None:
    """SIGKILL ``proc`` as soon as ``moment()`` holds."""
    wait_until(moment, proc, what, poll_s=0.001)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=GUARD_S)


def _keys(out: Path) -> Counter:
    """How often each key has a finished (parseable) line in results.jsonl."""
    keys: Counter = Counter()
    for raw in (out / "results.jsonl").read_text().splitlines():
        try:
            keys[json.loads(raw)["key"]] += 1
        except (json.JSONDecodeError, KeyError, TypeError):
            continue
    return keys


def _assert_complete(out: Path) -> None:
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] and summary["n_expected"] == N_CASES and summary["n_cases"] == N_CASES
    case_keys = {k: n for k, n in _keys(out).items() if k.endswith(f"::{AFFORDANCE}") and "padding" not in k}
    assert len(case_keys) == N_CASES and set(case_keys.values()) == {1}


def test_kill_while_the_dataset_is_written(module_cache, tmp_path):
    labels = lambda out: out / "dataset" / "labels.jsonl"  # noqa: E731
    for attempt in range(3):  # the generator is fast: retry when the kill came after the last mesh
        out = tmp_path / f"run{attempt}"
        proc = _start(out, resume=False)
        # the lambda is called within this iteration, so it sees this out
        _kill_when(proc, lambda: any((out / "dataset").rglob("*.obj")), "a mesh was written")  # noqa: B023
        if not labels(out).exists() or len(labels(out).read_text().splitlines()) < N_CASES:
            break
    else:
        pytest.skip("three kills all came after the dataset was whole")
    # never a labels file listing part of the objects (a resume then planned only those)
    assert not labels(out).exists()
    status, log = _run(out, resume=True)
    assert status == 0, log
    _assert_complete(out)
    assert not list((out / "dataset").glob(STAGING_PREFIX + "*"))  # the killed run's staging folder is gone


def test_second_run_on_one_out_fails_naming_the_holder(finished_run, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(finished_run, out)
    results = out / "results.jsonl"
    results.write_text("".join(results.read_text().splitlines(keepends=True)[: N_CASES // 2]))
    holder = _start(out, resume=True)
    try:
        _stop_when_locked(holder, out)
        before = results.read_bytes()
        status, log = _run(out, resume=True)
        assert status == 1, log  # the CLI rule: a valid command line that could not run now
        assert f"{out} is in use by another run (pid {holder.pid} on " in log and "--resume" in log
        assert results.read_bytes() == before
    finally:
        holder.kill()  # SIGKILL, even while stopped: the kernel releases its lock
        holder.wait(timeout=GUARD_S)
    status, log = _run(out, resume=True)
    assert status == 0, log
    _assert_complete(out)


def _stop_when_locked(proc: subprocess.Popen, out: Path) -> None:
    wait_until((out / HOLDER_FILE).exists, proc, "it took the lock", poll_s=0.001)
    proc.send_signal(signal.SIGSTOP)


def test_kill_during_the_resume_rewrite_keeps_every_finished_line(finished_run, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(finished_run, out)
    results = out / "results.jsonl"
    lines = results.read_text().splitlines()
    # lines of cases this command does not ask for (an earlier, larger run) make the rewrite long
    # enough to kill it part way; a repeated and a torn line make it necessary
    line = json.loads(lines[0])
    padding = [json.dumps({**line, "mesh": f"meshes/padding_{i:05d}.obj",
                           "key": f"meshes/padding_{i:05d}.obj::{AFFORDANCE}"})
               for i in range(40 * 2**20 // len(lines[0]))]
    results.write_text("\n".join(lines + padding + [lines[0]]) + "\n" + lines[1][: len(lines[1]) // 2])
    finished = set(_keys(out))
    size = results.stat().st_size
    proc = _start(out, resume=True)
    _kill_when(proc, lambda: any(out.glob(".results.jsonl.*")) or results.stat().st_size < size, "the rewrite began")
    assert set(_keys(out)) == finished  # the rewrite in place truncated the file first: a kill lost every line
    status, log = _run(out, resume=True)
    assert status == 0, log
    _assert_complete(out)
    assert set(_keys(out)) == finished and set(_keys(out).values()) == {1}
    assert not list(out.glob(".*.tmp"))


def test_staging_removes_only_dead_processes_leftovers(tmp_path):
    host = socket.gethostname()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    left = tmp_path / f"{STAGING_PREFIX}{host}@{int(dead.stdout)}-0"  # killed before it cleaned up
    live = tmp_path / f"{STAGING_PREFIX}{host}@{os.getpid()}-0"  # another generate() still writing
    left.mkdir()
    live.mkdir()
    with staging_dir(tmp_path) as stage:
        assert stage.is_dir() and not left.exists() and live.exists()
    assert not stage.exists()
