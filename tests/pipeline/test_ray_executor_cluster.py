"""`python -m rail_mj.eval --ray ADDRESS` on a Ray cluster of several nodes on loopback: spread, a node lost, bad input.

The nodes are ``ray.cluster_utils.Cluster`` nodes (each its own raylet and CPU count; the head holds the
session folder under a temporary HOME, so no state of another Ray on this machine, such as
``~/.ray/auth_token``, reaches them). They are bound to 127.0.0.1: Ray turns ``127.0.0.1`` into the
machine's interface address unless ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` (then its "local address" is
loopback), so that is set for the nodes and for the eval's driver, and every test checks the address the
nodes report. The cluster is shut down, and any process left with its HOME killed by pid, whatever happened.

Needs the ``[cluster]`` extra; skipped without Ray. CI runs this file in its extras step.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import time
from collections import Counter
from pathlib import Path

import pytest
from eval_procs import GUARD_S, REPO, output, start_eval, wait_until

from rail_mj.core.errors import ConfigError
from rail_mj.core.paths import CACHE_ENV
from rail_mj.dataset.procedural import generate
from rail_mj.eval import run as rail_eval
from rail_mj.eval.run import cases_without_timings as _cases
from rail_mj.pipeline.ray_executor import _head_reachable

ray = pytest.importorskip("ray")
from ray.cluster_utils import Cluster  # noqa: E402 - only with Ray installed

LOOPBACK = "127.0.0.1"
CLASSES, AFFORDANCE = ["solid_box", "cone"], "bathtub"  # cheap convex objects (see test_eval_faults)
ARGS = ["--classes", ",".join(CLASSES), "--affordances", AFFORDANCE, "--provider", "offline", "--backend", "native",
        "--drops", "8", "--no-render", "--no-progress"]
#: the head declares a node dead after 5 missed 1 s health checks (Ray's default waits longer than these runs last)
HEALTH_CHECK = {"health_check_period_ms": 1000, "health_check_failure_threshold": 5}
#: a node "without rail_mj": its Pythons start with this sitecustomize, which makes every import of rail_mj fail
#: (Ray puts the driver's folder on its workers' sys.path, so a shadow package on PYTHONPATH would not do)
NO_RAIL_MJ = """
import sys


class NoRailMj:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] == "rail_mj":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)


sys.meta_path.insert(0, NoRailMj())
"""


def _leftovers(home: Path) -> list[int]:
    """Processes (other than this one) whose environment has ``HOME=home``: what the cluster started."""
    want, pids = f"HOME={home}".encode(), []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if want in (entry / "environ").read_bytes().split(b"\0"):
                pids.append(int(entry.name))
        except OSError:
            continue
    return pids


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A head and one worker node on loopback, one CPU each, sharing this module's cache; then shut down."""
    home, cache = tmp_path_factory.mktemp("home"), tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        # the nodes and the eval drivers inherit this environment
        mp.setenv("HOME", str(home))
        mp.setenv(CACHE_ENV, str(cache))
        mp.setenv("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
        mp.setenv("PYTHONPATH", os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p))
        mp.setenv("RAY_USAGE_STATS_ENABLED", "0")
        # ray.init sets RAY_AUTH_MODE=token in its process (test_ray's local Ray, run first in CI): this cluster's
        # fresh HOME holds no token, and its GCS would abort at start
        mp.delenv("RAY_AUTH_MODE", raising=False)
        nodes = Cluster(initialize_head=True, head_node_args=dict(
            num_cpus=1, node_ip_address=LOOPBACK, temp_dir=str(home / "ray"), include_dashboard=False,
            _system_config=HEALTH_CHECK))
        try:
            nodes.add_node(num_cpus=1, node_ip_address=LOOPBACK)
            yield nodes
        finally:
            nodes.shutdown()
            for pid in _leftovers(home):
                try:
                    os.kill(pid, 9)
                except ProcessLookupError:
                    pass


def _serial(out: Path, per_class: int, seed: int) -> None:
    cfg = rail_eval.EvalConfig(dataset={"classes": CLASSES, "per_class": per_class, "seed": seed},
                               affordances=[AFFORDANCE],
                               run={"provider": "offline", "backend": "native", "stable_poses": {"n_drops": 8}},
                               render=False)
    assert rail_eval.run_eval(cfg, out, progress=False, workers=1)["complete"]


def _finish(proc: subprocess.Popen) -> int:
    try:
        return proc.wait(timeout=GUARD_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"eval hung:\n{output(proc)}")


def _execution(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())["execution"]


def test_a_run_spreads_over_every_node_and_equals_the_serial_one(cluster, tmp_path):
    out, serial = tmp_path / "ray", tmp_path / "serial"
    proc = start_eval(out, [*ARGS, "--per-class", "3", "--ray", cluster.address])
    assert _finish(proc) == 0, output(proc)
    _serial(serial, 3, 0)
    assert _cases(out) == _cases(serial)
    execution = _execution(out)
    live = {cluster.head_node.node_id, *(n.node_id for n in cluster.worker_nodes)}
    assert set(execution["nodes"]) == live and all(execution["nodes"].values())
    ran = Counter(label for labels in execution["nodes"].values() for label in labels)
    assert sorted(ran) == sorted({ln["mesh"] for ln in _cases(serial).values()}) and set(ran.values()) == {1}
    assert set(execution["node_ips"].values()) == {LOOPBACK} and execution["lost_nodes"] == []


def _busy(node) -> bool:
    """Whether one of ``node``'s Ray workers is running an object (Ray titles it after the task)."""
    raylet = node.all_processes["raylet"][0].process.pid
    for entry in Path("/proc").iterdir():
        try:
            if (entry.name.isdigit() and int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1]) == raylet
                    and (entry / "cmdline").read_bytes().startswith(b"ray::_ray_task")):
                return True
        except (OSError, IndexError, ValueError):
            continue
    return False


def test_a_node_killed_mid_run_loses_and_repeats_nothing(cluster, tmp_path):
    victim = cluster.add_node(num_cpus=1, node_ip_address=LOOPBACK)
    out, serial = tmp_path / "ray", tmp_path / "serial"
    # seed 1: objects this module has not cached yet, so each takes a while
    proc = start_eval(out, [*ARGS, "--per-class", "4", "--seed", "1", "--ray", cluster.address])
    wait_until(lambda: _busy(victim), proc, "the victim node runs an object", poll_s=0.02)
    cluster.remove_node(victim, allow_graceful=False)  # SIGKILL to its raylet and the rest of its processes
    assert _finish(proc) == 0, output(proc)
    lines = (out / "results.jsonl").read_text().splitlines()
    assert len(lines) == len({json.loads(ln)["key"] for ln in lines}) == len(CLASSES) * 4
    execution = _execution(out)
    # the run records a node as lost once Ray's GCS reports it dead; on a quiet machine the run can end first
    # (its task retried by Ray before the health check fails), so the record may miss it, never invent one
    assert execution["lost_nodes"] in ([], [victim.node_id])
    ran = Counter(label for labels in execution["nodes"].values() for label in labels)
    assert len(ran) == len(CLASSES) * 4 and set(ran.values()) == {1}
    _serial(serial, 4, 1)
    assert _cases(out) == _cases(serial)


def test_an_address_where_no_head_listens_fails_at_once(tmp_path):
    with socket.socket() as s:  # a port nothing listens on
        s.bind((LOOPBACK, 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    proc = start_eval(tmp_path / "out", [*ARGS, "--per-class", "1", "--ray", f"{LOOPBACK}:{port}"])
    assert _finish(proc) != 0
    assert f"no Ray head answers at {LOOPBACK}:{port}" in output(proc) and time.monotonic() - t0 < 60


def test_a_mesh_the_nodes_cannot_read_is_named_with_each_node(cluster, tmp_path):
    data, out = tmp_path / "data", tmp_path / "out"
    generate(data, classes=CLASSES, per_class=1, seed=0, affordances=[AFFORDANCE])
    gone = sorted((data / "meshes").glob("*.obj"))[0]
    proc = start_eval(out, [*ARGS[2:], "--dataset", str(data), "--ray", cluster.address])
    # the driver has read the labels (which checks every mesh is there) and is connecting to Ray: on one machine,
    # removing the file now is how the nodes come to lack a mesh that the driver saw
    wait_until(lambda: (out / rail_eval.PLAN_FILE).exists(), proc, "the run is planned")
    gone.unlink()
    assert _finish(proc) != 0
    text = output(proc)
    for node in (cluster.head_node, *cluster.worker_nodes):
        assert f"node {node.node_id} ({LOOPBACK}) cannot read 1 of the 2 mesh files, e.g. {gone};" in text, text
    assert (out / "results.jsonl").read_text() == ""  # no object ran


def test_a_node_without_rail_mj_is_named(cluster, tmp_path, monkeypatch):
    (tmp_path / "sitecustomize.py").write_text(NO_RAIL_MJ)
    with monkeypatch.context() as mp:
        mp.setenv("PYTHONPATH", str(tmp_path))  # this node's processes, and only they, cannot import rail_mj
        bare = cluster.add_node(num_cpus=1, node_ip_address=LOOPBACK)
    try:
        proc = start_eval(tmp_path / "out", [*ARGS, "--per-class", "1", "--ray", cluster.address])
        assert _finish(proc) != 0
        text = output(proc)
        assert f"node {bare.node_id} ({LOOPBACK}) cannot import rail_mj.pipeline.chain (ModuleNotFoundError" in text
        assert f"node {cluster.head_node.node_id} " not in text  # the nodes with rail_mj are not blamed
    finally:
        cluster.remove_node(bare)


@pytest.mark.parametrize("address", ["headnode", "ray://headnode", "headnode:port", ":6379"])
def test_an_address_without_host_and_port_is_refused_with_the_forms_that_work(address):
    with pytest.raises(ConfigError, match=r"give host:port .* or ray://host:10001"):
        _head_reachable(address)
