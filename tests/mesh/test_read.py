"""Mesh loading, repair, validation, CoACD decomposition and its cache, object properties."""

from __future__ import annotations

import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh
from meshes import small_cup  # tests/helpers

import rail_mj.mesh.coacd_run as coacd_run
import rail_mj.mesh.decomposition as mesh_decomposition
import rail_mj.mesh.quality as mesh_quality
import rail_mj.mesh.read as mesh_read
import rail_mj.mesh.repair as mesh_repair
from rail_mj.core.errors import ConfigError, DecompositionError, DecompositionTimeout, MeshError
from rail_mj.mesh import (
    DEFAULT_DENSITY,
    DENSE_DECOMPOSITION,
    DENSE_FACES,
    GUARD_DECOMPOSITION,
    MAX_EXCESS,
    SUPPORTED_EXTENSIONS,
    DecompositionConfig,
    decompose,
    decomposition_for,
    hull_quality,
    load_mesh,
    load_object,
    mesh_hash,
    mesh_notes,
    object_from_mesh,
    reduce_hull,
    repair_mesh,
)
from rail_mj.mesh.coacd_run import CoacdCrash

# Tiny CoACD settings: a test decomposition takes seconds, not minutes.
# (mcts_max_depth=1 is a trap: CoACD then cuts badly and merging takes ~50x longer.)
TINY = DecompositionConfig(
    threshold=0.15,
    max_convex_hull=16,
    max_hull_vertices=16,
    preprocess_mode="off",
    resolution=200,
    mcts_nodes=4,
    mcts_iterations=8,
    mcts_max_depth=2,
)


pytestmark = pytest.mark.usefixtures("shared_cache")


@pytest.fixture(scope="module")
def cup_object(tmp_path_factory: pytest.TempPathFactory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RAIL_MJ_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))
        return object_from_mesh(small_cup(), name="cup", decomposition=TINY)


def box(extents=(0.1, 0.2, 0.3)) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=extents)


@pytest.mark.parametrize("ext", ["obj", "stl", "ply", "off", "glb"])
def test_loads_every_format(tmp_path: Path, ext: str) -> None:
    path = tmp_path / f"box.{ext}"
    box().export(path)
    mesh = load_mesh(path)
    np.testing.assert_allclose(np.sort(mesh.extents), [0.1, 0.2, 0.3], atol=1e-6)
    assert mesh.is_watertight and mesh.volume > 0


def _two_mesh_scene() -> trimesh.Scene:
    scene = trimesh.Scene()
    scene.add_geometry(
        box((0.1, 0.1, 0.1)), node_name="a", transform=trimesh.transformations.translation_matrix([0.5, 0, 0])
    )
    scene.add_geometry(
        box((0.1, 0.1, 0.1)), node_name="b", transform=trimesh.transformations.translation_matrix([0, 0, 0.3])
    )
    return scene


def test_glb_scene_merges_with_transforms(tmp_path: Path) -> None:
    path = tmp_path / "two.glb"
    _two_mesh_scene().export(path)
    mesh = load_mesh(path)
    assert len(mesh.faces) == 24
    np.testing.assert_allclose(mesh.bounds, [[-0.05, -0.05, -0.05], [0.55, 0.05, 0.35]], atol=1e-6)


def test_gltf_scene_with_buffer_file(tmp_path: Path) -> None:
    files = _two_mesh_scene().export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    gltf = next(tmp_path / n for n in files if n.endswith(".gltf"))
    mesh = load_mesh(gltf)
    assert len(mesh.faces) == 24
    assert mesh.bounds[1][0] == pytest.approx(0.55, abs=1e-6)


def test_units_scale(tmp_path: Path) -> None:
    path = tmp_path / "mm.stl"
    box((100.0, 200.0, 300.0)).export(path)
    mesh = load_mesh(path, units=0.001)
    np.testing.assert_allclose(np.sort(mesh.extents), [0.1, 0.2, 0.3], atol=1e-6)


def test_y_up_becomes_z_up(tmp_path: Path) -> None:
    path = tmp_path / "tall_y.obj"
    tall = box((0.1, 0.4, 0.2))
    tall.apply_translation([0, 0.2, 0.1])  # occupies y in [0, 0.4], z in [0, 0.2]
    tall.export(path)
    mesh = load_mesh(path, up="y")
    # (x, y, z) -> (x, -z, y): old y becomes z, old z becomes -y
    np.testing.assert_allclose(mesh.bounds, [[-0.05, -0.2, 0.0], [0.05, 0.0, 0.4]], atol=1e-6)
    assert mesh.volume > 0  # a proper rotation keeps the winding outward


def test_repair_merges_vertices_and_drops_degenerate_faces() -> None:
    base = box()
    soup = trimesh.Trimesh(base.vertices[base.faces].reshape(-1, 3), np.arange(36).reshape(-1, 3), process=False)
    faces = np.vstack([soup.faces, soup.faces[:1], [[0, 0, 1]]])  # a duplicate and a degenerate face
    flipped = faces.copy()
    flipped[:3] = flipped[:3, ::-1]  # inconsistent winding on some faces
    mesh = repair_mesh(trimesh.Trimesh(soup.vertices, flipped, process=False))
    assert len(mesh.vertices) == 8 and len(mesh.faces) == 12
    assert mesh.is_volume


def _write(path: Path, text: str | bytes) -> Path:
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("name", "content", "units", "pattern"),
    [
        ("empty.obj", "", 1.0, "empty file"),
        ("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", 1.0, "no faces"),
        (
            "nan.obj",
            "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 nan\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n",
            1.0,
            "NaN or inf",
        ),
        ("flat.obj", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0.1 0.1 0\nf 1 2 3\nf 2 4 3\n", 1.0, "flat"),
        ("garbage.stl", b"\x00\x01garbage\xff" * 3, 1.0, "not a valid STL file.*binary.*ASCII"),
        ("model.fbx", "whatever", 1.0, r"unknown extension '\.fbx'.*\.obj"),
    ],
)
def test_bad_files_are_rejected(tmp_path: Path, name: str, content: str, units: float, pattern: str) -> None:
    path = _write(tmp_path / name, content)
    with pytest.raises(MeshError, match=pattern) as info:
        load_mesh(path, units=units)
    assert name in str(info.value)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MeshError, match="not found"):
        load_mesh(tmp_path / "nope.obj")


def test_directory_is_not_a_file(tmp_path: Path) -> None:
    (tmp_path / "dir.obj").mkdir()
    with pytest.raises(MeshError, match="not a regular file"):
        load_mesh(tmp_path / "dir.obj")


@pytest.mark.parametrize(("size", "pattern"), [(20.0, "too large.*units="), (0.001, "too small.*units=")])
def test_absurd_sizes(tmp_path: Path, size: float, pattern: str) -> None:
    path = tmp_path / "cube.stl"
    box((size, size, size)).export(path)
    with pytest.raises(MeshError, match=pattern):
        load_mesh(path)


def test_bad_options(tmp_path: Path) -> None:
    path = tmp_path / "b.stl"
    box().export(path)
    with pytest.raises(ConfigError, match="units"):
        load_mesh(path, units=0.0)
    with pytest.raises(ConfigError, match="'z' or 'y'"):
        load_mesh(path, up="x")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="max_hull_vertices"):
        DecompositionConfig(max_hull_vertices=65)


def test_supported_extensions_are_listed() -> None:
    assert set(SUPPORTED_EXTENSIONS) == {".obj", ".stl", ".ply", ".off", ".glb", ".gltf"}


def test_reduce_hull_caps_vertices_and_fits() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)  # 642 vertices
    reduced = reduce_hull(sphere.vertices, 32)
    assert len(reduced) == 32
    hull = trimesh.convex.convex_hull(reduced)
    assert hull.volume > 0.75 * sphere.volume  # an inscribed 32-point hull of a sphere keeps most of it
    assert np.all(np.linalg.norm(reduced, axis=1) == pytest.approx(0.1, abs=1e-9))


def test_decomposition_of_cup(cup_object) -> None:
    hulls = cup_object.hulls
    assert 2 <= len(hulls) <= TINY.max_convex_hull
    assert all(len(h) <= TINY.max_hull_vertices and h.shape[1] == 3 for h in hulls)
    lo = np.min([h.min(0) for h in hulls], axis=0)
    hi = np.max([h.max(0) for h in hulls], axis=0)
    np.testing.assert_allclose(lo, cup_object.mesh.bounds[0], atol=5e-3)
    np.testing.assert_allclose(hi, cup_object.mesh.bounds[1], atol=5e-3)
    # the cavity stays open: no hull covers the point in the middle of the cup
    centre = np.array([0.0, 0.0, 0.05])
    for h in hulls:
        assert not trimesh.convex.convex_hull(h).contains([centre])[0]


def test_second_call_hits_cache(cup_object, monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(*args, **kwargs):
        raise AssertionError("CoACD must not run on a cache hit")

    monkeypatch.setattr(mesh_decomposition, "_run_coacd", boom)
    assert list((mesh_decomposition.cache_dir("hulls")).glob("*.npz"))  # stored under RAIL_MJ_CACHE/hulls
    again = object_from_mesh(small_cup(), name="cup", decomposition=TINY)
    assert again.mesh_hash == cup_object.mesh_hash
    assert len(again.hulls) == len(cup_object.hulls)
    for a, b in zip(again.hulls, cup_object.hulls, strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_coacd_crash_is_retried_with_its_remeshing_then_a_named_error(tmp_path, monkeypatch):
    seen = []

    def crash_without_remeshing(vertices, faces, options, time_limit_s):
        seen.append(options["preprocess_mode"])
        if options["preprocess_mode"] != "on":
            raise CoacdCrash("killed by signal 11")
        return [np.asarray(vertices)]

    monkeypatch.setattr(mesh_decomposition, "coacd_child", crash_without_remeshing)
    mesh = small_cup()
    assert len(mesh_decomposition._run_coacd(mesh, DecompositionConfig(preprocess_mode="off"))) == 1
    assert seen == ["off", "on"]
    # a child that really dies by a signal, every time: the caller lives and is told what happened
    segv = tmp_path / "segv"
    segv.write_text("#!/bin/sh\nkill -SEGV $$\n")
    segv.chmod(0o755)
    monkeypatch.undo()
    monkeypatch.setattr(coacd_run, "_idle", [])  # a server of its own, the one that dies
    monkeypatch.setattr(coacd_run.sys, "executable", str(segv))
    with pytest.raises(DecompositionError, match=r"CoACD crashed on this mesh \(killed by signal 11\), and again"):
        mesh_decomposition._run_coacd(mesh, DecompositionConfig(preprocess_mode="off"))


def test_damaged_cache_entry_is_recomputed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path))
    sphere = trimesh.creation.icosphere(subdivisions=1, radius=0.05)
    first = decompose(sphere)
    (entry,) = (tmp_path / "hulls").glob("*.npz")
    entry.write_bytes(b"not a zip")
    again = decompose(sphere)
    np.testing.assert_array_equal(first[0], again[0])
    assert entry.stat().st_size > 9


def test_convex_mesh_skips_coacd(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_decomposition, "_run_coacd", lambda *a, **k: pytest.fail("convex meshes need no CoACD"))
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    hulls = decompose(sphere, DecompositionConfig(max_hull_vertices=20))
    assert len(hulls) == 1 and len(hulls[0]) == 20


def test_auto_preprocess_only_for_open_meshes() -> None:
    open_box = box()
    open_box.update_faces(open_box.face_normals[:, 2] < 0.5)
    assert mesh_decomposition._preprocess_mode(small_cup(), DecompositionConfig()) == "off"
    assert mesh_decomposition._preprocess_mode(open_box, DecompositionConfig()) == "on"
    assert mesh_decomposition._preprocess_mode(small_cup(), DecompositionConfig(preprocess_mode="on")) == "on"


def test_coacd_without_hulls_raises(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_decomposition, "_run_coacd", lambda *a, **k: [])
    with pytest.raises(DecompositionError, match="no usable hull"):
        decompose(small_cup(), DecompositionConfig(threshold=0.5))


def test_cup_properties(cup_object) -> None:
    # solid of revolution: outer cylinder minus the cavity
    volume = np.pi * (0.03**2 * 0.08 - 0.026**2 * 0.075)
    assert cup_object.mass == pytest.approx(DEFAULT_DENSITY * volume, rel=0.05)  # 12-gon vs circle
    assert cup_object.com[:2] == pytest.approx([0.0, 0.0], abs=1e-9)
    assert 0.02 < cup_object.com[2] < 0.04  # heavy bottom pulls it below mid-height
    assert cup_object.obb_dims[0] == pytest.approx(0.08, abs=1e-6)
    assert list(cup_object.obb_dims) == sorted(cup_object.obb_dims, reverse=True)
    assert len(cup_object.mesh_hash) == 64


def test_load_object_box(tmp_path: Path) -> None:
    path = tmp_path / "crate.obj"
    box((0.1, 0.2, 0.3)).export(path)
    obj = load_object(path, density=1000.0)
    assert obj.name == "crate" and obj.source == str(path)
    np.testing.assert_allclose(obj.obb_dims, [0.3, 0.2, 0.1], atol=1e-6)
    assert obj.mass == pytest.approx(6.0)
    np.testing.assert_allclose(obj.com, [0, 0, 0], atol=1e-9)
    assert len(obj.hulls) == 1 and len(obj.hulls[0]) == 8


def test_open_mesh_mass_from_hulls(monkeypatch: pytest.MonkeyPatch) -> None:
    open_box = box((0.1, 0.1, 0.1))
    open_box.update_faces(open_box.face_normals[:, 2] < 0.5)  # remove the top: not a closed volume
    assert not open_box.is_watertight
    monkeypatch.setattr(
        mesh_decomposition, "_run_coacd", lambda mesh, config: [np.asarray(box((0.1, 0.1, 0.1)).vertices)]
    )
    obj = object_from_mesh(open_box, name="open", density=100.0)
    assert obj.mass == pytest.approx(100.0 * 0.001)


def test_bad_density() -> None:
    with pytest.raises(ConfigError, match="density"):
        object_from_mesh(box(), name="b", density=-1.0)


# ---- garbage bytes, other encodings ------------------------------------------------------


@pytest.mark.parametrize("ext", ["stl", "obj", "ply", "off", "glb", "gltf"])
@pytest.mark.parametrize("seed", [0, 1])
def test_random_bytes_are_not_a_valid_file(tmp_path: Path, ext: str, seed: int) -> None:
    path = _write(tmp_path / f"noise.{ext}", np.random.default_rng(seed).bytes(4096))
    with pytest.raises(MeshError) as info:
        load_mesh(path)
    message = str(info.value)
    assert f"is not a valid {ext.upper()} file" in message and "accepted formats: OBJ, STL" in message
    assert "charset" not in message and "module" not in message  # never blame an optional module
    if ext == "stl":
        assert "binary STL" in message and "ASCII STL" in message and "4,096 bytes" in message


def test_binary_stl_with_a_non_utf8_header_loads(tmp_path: Path) -> None:
    data = bytearray(trimesh.exchange.stl.export_stl(box()))
    data[:80] = bytes(range(128, 208))  # exporters write arbitrary bytes there
    mesh = load_mesh(_write(tmp_path / "header.stl", bytes(data)))
    assert len(mesh.faces) == 12 and mesh.is_volume


def test_latin1_obj_loads(tmp_path: Path) -> None:
    text = "# mod\xe8le export\xe9\n" + trimesh.exchange.obj.export_obj(box())
    mesh = load_mesh(_write(tmp_path / "latin1.obj", text.encode("latin-1")))
    assert len(mesh.faces) == 12 and mesh.is_volume


# ---- face budget: decimation and refusal -------------------------------------------------


def fine_cup(rows: int = 16, sections: int = 64) -> trimesh.Trimesh:
    """The 6 cm x 8 cm cup of :func:`small_cup` with subdivided walls, 4096 faces."""
    outer = np.column_stack([np.full(rows, 0.03), np.linspace(0, 0.08, rows)])
    inner = np.column_stack([np.full(rows, 0.026), np.linspace(0.08, 0.005, rows)])
    return trimesh.creation.revolve(np.vstack([[0, 0], outer, inner, [0, 0.005]]), sections=sections)


def test_mesh_below_the_face_budget_is_untouched() -> None:
    mesh = repair_mesh(small_cup())
    assert mesh_notes(mesh) == [] and len(mesh.faces) == 96
    # the digest the hull and stable-pose caches were keyed by before the face budget existed
    assert mesh_hash(mesh) == "380e4a20063137c899d4c8527f799f1e6a2f5d3b0c968a47e9647966a5752a2a"


def test_mesh_over_the_face_budget_is_decimated_and_keeps_a_cups_cavity(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_repair, "FACE_BUDGET", 1000)
    cup = fine_cup()
    mesh = repair_mesh(cup)
    assert len(mesh.faces) <= 1000
    assert mesh_notes(mesh) == [f"decimated from 4,096 to {len(mesh.faces):,} faces (face budget 1,000)"]
    assert mesh.is_volume and mesh.volume == pytest.approx(cup.volume, rel=0.05)
    np.testing.assert_allclose(mesh.bounds, cup.bounds, atol=5e-4)
    cavity = [[0, 0, 0.04], [0.015, 0.0, 0.07], [0, 0, 0.0075]]
    wall = [[0.028, 0, 0.04], [0, 0.028, 0.06], [0, 0, 0.0025]]
    assert not mesh.contains(cavity).any() and mesh.contains(wall).all()
    again = repair_mesh(mesh)  # object_from_mesh repairs a loaded mesh again: the note stays
    assert mesh_notes(again) == mesh_notes(mesh) and len(again.faces) == len(mesh.faces)


def test_costly_steps_see_only_the_decimated_mesh(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_repair, "FACE_BUDGET", 1000)
    seen: dict[str, int] = {}
    oriented_bounds = trimesh.bounds.oriented_bounds

    def spy_bounds(obj, *args, **kwargs):
        seen["oriented_bounds"] = len(obj.faces)
        return oriented_bounds(obj, *args, **kwargs)

    def spy_coacd(mesh, config):
        seen["coacd"] = len(mesh.faces)
        return [np.asarray(mesh.vertices)]

    monkeypatch.setattr(trimesh.bounds, "oriented_bounds", spy_bounds)
    monkeypatch.setattr(mesh_decomposition, "_run_coacd", spy_coacd)
    fine_cup().export(tmp_path / "fine.ply")
    obj = load_object(tmp_path / "fine.ply")
    assert seen == {"oriented_bounds": len(obj.mesh.faces), "coacd": len(obj.mesh.faces)}
    assert len(obj.mesh.faces) <= 1000 and mesh_notes(obj.mesh)
    assert obj.mesh_hash == mesh_hash(obj.mesh)


@pytest.mark.parametrize("ext", ["ply", "stl", "off"])
def test_mesh_over_the_face_limit_is_refused_before_parsing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ext: str
) -> None:
    monkeypatch.setattr(mesh_read, "MAX_FACES", 1000)  # the header check
    monkeypatch.setattr(mesh_repair, "MAX_FACES", 1000)  # repair_mesh's check and the message
    path = tmp_path / f"fine.{ext}"
    fine_cup().export(path)
    monkeypatch.setattr(mesh_read.trimesh, "load", lambda *a, **k: pytest.fail("refused meshes are not parsed"))
    with pytest.raises(MeshError, match=r"has 4,096 faces, over the limit of 1,000.*decimate it first"):
        load_mesh(path)


def test_mesh_over_the_face_limit_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_read, "MAX_FACES", 1000)  # the header check
    monkeypatch.setattr(mesh_repair, "MAX_FACES", 1000)  # repair_mesh's check and the message
    fine_cup().export(tmp_path / "fine.glb")  # no face count in a header: counted after parsing
    with pytest.raises(MeshError, match=r"has 4,096 faces, over the limit of 1,000"):
        load_mesh(tmp_path / "fine.glb")
    monkeypatch.setattr(mesh_quality, "decompose", lambda *a, **k: pytest.fail("refused meshes are not decomposed"))
    with pytest.raises(MeshError, match=r"over the limit of 1,000"):
        object_from_mesh(fine_cup(), name="fine")


def test_file_over_the_size_limit_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_read, "MAX_FILE_BYTES", 2**20)
    path = tmp_path / "big.obj"
    path.write_bytes(b"# padding\n" * 2**17)
    monkeypatch.setattr(mesh_read.trimesh, "load", lambda *a, **k: pytest.fail("refused files are not parsed"))
    with pytest.raises(MeshError, match=r"big.obj: is 1.2 MiB, over the 1 MiB limit"):
        load_mesh(path)


def noisy_sphere() -> trimesh.Trimesh:
    """A closed 5 cm sphere of 5,120 faces with 1 mm noise: quadric decimation leaves it with holes."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    sphere.vertices += np.random.default_rng(0).normal(0.0, 0.001, sphere.vertices.shape)
    return sphere


def test_decimation_keeps_a_closed_mesh_closed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_repair, "FACE_BUDGET", 2000)
    sphere = noisy_sphere()
    quadric = sphere.simplify_quadric_decimation(face_count=2000)
    assert not trimesh.Trimesh(quadric.vertices, quadric.faces).is_volume  # what fast-simplification gives
    mesh = repair_mesh(sphere)
    assert len(mesh.faces) <= 2000 and mesh.is_volume
    assert mesh.volume == pytest.approx(sphere.volume, rel=0.03)


# ---- hull quality ------------------------------------------------------------------------


def test_hull_quality_of_exact_hulls() -> None:
    crate = box((0.1, 0.2, 0.3))
    quality = hull_quality(crate, (np.asarray(crate.vertices),))
    assert quality.n_hulls == 1 and quality.volume_ratio == pytest.approx(1.0, abs=0.01)
    assert quality.excess == pytest.approx(0.0, abs=1e-9) and quality.missing == 0.0


def test_hull_quality_sees_a_filled_cavity_and_a_lost_part() -> None:
    cup = repair_mesh(small_cup())
    filled = hull_quality(cup, (np.asarray(cup.vertices),))  # one hull: the cup holds nothing
    assert filled.excess > 0.5 and filled.volume_ratio > 2.0 and filled.missing == 0.0
    bottom = hull_quality(cup, (cup.vertices[cup.vertices[:, 2] < 0.01],))  # the walls are lost
    assert bottom.missing > 0.5 and bottom.volume_ratio < 0.5 and bottom.excess < 0.01


def test_hull_quality_of_an_open_mesh() -> None:
    bin_ = box((0.1, 0.1, 0.1))
    bin_.update_faces(bin_.face_normals[:, 2] < 0.5)  # no top: a single-surface bin
    filled = hull_quality(bin_, (np.asarray(bin_.vertices),))
    assert filled.volume_ratio is None and filled.missing == 0.0
    assert filled.excess == pytest.approx(1.0, abs=0.01)  # seen from above, the one hull fills the whole bin
    walls = []
    for axis in range(3):
        for side in (-0.05, 0.05):
            if axis == 2 and side > 0:
                continue  # the open top
            # 1 mm walls inside the surface, thinner than the probe grid's half cell (1.6 mm)
            slab = box(np.where(np.arange(3) == axis, 0.001, 0.1))
            slab.apply_translation(np.where(np.arange(3) == axis, side - np.sign(side) * 0.0005, 0.0))
            walls.append(np.asarray(slab.vertices))
    kept = hull_quality(bin_, tuple(walls))
    assert kept.excess < 0.05 and kept.missing == 0.0


def test_hull_quality_of_the_decomposed_cup(cup_object) -> None:
    quality = hull_quality(cup_object.mesh, cup_object.hulls)
    assert quality.n_hulls == len(cup_object.hulls)
    # TINY's coarse hulls bulge into the cup (its droplet test still passes: tests/mjcf/test_compose.py)
    assert quality.excess < MAX_EXCESS and quality.missing < 0.05 and 0.9 < quality.volume_ratio < 2.0


def test_axis_depths_match_ray_casting() -> None:
    mesh = repair_mesh(small_cup())
    bounds = np.asarray(mesh.bounds)
    intersector = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
    for axis in range(3):
        near, far = mesh_quality._axis_depths(mesh, bounds, axis, 16)
        for sign, depth in ((1.0, near), (-1.0, far)):
            origins, direction = mesh_quality._probe_origins(bounds, axis, sign, 16, 0.01)
            locations, rays, _ = intersector.intersects_location(
                origins, np.tile(direction, (len(origins), 1)), multiple_hits=False
            )
            expected = np.full(len(origins), np.nan)
            expected[rays] = locations[:, axis]
            np.testing.assert_allclose(depth, expected, atol=1e-9)


# ---- separate bodies -----------------------------------------------------------------------


def _spy_coacd(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> list[tuple[int, int]]:
    """Replace CoACD by each input's convex hull (with a cache of its own, so no other test reads those
    hulls); returns the (faces, max_convex_hull) of every call."""
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path))
    calls: list[tuple[int, int]] = []

    def fake(mesh, config):
        calls.append((len(mesh.faces), config.max_convex_hull))
        return [np.asarray(mesh.vertices)]

    monkeypatch.setattr(mesh_decomposition, "_run_coacd", fake)
    return calls


def test_overlapping_convex_bodies_are_their_own_hulls(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # a teddy made of overlapping convex pieces: CoACD on them together ran out of memory
    calls = _spy_coacd(monkeypatch, tmp_path)
    pieces = [trimesh.creation.icosphere(subdivisions=1, radius=0.03) for _ in range(3)]
    for i, piece in enumerate(pieces):
        piece.apply_translation([0.04 * i, 0.0, 0.0])
    teddy = repair_mesh(trimesh.util.concatenate(pieces))
    hulls = decompose(teddy)
    assert calls == [] and len(hulls) == 3


def test_concave_bodies_share_the_hull_cap(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    calls = _spy_coacd(monkeypatch, tmp_path)
    crate = box((0.04, 0.04, 0.04))
    crate.apply_translation([0.2, 0.0, 0.0])
    mesh = repair_mesh(trimesh.util.concatenate([small_cup(), crate]))
    hulls = decompose(mesh, DecompositionConfig(max_convex_hull=8))
    assert calls == [(96, 7)]  # the cup alone goes to CoACD, with what the box leaves of the cap
    assert len(hulls) == 2


def test_each_body_is_held_to_the_whole_objects_concavity_tolerance(monkeypatch: pytest.MonkeyPatch,
                                                                     tmp_path: Path) -> None:
    # CoACD scales what it is given to a unit box: a body half the object's size, given the object's threshold,
    # was cut to half the tolerance in metres that the object as one mesh gets
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path))
    thresholds: list[float] = []

    def fake(mesh, config):
        thresholds.append(config.threshold)
        return [np.asarray(mesh.vertices)]

    monkeypatch.setattr(mesh_decomposition, "_run_coacd", fake)
    big, small = small_cup(), small_cup()  # 8 cm tall, 6 cm wide
    big.apply_scale(2.0)  # 16 cm tall, 12 cm wide
    small.apply_translation([0.4, 0.0, 0.0])  # the two span 0.06 + 0.4 + 0.03 = 0.49 m
    decompose(trimesh.util.concatenate([big, small]), DecompositionConfig(threshold=0.05))
    np.testing.assert_allclose(thresholds, [0.05 * 0.49 / 0.16, 0.05 * 0.49 / 0.08])
    thresholds.clear()
    decompose(trimesh.util.concatenate([big, small.apply_translation([10.0, 0.0, 0.0])]))
    assert thresholds == [1.0, 1.0]  # CoACD's largest threshold


def test_stray_triangles_take_no_hull_and_the_cap_is_shared_whole(monkeypatch: pytest.MonkeyPatch,
                                                                    tmp_path: Path) -> None:
    # an open seam leaves loose triangles, bodies of their own with no volume: each used to take a hull of the cap,
    # and flooring each concave body's share lost more, so a small concave body got one hull (a bar chair's seat
    # and back made one wedge that filled the seat)
    calls = _spy_coacd(monkeypatch, tmp_path)
    big, small = small_cup(), small_cup()
    big.apply_scale(2.0)
    small.apply_translation([0.3, 0.0, 0.0])
    strays = [trimesh.Trimesh([[0.5 + 0.05 * i, 0, 0], [0.52 + 0.05 * i, 0, 0], [0.5 + 0.05 * i, 0.02, 0]],
                              [[0, 1, 2]]) for i in range(20)]
    mesh = trimesh.util.concatenate([big, small, *strays])
    hulls = decompose(mesh, DecompositionConfig(max_convex_hull=32))
    caps = [cap for _, cap in calls]
    assert len(caps) == 2 and sum(caps) == 32  # the strays take none, rounding loses none
    assert caps[0] > caps[1] >= 4  # by hull volume: the cup twice the size has eight times the share
    assert len(hulls) == 2


def test_a_single_body_goes_to_coacd_whole(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    calls = _spy_coacd(monkeypatch, tmp_path)
    decompose(repair_mesh(small_cup()))
    assert calls == [(96, DecompositionConfig().max_convex_hull)]


def test_cache_keys_of_single_bodies_did_not_change() -> None:
    # the keys the procedural dataset's hulls were cached under before max_faces and the body split
    digest = "0" * 64
    assert mesh_decomposition._cache_key(digest, DecompositionConfig(), 1) == (
        "82496c24c8cd318b41f73c1c3be66c6a99dbf1b53977774f4711195a0da23847"
    )
    assert mesh_decomposition._cache_key(digest, TINY, 1) == (
        "0e91cd61c40fff7a6e1f455d28148e6602525719d7bf1085a32811bf2604c5bd"
    )
    assert mesh_decomposition._cache_key(digest, DecompositionConfig(), 2) != (
        mesh_decomposition._cache_key(digest, DecompositionConfig(), 1)
    )
    assert mesh_decomposition._cache_key(digest, DecompositionConfig(max_faces=4000), 1) != (
        mesh_decomposition._cache_key(digest, DecompositionConfig(), 1)
    )


# ---- a smaller mesh for CoACD --------------------------------------------------------------


def test_max_faces_decimates_for_coacd_only(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path))
    seen: list[trimesh.Trimesh] = []
    monkeypatch.setattr(
        mesh_decomposition, "_run_coacd", lambda mesh, config: seen.append(mesh) or [np.asarray(mesh.vertices)]
    )
    mesh = repair_mesh(noisy_sphere())
    mesh.vertices[0] *= 0.5  # a dent, so the sphere is not convex and goes to CoACD
    decompose(mesh, DecompositionConfig(max_faces=2000))
    (coacd_mesh,) = seen
    assert len(coacd_mesh.faces) <= 2000 and coacd_mesh.is_volume  # still closed: CoACD does not remesh it
    assert mesh_decomposition._preprocess_mode(coacd_mesh, DecompositionConfig()) == "off"
    assert len(mesh.faces) == 5120


def test_max_faces_is_checked() -> None:
    with pytest.raises(ConfigError, match="max_faces must be None or a whole number >= 500"):
        DecompositionConfig(max_faces=100)


# ---- settings by mesh density, and the quality guard ----------------------------------------


def test_dense_meshes_get_the_faster_settings() -> None:
    assert decomposition_for(repair_mesh(small_cup())) == DecompositionConfig()
    dense = repair_mesh(noisy_sphere())
    assert len(dense.faces) > DENSE_FACES
    assert decomposition_for(dense) == DENSE_DECOMPOSITION
    assert DENSE_DECOMPOSITION.max_faces < DENSE_FACES


def test_meshes_up_to_the_dense_limit_keep_the_defaults() -> None:
    # the procedural dataset's meshes stay within rail_mj.dataset.procedural.MAX_FACES: their hulls must not change
    from rail_mj.dataset.procedural import MAX_FACES

    assert MAX_FACES <= DENSE_FACES
    sphere = trimesh.creation.icosphere(subdivisions=4)  # 5,120 faces
    at_limit = trimesh.Trimesh(sphere.vertices, sphere.faces[: DENSE_FACES], process=False)
    assert decomposition_for(at_limit) == DecompositionConfig()


def _fake_coacd(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, good: tuple[np.ndarray, ...]) -> list[float]:
    """CoACD stand-in: one hull filling the cup for the dense settings, ``good`` for the others."""
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path))
    thresholds: list[float] = []

    def fake(mesh, config):
        thresholds.append(config.threshold)
        return [np.asarray(mesh.vertices)] if config == DENSE_DECOMPOSITION else [np.asarray(h) for h in good]

    monkeypatch.setattr(mesh_decomposition, "_run_coacd", fake)
    return thresholds


def test_guard_redoes_failing_fast_hulls_with_the_defaults(
    cup_object, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    thresholds = _fake_coacd(monkeypatch, tmp_path, cup_object.hulls)
    monkeypatch.setattr(mesh_decomposition, "DENSE_FACES", 50)  # the 96-face cup counts as dense
    obj = object_from_mesh(small_cup(), name="cup")
    assert thresholds == [DENSE_DECOMPOSITION.threshold, DecompositionConfig().threshold]
    assert len(obj.hulls) == len(cup_object.hulls)
    (note,) = mesh_notes(obj.mesh)
    assert note.startswith("hulls made again with the default settings on at most 5,000 faces: the faster ones' "
                           "excess 0.6")


def test_the_guard_redoes_a_dense_mesh_with_the_defaults_on_the_dense_limits_faces(monkeypatch) -> None:
    # the defaults on a scan's whole face budget took up to twice as long for hulls no better
    calls = []

    def fake_decompose(mesh, config):
        calls.append(config)
        return (np.asarray(mesh.vertices),)

    monkeypatch.setattr(mesh_quality, "decompose", fake_decompose)
    monkeypatch.setattr(mesh_quality, "hull_quality", lambda mesh, hulls: SimpleNamespace(
        excess=0.6 if len(calls) == 1 else 0.1, missing=0.0))
    mesh = repair_mesh(trimesh.creation.icosphere(subdivisions=4))  # 5,120 faces: dense
    _, notes = mesh_quality._guarded_hulls(mesh, None)
    assert calls == [DENSE_DECOMPOSITION, GUARD_DECOMPOSITION]
    assert GUARD_DECOMPOSITION == DecompositionConfig(max_faces=DENSE_FACES)
    assert notes and notes[0].startswith("hulls made again with the default settings on at most 5,000 faces")


def test_guard_notes_hulls_that_fail_it(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    thresholds = _fake_coacd(monkeypatch, tmp_path, (np.asarray(small_cup().vertices),))
    obj = object_from_mesh(small_cup(), name="cup", decomposition=TINY)  # given settings are not redone
    assert thresholds == [TINY.threshold] and len(obj.hulls) == 1
    (note,) = mesh_notes(obj.mesh)
    assert note.startswith("hull quality below the guard (1 hulls): they fill 6") and "a cavity may be closed" in note


def test_guard_passes_good_hulls_without_a_note(cup_object) -> None:
    assert mesh_notes(cup_object.mesh) == []


def test_astronomic_coordinates_are_refused_before_cleaning(tmp_path: Path) -> None:
    # 1e30 m overflowed trimesh's vertex-merge grid (a RuntimeWarning) before the size rule spoke.
    path = tmp_path / "far.obj"
    path.write_text("v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nv 0 0 1e30\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(MeshError, match="too large.*units="):
            load_mesh(path)


def test_faces_indexing_missing_vertices_are_refused() -> None:
    mesh = trimesh.Trimesh(vertices=np.eye(3), faces=np.array([[0, 1, 7]]), process=False)
    with pytest.raises(MeshError, match=r"outside 0\.\.2"):
        repair_mesh(mesh, label="bad")


def test_the_time_limit_is_not_part_of_the_hull_cache_key() -> None:
    assert mesh_decomposition._cache_key("m", DecompositionConfig(), 1) == mesh_decomposition._cache_key(
        "m", DecompositionConfig(time_limit_s=5.0), 1)


def test_a_guard_redo_that_runs_out_of_time_keeps_the_first_hulls(monkeypatch) -> None:
    first = (np.asarray(box((0.1, 0.1, 0.1)).vertices),)
    calls = []

    def fake_decompose(mesh, config):
        calls.append(config)
        if len(calls) > 1:
            raise DecompositionTimeout("CoACD did not finish within 1 s")
        return first

    monkeypatch.setattr(mesh_quality, "decompose", fake_decompose)
    monkeypatch.setattr(mesh_quality, "_guard_score", lambda quality: 2.0)
    mesh = small_cup()
    monkeypatch.setattr(mesh_quality, "decomposition_for", lambda m: DENSE_DECOMPOSITION)
    hulls, notes = mesh_quality._guarded_hulls(mesh, None)
    assert hulls is first and len(calls) == 2
    assert any("not made again" in n and "did not finish" in n for n in notes)


def test_bodies_keep_only_their_own_vertices() -> None:
    # 300 separate cubes: each piece must carry its 8 vertices, not all 2,400
    rng = np.random.default_rng(0)
    tets = [trimesh.creation.box((0.01, 0.01, 0.01)).apply_translation(rng.random(3)) for _ in range(300)]
    soup = trimesh.util.concatenate(tets)
    labels = mesh_repair._body_labels(soup)
    pieces = mesh_decomposition._bodies(soup, labels)
    assert len(pieces) == 300
    assert all(len(p.vertices) == 8 and p.is_volume for p in pieces)
    np.testing.assert_allclose(pieces[7].bounds, tets[7].bounds)


def test_a_triangle_soup_is_refused_naming_its_loose_faces(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    vertices = rng.random((3000, 3)) * 0.1
    path = tmp_path / "soup.ply"
    trimesh.Trimesh(vertices, np.arange(3000).reshape(-1, 3), process=False).export(path)
    with pytest.raises(MeshError, match=r"triangle soup: 1,000 of its 1,000 faces .* weld the vertices"):
        load_mesh(path)


def test_a_few_loose_faces_beside_a_body_are_kept() -> None:
    cup = small_cup()
    debris = trimesh.Trimesh(np.array([[0.2, 0, 0], [0.21, 0, 0], [0.2, 0.01, 0]]), [[0, 1, 2]], process=False)
    mesh = repair_mesh(trimesh.util.concatenate([cup, debris]), label="cup with debris")
    assert len(mesh.faces) == len(cup.faces) + 1
