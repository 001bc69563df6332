"""An articulated human body as an agent fragment: pelvis (the root), torso, head, thighs, shanks and feet.

Segment lengths, breadths and mass fractions are Winter's (D. A. Winter, *Biomechanics and Motor Control of
Human Movement*, 4th ed., Wiley 2009, Fig. 4.1 for lengths as fractions of stature H, Table 4.1 for segment
masses as fractions of body mass M), for an adult of H = 1.75 m and M = 75 kg; a doll or a teddy is the same
body scaled by ``scale`` (lengths × scale, masses × scale³). Segment thicknesses follow from mass, length and
the body's density. Joint ranges are the normal active ranges of motion of the American Academy of
Orthopaedic Surgeons (*Joint Motion: Method of Measuring and Recording*, 1965). The lumbar, hip and knee
joints are hinges with a posture spring and damping (sitting, the trunk's spring rests reclined a little); the
head rides on the torso and the feet on the shanks.

Frame of the fragment: x forward (the way the body faces), y to its left, z up; the origin is the midpoint of
the hip joints. ``posture`` "sit" holds the hips at 90° and the knees at 105° (the feet a little forward),
"lie" lies on its back, head towards −x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from rail_mj.core.errors import ConfigError
from rail_mj.mjcf.scene import geom_bottom
from rail_mj.mjcf.surface import OwnSurface

__all__ = ["Posture", "POSTURES", "SEGMENTS", "SEGMENT_AXES", "FEET", "THIGHS", "SIT_KNEE", "TOE_REACH", "SAG_DEG",
           "EASY_SEAT_DEG", "TRUNK_THIGH_DEG", "REACH_PROBES", "BEARING_PROBES", "BodySize", "body_size",
           "body_fragment", "toes_reach", "seat_under", "sit_bones", "back_reach"]

Posture = Literal["sit", "lie"]
POSTURES: tuple[str, ...] = ("sit", "lie")
#: The body's segments (MJCF body names, the root first).
SEGMENTS = ("pelvis", "torso", "head", "thigh_l", "shank_l", "foot_l", "thigh_r", "shank_r", "foot_r")
#: Each segment's long axis in its own frame, proximal to distal (up the trunk, down the legs, toes forward).
SEGMENT_AXES = {"pelvis": (0.0, 0.0, 1.0), "torso": (0.0, 0.0, 1.0), "head": (0.0, 0.0, 1.0),
                "thigh_l": (0.0, 0.0, -1.0), "shank_l": (0.0, 0.0, -1.0), "foot_l": (1.0, 0.0, 0.0),
                "thigh_r": (0.0, 0.0, -1.0), "shank_r": (0.0, 0.0, -1.0), "foot_r": (1.0, 0.0, 0.0)}

FEET = ("foot_l", "foot_r")
THIGHS = ("thigh_l", "thigh_r")
#: A hanging foot's toes reach this far (units of the foot's length) below the ankle's standing height: the three
#: quarters of the foot ahead of the ankle (Winter Fig. 4.1) hanging at a relaxed foot's 30° of plantar flexion
#: (the ankle's resting angle with the foot unloaded, within the AAOS 0-50° range; tiptoe, 50°, is no sitting).
TOE_REACH = 0.75 * math.sin(math.radians(30))
#: Steps (deg) of the knee's swing in which a hanging foot's reach is probed: a rung 2 cm across, 0.5 m from the
#: knee, spans 2.3°; half of that misses none.
_SWING_STEP = 1.0
#: An easy chair's seat tilts back up to this (deg; Grandjean, easy chairs 14-24°, their back bearing the reclined
#: trunk); steeper, the sitter slides or lies.
EASY_SEAT_DEG = 24.0
#: A foot or a thigh rests on a surface whose normal is within 45° of vertical: friction on it (μ ≤ 1) holds it there;
#: a steeper face (a panel, a drawer front) it slides down.
_BEARING_COS = math.cos(math.radians(45))

STATURE = 1.75  # m, the adult the table is read for
BODY_MASS = 75.0  # kg
DENSITY = 1050.0  # kg/m³, whole-body density (Winter Table 4.1: segments 1.03-1.11 g/cm³)
_G = 9.81
# Winter Table 4.1, segment mass / body mass
_M_FOOT, _M_SHANK, _M_THIGH = 0.0145, 0.0465, 0.100
_M_PELVIS, _M_THORAX_ABDOMEN, _M_HEAD = 0.142, 0.355, 0.081
_M_ARM = 0.028 + 0.016 + 0.006  # upper arm + forearm + hand; the arms ride on the torso
# Winter Fig. 4.1, lengths / stature
_L_HIP, _L_KNEE, _L_ANKLE, _L_SHOULDER = 0.530, 0.285, 0.039, 0.818
_L_HEAD_NECK = 1.0 - _L_SHOULDER
_W_HIP, _W_SHOULDER, _L_FOOT, _W_FOOT = 0.191, 0.259, 0.152, 0.055
#: The heel lies this fraction of the foot's length behind the ankle (Fig. 4.1 draws the ankle over the rear quarter).
_HEEL = 0.25
# AAOS (1965) normal ranges, degrees of flexion (negative: extension)
_HIP_RANGE = (-30.0, 120.0)
_KNEE_RANGE = (0.0, 135.0)
_LUMBAR_RANGE = (-25.0, 80.0)
#: The lumbar spring's rest (deg of flexion; negative: the trunk reclined): a relaxed sitter reclines the trunk 15° past
#: upright, a 105° trunk-thigh angle (Keegan 1953, the relaxed sitting posture; ANSI/HFES 100: backrests 100-110°).
_LUMBAR_REST = -15.0
#: The knee angle sitting (deg between thigh and shank): a sitter's knees open past a right angle, the feet put down
#: a little ahead of the knees before the seat takes the weight; the middle of the 90-120° that seating guides give
#: (OSHA's computer workstations eTool: "feet slightly forward"). A 90° knee drops the heels on a deep seat's front
#: edge, which then holds the body up.
SIT_KNEE = 105.0
#: The posture spring lets a joint sag at most this far (deg) under the gravity moment of what it carries
#: held out horizontally: a carried body keeps its posture, a load on it bends it.
SAG_DEG = 10.0
#: Damping ratio of each joint's spring against what it carries: critically damped, so a set-down body settles.
_DAMPING_RATIO = 1.0


@dataclass(frozen=True)
class BodySize:
    """The body's dimensions (m) and mass (kg) at one scale, for the kinds' plans and rules."""

    scale: float
    stature: float
    mass: float
    thigh: float  # hip joint to knee joint
    shank: float  # knee joint to ankle
    ankle: float  # ankle above the sole
    trunk: float  # hip joint to shoulder
    head: float  # head-neck, shoulder to crown
    hip_breadth: float
    shoulder_breadth: float
    thigh_radius: float
    shank_radius: float

    @property
    def length(self) -> float:
        """Heel to crown lying straight (m): the stature."""
        return self.stature

    @property
    def foot(self) -> float:
        """The foot's length (m)."""
        return _L_FOOT * self.stature

    @property
    def foot_breadth(self) -> float:
        """The foot's breadth (m)."""
        return _W_FOOT * self.stature

    @property
    def toes_down(self) -> float:
        """The ankle's height (m) when a hanging foot's relaxed toes touch the floor (:data:`TOE_REACH`): a sitter's
        feet this high or lower reach it."""
        return self.ankle + TOE_REACH * self.foot

    @property
    def lumbar(self) -> float:
        """Hip joints to the lumbar joint (m): the trunk's length shared by pelvis and torso in proportion to their
        mass (a uniform trunk)."""
        return self.trunk * _M_PELVIS / (_M_PELVIS + _M_THORAX_ABDOMEN)

    @property
    def pelvis_half(self) -> tuple[float, float, float]:
        """The pelvis box's half sizes standing (front-back, across, up; m): the hip breadth across, from the
        thighs' undersides to the lumbar joint up, deep enough for its mass at the body's density."""
        across, up = self.hip_breadth / 2, (self.lumbar + self.thigh_radius) / 2
        return _M_PELVIS * self.mass / (DENSITY * 8 * across * up), across, up

    @property
    def torso_half(self) -> tuple[float, float, float]:
        """The torso box's half sizes standing (front-back, across, up; m): the chest as broad as the hips across
        (Fig. 4.1 gives the hips 0.191 H; a chest is as broad, the arms hang outside it and rest on armrests), from
        the lumbar joint to the shoulders up, deep enough for the thorax and abdomen's mass (the arms' rides on it,
        their volume outside it)."""
        across, up = self.hip_breadth / 2, (self.trunk - self.lumbar) / 2
        return _M_THORAX_ABDOMEN * self.mass / (DENSITY * 8 * across * up), across, up

    def below_root(self, posture: Posture) -> float:
        """How far (m) the body reaches below its root's origin (the hip joints) under the pelvis: the thighs'
        undersides sitting, the back (pelvis and torso flush) lying."""
        return self.thigh_radius if posture == "sit" else self.torso_half[0]


def _radius(mass: float, length: float) -> float:
    """Radius of a cylinder of the body's density with this mass and length."""
    return math.sqrt(mass / (DENSITY * math.pi * length))


def body_size(scale: float = 1.0) -> BodySize:
    """The body at ``scale`` (1: an adult's)."""
    if not (math.isfinite(scale) and scale > 0):
        raise ConfigError(f"a body scale must be a positive finite number; got {scale!r}")
    h, m = STATURE * scale, BODY_MASS * scale**3
    thigh, shank = (_L_HIP - _L_KNEE) * h, (_L_KNEE - _L_ANKLE) * h
    return BodySize(scale=scale, stature=h, mass=m, thigh=thigh, shank=shank, ankle=_L_ANKLE * h,
                    trunk=(_L_SHOULDER - _L_HIP) * h, head=_L_HEAD_NECK * h, hip_breadth=_W_HIP * h,
                    shoulder_breadth=_W_SHOULDER * h, thigh_radius=_radius(_M_THIGH * m, thigh),
                    shank_radius=_radius(_M_SHANK * m, shank))


def _quat_y(deg: float) -> np.ndarray:
    """Rotation about +y by ``deg``, wxyz."""
    a = math.radians(deg) / 2
    return np.array([math.cos(a), 0.0, math.sin(a), 0.0])


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _rot_y(v: np.ndarray, deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]])


def _f(v) -> str:
    return " ".join(f"{float(x):.6g}" for x in np.ravel(v))


def _spring(mass: float, arm: float) -> tuple[float, float]:
    """(stiffness N·m/rad, damping N·m·s/rad) of a joint carrying ``mass`` at lever ``arm`` (its centre of mass)."""
    stiffness = mass * _G * arm / math.radians(SAG_DEG)
    inertia = mass * arm * arm
    return stiffness, 2.0 * _DAMPING_RATIO * math.sqrt(stiffness * inertia)


def _joint(name: str, axis: tuple[float, float, float], ref: float, limits: tuple[float, float],
           mass: float, arm: float, rest: float | None = None) -> str:
    """A hinge whose model pose is at ``ref`` (deg) and whose spring rests at ``rest`` (``ref`` if None)."""
    k, c = _spring(mass, arm)
    return (f'<joint name="{name}" type="hinge" axis="{_f(axis)}" range="{limits[0]:g} {limits[1]:g}" '
            f'ref="{ref:g}" springref="{ref if rest is None else rest:g}" stiffness="{k:.6g}" damping="{c:.6g}"/>')


def body_fragment(posture: Posture, scale: float = 1.0, name: str = "pelvis") -> str:
    """The body in ``posture`` at ``scale`` as an agent MJCF fragment (its root body named ``name``)."""
    if posture not in POSTURES:
        raise ConfigError(f"a body posture must be one of {', '.join(POSTURES)}; got {posture!r}")
    b = body_size(scale)
    m = b.mass
    hip_deg, knee_deg = (90.0, 180.0 - SIT_KNEE) if posture == "sit" else (0.0, 0.0)
    # lying is standing turned about y by -90 deg: the spine along -x, the front facing up
    turn = 0.0 if posture == "sit" else -90.0
    turn_q = _quat_y(turn)

    pelvis_m, torso_m, head_m = _M_PELVIS * m, (_M_THORAX_ABDOMEN + 2 * _M_ARM) * m, _M_HEAD * m
    lumbar = b.lumbar
    pelvis_low = -b.thigh_radius  # the buttocks level with the thighs' undersides
    pelvis_half = np.array(b.pelvis_half)
    torso_len = b.trunk - lumbar
    torso_half = np.array(b.torso_half)
    back = torso_half[0] - pelvis_half[0]  # the pelvis's back flush with the torso's: one straight back
    head_r = (3 * head_m / (4 * math.pi * DENSITY)) ** (1 / 3)
    foot_half = np.array([b.foot / 2, b.foot_breadth / 2, b.ankle / 2])
    foot_m, shank_m, thigh_m = _M_FOOT * m, _M_SHANK * m, _M_THIGH * m

    def child(pos: np.ndarray, quat: np.ndarray) -> str:
        """pos/quat of a child of the pelvis, turned with the posture."""
        return f'pos="{_f(_rot_y(pos, turn))}" quat="{_f(_qmul(turn_q, quat))}"'

    leg_mass = thigh_m + shank_m + foot_m
    leg_arm = (thigh_m * b.thigh / 2 + (shank_m + foot_m) * b.thigh) / leg_mass  # hip to the leg's centre, knee out
    trunk_mass = torso_m + head_m
    trunk_arm = (torso_m * torso_len / 2 + head_m * (torso_len + b.head / 2)) / trunk_mass
    lower_arm = (shank_m * b.shank / 2 + foot_m * b.shank) / (shank_m + foot_m)
    parts = [f'<body name="{name}">',
             f'<geom name="pelvis" type="box" size="{_f(pelvis_half)}" '
             f'pos="{_f(_rot_y(np.array([-back, 0.0, (lumbar + pelvis_low) / 2]), turn))}" quat="{_f(turn_q)}" '
             f'mass="{pelvis_m:.6g}"/>',
             f'<body name="torso" {child(np.array([0.0, 0.0, lumbar]), np.array([1.0, 0, 0, 0]))}>',
             _joint("lumbar", (0.0, 1.0, 0.0), 0.0, _LUMBAR_RANGE, trunk_mass, trunk_arm,
                    _LUMBAR_REST if posture == "sit" else None),
             f'<geom name="torso" type="box" size="{_f(torso_half)}" pos="0 0 {torso_len / 2:.6g}" '
             f'mass="{torso_m:.6g}"/>',
             f'<body name="head" pos="0 0 {torso_len:.6g}">',
             f'<geom name="head" type="sphere" size="{head_r:.6g}" pos="0 0 {b.head - head_r:.6g}" '
             f'mass="{head_m:.6g}"/>',
             "</body></body>"]
    for side, sign in (("l", 1.0), ("r", -1.0)):
        hip = np.array([0.0, sign * (b.hip_breadth / 2 - b.thigh_radius), 0.0])
        # hip flexion turns the thigh forward: about -y; knee flexion turns the shank back: about +y
        parts += [f'<body name="thigh_{side}" {child(hip, _quat_y(-hip_deg))}>',
                  _joint(f"hip_{side}", (0.0, -1.0, 0.0), hip_deg, _HIP_RANGE, leg_mass, leg_arm),
                  f'<geom name="thigh_{side}" type="capsule" size="{b.thigh_radius:.6g}" '
                  f'fromto="0 0 0 0 0 {-b.thigh:.6g}" mass="{thigh_m:.6g}"/>',
                  f'<body name="shank_{side}" pos="0 0 {-b.thigh:.6g}" quat="{_f(_quat_y(knee_deg))}">',
                  _joint(f"knee_{side}", (0.0, 1.0, 0.0), knee_deg, _KNEE_RANGE, shank_m + foot_m, lower_arm),
                  f'<geom name="shank_{side}" type="capsule" size="{b.shank_radius:.6g}" '
                  f'fromto="0 0 0 0 0 {-b.shank:.6g}" mass="{shank_m:.6g}"/>',
                  f'<body name="foot_{side}" pos="0 0 {-b.shank:.6g}">',
                  f'<geom name="foot_{side}" type="box" size="{_f(foot_half)}" '
                  f'pos="{_f([foot_half[0] - _HEEL * 2 * foot_half[0], 0.0, -foot_half[2]])}" '
                  f'mass="{foot_m:.6g}"/>',
                  "</body></body></body>"]
    parts.append("</body>")
    return f'<mujoco><worldbody>{"".join(parts)}</worldbody></mujoco>'


def toes_reach(m: mujoco.MjModel, data: mujoco.MjData, foot: int, geoms: np.ndarray) -> bool:
    """Whether a hanging foot (body id ``foot``, its parent the shank) can rest on one of ``geoms`` or on the floor:
    the knee bent on from where it rests towards its flexion limit (AAOS), the sole and the relaxed toes
    (:data:`TOE_REACH`), swept along the shank's line, meet a face of it a foot can stand on, or the floor (z = 0),
    before the shank itself meets the object (the seat's front stops the knee there). A sitter high above the floor
    puts the feet on a rung or a ring so, and one whose knees a reclined seat raises lets the shanks down to the floor;
    ``data`` holds the world's kinematics (``mj_kinematics``)."""
    shank = int(m.body_parentid[foot])
    joint, geom, sole = int(m.body_jntadr[shank]), int(m.body_geomadr[shank]), int(m.body_geomadr[foot])
    ankle, length = 2 * float(m.geom_size[sole][2]), 2 * float(m.geom_size[sole][0])
    shin = 2 * float(m.geom_size[geom][1])  # knee to ankle
    reach = shin + ankle + TOE_REACH * length  # knee to the toes along the shank's line
    knee, frame = data.xpos[shank], data.xmat[shank].reshape(3, 3)
    near = [int(g) for g in geoms
            if np.linalg.norm(data.geom_xpos[g] - knee) <= reach + float(m.geom_rbound[g])]
    if not near and knee[2] > reach:
        return False
    swing = float(m.jnt_range[joint][1] - data.qpos[m.jnt_qposadr[joint]])
    for phi in np.arange(0.0, max(swing, 0.0) + 1e-9, math.radians(_SWING_STEP)):
        # knee flexion turns the shank back, about its +y: its distal axis (0, 0, -1) goes to (-sin, 0, -cos)
        ray = frame @ np.array([-math.sin(phi), 0.0, -math.cos(phi)])
        floor = knee[2] / -ray[2] if ray[2] < 0.0 else math.inf  # along the ray to the floor
        hits = [hit for g in near if (hit := _ray(m, data, g, knee, ray))[0] >= 0.0]
        distance, normal_z = min(hits) if hits else (math.inf, 0.0)
        if distance < min(shin, floor):
            return False
        if distance <= min(reach, floor) and normal_z >= _BEARING_COS:
            return True
        if floor <= reach and floor <= distance:
            return True
    return False


def _ray(m: mujoco.MjModel, data: mujoco.MjData, g: int, pnt: np.ndarray, vec: np.ndarray) -> tuple[float, float]:
    """(distance along the unit ``vec`` from ``pnt`` to geom ``g``, -1 when the ray misses it; the vertical part of
    the surface's normal where it meets it)."""
    normal = np.zeros(3)
    if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        distance = mujoco.mj_rayMesh(m, data, g, pnt, vec, normal)
    else:
        distance = mujoco.mju_rayGeom(data.geom_xpos[g], data.geom_xmat[g], m.geom_size[g], pnt, vec,
                                      int(m.geom_type[g]), normal)
    return distance, float(normal[2])


def seat_under(m: mujoco.MjModel, data: mujoco.MjData, thigh: int, geoms: np.ndarray) -> bool:
    """Whether one of ``geoms`` lies under a thigh (body id ``thigh``) that does not touch it: straight below the
    thigh's middle, a face within 45° of level no lower than the buttocks less a thigh's thickness. On a seat lower
    than the knees the feet hold the knees above the hips and the thighs rise off the seat's front; over an edge or a
    rail nothing is under them but the floor. ``data`` holds the world's kinematics (``mj_kinematics``)."""
    geom = int(m.body_geomadr[thigh])
    radius = float(m.geom_size[geom][0])
    middle = data.geom_xpos[geom]
    lowest = data.xpos[thigh][2] - 2 * radius  # the buttocks (a thigh's radius under the hip joint), less a radius
    down = np.array([0.0, 0.0, -1.0])
    for g in geoms:
        distance, normal_z = _ray(m, data, int(g), middle, down)
        if 0.0 <= distance <= middle[2] - lowest and normal_z >= _BEARING_COS:
            return True
    return False


#: The sitting bones (ischial tuberosities), which bear a sitter's weight, lie about 12 cm apart in adults (the
#: bi-ischial breadth, 10-14 cm): 0.36 of Winter's hip breadth (0.191 H, 33 cm at 1.75 m), under the hip joints.
_SIT_BONES = 0.36
#: The soft tissue under a sitting bone gives about 2 cm under a sitter's weight (MRI of seated adults): a quarter of
#: a thigh's radius (7 cm at 1.75 m and 75 kg). A face farther below the buttocks does not bear the bone.
_SIT_TISSUE = 0.25
#: Flesh fills a hollow no deeper than itself: the buttock between a sitting bone and a flat seat, a thigh's radius
#: (units of it) thick, still bears on the object's own surface that far under the face of a convex hull that rounds
#: a crease (an armchair's seat and back); under a hull that spans a gap (two legs of a chair on its side, as rails)
#: the object is farther, and the bone bears on nothing.
_FLESH_CONFORMS = 1.0


def sit_bones(m: mujoco.MjModel, data: mujoco.MjData, pelvis: int, geoms: np.ndarray,
              own: OwnSurface | None = None) -> bool:
    """Whether the object bears both sitting bones of a pelvis (body id ``pelvis``) that touches it: straight below
    each, at the hip joints' line or a thigh's radius ahead of or behind it (the loaded tissue under a sit bone), a
    face within 45° of level no lower than the buttocks, as low as the pelvis box reaches, less the tissue's give
    (:data:`_SIT_TISSUE`): a face of the object's ``own`` surface, or of one of ``geoms`` (its hulls, on which the
    body rests) with, given ``own``, that surface within a buttock's depth under it (:data:`_FLESH_CONFORMS`). A seat
    pan, a shell (whose curve the hulls may split, none of them level under a bone), a bench's slats bear them; an
    upturned stool's leg ends, a pouf's feet, a rail or an edge under the hips, or a hull spanning the gap between two
    rails do not. ``data`` holds the world's kinematics (``mj_kinematics``)."""
    pelvis_geom, thigh_geom = int(m.body_geomadr[pelvis]), int(m.body_geomadr[pelvis + SEGMENTS.index(THIGHS[0])])
    half = _SIT_BONES * float(m.geom_size[pelvis_geom][1])  # the pelvis box's half breadth is the hips'
    radius = float(m.geom_size[thigh_geom][0])
    frame = data.xmat[pelvis].reshape(3, 3)
    down = np.array([0.0, 0.0, -1.0])
    # the buttocks reach as low as the pelvis box's lowest edge: a thigh's radius under the hips when level; rolled
    # back (a reclined seat) the box rests on its rear edge, 10 cm behind the hips, where a buttock is round, and holds
    # the hips up by that edge's drop, which a round buttock would sink back into the seat
    reach = float(data.xpos[pelvis][2]) - geom_bottom(m, data, pelvis_geom) + _SIT_TISSUE * radius

    def bears(distance: float, normal_z: float) -> bool:
        return 0.0 <= distance <= reach and normal_z >= _BEARING_COS

    def borne(point: np.ndarray) -> bool:
        surface = None if own is None else own.ray(point, down)
        if surface is not None and bears(*surface):
            return True
        for g in geoms:
            distance, normal_z = _ray(m, data, int(g), point, down)
            if bears(distance, normal_z):
                return surface is None or 0.0 <= surface[0] <= distance + _FLESH_CONFORMS * radius
        return False

    return all(any(borne(data.xpos[pelvis] + frame @ np.array([ahead, side, 0.0])) for ahead in (0.0, radius, -radius))
               for side in (half, -half))


#: Keegan's (1953) relaxed sitting keeps the trunk-thigh angle within this (deg); opened further, the sitter lies.
TRUNK_THIGH_DEG = 135.0
#: Steps (deg) of the trunk's recline in which its reach of a back is probed: 1.3 cm at the shoulders.
_RECLINE_STEP = 2.0
#: Steps (m) of a sitter's shift back along the seat in which its reach of a back is probed.
_SHIFT_STEP = 0.02
#: Where along the torso (fractions of its length from the lumbar joint) a back may bear it: the lumbar curve, the
#: shoulder blades, the shoulders.
_BACK_HEIGHTS = (0.3, 0.6, 0.9)


def _object_ray(m: mujoco.MjModel, data: mujoco.MjData, pnt: np.ndarray, vec: np.ndarray, exclude: int,
                objects: set[int]) -> tuple[float, np.ndarray]:
    """(distance along the unit ``vec`` from ``pnt`` to the nearest geom but the ground and body ``exclude``'s, -1
    when that is none of ``objects``; its surface normal there)."""
    geom, normal = np.full(1, -1, dtype=np.int32), np.zeros(3)
    distance = mujoco.mj_ray(m, data, pnt, vec, None, False, exclude, geom, normal)
    return (distance if int(geom[0]) in objects else -1.0), normal


def back_reach(m: mujoco.MjModel, data: mujoco.MjData, torso: int, geoms: np.ndarray) -> bool:
    """Whether a torso (body id ``torso``) that touches nothing comes to rest on one of ``geoms`` as a sitter settles
    back: shifted back along the seat, as far as the seat still bears the hips and no further than a seat is deep (a
    thigh's length, Pheasant's buttock-popliteal length), and reclined on, the hips opening no further than
    :data:`TRUNK_THIGH_DEG` from either thigh, its back meets, within the soft tissue's give (:data:`_SIT_TISSUE`), a
    face that bears it (its normal within 45° of the trunk's front). A sitter put down forward of a lounge chair's
    back, which leans 30-55° from vertical, sits back and relaxes onto it; one on a stool, with nothing behind, holds
    the trunk up. ``data`` holds the world's kinematics (``mj_kinematics``)."""
    pelvis = int(m.body_parentid[torso])
    geom = int(m.body_geomadr[torso])
    thighs = [pelvis + SEGMENTS.index(t) for t in THIGHS]
    thigh_geom = int(m.body_geomadr[thighs[0]])
    depth, length = float(m.geom_size[geom][0]), 2 * float(m.geom_size[geom][2])
    radius, seat_depth = float(m.geom_size[thigh_geom][0]), 2 * float(m.geom_size[thigh_geom][1])
    give = _SIT_TISSUE * radius
    frame, lumbar = data.xmat[torso].reshape(3, 3), data.xpos[torso]
    hips, pelvis_frame = data.xpos[pelvis], data.xmat[pelvis].reshape(3, 3)
    # a thigh's z axis runs from the knee to the hip: its distal direction is -z
    opened = max(math.degrees(math.acos(float(np.clip(-(data.xmat[t].reshape(3, 3)[:, 2] @ frame[:, 2]), -1.0, 1.0))))
                 for t in thighs)
    swing = TRUNK_THIGH_DEG - opened
    backward = -pelvis_frame[:, 0] * np.array([1.0, 1.0, 0.0])
    if swing < 0.0 or np.linalg.norm(backward) < 1e-6:
        return False
    backward /= np.linalg.norm(backward)
    objects = {int(g) for g in geoms}
    down = np.array([0.0, 0.0, -1.0])
    seat, _ = _object_ray(m, data, hips, down, pelvis, objects)
    if seat < 0.0:
        return False
    slope = math.tan(math.radians(EASY_SEAT_DEG))
    # opening the hips turns the trunk back about the hip axis, the pelvis's y: in the pelvis's frame a turn about y
    # by -phi (its top towards -x). Per recline: the trunk's axis, its front, and the lumbar joint from the hips
    local = pelvis_frame.T @ np.column_stack([frame[:, 2], frame[:, 0], lumbar - hips])
    reclined = [pelvis_frame @ np.column_stack([_rot_y(v, -phi) for v in local.T])
                for phi in np.arange(0.0, swing + 1e-9, _RECLINE_STEP)]
    for shift in np.arange(0.0, seat_depth + 1e-9, _SHIFT_STEP):
        moved = hips + shift * backward
        if shift > 0.0:
            # the seat still bears the hips, sloping down at most as an easy chair's; a steeper face is the back
            under, normal = _object_ray(m, data, moved, down, pelvis, objects)
            if not (0.0 <= under <= seat + shift * slope + give and normal[2] >= _BEARING_COS):
                return False
        for axis, ahead, to_lumbar in (r.T for r in reclined):
            base = moved + to_lumbar
            for height in _BACK_HEIGHTS:
                distance, normal = _object_ray(m, data, base + height * length * axis, -ahead, torso, objects)
                if 0.0 <= distance <= depth + give and normal @ ahead >= _BEARING_COS:
                    return True
    return False


#: Each segment whose reach of the object is probed when it touches nothing, with its probe.
REACH_PROBES = {**dict.fromkeys(FEET, toes_reach), **dict.fromkeys(THIGHS, seat_under), "torso": back_reach}
#: Each segment whose bearing is probed when it touches the object, with its probe (its ``reaches_object``).
BEARING_PROBES = {"pelvis": sit_bones}
