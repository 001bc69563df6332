"""One registry row (:class:`Affordance`) and the base of every kind's own parameters (:class:`KindParams`).

A row names its kind (:mod:`rail_mj.affordances.kinds`) and holds that kind's
parameter model in ``params``; a kind registers its model here when it
registers itself (:func:`rail_mj.affordances.kinds.register_kind`), so a row
checks that its params are its kind's.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

from rail_mj.affordances.envelope import ANY, VESSEL_BASE, Envelope, Range
from rail_mj.affordances.prior import FUNCTIONAL, Prior, reach, width_of
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
    #: typical ranges of the largest / smallest OBB dim, m, for a row whose envelope leaves the box free (a
    #: chair's box is no seat's size); stage 1 also reads the envelope's box sizes (:meth:`size_prior`)
    largest: Range = ANY
    smallest: Range = ANY
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

    def _width(self, name: str) -> float:
        return dict(self.envelope.widths).get(name, width_of(name))

    def size_prior(self, dims: Iterable[float]) -> Prior:
        """The pose-free part of a use's prior: the plausibility of the OBB's largest and smallest dims against
        ``largest`` / ``smallest`` (1 for a row whose sizes are all in its envelope). A pose's probability is
        this times its :meth:`pose_prior` times its physics: each size is weighed once."""
        dims = [float(v) for v in dims]
        return Prior.of([(name, v, rng, self._width(name)) for name, v, rng in
                         (("largest dim", max(dims), self.largest), ("smallest dim", min(dims), self.smallest))
                         if rng != ANY])

    def dims_prior(self, dims: Iterable[float]) -> Prior:
        """Stage 1's dimension check as a prior, from the OBB dims alone (no pose known yet): the
        :meth:`size_prior` times the envelope's :meth:`pose_prior` in the OBB's most plausible orientation
        (each of its axes up in turn; a vessel's rim unknown)."""
        dims = [float(v) for v in dims]
        prior = self.size_prior(dims)
        if self.envelope.ranges():
            a, b, c = dims
            poses = [(b / 2, c / 2, a / 2), (a / 2, c / 2, b / 2), (a / 2, b / 2, c / 2)]
            prior = prior * max((self.pose_prior(h) for h in poses), key=lambda p: p.value)
        return prior

    def dims_fit(self, dims: Iterable[float]) -> bool:
        """Stage 1's dimension check: the :meth:`dims_prior` is at least
        :data:`~rail_mj.affordances.prior.FUNCTIONAL` (the sizes are as plausible for this use as not)."""
        return self.dims_prior(dims).value >= FUNCTIONAL

    def pose_prior(self, half: Iterable[float], rim: float | None = None, floor: float | None = None) -> Prior:
        """The envelope as a prior over one pose's box (half extents), a vessel's aspect at its ``rim`` (the
        pose's spill level, m) when given: the product of each constrained size's plausibility. A vessel (the
        container kind) whose basin ``floor`` (m) stands higher than :data:`VESSEL_BASE` is weighed without its
        stem: a wine glass by its bowl, not by its bowl on a stem."""
        stem = max(0.0, floor - VESSEL_BASE) if floor is not None and self.kind == "container" else 0.0
        values = self.envelope.values([float(v) for v in half], rim, stem)
        return Prior.of([(name, v, rng, self._width(name)) for name, v, rng in values])

    def pose_fits(self, half: Iterable[float], rim: float | None = None) -> tuple[bool, str]:
        """Whether a pose's box (half extents) is inside the envelope's typical ranges, a vessel's aspect at its
        ``rim`` (the pose's spill level, m) when given; the sizes outside them when it is not."""
        out = [f for f in self.pose_prior(half, rim).factors if f.plausibility < 1.0]
        if not out:
            return True, ""
        return False, "; ".join(f"in this pose its {f.name} is {f.value:.3f}; a {self.name} typically has "
                                f"{f.lo:g}-{f.hi:g} (plausibility {f.plausibility:.2f})" for f in out)

    def rest_prior(self, height: float) -> Prior:
        """The envelope's ``rest`` as a prior over the agent's rest height (m) where the physics put it down (no
        factor for a row without one)."""
        if self.envelope.rest == ANY:
            return Prior()
        return Prior.of([("rest height", height, self.envelope.rest, self._width("rest height"))])

    def rest_limits(self) -> Range:
        """The rest heights (m) the seat and lie kinds' rules let through: the envelope's typical ``rest`` widened on
        each side to where its :meth:`rest_prior` falls to NEGLIGIBLE (:func:`~rail_mj.affordances.prior.reach`).
        A rest height a real object of the use can give is a prior, not a veto."""
        lo, hi = self.envelope.rest
        f = reach(self._width("rest height"))
        return lo / f, hi * f

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
                            aspect=env.aspect, rest=times(env.rest), widths=env.widths)
        return replace(self, largest=times(self.largest), smallest=times(self.smallest), envelope=envelope,
                       params=self.params.scaled(factor), scale=self.scale * factor)
