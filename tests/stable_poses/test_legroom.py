"""A table is used from beside it: a foot gets under its top at toe height (issue 13). A desk higher than it is
deep is a table, and so is a TV console on a plinth whose open compartments take the feet; a tub lying on its
side, whose flat side is as good a top, is not. The verdicts run the whole pipeline on a generated mesh."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rail_mj.dataset.shapes import parts as shape_parts
from rail_mj.dataset.shapes.world import _open_front_box
from rail_mj.mesh import object_from_mesh
from rail_mj.mjcf.body import body_size
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig
from rail_mj.stable_poses import StablePoseConfig
from rail_mj.stable_poses.legroom import toe_room

FOOT = body_size().foot_breadth


pytestmark = pytest.mark.usefixtures("shared_cache")


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
    """Its side is a flat top 0.79 m high, but a foot meets a wall at the edge."""
    L, W, H, t = 1.5, 0.79, 0.52, 0.05
    shell = shape_parts._difference(_box((-L / 2, -W / 2, 0.0), (L / 2, W / 2, H)),
                               _box((-L / 2 + t, -W / 2 + t, t), (L / 2 - t, W / 2 - t, H + 0.05)))
    shell.apply_transform(trimesh.transformations.rotation_matrix(-1.5707963, (1, 0, 0)))  # opening to one side
    r = _table_verdict(shell, "tub_on_its_side")
    assert not r.functional, r.analyzer_reasons
    assert any("no room for feet" in reason for reason in r.analyzer_reasons), r.analyzer_reasons


def _room(mesh: trimesh.Trimesh) -> float:
    points = np.asarray(trimesh.sample.sample_surface(mesh, 60000, seed=0)[0])
    lo, hi = points.min(axis=0), points.max(axis=0)
    return toe_room(points - lo, (hi - lo) / 2)


def test_feet_get_between_legs_and_into_a_consoles_compartments_not_into_a_closed_cabinet() -> None:
    """Room is wherever a foot fits along the edge: a plinth console's divider in the middle of its front leaves the
    compartments either side; a cabinet closed at the front, or one whose toe kick is lower than toes, leaves none."""
    top = _box((-0.6, -0.3, 0.71), (0.6, 0.3, 0.74))
    legs = [_box((x - 0.02, y - 0.02, 0.0), (x + 0.02, y + 0.02, 0.72)) for x in (-0.55, 0.55) for y in (-0.25, 0.25)]
    assert _room(shape_parts._union([top, *legs])) >= FOOT
    console = _open_front_box(1.4, 0.55, 0.66, 0.02, 0.01, dividers=1)  # one divider, at the middle of the front
    assert _room(console) >= FOOT
    closed = _box((-0.7, -0.275, 0.0), (0.7, 0.275, 0.66))
    assert _room(closed) == 0.0
    toe_kick = shape_parts._union([_box((-0.7, -0.275, 0.03), (0.7, 0.275, 0.66)),
                                   _box((-0.68, -0.25, 0.0), (0.68, 0.25, 0.031))])  # 2.5 cm of shadow gap
    assert _room(toe_kick) < FOOT


def test_a_console_on_a_plinth_is_a_table_standing() -> None:
    """0.66 m high, two open compartments: its divider stands where a slide down the middle of its front would stop,
    but feet go into either compartment."""
    r = _table_verdict(_open_front_box(1.4, 0.55, 0.66, 0.02, 0.01, dividers=1), "plinth_console")
    assert r.functional, r.analyzer_reasons
    assert r.functional_pose is not None and abs(r.functional_pose.up_in_mesh_frame[2]) > 0.95
