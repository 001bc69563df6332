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
from collections.abc import Callable, Generator, Sequence

from rail_mj.core.errors import ConfigError
from rail_mj.core.results import AffordanceResult
from rail_mj.pipeline.local_pool import local_tasks
from rail_mj.pipeline.ray_executor import Placement, ray_tasks
from rail_mj.pipeline.tasks import ObjectTask, decode_results, largest_first, plan_workers

__all__ = ["EXECUTORS", "check_executor", "run_tasks"]

EXECUTORS = ("local", "ray")


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
        return ray_tasks(largest_first(tasks), ray_address, workers, placement)
    n, threads = plan_workers(workers, len(tasks))
    if n == 1:
        return ((t, decode_results(t, t.run(t))) for t in tasks)
    return local_tasks(largest_first(tasks), n, threads)


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

