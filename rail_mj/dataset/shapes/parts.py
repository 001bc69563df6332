"""What every procedural builder shares: the :class:`Built` result, the basket constants and the primitives.

The primitives (revolved profiles, boxes, cylinders, rods, balls, manifold3d booleans, uniform draws, lengths
as text) are the package's own building blocks, hence their underscores: the builders of
:mod:`rail_mj.dataset.shapes.core` and :mod:`rail_mj.dataset.shapes.world` and the corruptions import them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

__all__ = [
    "Built",
    "BASKET_GAP",
    "BASKET_AGENT_MIN",
    "_revolve",
    "_box",
    "_cylinder",
    "_union",
    "_difference",
    "_u",
    "_cm",
    "_rod",
    "_intersection",
    "_ball",
    "_on_floor",
    "_feet",
]

#: Width of the slots between basket slats (m).
BASKET_GAP = 0.01
#: Smallest agent (sphere diameter, m) a basket is guaranteed to hold.
BASKET_AGENT_MIN = 0.015

_SECTIONS = 48  # revolve resolution: ~400-1500 faces per revolved part


@dataclass(frozen=True)
class Built:
    """A generated object in its build frame and a description of the instance."""

    mesh: trimesh.Trimesh
    notes: str


# ---------------------------------------------------------------- primitives


def _revolve(profile: list[tuple[float, float]], sections: int = _SECTIONS) -> trimesh.Trimesh:
    """Revolve a closed (r, z) polygon about z; the winding is fixed so the volume is positive."""
    pts = np.asarray(profile + [profile[0]], dtype=np.float64)
    mesh = trimesh.creation.revolve(pts, sections=sections)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    lo_a, hi_a = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return trimesh.creation.box(extents=hi_a - lo_a,
                                transform=trimesh.transformations.translation_matrix((lo_a + hi_a) / 2))


def _cylinder(
    radius: float, z0: float, z1: float, x: float = 0.0, y: float = 0.0, sections: int = 32
) -> trimesh.Trimesh:
    tf = trimesh.transformations.translation_matrix((x, y, (z0 + z1) / 2))
    return trimesh.creation.cylinder(radius=radius, height=z1 - z0, sections=sections, transform=tf)


def _union(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    return trimesh.boolean.union(parts, engine="manifold")


def _difference(a: trimesh.Trimesh, b: trimesh.Trimesh) -> trimesh.Trimesh:
    return trimesh.boolean.difference([a, b], engine="manifold")


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _cm(x: float) -> str:
    return f"{100 * x:.1f} cm"


def _rod(
    p0: tuple[float, float, float], p1: tuple[float, float, float], radius: float, sections: int = 16
) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([p0, p1], dtype=np.float64), sections=sections)


def _intersection(a: trimesh.Trimesh, b: trimesh.Trimesh) -> trimesh.Trimesh:
    return trimesh.boolean.intersection([a, b], engine="manifold")


def _ball(radius: float, centre: tuple[float, float, float], subdivisions: int = 3) -> trimesh.Trimesh:
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    mesh.apply_translation(centre)
    return mesh


def _on_floor(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh cut at z = 0: the tilted end caps of splayed legs become flat feet."""
    lo, hi = mesh.bounds
    return _intersection(mesh, _box((lo[0] - 0.1, lo[1] - 0.1, 0.0), (hi[0] + 0.1, hi[1] + 0.1, hi[2] + 0.1)))


def _feet(x: float, y: float, top: float, radius: float) -> list[trimesh.Trimesh]:
    return [_cylinder(radius, 0.0, top, sx * x, sy * y, 16) for sx in (-1, 1) for sy in (-1, 1)]

