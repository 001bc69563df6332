"""The pose envelope: the sizes an affordance's object typically has in the pose in which it is used.

One stable pose's task-frame box (half extents ``h``) has ``H = 2 h_z``, ``W`` / ``L`` the smaller / larger
horizontal full extent, and ``aspect = H / W``. ``rest`` is the agent's bottom height above the ground for
the seat and lie kinds (measured where the physics puts the agent down; it is no size of the object's box). The
ranges are typical ranges, never vetoes: :meth:`Affordance.pose_prior <rail_mj.affordances.row.Affordance.pose_prior>`
and :meth:`~rail_mj.affordances.row.Affordance.rest_prior` turn them into a plausibility
(:mod:`rail_mj.affordances.prior`). A vessel's aspect is judged at its rim (the pose's
spill level over ``W``), which a handle rising above the rim does not raise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from rail_mj.affordances.prior import check_width
from rail_mj.core.errors import ConfigError

__all__ = ["ANY", "BOX", "QUANTITIES", "VESSEL_BASE", "Range", "Envelope"]

Range = tuple[float, float]
#: No constraint.
ANY: Range = (0.0, math.inf)
#: The envelope's sizes of the object's box (``rest`` is the agent's, not the box's).
BOX = ("height", "width", "length", "height/width")
#: The thickest solid base under a vessel's cavity, m (a heavy tumbler's, 2-3 cm): a cavity floor higher than this
#: stands on a stem or a foot, which raises the vessel without making it a larger one (a 20 cm wine glass is a
#: 12 cm cup on a stem).
VESSEL_BASE = 0.03
#: Every quantity a prior weighs: the envelope's box sizes, the OBB's largest and smallest dims, and the agent's rest
#: height (``rest``, measured in the rollouts).
QUANTITIES = (*BOX, "largest dim", "smallest dim", "rest height")


@dataclass(frozen=True)
class Envelope:
    """Typical ranges (m, or a ratio for ``aspect``) of the pose-dependent sizes; ``ANY`` leaves one free.
    ``widths``: (quantity, width) pairs for a quantity whose spread past its range is not the default one
    (:func:`rail_mj.affordances.prior.width_of`), each a ConfigError unless in the valid range."""

    height: Range = ANY
    width: Range = ANY
    length: Range = ANY
    aspect: Range = ANY
    rest: Range = ANY
    widths: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        for name, w in self.widths:
            if name not in QUANTITIES:
                raise ConfigError(f"a prior width is for one of {', '.join(QUANTITIES)}; got {name!r}")
            check_width(w)

    def ranges(self) -> dict[str, Range]:
        """The constrained box sizes' ranges by name (``height``, ``width``, ``length``, ``height/width``)."""
        ranges = dict(zip(BOX, (self.height, self.width, self.length, self.aspect), strict=True))
        return {name: rng for name, rng in ranges.items() if rng != ANY}

    def values(self, half: Sequence[float], rim: float | None = None,
               stem: float = 0.0) -> list[tuple[str, float, Range]]:
        """(name, value, range) of each constrained box size of a pose (half extents); with the pose's ``rim``
        (spill level, m) the aspect is the rim's, ``min(H, rim) / W``: a handle rising above the rim makes a
        vessel neither taller than a bowl nor deep enough for a cup. ``stem`` (m) is taken off the height and the
        rim: a stem or a foot under a vessel's cavity (its floor above :data:`VESSEL_BASE`)."""
        hx, hy, hz = (float(v) for v in half)
        hz -= stem / 2
        width = min(hx, hy)
        aspect = hz / width if width > 0 else math.inf
        if rim is not None and width > 0:
            aspect = min(hz, (rim - stem) / 2) / width
        values = {"height": 2 * hz, "width": 2 * width, "length": 2 * max(hx, hy), "height/width": aspect}
        return [(name, values[name], rng) for name, rng in self.ranges().items()]

    def doc(self) -> str:
        """The box-size ranges in words, e.g. ``height 0.06-0.16, width 0.03-0.15``."""
        parts = [f"{name} {lo:g}-{hi:g}" for name, (lo, hi) in self.ranges().items()]
        return ", ".join(parts) if parts else "any size"
