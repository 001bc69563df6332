"""A use's typical sizes as a model states them for a profile that serves every object of the use.

A free-form profile (a use no kind models, :mod:`rail_mj.pipeline.definitions`) is written once per affordance, so
the per-object dimension check of the paper's stage 1 becomes a prior the project applies to each object: the
plausibility of its OBB's largest and smallest dims against the ranges the model gave, with the registry rows'
width (:data:`rail_mj.affordances.prior.DEFAULT_WIDTH`), so a model's sizes weigh as a row's do.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from pydantic import BaseModel, ConfigDict, Field, model_validator

from rail_mj.affordances.prior import DEFAULT_WIDTH, Prior

__all__ = ["UseSizes"]

Range2 = tuple[float, float]


class UseSizes(BaseModel):
    """The typical OBB sizes of a use's objects, for its own user (scale 1: a person, or the scale's agent)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    largest: Range2 = Field(description="[lo, hi] m: the typical range of the object's largest OBB dim")
    smallest: Range2 = Field(description="[lo, hi] m: the typical range of the object's smallest OBB dim")
    basis: list[str] = Field(min_length=1, description="one line per range: the real objects measured and where the "
                                                       "numbers come from (a standard, catalogues, anthropometry)")

    @model_validator(mode="after")
    def _ranges(self) -> UseSizes:
        for name, (lo, hi) in (("largest", self.largest), ("smallest", self.smallest)):
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ValueError(f"{name} must be [lo, hi] in metres with 0 < lo <= hi, finite; got [{lo}, {hi}]")
        if self.smallest[0] > self.largest[1]:
            raise ValueError(f"smallest's lo {self.smallest[0]} exceeds largest's hi {self.largest[1]}: no object "
                             "has both")
        return self

    def prior(self, dims: Iterable[float]) -> Prior:
        """The plausibility of an object's OBB ``dims`` (any order) for the use."""
        d = sorted((float(v) for v in dims), reverse=True)
        return Prior.of([("largest dim", d[0], self.largest, DEFAULT_WIDTH),
                         ("smallest dim", d[-1], self.smallest, DEFAULT_WIDTH)])

    def boxes(self) -> list[list[float]]:
        """The extreme typical boxes (dims sorted descending) a profile for every object of the use must serve:
        each end of each range, the middle dim at either bound."""
        out: list[list[float]] = []
        for big in self.largest:
            for small in self.smallest:
                if small > big:
                    continue
                for mid in (small, big):
                    box = [big, mid, small]
                    if box not in out:
                        out.append(box)
        return out
