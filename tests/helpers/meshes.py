"""Small generated meshes the mesh tests share."""

import numpy as np
import trimesh


def small_cup() -> trimesh.Trimesh:
    """A watertight 6 cm x 8 cm cup (open top, 5 mm bottom), 96 faces."""
    profile = np.array([[0, 0], [0.03, 0], [0.03, 0.08], [0.026, 0.08], [0.026, 0.005], [0, 0.005]])
    return trimesh.creation.revolve(profile, sections=12)
