"""The helpers every composed scene shares (rail_mj.mjcf.scene): a geom's lowest point."""

from __future__ import annotations

import math

import mujoco

from rail_mj.mjcf import geom_bottom


def test_a_geoms_bottom_is_its_bounding_boxs_lowest_corner_as_it_lies():
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body pos="0 0 1" euler="0 30 0"><geom name="box" type="box" size="0.1 0.2 0.05"/>'
        '<geom name="ball" type="sphere" size="0.05" pos="0.3 0 0"/></body></worldbody></mujoco>')
    data = mujoco.MjData(m)
    mujoco.mj_kinematics(m, data)
    box, ball = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("box", "ball"))
    s, c = math.sin(math.radians(30)), math.cos(math.radians(30))
    assert math.isclose(geom_bottom(m, data, box), 1.0 - 0.1 * s - 0.05 * c, abs_tol=1e-9)
    # the ball's box, turned with its body: its centre 0.3 m along the tilted x, its corner 0.05 (sin + cos) lower
    assert math.isclose(geom_bottom(m, data, ball), 1.0 - 0.3 * s - 0.05 * (s + c), abs_tol=1e-9)
