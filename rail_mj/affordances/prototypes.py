"""Prototypes: the small typed vocabulary of objects a model names to prove its affordance before it is used.

A model that defines a use (stage 0) names, in the same answer, a positive prototype the use must find functional
as it stands and a near-miss negative it must not (the same shell closed or a slab, a box too small). Each is one
of these shapes, in metres, built upright with its base on the ground from convex parts (its hulls, so no
decomposition runs):

- ``open_box`` / ``open_cylinder``: a shell open at the top, ``wall`` thick (walls and floor); a cylinder's
  diameter is ``length``;
- ``closed_box`` / ``closed_cylinder``: the same outline, closed (solid);
- ``slab``: a solid box ``length`` x ``width`` x ``height``;
- ``seat_on_legs``: a top ``length`` x ``width``, ``wall`` thick, its upper face ``height`` above the ground, on
  four legs at its corners;
- ``rod``: a bar ``length`` long and ``width`` across, lying along x;
- ``sphere``: a ball ``length`` across.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field

from rail_mj.core.types import RailObject
from rail_mj.mesh.object import object_from_parts

__all__ = ["SHAPES", "Prototype", "build", "extents", "describe"]

Shape = Literal["open_box", "closed_box", "open_cylinder", "closed_cylinder", "slab", "seat_on_legs", "rod",
                "sphere"]
SHAPES: tuple[str, ...] = Shape.__args__  # type: ignore[attr-defined]
#: the sides of a cylinder's outline and of its wall: a 16-gon's area is within 2.6% of the circle's
_SEGMENTS = 16
#: the largest size of a prototype, m: a bed or a sofa is at most about 2.5 m long; twice that is no household object
_MAX_SIZE = 5.0
#: the thickest wall, m: a 20 cm wall is a solid block, not a shell
_MAX_WALL = 0.2
#: a leg's least side, m: a slim metal stool leg is about 3 cm across
_MIN_LEG = 0.03


class Prototype(BaseModel):
    """One prototype a model names: its role, shape and sizes (m), and why it is a positive or a near miss."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    role: Literal["positive", "negative"]
    shape: Shape
    length: float = Field(gt=0.0, le=_MAX_SIZE, description="x extent, m (a cylinder's or a sphere's diameter)")
    width: float = Field(ge=0.0, le=_MAX_SIZE, description="y extent, m (a rod's thickness; 0 for a cylinder or a "
                                                     "sphere)")
    height: float = Field(ge=0.0, le=_MAX_SIZE, description="z extent, m (the top's upper face for seat_on_legs; 0 for "
                                                      "a rod or a sphere)")
    # default: a 1 cm wall, a plastic or ceramic vessel's
    wall: float = Field(default=0.01, gt=0.0, le=_MAX_WALL, description="wall and floor thickness of a shell, a "
                                                                  "seat_on_legs top's thickness, m")
    why: str = Field(description="why the use must find it functional (positive) or not (negative)")


def _box(lo: list[float], hi: list[float]) -> np.ndarray:
    return trimesh.creation.box(bounds=[lo, hi]).vertices


def _disc(d: float, z0: float, z1: float) -> np.ndarray:
    a = np.linspace(0.0, 2 * math.pi, _SEGMENTS, endpoint=False)
    ring = np.stack([d / 2 * np.cos(a), d / 2 * np.sin(a)], axis=1)
    return np.concatenate([np.c_[ring, np.full(_SEGMENTS, z0)], np.c_[ring, np.full(_SEGMENTS, z1)]])


def _parts(p: Prototype) -> list[np.ndarray]:
    L, W, H, t = p.length, p.width, p.height, p.wall
    if p.shape in ("closed_box", "slab"):
        return [_box([-L / 2, -W / 2, 0.0], [L / 2, W / 2, H])]
    if p.shape == "open_box":
        return [_box([-L / 2, -W / 2, 0.0], [L / 2, W / 2, t]),
                _box([-L / 2, -W / 2, t], [-L / 2 + t, W / 2, H]), _box([L / 2 - t, -W / 2, t], [L / 2, W / 2, H]),
                _box([-L / 2 + t, -W / 2, t], [L / 2 - t, -W / 2 + t, H]),
                _box([-L / 2 + t, W / 2 - t, t], [L / 2 - t, W / 2, H])]
    if p.shape == "closed_cylinder":
        return [_disc(L, 0.0, H)]
    if p.shape == "open_cylinder":
        parts = [_disc(L, 0.0, t)]
        step = 2 * math.pi / _SEGMENTS
        for i in range(_SEGMENTS):
            a0, a1 = i * step, (i + 1) * step
            ring = [(r * math.cos(a), r * math.sin(a)) for r in (L / 2 - t, L / 2) for a in (a0, a1)]
            parts.append(np.array([(x, y, z) for x, y in ring for z in (t, H)]))
        return parts
    if p.shape == "seat_on_legs":
        leg = max(2 * t, _MIN_LEG)
        top = [_box([-L / 2, -W / 2, H - t], [L / 2, W / 2, H])]
        return top + [_box([sx * L / 2 - (leg if sx > 0 else 0), sy * W / 2 - (leg if sy > 0 else 0), 0.0],
                           [sx * L / 2 + (0 if sx > 0 else leg), sy * W / 2 + (0 if sy > 0 else leg), H - t])
                      for sx in (-1, 1) for sy in (-1, 1)]
    if p.shape == "rod":
        r = p.width / 2
        disc = _disc(p.width, -L / 2, L / 2)  # along z, then turned onto x
        return [np.c_[disc[:, 2], disc[:, 1], disc[:, 0] + r]]
    return [trimesh.creation.icosphere(subdivisions=2, radius=L / 2).vertices + [0.0, 0.0, L / 2]]


def extents(p: Prototype) -> list[float]:
    """The prototype's box extents x, y, z as :func:`build` makes it."""
    if p.shape in ("open_cylinder", "closed_cylinder"):
        return [p.length, p.length, p.height]
    if p.shape == "sphere":
        return [p.length] * 3
    if p.shape == "rod":
        return [p.length, p.width, p.width]
    return [p.length, p.width, p.height]


def build(p: Prototype, name: str) -> RailObject:
    """The prototype as an object, upright, its base on the ground (its convex parts are its hulls)."""
    return object_from_parts(name, _parts(p))


def describe(p: Prototype) -> str:
    """``open_box 0.30 x 0.30 x 0.12 m (wall 0.010)``."""
    sizes = {"open_cylinder": (p.length, p.height), "closed_cylinder": (p.length, p.height),
             "rod": (p.length, p.width), "sphere": (p.length,)}.get(p.shape, (p.length, p.width, p.height))
    wall = f" (wall {p.wall:.3f})" if p.shape in ("open_box", "open_cylinder", "seat_on_legs") else ""
    return f"{p.shape} {' x '.join(f'{v:.2f}' for v in sizes)} m{wall}"
