"""Agent-fragment rules and the names and constants every composed scene shares.

``check_fragment`` validates untrusted agent MJCF; :mod:`rail_mj.mjcf.compose` builds scenes from it.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from rail_mj.core.errors import FragmentError

__all__ = [
    "GROUND_GEOM",
    "OBJECT_BODY",
    "OBJECT_JOINT",
    "GROUND_BIT",
    "OBJECT_BIT",
    "AGENT_BIT",
    "FRICTION",
    "SOLREF_TIMECONST_FACTOR",
    "MAX_AGENT_RADIUS",
    "VALID_FRAGMENT_EXAMPLE",
    "MAX_FRAGMENT_BYTES",
    "parse_untrusted_xml",
    "MAX_FRAGMENT_ELEMENTS",
    "MAX_FRAGMENT_GEOMS",
    "MAX_FRAGMENT_VERTICES",
    "check_fragment",
    "agent_prefix",
    "agent_body_name",
    "hull_geom_name",
    "geom_bottom",
]

GROUND_GEOM = "ground"
OBJECT_BODY = "object"
#: Name of the object's free joint (present only when ``object_free``).
OBJECT_JOINT = "object"
GROUND_BIT = 1
OBJECT_BIT = 2
AGENT_BIT = 4
#: sliding, torsional, rolling friction on the ground, object and agents.
FRICTION = (1.0, 0.005, 0.0001)
#: solref time constant = factor * timestep; stops droplets sinking through thin bottoms (design.md).
SOLREF_TIMECONST_FACTOR = 2.5
#: Largest allowed bounding radius of an agent about its body origin, metres (a person is ~1 m).
MAX_AGENT_RADIUS = 3.0
VALID_FRAGMENT_EXAMPLE = (
    '<mujoco><worldbody><body name="drop"><geom type="sphere" size="0.01" mass="0.001"/></body></worldbody></mujoco>'
)
#: Caps on one agent fragment (the layout replicates it), checked before MuJoCo parses it. Real agents are a
#: handful of primitives (the offline library's have one geom); the caps bound validation to milliseconds.
MAX_FRAGMENT_BYTES = 65_536
MAX_FRAGMENT_ELEMENTS = 256
MAX_FRAGMENT_GEOMS = 64
MAX_FRAGMENT_VERTICES = 1024  # inline mesh vertices, all meshes together

_POSE = ("pos", "quat", "axisangle", "euler", "xyaxes", "zaxis")
_GEOM_ATTRS = ("name", "class", "type", "size", "fromto", *_POSE, "mass", "density", "rgba", "material", "friction",
               "condim", "contype", "conaffinity", "group", "priority", "solmix", "solref", "solimp", "margin", "gap",
               "mesh", "shellinertia")
_SITE_ATTRS = ("name", "class", "type", "size", "fromto", *_POSE, "rgba", "material", "group")
_MESH_ATTRS = ("name", "class", "vertex", "face", "normal", "scale", "refpos", "refquat", "maxhullvert", "inertia",
               "smoothnormal")
_JOINT_ATTRS = ("name", "class", "type", "pos", "axis", "range", "limited", "ref", "springref", "stiffness", "damping",
                 "armature", "frictionloss")
_MATERIAL_ATTRS = ("name", "class", "rgba", "emission", "specular", "shininess", "reflectance", "metallic",
                   "roughness")
# The allow-list: element -> (its allowed attributes, its allowed child elements). An agent is one body of
# primitive or inline-mesh geoms, rigid or articulated by hinge joints in its nested bodies (an articulated body:
# rail_mj.mjcf.body); anything else (files, plugins, other joints, flexes, actuators, ...) is refused.
_ALLOWED: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "mujoco": (("model",), ("compiler", "default", "asset", "worldbody")),
    "compiler": (("angle", "eulerseq"), ()),
    "default": (("class",), ("default", "geom", "site", "mesh", "material")),
    "asset": ((), ("mesh", "material")),
    "mesh": (_MESH_ATTRS, ()),
    "material": (_MATERIAL_ATTRS, ()),
    "worldbody": ((), ("body",)),
    "body": (("name", "childclass", *_POSE), ("body", "geom", "site", "inertial", "joint")),
    "joint": (_JOINT_ATTRS, ()),
    "geom": (_GEOM_ATTRS, ()),
    "site": (_SITE_ATTRS, ()),
    "inertial": ((*_POSE, "mass", "diaginertia", "fullinertia"), ()),
}
_GEOM_TYPES = ("sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh")
_SITE_TYPES = ("sphere", "capsule", "ellipsoid", "cylinder", "box")
# Why common refused elements are refused (the allow-list alone would refuse them too).
_WHY = {
    "include": "it pulls in another file",
    "joint": "the scene adds a free joint itself; only nested bodies may have hinge joints",
    "freejoint": "the scene adds a free joint itself",
    "flexcomp": "it builds a deformable body and can read a mesh file",
    "texture": "it can read an image file",
    "hfield": "it can read a file, and height fields cannot move",
    "skin": "it can read a file",
    "extension": "it loads engine plugins",
    "plugin": "it instantiates an engine plugin",
    "keyframe": "it sets a state that breaks once the scene adds joints",
}
_RULES = (
    f"a valid fragment is a <mujoco> document of at most {MAX_FRAGMENT_BYTES} bytes whose <worldbody> holds exactly "
    "one body (nested bodies allowed, joined to it rigidly or by hinge <joint>s) made only of <body>, <geom> (type "
    f"{', '.join(_GEOM_TYPES)}; a mesh given inline by <asset><mesh vertex=...>), <site>, <inertial> and, in nested "
    "bodies, <joint type=\"hinge\">, plus optional <compiler angle/eulerseq>, <default> and <asset> (<mesh>, "
    "<material>); no files, plugins or other joints; "
    f"at most {MAX_FRAGMENT_ELEMENTS} elements, {MAX_FRAGMENT_GEOMS} geoms and {MAX_FRAGMENT_VERTICES} inline mesh "
    f"vertices; geoms of positive size; e.g. {VALID_FRAGMENT_EXAMPLE}"
)
_SIZE_DIMS = {
    mujoco.mjtGeom.mjGEOM_SPHERE: 1,
    mujoco.mjtGeom.mjGEOM_CAPSULE: 2,
    mujoco.mjtGeom.mjGEOM_CYLINDER: 2,
    mujoco.mjtGeom.mjGEOM_ELLIPSOID: 3,
    mujoco.mjtGeom.mjGEOM_BOX: 3,
}


def _reject(problem: str) -> FragmentError:
    return FragmentError(f"invalid agent fragment: {problem}; {_RULES}")


def _check_element(el: ET.Element, parent: str) -> None:
    """One element against the allow-list: allowed under its parent, allowed attributes, allowed types."""
    allowed_children = _ALLOWED[parent][1]
    if el.tag not in allowed_children:
        why = f" ({_WHY[el.tag]})" if el.tag in _WHY else ""
        raise _reject(
            f"<{el.tag}> is not allowed inside <{parent}>{why}; allowed there: "
            f"{', '.join(f'<{t}>' for t in allowed_children) or 'nothing'}"
        )
    attributes = _ALLOWED[el.tag][0]
    bad = [k for k in el.attrib if k not in attributes]
    if bad:
        raise _reject(
            f"<{el.tag}> attribute {bad[0]!r} is not allowed; allowed <{el.tag}> attributes: "
            f"{', '.join(attributes) or 'none'}"
        )
    types = {"geom": _GEOM_TYPES, "site": _SITE_TYPES, "joint": ("hinge",)}.get(el.tag)
    default = "hinge" if el.tag == "joint" else "sphere"
    if types is not None and el.attrib.get("type", default) not in types:
        raise _reject(f"<{el.tag}> type {el.attrib['type']!r} is not allowed; allowed: {', '.join(types)}")


def parse_untrusted_xml(xml: str, root_tag: str) -> ET.Element:
    """An untrusted XML document (an LLM's MJCF, a profile folder's URDF) parsed, once it is at most
    MAX_FRAGMENT_BYTES, declares no DOCTYPE or ENTITY and its root is ``<root_tag>``; else a ValueError saying
    which (the caller names the document and its own error type)."""
    size = len(xml.encode("utf-8"))
    if size > MAX_FRAGMENT_BYTES:
        raise ValueError(f"the document is {size} bytes, more than {MAX_FRAGMENT_BYTES}")
    if "<!DOCTYPE" in xml or "<!ENTITY" in xml:
        raise ValueError("DOCTYPE/ENTITY declarations are not allowed")
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise ValueError(f"not well-formed XML ({exc})") from exc
    if root.tag != root_tag:
        raise ValueError(f"the root element is <{root.tag}>, expected <{root_tag}>")
    return root


def _scan_xml(xml: str) -> None:
    """Check size caps, the element and attribute allow-list by looking at the raw XML, before MuJoCo parses it."""
    try:
        root = parse_untrusted_xml(xml, "mujoco")
    except ValueError as exc:
        raise _reject(str(exc)) from exc
    bad = [k for k in root.attrib if k not in _ALLOWED["mujoco"][0]]
    if bad:
        raise _reject(f"<mujoco> attribute {bad[0]!r} is not allowed; allowed <mujoco> attributes: model")
    n_elements = n_geoms = n_vertices = 0
    queue: list[tuple[ET.Element, bool]] = [(root, False)]  # (element, inside <worldbody>), breadth first
    tops = {id(body) for world in root.findall("worldbody") for body in world}
    for el, in_world in queue:
        n_elements += 1
        if n_elements > MAX_FRAGMENT_ELEMENTS:
            raise _reject(f"the document has more than {MAX_FRAGMENT_ELEMENTS} elements")
        for child in el:
            if child.tag == "joint" and id(el) in tops:  # the top body moves by the scene's free joint alone
                raise _reject("<joint> is not allowed inside <body> (the scene adds a free joint itself to the top "
                              "body; only nested bodies may have hinge joints)")
            _check_element(child, el.tag)
            queue.append((child, in_world or child.tag == "worldbody"))
        if el.tag == "geom" and in_world:
            n_geoms += 1
        if el.tag == "mesh" and "vertex" in el.attrib:
            n_vertices += len(el.attrib["vertex"].split()) // 3
    if n_geoms > MAX_FRAGMENT_GEOMS:
        raise _reject(f"the body has {n_geoms} geoms, more than {MAX_FRAGMENT_GEOMS}")
    if n_vertices > MAX_FRAGMENT_VERTICES:
        raise _reject(f"the meshes have {n_vertices} vertices in all, more than {MAX_FRAGMENT_VERTICES}")


def check_fragment(xml: str) -> mujoco.MjSpec:
    """Validate an agent MJCF fragment and return its parsed spec; raise FragmentError."""
    if not isinstance(xml, str) or not xml.strip():
        raise _reject("empty document")
    _scan_xml(xml)
    try:
        spec = mujoco.MjSpec.from_string(xml)
    except Exception as exc:  # MuJoCo's parser raises ValueError with its own message
        raise _reject(f"does not parse ({exc})") from exc
    n_top = len(spec.worldbody.bodies)
    if n_top != 1:
        raise _reject(f"worldbody holds {n_top} bodies, expected exactly one")
    for geom in spec.geoms:
        dims = _SIZE_DIMS.get(geom.type)
        has_fromto = np.isfinite(geom.fromto).all() and np.any(np.asarray(geom.fromto) != 0)
        if dims is not None and not (np.asarray(geom.size[: 1 if has_fromto else dims]) > 0).all():
            raise _reject(
                f"geom {geom.name or '(unnamed)'} ({geom.type.name[7:].lower()}) has size "
                f"{list(np.asarray(geom.size[:dims]))}; needs {dims} positive size value(s)"
            )
    try:
        model = spec.compile()
    except Exception as exc:  # compile errors (undefined assets, bad meshes) come as ValueError
        raise _reject(f"does not compile ({exc})") from exc
    mass = float(model.body_mass[1:].sum())
    if not (np.isfinite(mass) and mass > 0):
        raise _reject(f"total mass is {mass}; it must be positive and finite")
    if model.ngeom == 0:
        raise _reject("the body has no geoms")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    radius = float((np.linalg.norm(data.geom_xpos - data.xpos[1], axis=1) + model.geom_rbound).max())
    if radius > MAX_AGENT_RADIUS:
        raise _reject(f"the agent reaches {radius:.3g} m from its origin, more than {MAX_AGENT_RADIUS} m")
    return spec


def agent_prefix(i: int) -> str:
    """Name prefix of agent ``i``'s elements in a scene."""
    return f"agent{i}/"


def agent_body_name(spec_or_xml: mujoco.MjSpec | str, i: int) -> str:
    """Name of agent ``i``'s body: the fragment's top body name (``agent`` if unnamed), prefixed."""
    spec = check_fragment(spec_or_xml) if isinstance(spec_or_xml, str) else spec_or_xml
    return agent_prefix(i) + (spec.worldbody.first_body().name or "agent")


def hull_geom_name(i: int) -> str:
    """Name of the object's i-th hull geom (and its mesh asset)."""
    return f"{OBJECT_BODY}/hull{i}"


def geom_bottom(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    """The height (m) of the lowest point of geom ``g``'s bounding box as it lies in ``data`` (kinematics done): a
    box geom's lowest corner."""
    rot_z = data.geom_xmat[g].reshape(3, 3)[2]
    return float(data.geom_xpos[g, 2] - np.abs(rot_z) @ model.geom_aabb[g, 3:] + rot_z @ model.geom_aabb[g, :3])
