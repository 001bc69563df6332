"""The repair step on meshes exported as many closed pieces: more than the decomposition can take one by one are
united into one surface, which is what a simulator collides with; fewer are left for the decomposition."""

from __future__ import annotations

import numpy as np
import trimesh

from rail_mj.mesh import load_object, mesh_notes
from rail_mj.mesh.repair import MAX_PIECES, repair_mesh
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig


def _bowl_of_pieces(n_wall: int = 32, n_floor: int = 8) -> trimesh.Trimesh:
    """A 20 cm bowl 8 cm tall as overlapping closed boxes: wall slabs round a ring (each 60% longer than its arc, so
    neighbours overlap) and floor boxes crossing at the middle, as collision geometry is often exported."""
    parts = []
    r, h, t = 0.1, 0.08, 0.008
    for k in range(n_wall):
        box = trimesh.creation.box([t, 2 * np.pi * r / n_wall * 1.6, h])
        box.apply_translation([r - t / 2, 0, h / 2])
        box.apply_transform(trimesh.transformations.rotation_matrix(2 * np.pi * k / n_wall, [0, 0, 1]))
        parts.append(box)
    for k in range(n_floor):
        box = trimesh.creation.box([2 * r * 0.98, 2 * r * 0.3, t])
        box.apply_translation([0, 0, t / 2])
        box.apply_transform(trimesh.transformations.rotation_matrix(np.pi * k / n_floor, [0, 0, 1]))
        parts.append(box)
    return trimesh.util.concatenate(parts)


def test_forty_overlapping_closed_pieces_are_united_and_the_bowl_is_a_bowl(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "bowl40.stl"
    _bowl_of_pieces().export(path)
    obj = load_object(path)
    assert mesh_notes(obj.mesh) == [f"united 40 overlapping closed pieces into 1 (more than {MAX_PIECES})"]
    assert obj.mesh.is_watertight and obj.mesh.body_count == 1 and len(obj.hulls) <= 32
    (bowl,) = classify([obj], ["bowl"], config=RunConfig(provider="offline", backend="native"), progress=False,
                       workers=1)
    assert bowl.error is None and bowl.functional, bowl.analyzer_reasons


def test_pieces_the_decomposition_takes_one_by_one_are_left_apart() -> None:
    mesh = repair_mesh(_bowl_of_pieces(n_wall=24, n_floor=4))  # 28 pieces: each convex one its own hull
    assert mesh.body_count == 28 and mesh_notes(mesh) == []


def test_open_pieces_are_not_united() -> None:
    """A union of surfaces that enclose nothing is undefined: such a mesh goes to the decomposition as it is."""
    pieces = _bowl_of_pieces()
    open_box = trimesh.creation.box([0.05, 0.05, 0.05])
    open_box.update_faces(np.arange(len(open_box.faces)) != 0)  # one triangle gone: no longer closed
    open_box.apply_translation([0.0, 0.0, 0.2])
    mesh = repair_mesh(trimesh.util.concatenate([pieces, open_box]))
    assert mesh_notes(mesh) == [] and mesh.body_count == 41


def _split_cylinder(gap: float) -> trimesh.Trimesh:
    """A closed 8 cm can whose lid (the faces above 3.9 cm) is a shell of its own, its vertices copied and moved
    ``gap`` m off the body's: how a file storing float32 keeps two faces' copies of one vertex apart."""
    can = trimesh.creation.cylinder(radius=0.025, height=0.08, sections=24)
    top = can.triangles_center[:, 2] > 0.039
    body = trimesh.Trimesh(can.vertices, can.faces[~top], process=False)
    lid = trimesh.Trimesh(can.vertices + gap, can.faces[top], process=False)
    return trimesh.util.concatenate([body, lid])


def test_copies_of_a_vertex_nanometres_apart_are_welded_a_seam_is_not() -> None:
    rounded = repair_mesh(_split_cylinder(4e-9))  # a few float32 roundings at 4 cm
    assert rounded.is_volume and len(rounded.vertices) == 50
    seam = repair_mesh(_split_cylinder(2e-4))  # an open seam of 0.2 mm, as the world family's corruption makes
    assert not seam.is_watertight
