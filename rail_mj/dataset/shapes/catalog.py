"""The builder of every class, by class name: :data:`GENERATORS` (the core family's, then the world family's)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from rail_mj.dataset.shapes.core import (
    basket,
    bathtub,
    bench,
    bowl,
    bowl_holed,
    chair,
    chair_high_seat,
    cone,
    cup,
    cup_no_bottom,
    plate,
    pot,
    rack,
    solid_box,
    solid_cylinder,
    sphere,
    table,
    table_tilted,
    torus,
    trash_bin,
    tray,
    vase,
    vase_closed,
)
from rail_mj.dataset.shapes.parts import Built
from rail_mj.dataset.shapes.world import (
    ashtray,
    bed,
    bowl_real,
    carton,
    console,
    cubby,
    desk,
    goblet,
    handle_pot,
    ladle,
    plate_real,
    riser,
    saucepan,
    scoop,
    wall_shelf_box,
)
from rail_mj.dataset.shapes.world_seats import armchair, bar_chair, lounge_chair, ottoman, shell_chair, sofa, stool

__all__ = ["GENERATORS"]

#: Generator of every class, by class name.
GENERATORS: dict[str, Callable[[np.random.Generator], Built]] = {
    "cup": cup,
    "bowl": bowl,
    "vase": vase,
    "basket": basket,
    "bathtub": bathtub,
    "plate": plate,
    "table": table,
    "chair": chair,
    "pot": pot,
    "trash_bin": trash_bin,
    "tray": tray,
    "bench": bench,
    "cup_no_bottom": cup_no_bottom,
    "bowl_holed": bowl_holed,
    "chair_high_seat": chair_high_seat,
    "table_tilted": table_tilted,
    "vase_closed": vase_closed,
    "solid_cylinder": solid_cylinder,
    "solid_box": solid_box,
    "sphere": sphere,
    "cone": cone,
    "torus": torus,
    "rack": rack,
    "armchair": armchair,
    "bar_chair": bar_chair,
    "shell_chair": shell_chair,
    "lounge_chair": lounge_chair,
    "stool": stool,
    "ottoman": ottoman,
    "sofa": sofa,
    "bowl_real": bowl_real,
    "saucepan": saucepan,
    "handle_pot": handle_pot,
    "scoop": scoop,
    "goblet": goblet,
    "plate_real": plate_real,
    "cubby": cubby,
    "wall_shelf_box": wall_shelf_box,
    "bed": bed,
    "desk": desk,
    "console": console,
    "ladle": ladle,
    "ashtray": ashtray,
    "riser": riser,
    "carton": carton,
}
