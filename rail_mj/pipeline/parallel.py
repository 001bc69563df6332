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
from collections import deque
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any, cast

from rail_mj.core.errors import ConfigError, WorkerError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.imagination.config import THREADS_ENV
from rail_mj.pipeline.config import ObjectInput, RunConfig

__all__ = [
    "EXECUTORS", "ObjectTask", "cpu_count", "plan_workers", "check_executor", "largest_first", "run_tasks", "serve",
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
    ray_address: str | None = None,
) -> Generator[tuple[ObjectTask, list[AffordanceResult]], None, None]:
    """Run every task and yield ``(task, its results)`` as each finishes.

    ``workers``: processes for ``executor="local"`` (None: every core; 1: this process), or the CPUs of a local
    Ray started here. Close the iterator (``contextlib.closing``) to stop early. That also happens on Ctrl-C,
    after the results already back have been yielded. Raises :class:`WorkerError` when no worker starts.
    """
    check_executor(executor, ray_address, workers)
    for run in {t.run for t in tasks}:
        _check_importable(run)
    if executor == "ray":
        return _ray_tasks(largest_first(tasks), ray_address, workers)
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


def _ray_task(task: ObjectTask) -> str:
    # a Ray worker process is reused across tasks: one CPU each, so one MuJoCo thread (Ray sets OMP_NUM_THREADS)
    os.environ[THREADS_ENV] = "1"
    return task.run(task)


def _ray_tasks(
    tasks: Sequence[ObjectTask], address: str | None, workers: int | None
) -> Generator[tuple[ObjectTask, list], None, None]:
    import ray
    import ray.exceptions

    started = not ray.is_initialized()
    if started:
        options: dict[str, Any] = {"log_to_driver": False}
        if address:
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

    def finished(refs: list) -> Iterator[tuple[ObjectTask, list]]:
        for ref in refs:
            task = pending.pop(ref)
            try:
                text = cast(str, ray.get(ref))  # what _ray_task returns
            except ray.exceptions.RayError as exc:
                first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                yield task, _failed(task, f"WorkerError: the Ray task for {task.label} failed ({type(exc).__name__}: "
                                    f"{first}); nothing was recorded for it")
            else:
                yield task, _decode(task, text)

    try:
        remote = ray.remote(num_cpus=1, max_retries=_RAY_RETRIES)(_ray_task)
        ahead = _RAY_INFLIGHT_PER_CPU * max(1, int(ray.cluster_resources().get("CPU", 1)))
        while queue or pending:
            while queue and len(pending) < ahead:
                task = queue.popleft()
                pending[remote.remote(task)] = task
            try:
                done, _ = ray.wait(list(pending), num_returns=1)
            except KeyboardInterrupt:
                done, _ = ray.wait(list(pending), num_returns=len(pending), timeout=0)
                yield from finished(done)
                raise
            yield from finished(done)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()
