"""A task of batch classification: one object and its affordances, what every executor runs, and its results.

:mod:`rail_mj.pipeline.parallel` runs tasks in this process, in local worker processes
(:mod:`rail_mj.pipeline.local_pool`) or on Ray (:mod:`rail_mj.pipeline.ray_executor`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rail_mj.core.errors import ConfigError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.pipeline.config import ObjectInput, RunConfig

__all__ = ["ObjectTask", "cpu_count", "plan_workers", "failed_results", "decode_results", "largest_first"]


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


def failed_results(task: ObjectTask, message: str) -> list[AffordanceResult]:
    """Error results for every case of ``task`` (no check ran: ``dims_fit`` stays None)."""
    return [
        AffordanceResult(object=task.label, affordance=a, requested=a, dims_fit=None, error=message,
                         provider=task.config.provider, backend=task.config.backend)
        for a in task.affordances
    ]


def decode_results(task: ObjectTask, text: str) -> list[AffordanceResult]:
    reply = json.loads(text)
    if "error" in reply:
        return failed_results(task, reply["error"])
    return [AffordanceResult.model_validate(r) for r in reply["results"]]



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

