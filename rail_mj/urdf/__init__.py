"""URDF in and out: an agent's URDF as an MJCF fragment and back (:mod:`rail_mj.urdf.agent`), and an object's
URDF assembled into one mesh (:mod:`rail_mj.urdf.assembly`)."""

from rail_mj.urdf.agent import fragment_to_urdf, urdf_to_fragment
from rail_mj.urdf.assembly import assemble_urdf

__all__ = ["fragment_to_urdf", "urdf_to_fragment", "assemble_urdf"]
