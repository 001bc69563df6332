"""The shape facts a model judging a pose gets: which faces the object's cavity opens through, how much of the box
the cavity is, whether the pose is the one the object came in."""

from __future__ import annotations

import numpy as np
import pytest

from rail_mj.core.types import StablePose
from rail_mj.robot.demo import make_object
from rail_mj.stable_poses.shape import ObjectShapes, came_in_shape, pose_shape, tilt_from_came, tilt_from_up


def _pose(up_axis: str) -> StablePose:
    """The pose that puts the mesh's ``up_axis`` (+z, -z, +x) up (the position does not matter to the shape)."""
    quat = {"+z": [1.0, 0.0, 0.0, 0.0], "-z": [0.0, 1.0, 0.0, 0.0],
            "+x": [np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0]}[up_axis]
    return StablePose(pos=np.zeros(3), quat=np.asarray(quat), probability=0.5, half_extents=np.ones(3))


@pytest.mark.parametrize("up_axis, tilt", [("+z", 0.0), ("+x", 90.0), ("-z", 180.0)])
def test_a_pose_and_its_up_tilt_alike_from_the_up_it_came_in(up_axis: str, tilt: float) -> None:
    pose = _pose(up_axis)
    assert tilt_from_came(pose) == pytest.approx(tilt, abs=1e-6)
    assert tilt_from_up(pose.up_in_mesh_frame) == tilt_from_came(pose)
    assert tilt_from_up(1.0000001 * np.asarray(pose.up_in_mesh_frame)) == pytest.approx(tilt, abs=1e-3)  # rounding


@pytest.mark.parametrize("kind, up_axis, faces, came", [
    ("cup", "+z", ["top"], True),
    ("cup", "-z", ["bottom"], False),  # upside down: its mouth on the floor
    ("basket", "+x", ["back"], False),  # on its side (its +x up): the mouth, along +z, faces -x
])
def test_a_vessel_opens_where_its_mouth_faces(kind, up_axis, faces, came) -> None:
    shape = pose_shape(make_object(kind, 0), _pose(up_axis))
    assert shape.open_faces == faces and shape.as_it_came is came and shape.cavity > 0.3


def test_a_cupboard_as_it_came_opens_to_one_side_and_a_table_has_no_cavity() -> None:
    cupboard = came_in_shape(make_object("cupboard", 0))
    assert cupboard.as_it_came and len(cupboard.open_faces) == 1 and cupboard.open_faces[0] != "top"
    table = came_in_shape(make_object("table", 0))
    assert table.open_faces == [] and table.cavity == 0.0  # under a table top is not a cavity


def test_the_facts_are_measured_once_per_pose() -> None:
    cup = make_object("cup", 0)
    shapes = ObjectShapes(cup, [_pose("+z"), _pose("-z")])
    assert shapes.pose(1) is shapes.pose(1) and shapes.pose(0).open_faces == ["top"]
    assert shapes.came_in.open_faces == ["top"]
