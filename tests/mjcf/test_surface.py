"""The object's own surface: rays from world points meet the mesh where the object stands in a world."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

from rail_mj.mjcf.surface import OwnSurface, static_meshes, surface_data

DOWN = np.array([0.0, 0.0, -1.0])


def _slab() -> OwnSurface:
    """A 0.4 x 0.4 x 0.1 m slab whose top is 0.1 m above its frame's origin."""
    box = trimesh.creation.box(bounds=[[-0.2, -0.2, 0.0], [0.2, 0.2, 0.1]])
    model = static_meshes([(box.vertices, box.faces)])
    return OwnSurface(model, surface_data(model), np.zeros(3), np.eye(3))


def test_a_ray_meets_the_top_of_the_object_where_it_stands() -> None:
    own = _slab()
    assert own.ray(np.array([0.05, 0.0, 0.5]), DOWN) == pytest.approx((0.4, 1.0))  # its level top
    own = dataclasses.replace(own, pos=np.array([1.0, 0.0, 0.2]))  # the object moved 1 m across and 0.2 m up
    assert own.ray(np.array([1.05, 0.0, 0.5]), DOWN)[0] == pytest.approx(0.2)
    assert own.ray(np.array([0.05, 0.0, 0.5]), DOWN)[0] == -1.0  # where it stood, nothing now


def test_a_turned_and_scaled_world_is_measured_in_metres() -> None:
    own = _slab()
    # upside down (its top faces down), 0.3 m up
    own = dataclasses.replace(own, mat=np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
                              pos=np.array([0.0, 0.0, 0.3]))
    assert own.ray(np.array([0.0, 0.0, 0.5]), DOWN)[0] == pytest.approx(0.2)  # its base, now on top, at 0.3 m
    # the same object twice as large, about its frame's origin: 0.2 m thick, from 0.1 to 0.3 m up
    own = dataclasses.replace(own, scale=2.0)
    assert own.ray(np.array([0.0, 0.0, 0.5]), DOWN)[0] == pytest.approx(0.2)
    assert own.ray(np.array([0.0, 0.0, 0.05]), -DOWN) == pytest.approx((0.05, -1.0))  # its top, facing down
