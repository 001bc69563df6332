"""Scene composition: object hulls + agent fragments + ground, via ``mujoco.MjSpec``."""

from __future__ import annotations

from rail_mj.mjcf.scene import (
    AGENT_BIT,
    FRICTION,
    GROUND_BIT,
    GROUND_GEOM,
    MAX_AGENT_RADIUS,
    MAX_FRAGMENT_BYTES,
    MAX_FRAGMENT_ELEMENTS,
    MAX_FRAGMENT_GEOMS,
    MAX_FRAGMENT_VERTICES,
    OBJECT_BIT,
    OBJECT_BODY,
    OBJECT_JOINT,
    SOLREF_TIMECONST_FACTOR,
    VALID_FRAGMENT_EXAMPLE,
    agent_body_name,
    agent_prefix,
    build_scene,
    check_fragment,
    hull_geom_name,
)

__all__ = [
    "AGENT_BIT",
    "FRICTION",
    "GROUND_BIT",
    "GROUND_GEOM",
    "MAX_AGENT_RADIUS",
    "MAX_FRAGMENT_BYTES",
    "MAX_FRAGMENT_ELEMENTS",
    "MAX_FRAGMENT_GEOMS",
    "MAX_FRAGMENT_VERTICES",
    "OBJECT_BIT",
    "OBJECT_BODY",
    "OBJECT_JOINT",
    "SOLREF_TIMECONST_FACTOR",
    "VALID_FRAGMENT_EXAMPLE",
    "agent_body_name",
    "agent_prefix",
    "build_scene",
    "check_fragment",
    "hull_geom_name",
]
