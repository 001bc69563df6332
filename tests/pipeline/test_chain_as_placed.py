"""classify(..., pose="as_placed"): the object is imagined in the pose it stands in, not its stable poses."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from pydantic import ValidationError

from rail_mj.core.types import RailObject
from rail_mj.mesh import mesh_hash
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.demo import make_object


def _upside_down(obj: RailObject) -> RailObject:
    """The same object turned over (180 deg about x), mesh frame and hulls alike."""
    rot = np.diag([1.0, -1.0, -1.0])
    mesh = obj.mesh.copy()
    transform = np.eye(4)
    transform[:3, :3] = rot
    mesh.apply_transform(transform)
    return replace(obj, name=f"{obj.name}_upside_down", mesh=mesh, hulls=tuple(h @ rot.T for h in obj.hulls),
                   mesh_hash=mesh_hash(mesh), com=obj.com @ rot.T)


def _cup(obj: RailObject, pose: str):
    return classify([obj], ["cup"], config=RunConfig(provider="offline", pose=pose), progress=False, workers=1)[0]


def test_upright_cup_is_a_cup_as_placed():
    r = _cup(make_object("cup", 0), "as_placed")
    assert r.functional and len(r.stable_poses) == 1 and r.stable_poses[0].probability == 1.0
    assert r.functional_pose.up_in_mesh_frame == pytest.approx([0.0, 0.0, 1.0])
    assert r.best_plan is not None


def test_upside_down_cup_is_not_a_cup_as_placed_but_is_one_in_a_stable_pose():
    cup = _upside_down(make_object("cup", 0))
    assert not _cup(cup, "as_placed").functional
    stable = _cup(cup, "stable")
    assert stable.functional and len(stable.stable_poses) > 1
    assert stable.functional_pose.up_in_mesh_frame[2] < -0.9  # the mesh frame's -z is up: turned back over


def test_doll_sized_chair_is_a_chair_for_a_doll_not_for_a_person():
    chair = make_object("chair", 0)
    person = classify([chair], ["chair"], config=RunConfig(provider="offline", pose="as_placed"),
                      progress=False, workers=1)[0]
    doll = classify([chair], ["chair"], config=RunConfig(provider="offline", pose="as_placed", agent="doll"),
                    progress=False, workers=1)[0]
    assert person.dims_fit is False and not person.functional
    assert doll.dims_fit and doll.functional


def test_unknown_pose_mode_is_refused_naming_the_valid_ones():
    with pytest.raises(ValidationError, match="'stable' or 'as_placed'"):
        RunConfig(provider="offline", pose="upright")  # pyright: ignore[reportArgumentType]
