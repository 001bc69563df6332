"""Objects as Ray tasks on a local ``ray.init(num_cpus=2)`` cluster: the serial results, resume, crashes.

Needs the ``[cluster]`` extra (``pip install -e ".[cluster,test]"``); skipped without Ray. CI runs this file
in its own step with that extra installed.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import trimesh
from eval_procs import CRASHER

from rail_mj.core.paths import CACHE_ENV
from rail_mj.eval import run as rail_eval
from rail_mj.eval.run import cases_without_timings as _cases
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.stable_poses import StablePoseConfig

ray = pytest.importorskip("ray")

CLASSES, PER_CLASS, AFFORDANCE = ["solid_box", "cone"], 3, "bathtub"
RUN_ONLY = {"timing", "wall_s_this_run", "execution"}


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A local two-CPU Ray, with a HOME of its own, whose workers share this module's cache and can import the
    crashing object."""
    cache, code = tmp_path_factory.mktemp("cache"), tmp_path_factory.mktemp("code")
    (code / "crashing_mesh.py").write_text(CRASHER)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HOME", str(tmp_path_factory.mktemp("home")))  # Ray's state (~/.ray) stays out of the next Ray
        mp.setenv(CACHE_ENV, str(cache))  # Ray's workers inherit this process's environment
        mp.setenv("PYTHONPATH", os.pathsep.join([str(code), os.environ.get("PYTHONPATH", "")]))
        mp.syspath_prepend(str(code))
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            yield cache
        finally:
            ray.shutdown()


def _cfg() -> rail_eval.EvalConfig:
    return rail_eval.EvalConfig(dataset={"classes": CLASSES, "per_class": PER_CLASS}, affordances=[AFFORDANCE],
                                run={"provider": "offline", "backend": "native", "stable_poses": {"n_drops": 8}},
                                render=False)




def _summary(out: Path) -> dict:
    return {k: v for k, v in json.loads((out / "summary.json").read_text()).items() if k not in RUN_ONLY}


def test_ray_run_equals_the_serial_one_and_resumes(cluster, tmp_path):
    serial, out = tmp_path / "serial", tmp_path / "ray"
    assert rail_eval.run_eval(_cfg(), serial, progress=False, workers=1)["complete"]
    summary = rail_eval.run_eval(_cfg(), out, progress=False, executor="ray")
    assert summary["complete"] and summary["execution"]["executor"] == "ray"
    assert _cases(out) == _cases(serial) and _summary(out) == _summary(serial)
    # a run killed part way: half the lines, the last one torn
    results = out / "results.jsonl"
    lines = results.read_text().splitlines()
    results.write_text("\n".join(lines[: len(lines) // 2]) + "\n" + lines[-1][:40])
    summary = rail_eval.run_eval(_cfg(), out, resume=True, progress=False, executor="ray")
    assert summary["complete"] and summary["n_cases"] == len(lines)
    assert _cases(out) == _cases(serial) and len(results.read_text().splitlines()) == len(lines)


def test_a_crashed_ray_worker_is_an_error_line_and_the_run_goes_on(cluster, tmp_path):
    from crashing_mesh import Crasher  # type: ignore[import-not-found]

    boxes = []
    for i in range(2):
        boxes.append(tmp_path / f"b{i}.stl")
        trimesh.creation.box(extents=(0.2 + 0.1 * i, 0.1, 0.05)).export(boxes[-1])
    kw = dict(progress=False, config=RunConfig(provider="offline", stable_poses=StablePoseConfig(n_drops=8)))
    results = classify([boxes[0], Crasher(), boxes[1]], [AFFORDANCE], executor="ray", **kw)
    assert results[1].object == "crasher.obj" and results[1].error.startswith("WorkerError: the Ray task")
    assert results[0].error is None and results[2].error is None
    serial = classify(boxes, [AFFORDANCE], workers=1, **kw)
    assert [r.model_dump(exclude={"timings"}) for r in (results[0], results[2])] == [
        r.model_dump(exclude={"timings"}) for r in serial]
