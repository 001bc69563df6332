"""Room for feet under a resting pose: how wide a foot gets in at toe height from beside the object, from
surface samples.

A table is used from beside it: a person standing or sitting at it puts the feet under the top's edge, anywhere
along it (between legs, past a pedestal's foot, into a desk's knee space or a console's open compartment). A
closed block, an upturned tub or a bathtub on its side meets a wall at its edge. The slab of space at toe height
is mapped from the samples that fall in it (a wall, a leg or a divider there leaves samples in its cells), and a
foot of breadth b fits where every cell within b/2 is free; it gets under the middle when the free space it fits
in joins the outside and reaches the footprint's middle (:data:`~rail_mj.core.profile.BENEATH_MIDDLE`).
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage

from rail_mj.core.profile import BENEATH_MIDDLE
from rail_mj.mjcf.body import body_size

__all__ = ["toe_room", "TOE_SLAB"]

_ADULT = body_size(1.0)
#: The slab (m above the floor) a foot's forepart fills: from over a pedestal's foot plate (3 cm), which feet step
#: over, to the ankle's height (Winter Fig. 4.1, 0.039 H); the toes lie below the ankle.
TOE_SLAB = (0.035, _ADULT.ankle)
#: Cells across a foot's breadth in the slab's map: a foot fits in a gap a quarter of its breadth wider or
#: narrower than it really is.
_CELLS_PER_FOOT = 4


def toe_room(points: np.ndarray, half: np.ndarray) -> float:
    """The breadth (m) of the widest foot that gets under the middle of the object at toe height from outside:
    0 when none does (a wall all round at the floor); at most the largest breadth tried, four adult feet.

    ``points``: surface samples in the pose's frame (z up, lowest point at 0); ``half``: the pose's box half sizes
    (its centre at ``half[:2]`` in that frame).
    """
    foot = _ADULT.foot_breadth
    cell = foot / _CELLS_PER_FOOT
    lo_z, hi_z = TOE_SLAB
    slab = points[(points[:, 2] >= lo_z) & (points[:, 2] <= hi_z), :2] - half[:2]
    margin = 4 * _CELLS_PER_FOOT + 1  # free cells all round, as wide as the widest foot tried
    n = np.ceil(2 * half[:2] / cell).astype(int) + 2 * margin
    origin = -half[:2] - margin * cell
    blocked = np.zeros(tuple(n), dtype=bool)
    ij = np.floor((slab - origin) / cell).astype(int)
    ij = ij[np.all((ij >= 0) & (ij < n), axis=1)]
    blocked[ij[:, 0], ij[:, 1]] = True
    # a foot's centre may stand where the nearest blocked cell is more than half its breadth away
    clear = np.asarray(scipy.ndimage.distance_transform_edt(~blocked), dtype=np.float64) * cell
    centres = origin + (np.indices(tuple(n)).transpose(1, 2, 0) + 0.5) * cell
    middle = np.sum((centres / np.maximum(half[:2], 1e-9)) ** 2, axis=-1) < BENEATH_MIDDLE
    best = 0.0
    for k in range(1, 4 * _CELLS_PER_FOOT + 1):
        breadth = k * cell
        fits = clear > breadth / 2
        labels = np.asarray(scipy.ndimage.label(fits)[0])  # pyright: ignore[reportIndexIssue]  # (labels, count)
        outside = labels[0, 0]
        if outside == 0 or not np.any((labels == outside) & middle):
            break
        best = breadth
    return float(best)
