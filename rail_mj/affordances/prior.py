"""Size priors: how plausible a size is for an affordance, in [0, 1], smooth at a range's edges.

A registry range (the OBB's largest and smallest dims, a pose envelope's height, width, length, aspect, rest)
is the *typical* range of an object of that use. Inside it the plausibility is 1; outside it falls off as a
Gaussian in log-size, so that a size ``1 + width`` times past an edge keeps half of it:

    p(v) = 2 ** -((ln(v / hi) / ln(1 + width)) ** 2)    for v > hi   (and ln(lo / v) below lo)

It is continuous at the edges (no cliff), and a size far outside the range (a 2 m "cup") is near 0 without
ever being a veto. The prior of several sizes is the product of their plausibilities.

How the pipeline uses a prior (:mod:`rail_mj.pipeline.chain`): where the object's prior is below
:data:`NEGLIGIBLE` the physics is not run (the probability, at most the prior, is reported as the prior), nor for a
stable pose whose own prior is; otherwise a pose's probability is the prior times its physics, and a use is
functional when that is at least :data:`FUNCTIONAL`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from rail_mj.core.errors import ConfigError

__all__ = ["DEFAULT_WIDTH", "ASPECT_WIDTH", "NEGLIGIBLE", "FUNCTIONAL", "WIDTH_RANGE", "Factor", "Prior",
           "plausibility", "check_width", "width_of", "reach"]

#: Half the plausibility of a length is gone this far past its range, as a fraction of the bound. Things of
#: everyday use are sized to the body that uses them (a hand, a seat, a lying person), and their typical range
#: already spans the 5th to 95th percentile of users; past it they fit fewer users as fast as body sizes thin
#: out: adult body dimensions have a coefficient of variation of about 5% (Pheasant, Bodyspace, 3rd ed.,
#: tables 2.x), and half is gone two of them past the range.
DEFAULT_WIDTH = 0.1
#: A ratio of two lengths (height/width) spreads as both do, independently: ln(1 + w) grows by sqrt(2).
ASPECT_WIDTH = (1.0 + DEFAULT_WIDTH) ** math.sqrt(2.0) - 1.0
#: A prior below this is no use worth imagining: a size about 2.6 widths past its range (2 ** -6.6), a 30%
#: larger or smaller object than any of its class; the physics is skipped and the prior is the probability.
NEGLIGIBLE = 0.01
#: A use is functional when its probability is at least this: more likely than not.
FUNCTIONAL = 0.5
#: Widths outside this range are no prior: 1% would be a cliff again, a factor 10 would accept anything.
WIDTH_RANGE = (0.01, 10.0)


def check_width(width: float) -> float:
    """``width`` if it is a usable prior width, else a ConfigError naming the valid range."""
    lo, hi = WIDTH_RANGE
    if isinstance(width, bool) or not isinstance(width, (int, float)) or not lo <= width <= hi:
        raise ConfigError(f"a prior width must be a number in [{lo:g}, {hi:g}] (a fraction of the bound); "
                          f"got {width!r}")
    return float(width)


def width_of(name: str) -> float:
    """The width of a quantity by its name: :data:`ASPECT_WIDTH` for a ratio (``height/width``), else
    :data:`DEFAULT_WIDTH`."""
    return ASPECT_WIDTH if "/" in name else DEFAULT_WIDTH


def reach(width: float = DEFAULT_WIDTH) -> float:
    """The factor past a range's bound at which the plausibility falls to :data:`NEGLIGIBLE` (1.28 for the default
    width): ``(1 + width) ** sqrt(log2(1 / NEGLIGIBLE))``. A rule that must bound a size the physics measures (a
    sitter's hips above the ground) bounds it here; inside, the size is a prior, not a veto."""
    return float((1.0 + check_width(width)) ** math.sqrt(math.log2(1.0 / NEGLIGIBLE)))


def plausibility(value: float, lo: float, hi: float, width: float = DEFAULT_WIDTH) -> float:
    """The plausibility in [0, 1] of ``value`` for a typical range ``[lo, hi]`` (``lo`` 0 or ``hi`` inf leave a
    side open); ``width``: the fraction past a bound at which half of it is gone. A non-positive or non-finite
    value has plausibility 0 against a range with a positive lower bound, else 1 or 0 as it lies."""
    check_width(width)
    if not math.isfinite(value):
        return 0.0 if math.isfinite(hi) else 1.0
    if lo <= value <= hi:
        return 1.0
    if value <= 0.0:
        return 0.0
    ratio = hi / value if value > hi else value / lo
    x = math.log(ratio) / math.log1p(width)
    return float(2.0 ** -(x * x))


@dataclass(frozen=True)
class Factor:
    """One size's share of a prior: the size, its typical range, its width and its plausibility."""

    name: str  # e.g. "largest dim", "height", "height/width"
    value: float
    lo: float
    hi: float
    width: float
    plausibility: float
    #: a factor that is no size (how the object came): its words, and no range
    words: str = ""

    @classmethod
    def said(cls, words: str, plausibility: float) -> Factor:
        """A factor that is no size's: ``words`` and a plausibility."""
        return cls(words, plausibility, 0.0, 1.0, 0.0, plausibility, words)

    def doc(self) -> str:
        """``height 0.175 (typical 0.06-0.16, width 25%): 0.72``."""
        if self.words:
            return f"{self.words}: {self.plausibility:.2f}"
        return (f"{self.name} {self.value:.3g} (typical {self.lo:g}-{self.hi:g}, width {self.width:.0%}): "
                f"{self.plausibility:.2f}")


@dataclass(frozen=True)
class Prior:
    """A product of size plausibilities, each kept as a :class:`Factor` for the explanation."""

    factors: tuple[Factor, ...] = ()

    @classmethod
    def of(cls, terms: Iterable[tuple[str, float, tuple[float, float], float]]) -> Prior:
        """From (name, value, (lo, hi), width) terms."""
        return cls(tuple(Factor(name, float(v), lo, hi, w, plausibility(v, lo, hi, w))
                         for name, v, (lo, hi), w in terms))

    @property
    def value(self) -> float:
        p = 1.0
        for f in self.factors:
            p *= f.plausibility
        return p

    def __mul__(self, other: Prior) -> Prior:
        return Prior(self.factors + other.factors)

    def doc(self) -> str:
        """Each factor in words, ``; ``-separated, then the product."""
        if not self.factors:
            return "no size prior: 1"
        return "; ".join(f.doc() for f in self.factors) + f" -> prior {self.value:.2f}"
