"""Batch classification spread over processes or a Ray cluster: one task per object.

A task is one object with every requested affordance of it, and the task callable that classifies it
(:attr:`ObjectTask.run`, a module-level function, so a worker process or a Ray task imports it by name;
:func:`rail_mj.pipeline.chain.run_object` runs the whole chain). The callable returns the JSON text of the
task's results. :func:`run_tasks` yields each task's results as the task finishes; callers place them by
:attr:`ObjectTask.index` and write them from one process, so a results file has a single writer.

* ``workers=1``: the tasks run one after another in this process, MuJoCo on every core. No crash isolation.
* ``workers=N`` (``executor="local"``): N worker processes. They are fresh interpreters (``subprocess``: no
  re-import of the caller's ``__main__``, and each worker's thread settings are in its environment before
  anything loads). Each gets ``cores // N`` MuJoCo batch threads (``RAIL_MJ_THREADS``) and as many OpenMP and
  BLAS threads (CoACD), so workers × threads = cores. A worker that dies (a segfault on a bad mesh, the OOM
  killer) becomes error results for the object it was on, and a fresh worker takes its place. Workers run in
  their own session, so a Ctrl-C reaches only the parent, which stops them. They exit on their own when the
  parent dies, SIGKILL included.
* ``executor="ray"``: the same task as a Ray task (1 CPU, 1 MuJoCo thread) on an existing cluster
  (``ray_address``) or on a local Ray (``num_cpus=workers``). Needs the ``[cluster]`` extra and rail_mj
  installed on every node. Mesh paths must be readable from every node. An API key (``ANTHROPIC_API_KEY``)
  must be set on the nodes, e.g. through ``ray.init(runtime_env={"env_vars": ...})``. rail_mj never ships it.
  Before the first task, every node runs a check (a task pinned to it): a node that cannot import rail_mj
  (or the task callable's module) or read a mesh file stops the run with a :class:`WorkerError` naming the
  node and what it lacks. A task whose node dies runs again on another node (Ray's retry, then rail_mj's
  resubmission); every object's results come back once. When no node with a CPU is left the run stops,
  naming the lost nodes, with the results already back kept. An unreachable address fails in seconds.

Results come back as JSON text. The parent never unpickles what a worker that parsed an untrusted mesh sends.

Caches on a cluster: hulls and stable poses are keyed by a content hash (the mesh arrays plus the settings)
and written to a temporary file that is then renamed. So the workers of one machine share them safely, and
so do the nodes of a cluster when ``RAIL_MJ_CACHE`` points to shared storage. Without shared storage, each
node keeps its own cache (``~/.cache/rail_mj``), computes an object's hulls the first time that node meets
it, and reuses them afterwards. The results do not depend on which node computed them.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any, cast

from rail_mj.core.errors import ConfigError, WorkerError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.imagination.config import THREADS_ENV
from rail_mj.pipeline.config import ObjectInput, RunConfig

__all__ = [
    "EXECUTORS", "ObjectTask", "Placement", "cpu_count", "plan_workers", "check_executor", "largest_first",
    "run_tasks", "serve",
]

EXECUTORS = ("local", "ray")
#: the thread pools of CoACD (OpenMP) and numpy's BLAS, sized like MuJoCo's in each worker
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_READY = b"ready"
_PARENT_POLL_S = 0.5  # how often a worker checks that its parent still lives
_STOP_GRACE_S = 3.0  # a stopped worker gets this long before SIGKILL
_TAIL_BYTES = 1500  # how much of a dead worker's output goes into the error
_RAY_RETRIES = 1  # a Ray task lost with its node runs once more; a crash on a bad mesh costs two tries
_RAY_INFLIGHT_PER_CPU = 2  # tasks submitted ahead per cluster CPU (not all 10,000 at once)
_RAY_RESUBMITS = 2  # a task lost with its node after Ray's retry is submitted again by rail_mj this often
_RAY_CONNECT_TIMEOUT_S = 10.0  # a head that takes no TCP connection in this time is taken to be absent
_RAY_CHECK_TIMEOUT_S = 120.0  # every node answers the start check within this (a Ray worker starts in seconds)
_RAY_WAIT_S = 1.0  # the driver's wait on the tasks wakes this often (Ctrl-C, the cluster's health)
_RAY_HEALTH_S = 10.0  # with no result back for this long, the driver checks that a node is left


@dataclass(frozen=True)
class ObjectTask:
    """One object and the affordances to classify it for; ``config`` has provider and backend resolved."""

    index: int
    item: Any  # ObjectInput | RailObject | str | Path: what Pipeline.load accepts
    label: str  # the object's name in error results
    affordances: tuple[str, ...]
    config: RunConfig
    #: classifies the task's object: JSON ``{"results": [...]}``, or ``{"error": ...}`` when something other
    #: than a RailError stopped it; a module-level function (workers import it by name)
    run: Callable[[ObjectTask], str]


def cpu_count() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def plan_workers(workers: int | None, n_tasks: int) -> tuple[int, int]:
    """(worker processes, MuJoCo threads each) for ``n_tasks`` objects: ``workers`` (None: every core), at most
    one per object, and the cores split evenly among them (at least one thread each)."""
    cores = cpu_count()
    if workers is None:
        workers = cores
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(
            f"workers must be a whole number >= 1 (or None for every core, {cores} here); got {workers!r}"
        )
    n = max(1, min(workers, n_tasks))
    return n, max(1, cores // n)


def _failed(task: ObjectTask, message: str) -> list[AffordanceResult]:
    """Error results for every case of ``task`` (no check ran: ``dims_fit`` stays None)."""
    return [
        AffordanceResult(object=task.label, affordance=a, requested=a, dims_fit=None, error=message,
                         provider=task.config.provider, backend=task.config.backend)
        for a in task.affordances
    ]


def _decode(task: ObjectTask, text: str) -> list[AffordanceResult]:
    reply = json.loads(text)
    if "error" in reply:
        return _failed(task, reply["error"])
    return [AffordanceResult.model_validate(r) for r in reply["results"]]


def check_executor(executor: str, ray_address: str | None = None, workers: int | None = None) -> None:
    """Refuse an unknown executor, an address without Ray, Ray not installed, or a bad worker count."""
    if executor not in EXECUTORS:
        raise ConfigError(f"unknown executor {executor!r}; valid: {', '.join(EXECUTORS)}")
    if ray_address is not None and executor != "ray":
        raise ConfigError(f"ray_address {ray_address!r} needs executor='ray'; got executor={executor!r}")
    if executor == "ray" and importlib.util.find_spec("ray") is None:
        raise ConfigError(
            "executor='ray' needs Ray: pip install -e '.[cluster]' (or pip install 'ray>=2.30'); "
            "without it, use executor='local'"
        )
    if workers is not None:
        plan_workers(workers, 1)


def run_tasks(
    tasks: Sequence[ObjectTask], *, workers: int | None = None, executor: str = "local",
    ray_address: str | None = None, placement: Placement | None = None,
) -> Generator[tuple[ObjectTask, list[AffordanceResult]], None, None]:
    """Run every task and yield ``(task, its results)`` as each finishes.

    ``workers``: processes for ``executor="local"`` (None: every core; 1: this process), or the CPUs of a local
    Ray started here. Close the iterator (``contextlib.closing``) to stop early. That also happens on Ctrl-C,
    after the results already back have been yielded. Raises :class:`WorkerError` when no worker starts, and
    on Ray when a node cannot import the task code or read a mesh file, or when every node is gone.
    ``placement`` (Ray only) is filled with the node each object ran on.
    """
    check_executor(executor, ray_address, workers)
    for run in {t.run for t in tasks}:
        _check_importable(run)
    if executor == "ray":
        return _ray_tasks(largest_first(tasks), ray_address, workers, placement)
    n, threads = plan_workers(workers, len(tasks))
    if n == 1:
        return ((t, _decode(t, t.run(t))) for t in tasks)
    return _local_tasks(largest_first(tasks), n, threads)


def _check_importable(run: Callable) -> None:
    """Refuse a task callable that a worker cannot import by its name (a lambda, a nested function)."""
    module = getattr(run, "__module__", None)
    name = getattr(run, "__qualname__", "")
    found = importlib.import_module(module) if module else None
    for part in name.split("."):
        found = getattr(found, part, None)
    if found is not run:
        raise ConfigError(f"the task callable {run!r} cannot be imported by name ({module}:{name}) in a worker; "
                          "give a module-level function")


def _size(item: Any) -> int:
    """A task's expected cost: the mesh's bytes on disk (CoACD and the stable poses grow with the mesh), or its
    array bytes for an in-memory object; 0 when unknown."""
    if isinstance(item, RailObject):
        return int(item.mesh.vertices.nbytes + item.mesh.faces.nbytes)
    path = item.path if isinstance(item, ObjectInput) else item
    if not isinstance(path, (str, Path)):  # another path-like runs its own code: only in the worker, never here
        return 0
    try:
        return os.stat(path).st_size
    except (OSError, ValueError):
        return 0


def largest_first(tasks: Sequence[ObjectTask]) -> list[ObjectTask]:
    """The tasks, largest mesh first (ties in input order): with workers pulling from one queue, a large mesh
    started last would run alone while the other workers sit idle."""
    return sorted(tasks, key=lambda t: -_size(t.item))


# ---- local worker processes -----------------------------------------------------------------------------


def serve(fd: int, modules: Sequence[str] = ()) -> None:
    """A worker's loop: tasks arrive pickled on socket ``fd`` (from the parent, which it trusts), results go
    back as JSON; it ends when the parent closes the socket or dies. ``modules`` (those of the task callables)
    are imported before the worker says it is ready."""
    conn = Connection(fd)
    parent = os.getppid()

    def watch_parent() -> None:
        while os.getppid() == parent:
            time.sleep(_PARENT_POLL_S)
        os._exit(1)  # orphaned (the parent was killed): stop computing for nobody

    threading.Thread(target=watch_parent, daemon=True).start()
    for module in modules:  # the slow imports, before saying ready
        importlib.import_module(module)
    conn.send_bytes(_READY)
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        conn.send_bytes(task.run(task).encode())


class _Worker:
    """One worker process and its end of the socket; its output goes to a temporary file."""

    def __init__(self, threads: int, modules: Sequence[str]):
        ours, theirs = socket.socketpair()
        self.log = tempfile.TemporaryFile()
        package_root = str(Path(__file__).resolve().parents[2])  # the rail_mj this process runs
        env = {**os.environ, THREADS_ENV: str(threads), **{v: str(threads) for v in _THREAD_VARS}}
        env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c",
                 "import sys; from rail_mj.pipeline.parallel import serve; serve(int(sys.argv[1]), sys.argv[2:])",
                 str(theirs.fileno()), *modules],
                pass_fds=(theirs.fileno(),), env=env, stdin=subprocess.DEVNULL, stdout=self.log,
                stderr=subprocess.STDOUT, start_new_session=True,
            )
        except OSError as exc:
            self.log.close()
            ours.close()
            raise WorkerError(f"could not start a worker process ({exc}); run with workers=1") from exc
        finally:
            theirs.close()
        self.conn = Connection(ours.detach())
        self.ready = False
        self.task: ObjectTask | None = None

    def death(self) -> str:
        """Why the worker's socket closed: its exit status and the end of its output."""
        try:
            code = self.proc.wait(timeout=_STOP_GRACE_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        how = f"was killed by {signal.Signals(-code).name}" if code < 0 else f"exited with status {code}"
        self.log.seek(max(0, self.log.seek(0, os.SEEK_END) - _TAIL_BYTES))
        tail = self.log.read().decode("utf-8", "replace").strip()
        return f"the worker process (pid {self.proc.pid}) {how}" + (f"; its last output: {tail}" if tail else "")


def _stop(workers: Sequence[_Worker]) -> None:
    """Close every socket (an idle worker then exits), SIGTERM the busy and starting ones, SIGKILL whatever
    is left after the grace time, and free the logs."""
    for w in workers:
        w.conn.close()
        if w.task is not None or not w.ready:
            w.proc.terminate()
    deadline = time.monotonic() + _STOP_GRACE_S
    for w in workers:
        try:
            w.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            w.proc.kill()
            w.proc.wait()
        w.log.close()


def _local_tasks(
    tasks: Sequence[ObjectTask], n: int, threads: int
) -> Generator[tuple[ObjectTask, list], None, None]:
    queue = deque(tasks)
    modules = sorted({t.run.__module__ for t in tasks})
    workers: list[_Worker] = []
    try:
        for _ in range(n):
            workers.append(_Worker(threads, modules))
        while queue or any(w.task is not None for w in workers):
            live = [w for w in workers if w.task is not None or not w.ready]
            by_conn = {w.conn: w for w in live}
            try:
                ready = cast(list[Connection], wait(list(by_conn)))  # wait returns some of those it is given
            except KeyboardInterrupt:
                yield from _drain(live)
                raise
            for conn in ready:
                w = by_conn[conn]
                try:
                    reply = conn.recv_bytes()
                except (EOFError, OSError):
                    task, w.task = w.task, None
                    why = w.death()
                    if not w.ready:  # never got through its imports: a problem of this machine, not of a mesh
                        raise WorkerError(f"a worker process could not start: {why}; run with workers=1 to see "
                                          "the error in this process") from None
                    workers.remove(w)
                    _stop([w])
                    if queue:
                        workers.append(_Worker(threads, modules))
                    if task is None:  # died between tasks: nothing was lost
                        continue
                    yield task, _failed(task, f"WorkerError: {why}, while on {task.label}; nothing was recorded "
                                        "for it (run this object alone to see the crash, or leave it out)")
                    continue
                if not w.ready:
                    w.ready = reply == _READY
                else:
                    task, w.task = w.task, None
                    assert task is not None  # a ready worker replies only to a task
                    yield task, _decode(task, reply.decode())
                if queue and w.ready and w.task is None:
                    w.task = queue.popleft()
                    w.conn.send(w.task)
    finally:
        _stop(workers)


def _drain(workers: Sequence[_Worker]) -> Iterator[tuple[ObjectTask, list]]:
    """The results already sent back by busy workers (after a Ctrl-C: finished work is kept)."""
    for w in workers:
        if w.task is None or not w.ready:
            continue
        try:
            if w.conn.poll(0):
                task, w.task = w.task, None
                yield task, _decode(task, w.conn.recv_bytes().decode())
        except (EOFError, OSError):
            continue


# ---- Ray ------------------------------------------------------------------------------------------------


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
        import importlib
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


def _ray_tasks(
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
                    yield task, _failed(task, f"WorkerError: the Ray task for {task.label} failed{why} "
                                        f"({type(exc).__name__}: {_first_last(exc)}); nothing was recorded for it")
                else:
                    reply = json.loads(text)
                    placement.nodes.setdefault(reply["node"], []).append(task.label)
                    yield task, _decode(task, reply["reply"])

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
