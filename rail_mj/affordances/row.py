"""One registry row (:class:`Affordance`) and the base of every kind's own parameters (:class:`KindParams`).

A row names its kind (:mod:`rail_mj.affordances.kinds`) and holds that kind's
parameter model in ``params``; a kind registers its model here when it
registers itself (:func:`rail_mj.affordances.kinds.register_kind`), so a row
checks that its params are its kind's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from rail_mj.affordances.envelope import Envelope, Range
from rail_mj.affordances.prior import DEFAULT_WIDTH, Prior
from rail_mj.core.errors import ConfigError

__all__ = ["KindParams", "KIND_PARAMS", "Affordance"]


@dataclass(frozen=True)
class KindParams:
    """Base of a kind's parameter model: the fields a row of that kind alone has (frozen dataclass fields, each
    with a default). A kind without any uses this model itself."""

    def scaled(self, factor: float) -> KindParams:
        """The params for an agent ``factor`` times the size (:meth:`Affordance.scaled`): a model whose fields
        include lengths scales them here; nothing scales by default."""
        return self


#: Every registered kind's parameter model by kind name (filled by ``register_kind``).
KIND_PARAMS: dict[str, type[KindParams]] = {}


@dataclass(frozen=True)
class Affordance:
    """One registry row."""

    name: str  # canonical: lower case, words separated by one space
    kind: str  # a registered kind's name (rail_mj.affordances.kinds.KINDS)
    ibd: str  # interaction-based definition
    largest: Range  # plausible range of the largest OBB dim, m
    smallest: Range  # plausible range of the smallest OBB dim, m
    envelope: Envelope = Envelope()
    aliases: tuple[str, ...] = ()
    paper: bool = False  # one of the paper's eight
    #: the kind's own parameters, an instance of its model (KIND_PARAMS[kind]); the default, a bare
    #: KindParams(), stands for the model's defaults
    params: KindParams = KindParams()
    #: size of the agent the row is for relative to the person its sizes are for (:meth:`scaled`; 1 = a person's)
    scale: float = 1.0

    def __post_init__(self) -> None:
        model = KIND_PARAMS.get(self.kind)
        if model is None:
            raise ConfigError(f"affordance {self.name!r}: unknown kind {self.kind!r}; valid: "
                              f"{', '.join(sorted(KIND_PARAMS))}")
        if type(self.params) is KindParams:
            object.__setattr__(self, "params", model())
        elif type(self.params) is not model:
            raise ConfigError(f"affordance {self.name!r}: the params of a {self.kind} row must be a "
                              f"{model.__name__}; got a {type(self.params).__name__}")

    @property
    def key(self) -> str:
        """The name as an identifier: label files, the ground-truth matrix, CLI lists (``trash_bin``)."""
        return self.name.replace(" ", "_")

    def dims_fit(self, dims: Sequence[float]) -> bool:
        """Whether OBB dims lie in the plausible size ranges (the stage-1 dimension check)."""
        return self.largest[0] <= max(dims) <= self.largest[1] and self.smallest[0] <= min(dims) <= self.smallest[1]

    def size_prior(self, dims: Sequence[float]) -> Prior:
        """The stage-1 dimension check as a prior: the plausibility of the OBB's largest and smallest dims."""
        return Prior.of([("largest dim", max(dims), self.largest, DEFAULT_WIDTH),
                         ("smallest dim", min(dims), self.smallest, DEFAULT_WIDTH)])

    def pose_prior(self, half: Sequence[float], rim: float | None = None) -> Prior:
        """The envelope as a prior over one pose's box (half extents), a vessel's aspect at its ``rim`` (the
        pose's spill level, m) when given: the product of each constrained size's plausibility."""
        return Prior.of([(name, value, rng, DEFAULT_WIDTH) for name, value, rng in self.envelope.values(half, rim)])

    def pose_fits(self, half: Sequence[float], rim: float | None = None) -> tuple[bool, str]:
        """Whether a pose's box (half extents) is inside the envelope, a vessel's aspect at its ``rim`` (the
        pose's spill level, m) when given; the reason when it is not."""
        bad = self.envelope.violation(half, rim)
        if bad is None:
            return True, ""
        name, value, (lo, hi) = bad
        return False, f"in this pose its {name} is {value:.3f}; a {self.name} has {lo:g}-{hi:g}"

    def scaled(self, factor: float) -> Affordance:
        """The row for an agent ``factor`` times the size of the one it is for ("put the doll on the chair": a
        chair for a doll). The dimension check and the envelope's lengths (height, width, length, rest) scale
        together, the params scale their own lengths (:meth:`KindParams.scaled`), and ``scale`` records the
        product; the aspect ratio stays, and so do the droplets (water is water at any scale)."""
        if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not (math.isfinite(factor)
                                                                                    and factor > 0):
            raise ConfigError(f"an agent scale must be a positive finite number; got {factor!r}")
        if factor == 1:
            return self

        def times(r: Range) -> Range:
            return r[0] * factor, r[1] * factor

        env = self.envelope
        envelope = Envelope(height=times(env.height), width=times(env.width), length=times(env.length),
                            aspect=env.aspect, rest=times(env.rest))
        return replace(self, largest=times(self.largest), smallest=times(self.smallest), envelope=envelope,
                       params=self.params.scaled(factor), scale=self.scale * factor)
