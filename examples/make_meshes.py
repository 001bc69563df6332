"""Write the example meshes the affordance files are tried on: ``python examples/make_meshes.py OUT_DIR``.

birdbath.stl: a shallow stone basin 45 cm across and 8 cm tall, water 5 cm deep; dog_bed.stl: a cushion
90 x 65 cm, 10 cm thick; coaster.stl: a ceramic coaster 10 cm across, 8 mm thick with a 3 mm well inside its rim.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

__all__ = ["revolve", "meshes"]


def revolve(profile: list[tuple[float, float]]) -> trimesh.Trimesh:
    """A closed (r, z) outline revolved about z (positive volume)."""
    mesh = trimesh.creation.revolve(np.asarray(profile + [profile[0]], dtype=float), sections=64)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def meshes() -> dict[str, trimesh.Trimesh]:
    """The three example objects by file name."""
    return {
        # outer foot 16 cm across, rim 45 cm across 8 cm up, a 2 cm wall, the basin floor 3 cm up
        "birdbath.stl": revolve([(0.0, 0.0), (0.08, 0.0), (0.225, 0.07), (0.225, 0.08), (0.205, 0.08),
                                 (0.07, 0.03), (0.0, 0.03)]),
        "dog_bed.stl": trimesh.creation.box(extents=(0.9, 0.65, 0.1),
                                            transform=trimesh.transformations.translation_matrix((0, 0, 0.05))),
        # 10 cm across, 8 mm tall, a 5 mm rim around a well whose floor is 3 mm up
        "coaster.stl": revolve([(0.0, 0.0), (0.05, 0.0), (0.05, 0.008), (0.045, 0.008), (0.043, 0.003),
                                (0.0, 0.003)]),
    }


if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    out.mkdir(parents=True, exist_ok=True)
    for name, mesh in meshes().items():
        mesh.export(out / name)
        print(out / name)
