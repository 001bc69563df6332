"""The pose envelope: the sizes an affordance's object has in the pose in which it is used.

The stage-1 dimension check looks at the OBB alone; the envelope looks at one
stable pose's task-frame box (half extents ``h``): ``H = 2 h_z``, ``W`` / ``L``
the smaller / larger horizontal full extent, ``aspect = H / W``. ``rest`` is
the agent's bottom height above the ground for the seat, lie and surface kinds.
The same terms become numpy conditions in the scoring source and a check in
the Functional Pose Analyzer, so the two never disagree; one exception: a
vessel's upper bound on ``aspect`` is its rim's (the pose's spill level over
``W``, which a handle rising above the rim does not raise), which only the
analyser sees, so a container's scoring leaves that bound out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["ANY", "Range", "Envelope"]

Range = tuple[float, float]
#: No constraint.
ANY: Range = (0.0, math.inf)


@dataclass(frozen=True)
class Envelope:
    """Plausible ranges (m, or a ratio for ``aspect``) of the pose-dependent sizes; ``ANY`` leaves one free."""

    height: Range = ANY
    width: Range = ANY
    length: Range = ANY
    aspect: Range = ANY
    rest: Range = ANY

    def terms(self) -> list[tuple[str, str, Range]]:
        """(name, numpy expression over ``e`` = pose half extents (n, 3), range) of the constrained box sizes."""
        terms = [("height", "2.0 * e[:, 2]", self.height),
                 ("width", "2.0 * np.minimum(e[:, 0], e[:, 1])", self.width),
                 ("length", "2.0 * np.maximum(e[:, 0], e[:, 1])", self.length),
                 ("height/width", "e[:, 2] / np.maximum(np.minimum(e[:, 0], e[:, 1]), 1e-9)", self.aspect)]
        return [t for t in terms if t[2] != ANY]

    def values(self, half: Sequence[float], rim: float | None = None) -> list[tuple[str, float, Range]]:
        """(name, value, range) of each constrained box size of a pose (half extents); with the pose's ``rim``
        (spill level, m) an aspect above its range is the rim's, ``min(H, rim) / W`` (a handle rising above the
        rim does not make a vessel taller)."""
        hx, hy, hz = half
        width = max(min(hx, hy), 1e-9)
        aspect = hz / width
        if rim is not None and aspect > self.aspect[1]:
            aspect = min(hz, rim / 2) / width
        values = {"height": 2 * hz, "width": 2 * min(hx, hy), "length": 2 * max(hx, hy), "height/width": aspect}
        return [(name, values[name], rng) for name, _, rng in self.terms()]

    def violation(self, half: Sequence[float], rim: float | None = None) -> tuple[str, float, Range] | None:
        """The first box size of a pose (half extents) outside its range: (name, value, range); None when all fit.
        With the pose's ``rim`` (spill level, m) the aspect's upper bound is the rim's: ``rim / W``."""
        hx, hy, hz = half
        width = max(min(hx, hy), 1e-9)
        values = {"height": 2 * hz, "width": 2 * min(hx, hy), "length": 2 * max(hx, hy),
                  "height/width": hz / width}
        for name, _, (lo, hi) in self.terms():
            value = values[name]
            if name == "height/width" and rim is not None and value > hi:
                value = min(hz, rim / 2) / width
            if not lo <= value <= hi:
                return name, value, (lo, hi)
        return None

    def source(self, *, rim_aspect: bool = False) -> str:
        """The box-size conditions as `` & (...)`` numpy terms over ``e``, to append to a scoring mask; with
        ``rim_aspect`` the aspect's upper bound is left to the analyser, which sees the rim."""
        conds = []
        for name, expr, (lo, hi) in self.terms():
            if lo > 0.0:
                conds.append(f"({expr} >= {lo:g})")
            if hi < math.inf and not (rim_aspect and name == "height/width"):
                conds.append(f"({expr} <= {hi:g})")
        return "".join(f" & {c}" for c in conds)

    def doc(self) -> str:
        """The box-size ranges in words, e.g. ``height 0.06-0.16, width 0.03-0.15``."""
        parts = [f"{name} {lo:g}-{hi:g}" for name, _, (lo, hi) in self.terms()]
        return ", ".join(parts) if parts else "any size"
