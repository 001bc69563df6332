"""Procedural object generators for the labelled dataset (metres, z up, base on z = 0).

Every generator takes a seeded ``numpy.random.Generator`` and returns a
:class:`Built`: one watertight mesh in its *build frame* (the functional or
natural pose: +z up, resting on z = 0, roughly centred on the z axis) plus a
one-line description of the instance. Parts are joined with manifold3d
booleans so each object is a single closed surface that CoACD can decompose.

Every builder is found by its class name in :data:`GENERATORS` (``shapes.GENERATORS["saucepan"]``):

* :mod:`~rail_mj.dataset.shapes.parts`: :class:`Built`, the basket constants and the shared primitives;
* :mod:`~rail_mj.dataset.shapes.core`: the core family's builders;
* :mod:`~rail_mj.dataset.shapes.world_seats` and :mod:`~rail_mj.dataset.shapes.world`: the world family's
  (armchairs to cartons: the shapes real meshes have);
* :mod:`~rail_mj.dataset.shapes.corruptions`: the scan-like corruptions (:data:`GEOMETRIC_CORRUPTIONS`),
  which take a built mesh and a generator of their own;
* :mod:`~rail_mj.dataset.shapes.catalog`: :data:`GENERATORS`, the builder of every class by class name.
"""

from __future__ import annotations

from rail_mj.dataset.shapes.catalog import GENERATORS
from rail_mj.dataset.shapes.corruptions import (
    DENSE_FACES,
    GEOMETRIC_CORRUPTIONS,
    add_noise,
    densify,
    open_seams,
    punch_holes,
    uneven_bottom,
)
from rail_mj.dataset.shapes.parts import BASKET_AGENT_MIN, BASKET_GAP, Built

__all__ = [
    "Built",
    "GENERATORS",
    "GEOMETRIC_CORRUPTIONS",
    "DENSE_FACES",
    "densify",
    "BASKET_GAP",
    "BASKET_AGENT_MIN",
    "add_noise",
    "punch_holes",
    "open_seams",
    "uneven_bottom",
]
