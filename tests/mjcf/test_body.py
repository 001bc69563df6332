"""The body's probes (rail_mj.mjcf.body): the sitting bones' bearing on a seat pan, and a hanging foot's reach of
the floor, built in MuJoCo."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from rail_mj.mjcf.body import body_fragment, body_size, sit_bones, toes_reach


def _rolled_back(deg: float) -> np.ndarray:
    """wxyz of a turn about y that tips +z towards -x by ``deg``: the pelvis rolled back."""
    return np.array([math.cos(math.radians(-deg) / 2), 0.0, math.sin(math.radians(-deg) / 2), 0.0])


def _borne(roll: float, gap: float) -> bool:
    """Whether a level pan 0.4 m up bears the sitting bones of a body whose pelvis is rolled back ``roll`` deg, the
    pelvis box's lowest edge ``gap`` m over the pan (held there as by a reclined chair's crease)."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(name="pan", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.3, 0.3, 0.025], pos=[0.0, 0.0, 0.375])
    body = mujoco.MjSpec.from_string(body_fragment("sit"))
    box, quat = body.geom("pelvis"), _rolled_back(roll)
    turn = np.zeros(9)
    mujoco.mju_quat2Mat(turn, quat)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * np.asarray(box.size)
    lowest = min(float(turn.reshape(3, 3)[2] @ (np.asarray(box.pos) + c)) for c in corners)
    spec.worldbody.add_frame(pos=[0.0, 0.0, 0.4 - lowest + gap], quat=quat).attach_body(
        body.worldbody.first_body(), "sitter_", "")
    m = spec.compile()
    data = mujoco.MjData(m)
    mujoco.mj_kinematics(m, data)
    return sit_bones(m, data, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "sitter_pelvis"),
                     np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "pan")]))


def test_the_sitting_bones_bear_within_the_tissues_give_under_the_buttocks():
    give = 0.25 * body_size().thigh_radius  # the tissue's 2 cm
    assert _borne(0.0, 0.0) and _borne(0.0, 0.8 * give)
    assert not _borne(0.0, 1.5 * give)


def test_a_pelvis_rolled_back_on_its_box_edge_bears_as_a_round_buttock_would():
    # rolled back 16° (a lounge chair's sitter), the box rests on its rear edge 10 cm behind the hips, 2.6 cm lower
    # than its underside under them, where a buttock is round: a pan 2.5 cm under that edge (the tissue's give, and
    # the bone's own drop behind the hips) still bears the bones; before, 1.2 cm was the most
    assert _borne(16.0, 0.0) and _borne(16.0, 0.025)
    assert not _borne(16.0, 0.05)


def _foot_reaches(knee: float, block: bool = False) -> tuple[bool, float]:
    """(whether a hanging left foot reaches the floor as its knee bends, its ankle's height) for the sitting body,
    thighs level, put with its knees ``knee`` m up and nothing under them; with ``block``, a seat's front 0.15 m
    under the knee and 0.2 m deep on either side of it, which the shank meets before its toes meet the floor."""
    def build(z: float, with_block: bool) -> tuple[mujoco.MjModel, mujoco.MjData]:
        spec = mujoco.MjSpec()
        body = mujoco.MjSpec.from_string(body_fragment("sit"))
        spec.worldbody.add_frame(pos=[0.0, 0.0, z]).attach_body(body.worldbody.first_body(), "sitter_", "")
        if with_block:
            spec.worldbody.add_geom(name="front", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.2, 0.3, 0.05],
                                    pos=[knee_x, 0.0, knee - 0.2])
        m = spec.compile()
        data = mujoco.MjData(m)
        mujoco.mj_kinematics(m, data)
        return m, data

    m, data = build(1.0, False)
    shank = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "sitter_shank_l")
    knee_x, z = float(data.xpos[shank][0]), 1.0 + knee - float(data.xpos[shank][2])
    m, data = build(z, block)
    foot = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "sitter_foot_l")
    geoms = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "front")] if block else [], dtype=int)
    return toes_reach(m, data, foot, geoms), float(data.xpos[foot][2])


def test_a_hanging_foot_reaches_the_floor_as_the_knee_bends_unless_a_seat_front_stops_the_shank():
    size = body_size()
    plumb = size.shank + size.toes_down  # the knee's height from which a shank hung plumb puts the toes down
    reaches, ankle = _foot_reaches(plumb - 0.01)
    assert reaches and ankle > size.toes_down  # the foot as the posture holds it hangs past the toes' reach
    assert not _foot_reaches(plumb + 0.03)[0]
    assert not _foot_reaches(plumb - 0.01, block=True)[0]
