"""A table is used from beside it: a box slid in just above the floor gets under its top (issue 13). A desk higher
than it is deep is a table; a tub lying on its side, whose flat side is as good a top, is not. Each runs the whole
pipeline on a generated mesh."""

from __future__ import annotations

import pytest
import trimesh

from rail_mj.dataset.shapes import parts as shape_parts
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig
from rail_mj.stable_poses import StablePoseConfig


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    return shape_parts._box(lo, hi)


def _table_verdict(mesh: trimesh.Trimesh, name: str):
    obj = object_from_mesh(mesh, name=name)
    pipe = Pipeline(RunConfig(provider="offline", stable_poses=StablePoseConfig(n_drops=16)))
    return pipe.run(obj, pipe.stable_poses(obj), "table")


def test_a_desk_higher_than_deep_is_a_table_standing() -> None:
    """0.74 m high, 0.6 m deep: its top is less deep than high, and its knee space reaches the floor."""
    top = _box((-0.6, -0.3, 0.71), (0.6, 0.3, 0.74))
    legs = [_box((x - 0.015, -0.27, 0.0), (x + 0.015, 0.27, 0.715)) for x in (-0.57, 0.57)]
    r = _table_verdict(shape_parts._union([top, *legs]), "desk")
    assert r.functional, r.analyzer_reasons
    assert r.functional_pose is not None and r.functional_pose.up_in_mesh_frame[2] > 0.95


def test_a_tub_on_its_side_is_no_table() -> None:
    """Its side is a flat top 0.79 m high, but the box slid in above the floor meets a wall at the edge."""
    L, W, H, t = 1.5, 0.79, 0.52, 0.05
    shell = shape_parts._difference(_box((-L / 2, -W / 2, 0.0), (L / 2, W / 2, H)),
                               _box((-L / 2 + t, -W / 2 + t, t), (L / 2 - t, W / 2 - t, H + 0.05)))
    shell.apply_transform(trimesh.transformations.rotation_matrix(-1.5707963, (1, 0, 0)))  # opening to one side
    r = _table_verdict(shell, "tub_on_its_side")
    assert not r.functional, r.analyzer_reasons
    assert any("no room for feet" in reason for reason in r.analyzer_reasons), r.analyzer_reasons
