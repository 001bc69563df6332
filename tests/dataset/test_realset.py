"""The real-mesh development set: the manifest, wheel and member checks, URDF assembly, the CLI (no network)."""

from __future__ import annotations

import dataclasses
import hashlib
import re
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh

from rail_mj.affordances import PAPER_AFFORDANCES, get
from rail_mj.core.errors import DatasetError
from rail_mj.dataset import cli as dataset
from rail_mj.dataset import realset
from rail_mj.dataset.labels import LabelRecord, read_labels
from rail_mj.dataset.realset import MANIFEST, WHEELS, RealMesh, Wheel
from rail_mj.mesh import load_mesh
from rail_mj.urdf.assembly import assemble_urdf

HEX64 = re.compile(r"[0-9a-f]{64}")
PAPER_KEYS = [get(a).key for a in PAPER_AFFORDANCES]

CUBE_OBJ = b"""v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 0.5 -0.5
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 0.5
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""

# a 0.6 m table: a scaled cube as the top, four box legs, one fixed joint from a bare root link
TABLE_URDF = b"""<?xml version="1.0"?>
<robot name="t">
  <link name="world"/>
  <joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 0"/></joint>
  <link name="base">
    <visual><origin xyz="0 0 0.6"/><geometry><mesh filename="parts/cube.obj" scale="0.8 0.6 0.04"/></geometry></visual>
    <visual><origin xyz="-0.35 -0.25 0.29"/><geometry><box size="0.04 0.04 0.58"/></geometry></visual>
    <visual><origin xyz="-0.35 0.25 0.29"/><geometry><box size="0.04 0.04 0.58"/></geometry></visual>
    <visual><origin xyz="0.35 -0.25 0.29"/><geometry><box size="0.04 0.04 0.58"/></geometry></visual>
    <visual><origin xyz="0.35 0.25 0.29"/><geometry><box size="0.04 0.04 0.58"/></geometry></visual>
  </link>
</robot>
"""


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _fake_wheel(folder: Path, files: dict[str, bytes], name: str = "fakepkg-1.0-py3-none-any.whl") -> tuple[Path, str]:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    with zipfile.ZipFile(path, "w") as z:
        for member, data in files.items():
            z.writestr(member, data)
    return path, _sha(path.read_bytes())


@pytest.fixture
def fake_set(tmp_path, monkeypatch) -> Path:
    """A manifest of two objects (a mesh copied as shipped, a URDF assembled) in one fake wheel."""
    wheels = tmp_path / "wheels"
    mug = trimesh.exchange.obj.export_obj(trimesh.creation.annulus(0.03, 0.04, 0.09)).encode()
    files = {"pkg/mug.obj": mug, "pkg/table.urdf": TABLE_URDF, "pkg/parts/cube.obj": CUBE_OBJ}
    path, digest = _fake_wheel(wheels, files)
    wheel = Wheel("fakepkg", "1.0", path.name, digest)
    rows = (
        RealMesh("fake_mug", "fakepkg", "pkg/mug.obj", _sha(mug), "mug", 0.5, "y", frozenset({"cup"}),
                 "test row: a mesh as shipped"),
        RealMesh("fake_table", "fakepkg", "pkg/table.urdf", _sha(TABLE_URDF), "table", 1.0, "z",
                 frozenset({"table"}), "test row: an assembled URDF", (("pkg/parts/cube.obj", _sha(CUBE_OBJ)),)),
    )
    monkeypatch.setattr(realset, "WHEELS", {"fakepkg": wheel})
    monkeypatch.setattr(realset, "MANIFEST", rows)
    return wheels


def test_manifest_rows_are_valid_labels_for_all_eight():
    assert 25 <= len(MANIFEST) <= 40
    assert len({m.name for m in MANIFEST}) == len(MANIFEST)
    assert len({m.sha256 for m in MANIFEST}) == len(MANIFEST), "the same file is listed twice"
    for m in MANIFEST:
        record = realset.label_record(m)
        assert isinstance(record, LabelRecord)
        assert list(record.affordances) == PAPER_KEYS, m.name
        assert m.affords <= set(PAPER_KEYS), m.name
        assert (record.functional_up is not None) == bool(m.affords), m.name
        assert HEX64.fullmatch(m.sha256) and all(HEX64.fullmatch(s) for _, s in m.parts), m.name
        assert m.wheel in WHEELS and m.units > 0 and m.up in ("z", "y") and m.why.strip(), m.name
        assert m.is_urdf or m.is_assembly or not m.parts, m.name
        assert len(m.poses) == (len(m.parts) if m.is_assembly else 0), m.name
        assert LabelRecord.model_validate_json(record.to_json()) == record
    for w in WHEELS.values():
        assert HEX64.fullmatch(w.sha256) and w.filename.endswith(".whl")
        assert w.filename.lower().replace("_", "-").startswith(w.name.replace("_", "-") + "-" + w.version)
    assert {m.wheel for m in MANIFEST} == set(WHEELS), "a wheel no object needs"


def test_manifest_has_positives_and_negatives():
    positives = {a: sum(a in m.affords for m in MANIFEST) for a in PAPER_KEYS}
    assert all(positives[a] >= 1 for a in ("cup", "bowl", "basket", "plate", "table", "bathtub"))
    assert sum(not m.affords for m in MANIFEST) >= 10


def test_build_extracts_and_writes_labels(fake_set, tmp_path):
    out = tmp_path / "ds"
    records = realset.build(out, wheels_dir=fake_set)
    assert [r.mesh for r in records] == ["meshes/fake_mug.obj", "meshes/fake_table.obj"]
    again = read_labels(out)
    assert again == records
    mug = read_labels(out)[0]
    assert mug.units == 0.5 and mug.up == "y" and mug.functional_up == (0.0, 1.0, 0.0)
    assert mug.affordances["cup"] and not mug.affordances["bowl"]
    table = load_mesh(out / "meshes/fake_table.obj")
    assert np.allclose(table.bounds, [[-0.4, -0.3, 0.0], [0.4, 0.3, 0.62]], atol=1e-9)
    assert not list(out.glob(".*")), "the staging folder is left behind"


def test_build_copies_a_mesh_member_as_shipped(fake_set, tmp_path):
    realset.build(tmp_path / "ds", objects=["fake_mug"], wheels_dir=fake_set)
    with zipfile.ZipFile(next(fake_set.glob("*.whl"))) as z:
        assert (tmp_path / "ds/meshes/fake_mug.obj").read_bytes() == z.read("pkg/mug.obj")


def test_wheel_sha_mismatch_is_refused(tmp_path):
    path, digest = _fake_wheel(tmp_path, {"a.obj": CUBE_OBJ})
    wrong = "0" * 64
    with pytest.raises(DatasetError) as err:
        realset.fetch_wheel(Wheel("fakepkg", "1.0", path.name, wrong), tmp_path)
    assert str(path) in str(err.value) and digest in str(err.value) and wrong in str(err.value)
    assert realset.fetch_wheel(Wheel("fakepkg", "1.0", path.name, digest), tmp_path) == path


def test_member_sha_mismatch_is_refused(tmp_path):
    path, _ = _fake_wheel(tmp_path, {"pkg/a.obj": CUBE_OBJ})
    with zipfile.ZipFile(path) as z:
        with pytest.raises(DatasetError, match=rf"pkg/a.obj: SHA-256 {_sha(CUBE_OBJ)}, expected {'1' * 64}"):
            realset.read_member(z, "pkg/a.obj", "1" * 64)
        with pytest.raises(DatasetError, match="no such file"):
            realset.read_member(z, "pkg/b.obj", _sha(CUBE_OBJ))


def test_urdf_part_not_in_the_manifest_is_refused(fake_set, tmp_path, monkeypatch):
    table = realset.MANIFEST[1]
    monkeypatch.setattr(realset, "MANIFEST", (dataclasses.replace(table, parts=()),))
    with pytest.raises(DatasetError, match="pkg/parts/cube.obj, which the manifest does not list"):
        realset.build(tmp_path / "ds", wheels_dir=fake_set)
    assert not (tmp_path / "ds" / "labels.jsonl").exists()


@pytest.mark.parametrize(
    "urdf, message",
    [
        (b"<robot><link name='a'/><link name='b'/><joint name='j' type='revolute'><parent link='a'/>"
         b"<child link='b'/></joint></robot>", "only fixed joints"),
        (b"<robot><link name='a'><visual><geometry><mesh filename='package://x/a.obj'/></geometry></visual>"
         b"</link></robot>", "relative to the URDF"),
        (b"<robot><link name='a'><visual><geometry><capsule radius='1'/></geometry></visual></link></robot>",
         "not supported"),
        (b"<robot><link name='a'/></robot>", "no <visual>"),
        (b"<robot><link", "not valid XML"),
    ],
)
def test_urdf_assembly_errors(urdf, message):
    with pytest.raises(DatasetError, match=message):
        assemble_urdf(urdf, "pkg", lambda member: CUBE_OBJ)


def test_urdf_rpy_rotates_about_fixed_axes():
    urdf = (b"<robot><link name='a'><visual><origin rpy='0 0 1.5707963267948966'/><geometry>"
            b"<box size='0.4 0.1 0.2'/></geometry></visual></link></robot>")
    mesh = assemble_urdf(urdf, "pkg", lambda member: b"")
    assert np.allclose(mesh.extents, [0.1, 0.4, 0.2])


def _assembly_row(wheels: Path, monkeypatch, poses) -> RealMesh:
    """A fake wheel with a source file and two cube parts, and its assembly row: the parts at ``poses`` in a frame
    whose up is -y (FurnitureBench's chair seat's)."""
    source = b"assembled_rel_poses = ...  # where the poses were read"
    path, digest = _fake_wheel(wheels, {"pkg/thing.py": source, "pkg/a.obj": CUBE_OBJ, "pkg/b.obj": CUBE_OBJ})
    monkeypatch.setattr(realset, "WHEELS", {"fakepkg": Wheel("fakepkg", "1.0", path.name, digest)})
    row = RealMesh("fake_stack", "fakepkg", "pkg/thing.py", _sha(source), "thing", 1.0, "z", frozenset(),
                   "test row: an assembly", (("pkg/a.obj", _sha(CUBE_OBJ)), ("pkg/b.obj", _sha(CUBE_OBJ))), poses,
                   (0.0, -1.0, 0.0))
    monkeypatch.setattr(realset, "MANIFEST", (row,))
    return row


def test_an_assembly_places_its_parts_and_stands_its_up_on_z(tmp_path, monkeypatch):
    """Two unit cubes: the second 2 m along -y (up in the assembly's frame) and turned a quarter about x; written
    as one mesh with that up on +z: a 1 x 1 x 3 m stack."""
    _assembly_row(tmp_path / "wheels", monkeypatch,
                  ((0.0, 0.0, 0.0, 0.0, 0.0, 0.0), (0.0, -2.0, 0.0, 1.5707963267948966, 0.0, 0.0)))
    realset.build(tmp_path / "ds", wheels_dir=tmp_path / "wheels")
    mesh = trimesh.load(tmp_path / "ds" / "meshes" / "fake_stack.obj", force="mesh")
    assert np.allclose(mesh.bounds, [[-0.5, -0.5, -0.5], [0.5, 0.5, 2.5]], atol=1e-9)


def test_an_assembly_needs_a_pose_per_part(tmp_path, monkeypatch):
    _assembly_row(tmp_path / "wheels", monkeypatch, ((0.0, 0.0, 0.0, 0.0, 0.0, 0.0),))
    with pytest.raises(DatasetError, match="one pose per part"):
        realset.build(tmp_path / "ds", wheels_dir=tmp_path / "wheels")


def test_pip_failure_names_the_package_and_the_manual_fetch(tmp_path, monkeypatch):
    def fail(cmd, **kwargs):
        return subprocess.CompletedProcess(cmd, 1, "", "ERROR: Could not find a version (network is unreachable)")

    monkeypatch.setattr(realset.subprocess, "run", fail)
    wheel = WHEELS["pybullet"]
    with pytest.raises(DatasetError) as err:
        realset.fetch_wheel(wheel, tmp_path)
    text = str(err.value)
    assert "pybullet==3.2.7" in text and "network is unreachable" in text
    assert "by hand" in text and wheel.filename in text and str(tmp_path) in text and "--platform" in text
    assert not list(tmp_path.iterdir()), "a failed download leaves files behind"


def test_pip_delivering_another_file_is_refused(tmp_path, monkeypatch):
    def other(cmd, **kwargs):
        dest = Path(cmd[cmd.index("--dest") + 1])
        (dest / "fakepkg-2.0-py3-none-any.whl").write_bytes(b"x")
        return subprocess.CompletedProcess(cmd, 0, "", "")

    monkeypatch.setattr(realset.subprocess, "run", other)
    with pytest.raises(DatasetError, match="pip delivered fakepkg-2.0-py3-none-any.whl instead of"):
        realset.fetch_wheel(Wheel("fakepkg", "1.0", "fakepkg-1.0-py3-none-any.whl", "0" * 64), tmp_path)


def test_cli_real_subcommand(fake_set, tmp_path, capsys):
    out = tmp_path / "ds"
    assert dataset.main(["real", "--out", str(out), "--wheels", str(fake_set)]) == 0
    assert "wrote 2 objects (2 afford at least one of the eight)" in capsys.readouterr().out
    assert len(read_labels(out)) == 2
    assert dataset.main(["real", "--out", str(out), "--objects", "nope"]) == 2
    assert "valid: fake_mug, fake_table" in capsys.readouterr().err
    assert dataset.main(["real"]) == 2
    assert dataset.main(["real", "--list"]) == 0
    assert "| fake_table | fakepkg 1.0 | table |" in capsys.readouterr().out


def test_cli_real_reports_a_bad_wheel(fake_set, tmp_path, capsys):
    next(fake_set.glob("*.whl")).write_bytes(b"not the wheel")
    assert dataset.main(["real", "--out", str(tmp_path / "ds"), "--wheels", str(fake_set)]) == 1
    assert "SHA-256" in capsys.readouterr().err


@pytest.mark.slow
def test_real_fetch_of_the_pybullet_objects(tmp_path):
    """Downloads pybullet 3.2.7 (103 MB) from PyPI and builds its eight objects."""
    names = [m.name for m in MANIFEST if m.wheel == "pybullet"]
    records = realset.build(tmp_path / "ds", objects=names)
    for record in records:
        mesh = load_mesh(tmp_path / "ds" / record.mesh, units=record.units, up=record.up)
        assert 0.05 < mesh.extents.max() < 3.0, record.mesh
