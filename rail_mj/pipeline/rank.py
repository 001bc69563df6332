"""What is this object for? Every affordance (or the ones given) ranked by probability, per object.

:func:`rank` runs one :func:`rail_mj.pipeline.chain.classify` over all the requested affordances, so each
object's hulls and stable poses are computed once and shared by every affordance (``classify_object``), and
then orders each object's results: most probable first; of equal probability, a functional verdict first;
then by name, so the order never depends on the run.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field

from rail_mj.affordances.registry import known_affordances, load_files
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import ObjectInput, RunConfig

__all__ = ["Ranking", "rank", "ranked"]


class Ranking(BaseModel):
    """One object's affordances, most probable first."""

    object: str
    results: list[AffordanceResult] = Field(description="one per affordance, most probable first")

    @property
    def best(self) -> AffordanceResult | None:
        """The most probable affordance that the object affords; None when it affords none of them."""
        return next((r for r in self.results if r.functional), None)


def ranked(results: Sequence[AffordanceResult]) -> list[AffordanceResult]:
    """``results`` ordered most probable first (a failed case last), then functional first, then by name."""
    return sorted(results, key=lambda r: (r.error is not None, -r.probability, not r.functional, r.affordance))


def rank(
    objects: Iterable[ObjectInput | RailObject | str | Path],
    affordances: Sequence[str] | None = None,
    *,
    config: RunConfig | None = None,
    **execution: Any,
) -> list[Ranking]:
    """Rank every registered affordance (or ``affordances``) for each object by probability; one
    :class:`Ranking` per object, in input order. ``config`` and the execution options (``progress``, ``workers``,
    ``executor``, ``ray_address``) are :func:`rail_mj.pipeline.chain.classify`'s; the rows of the config's
    ``affordances_files`` join the ranked set."""
    if affordances is None and config is not None and config.affordances_files:
        load_files(config.affordances_files)
    names = list(affordances) if affordances is not None else known_affordances()
    results = classify(list(objects), names, config=config, **execution)
    per_object: list[list[AffordanceResult]] = []
    for i in range(0, len(results), len(names)):
        per_object.append(ranked(results[i:i + len(names)]))
    return [Ranking(object=rs[0].object, results=rs) for rs in per_object]
