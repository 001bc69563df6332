"""The Ray executor: each task a Ray task on an existing cluster or a local Ray, nodes checked before the first.

See :mod:`rail_mj.pipeline.parallel` for what a lost node and a task that fails become.
"""

from __future__ import annotations

import importlib
import json
import os
import socket
import time
from collections import Counter, deque
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

from rail_mj.core.errors import ConfigError, WorkerError
from rail_mj.imagination.config import THREADS_ENV
from rail_mj.pipeline.config import ObjectInput
from rail_mj.pipeline.tasks import ObjectTask, decode_results, failed_results

__all__ = ["Placement", "ray_tasks"]

_RAY_RETRIES = 1  # a Ray task lost with its node runs once more; a crash on a bad mesh costs two tries
_RAY_INFLIGHT_PER_CPU = 2  # tasks submitted ahead per cluster CPU (not all 10,000 at once)
_RAY_RESUBMITS = 2  # a task lost with its node after Ray's retry is submitted again by rail_mj this often
_RAY_CONNECT_TIMEOUT_S = 10.0  # a head that takes no TCP connection in this time is taken to be absent
_RAY_CHECK_TIMEOUT_S = 120.0  # every node answers the start check within this (a Ray worker starts in seconds)
_RAY_WAIT_S = 1.0  # the driver's wait on the tasks wakes this often (Ctrl-C, the cluster's health)
_RAY_HEALTH_S = 10.0  # with no result back for this long, the driver checks that a node is left


@dataclass
class Placement:
    """Where a Ray run's objects ran, filled in by :func:`run_tasks` as their results come back."""

    nodes: dict[str, list[str]] = field(default_factory=dict)  # node id -> labels of the objects it ran
    node_ips: dict[str, str] = field(default_factory=dict)  # node id -> the address the node reports
    lost: list[str] = field(default_factory=list)  # ids of the nodes that died during the run


def _ray_task(task: ObjectTask) -> str:
    import ray

    # a Ray worker process is reused across tasks: one CPU each, so one MuJoCo thread (Ray sets OMP_NUM_THREADS)
    os.environ[THREADS_ENV] = "1"
    reply = task.run(task)
    return json.dumps({"node": ray.get_runtime_context().get_node_id(), "reply": reply})


def _node_check() -> Callable[[list[str], list[str]], str]:
    """The check run on every node before the first task. Nested, so Ray ships it by value: it runs, and
    names what is missing, on a node where rail_mj itself does not import."""

    def check(modules: list[str], paths: list[str]) -> str:
        import json
        import os

        import ray

        failed = {}
        for module in modules:
            try:
                importlib.import_module(module)
            except Exception as exc:  # noqa: BLE001 - any import failure is reported with its node
                failed[module] = f"{type(exc).__name__}: {exc}"
        missing = [p for p in paths if not os.access(p, os.R_OK)]
        return json.dumps({"node": ray.get_runtime_context().get_node_id(), "import_errors": failed,
                           "missing": missing})

    return check


def _alive(ray: Any) -> dict[str, str]:
    """The live nodes that have CPUs: id -> address."""
    return {n["NodeID"]: n["NodeManagerAddress"] for n in ray.nodes()
            if n.get("Alive") and n.get("Resources", {}).get("CPU", 0) > 0}


def _head_reachable(address: str) -> None:
    """Refuse at once an address where nothing listens (ray.init would retry for minutes)."""
    if address == "auto":  # Ray finds the address of a cluster started on this machine
        return
    host, colon, port = address.removeprefix("ray://").rpartition(":")
    if not colon or not port.isdigit() or not host:
        raise ConfigError(f"Ray address {address!r}: give host:port (the head's GCS, e.g. 10.0.0.5:6379) or "
                          "ray://host:10001 (Ray Client)")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=_RAY_CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise ConfigError(f"no Ray head answers at {address} ({exc}); start one with `ray start --head` or give "
                          "the address `ray status` prints on the head node") from None


def _first_last(exc: BaseException) -> str:
    """A Ray error in one line: its first line (which names the worker's pid and ip) and its last (the cause)."""
    lines = [ln.strip() for ln in str(exc).strip().splitlines() if ln.strip()]
    if not lines:
        return type(exc).__name__
    return lines[0] if len(lines) == 1 else f"{lines[0]} ... {lines[-1]}"


def _check_nodes(ray: Any, tasks: Sequence[ObjectTask]) -> dict[str, str]:
    """Run :func:`_node_check` on every live node; raise :class:`WorkerError` naming each node that cannot
    import the task code or read a mesh file, or does not answer. Returns the live nodes (id -> address)."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    nodes = _alive(ray)
    if not nodes:
        raise WorkerError("the Ray cluster has no live node with a CPU; add a worker node (ray start --address)")
    modules = sorted({t.run.__module__ for t in tasks} | {__name__})  # this module holds _ray_task
    paths = sorted({str(p) for p in (_path(t.item) for t in tasks) if p is not None})
    check = ray.remote(num_cpus=0, max_retries=0)(_node_check())
    refs = {check.options(scheduling_strategy=NodeAffinitySchedulingStrategy(node, soft=False)).remote(modules, paths):
            node for node in nodes}
    done, late = ray.wait(list(refs), num_returns=len(refs), timeout=_RAY_CHECK_TIMEOUT_S)
    problems = [f"node {refs[r]} ({nodes[refs[r]]}) did not answer within {_RAY_CHECK_TIMEOUT_S:.0f} s"
                for r in late]
    for ref in done:
        node = refs[ref]
        where = f"node {node} ({nodes[node]})"
        try:
            found = json.loads(cast(str, ray.get(ref, timeout=_RAY_CHECK_TIMEOUT_S)))
        except Exception as exc:  # noqa: BLE001 - whatever stopped the check is reported with its node
            problems.append(f"{where} could not run the check ({type(exc).__name__}: {_first_last(exc)})")
            continue
        if found["import_errors"]:
            failed = ", ".join(f"{module} ({error})" for module, error in found["import_errors"].items())
            problems.append(f"{where} cannot import {failed}; install rail_mj with the [cluster] extra in the "
                            "Python that Ray runs on every node")
        if found["missing"]:
            problems.append(f"{where} cannot read {len(found['missing'])} of the {len(paths)} mesh files, e.g. "
                            f"{', '.join(found['missing'][:3])}; put them on storage every node mounts at that path")
    for ref in late:
        ray.cancel(ref, force=True)
    if problems:
        raise WorkerError("the Ray cluster cannot run these objects: " + "; ".join(problems))
    return nodes


def _path(item: Any) -> str | None:
    """The mesh file a task reads, or None for an in-memory object."""
    path = item.path if isinstance(item, ObjectInput) else item
    return os.fspath(path) if isinstance(path, (str, Path)) else None


def ray_tasks(
    tasks: Sequence[ObjectTask], address: str | None, workers: int | None, placement: Placement | None,
) -> Generator[tuple[ObjectTask, list], None, None]:
    import ray
    import ray.exceptions

    placement = placement if placement is not None else Placement()
    started = not ray.is_initialized()
    if started:
        options: dict[str, Any] = {"log_to_driver": False}
        if address:
            _head_reachable(address)
            options["address"] = address
        else:
            options.update(num_cpus=workers, include_dashboard=False)
        try:
            ray.init(**options)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise ConfigError(
                f"could not connect to Ray at {address or 'a local cluster'}: {exc}; give the head node's "
                "address (ray://host:10001 or host:6379), or omit it for a local Ray"
            ) from None
    queue = deque(tasks)
    pending: dict[Any, ObjectTask] = {}
    tries: Counter[int] = Counter()  # submissions per task index

    try:
        known = _check_nodes(ray, tasks)
        placement.node_ips.update(known)
        remote = ray.remote(num_cpus=1, max_retries=_RAY_RETRIES)(_ray_task)

        def submit(task: ObjectTask) -> None:
            tries[task.index] += 1
            pending[remote.remote(task)] = task

        def lost_nodes() -> list[str]:
            alive = _alive(ray)
            known.update(alive)
            placement.node_ips.update(alive)
            placement.lost[:] = [n for n in known if n not in alive]
            return placement.lost

        def finished(refs: list) -> Iterator[tuple[ObjectTask, list]]:
            for ref in refs:
                task = pending.pop(ref)
                try:
                    text = cast(str, ray.get(ref, timeout=_RAY_WAIT_S))  # what _ray_task returns
                except ray.exceptions.RayError as exc:
                    lost = [] if isinstance(exc, ray.exceptions.RayTaskError) else lost_nodes()
                    if lost and tries[task.index] <= _RAY_RESUBMITS:
                        submit(task)  # its node died under it (Ray's own retry spent): run it again elsewhere
                        continue
                    why = f" while node(s) {', '.join(lost)} died" if lost else ""
                    yield task, failed_results(task, f"WorkerError: the Ray task for {task.label} failed{why} "
                                        f"({type(exc).__name__}: {_first_last(exc)}); nothing was recorded for it")
                else:
                    reply = json.loads(text)
                    placement.nodes.setdefault(reply["node"], []).append(task.label)
                    yield task, decode_results(task, reply["reply"])

        ahead = _RAY_INFLIGHT_PER_CPU * max(1, int(ray.cluster_resources().get("CPU", 1)))
        checked = time.monotonic()
        while queue or pending:
            while queue and len(pending) < ahead:
                submit(queue.popleft())
            try:
                done, _ = ray.wait(list(pending), num_returns=1, timeout=_RAY_WAIT_S)
            except KeyboardInterrupt:
                done, _ = ray.wait(list(pending), num_returns=len(pending), timeout=0)
                yield from finished(done)
                raise
            yield from finished(done)
            if not done and time.monotonic() - checked > _RAY_HEALTH_S:
                checked = time.monotonic()
                lost = lost_nodes()
                if not _alive(ray):  # nothing left to run the pending tasks on: stop instead of waiting forever
                    raise WorkerError(
                        f"every Ray node with a CPU is gone (lost: {', '.join(lost) or 'unknown'}); the results "
                        f"back so far are kept, {len(pending) + len(queue)} objects did not run; restart the "
                        "nodes and run again (python -m rail_mj.eval: --resume)"
                    )
        lost_nodes()  # for the record: the nodes that died while their tasks were retried by Ray
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()

