"""An agent as URDF: read through MuJoCo's own URDF compiler into an allow-listed MJCF fragment, and written back.

Reading refuses, before MuJoCo sees the text, whatever would reach outside the file or make the agent
anything but one rigid body: mesh files, textures, plugins and simulator extensions, unknown tags and
every joint type but ``fixed``. MuJoCo then compiles the links (fixed joints fused into one body, visual
shapes dropped: collision shapes are what collides) and the compiled body becomes the fragment, which
passes the project's own fragment check (:func:`rail_mj.mjcf.check_fragment`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from rail_mj.core.errors import FragmentError, ProfileFolderError
from rail_mj.mjcf import check_fragment, parse_untrusted_xml

__all__ = ["ALLOWED_URDF", "urdf_to_fragment", "fragment_to_urdf"]

#: The URDF allow-list: element -> its allowed child elements. What an LLM writes for a rigid agent of primitives.
ALLOWED_URDF: dict[str, tuple[str, ...]] = {
    "robot": ("link", "joint", "material"),
    "link": ("inertial", "visual", "collision"),
    "inertial": ("origin", "mass", "inertia"),
    "visual": ("origin", "geometry", "material"),
    "collision": ("origin", "geometry"),
    "geometry": ("box", "sphere", "cylinder"),
    "material": ("color",),
    "joint": ("origin", "parent", "child", "axis", "limit", "dynamics"),
    "origin": (), "mass": (), "inertia": (), "box": (), "sphere": (), "cylinder": (), "color": (), "axis": (),
    "limit": (), "dynamics": (), "parent": (), "child": (),
}
# Why common refused elements are refused (the allow-list alone would refuse them too).
_WHY = {
    "mesh": "it reads a mesh file; give the agent as box, sphere and cylinder shapes",
    "texture": "it reads an image file",
    "plugin": "it loads a simulator plugin",
    "gazebo": "it configures another simulator and may load plugins",
    "mujoco": "it sets MuJoCo compiler options (file directories among them)",
    "transmission": "agents have no actuators",
}
_RIGID = "agents are rigid: rail_mj moves each agent as one body, so links may be joined only by fixed joints"
_RGBA = (0.2, 0.5, 0.9, 1.0)  # the offline agents' blue


def _scan(text: str, where: str) -> ET.Element:
    """The URDF tree, once every element is on the allow-list and every joint is fixed."""
    try:
        root = parse_untrusted_xml(text, "robot")
    except ValueError as exc:
        raise ProfileFolderError(f"{where}: {exc}") from None
    for parent in root.iter():
        for el in parent:
            if el.tag not in ALLOWED_URDF.get(parent.tag, ()):
                why = _WHY.get(el.tag)
                allowed = ", ".join(f"<{t}>" for t in ALLOWED_URDF[parent.tag]) or "nothing"
                raise ProfileFolderError(
                    f"{where}: <{el.tag}> inside <{parent.tag}> is not allowed"
                    + (f" ({why})" if why else f" (an unknown tag; allowed there: {allowed})"))
    for joint in root.iter("joint"):
        kind = joint.get("type")
        if kind != "fixed":
            raise ProfileFolderError(f"{where}: joint {joint.get('name', '(unnamed)')!r} has type {kind!r}; "
                                     f"{_RIGID} (type=\"fixed\")")
    links = root.findall("link")
    if not links:
        raise ProfileFolderError(f"{where}: no <link>; the agent needs one link with box, sphere or cylinder shapes")
    if not any(link.find("collision") is not None for link in links):
        raise ProfileFolderError(f"{where}: no link has a <collision> shape; MuJoCo's URDF compiler keeps collision "
                                 "shapes only (visual ones are drawn, never collide), so the agent would have none")
    return root


def _floating(root: ET.Element, where: str) -> str:
    """The URDF with a floating joint from a new world link to its root link, so that MuJoCo compiles the links
    into one free body (the root link is otherwise welded to the world)."""
    children = {child.get("link") for j in root.iter("joint") if (child := j.find("child")) is not None}
    roots = [link.get("name") for link in root.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise ProfileFolderError(f"{where}: the links form {len(roots)} trees ({roots}); the agent must be one "
                                 "tree of links joined by fixed joints")
    names = {link.get("name") for link in root.iter("link")}
    world = next(f"world{i or ''}" for i in range(len(names) + 1) if f"world{i or ''}" not in names)
    ET.SubElement(root, "link", {"name": world})
    joint = ET.SubElement(root, "joint", {"name": f"{world}_free", "type": "floating"})
    ET.SubElement(joint, "parent", {"link": world})
    ET.SubElement(joint, "child", {"link": str(roots[0])})
    return ET.tostring(root, encoding="unicode")


def _fmt(values) -> str:
    return " ".join(f"{float(v) + 0.0:.9g}" for v in np.ravel(values))  # + 0.0: no "-0"


def _compiled_fragment(model: mujoco.MjModel, name: str) -> str:
    """Body 1 of a compiled model (its inertial and geoms) as an MJCF fragment."""
    geoms = []
    for g in np.flatnonzero(model.geom_bodyid == 1):
        kind = mujoco.mjtGeom(model.geom_type[g]).name[len("mjGEOM_"):].lower()
        size = model.geom_size[g][: {"sphere": 1, "cylinder": 2}.get(kind, 3)]
        geoms.append(f'<geom name="{name}_geom{len(geoms)}" type="{kind}" size="{_fmt(size)}" '
                     f'pos="{_fmt(model.geom_pos[g])}" quat="{_fmt(model.geom_quat[g])}" rgba="{_fmt(_RGBA)}"/>')
    inertial = (f'<inertial pos="{_fmt(model.body_ipos[1])}" quat="{_fmt(model.body_iquat[1])}" '
                f'mass="{float(model.body_mass[1]):.9g}" diaginertia="{_fmt(model.body_inertia[1])}"/>')
    return f'<mujoco><worldbody><body name="{name}">{inertial}{"".join(geoms)}</body></worldbody></mujoco>'


def urdf_to_fragment(text: str, where: str = "agent.urdf") -> str:
    """The agent fragment of a URDF (ProfileFolderError naming ``where`` and what was wrong)."""
    root = _scan(text, where)
    try:
        model = mujoco.MjSpec.from_string(_floating(root, where)).compile()
    except ValueError as exc:  # MuJoCo's URDF compiler says what it could not read
        raise ProfileFolderError(f"{where}: MuJoCo's URDF compiler refused it: {exc}") from None
    if model.nbody != 2:
        raise ProfileFolderError(f"{where}: compiled into {model.nbody - 1} bodies; the agent must be one rigid body")
    name = "".join(c if c.isalnum() or c in "_-" else "_" for c in (root.get("name") or "agent")) or "agent"
    fragment = _compiled_fragment(model, name)
    try:
        check_fragment(fragment)
    except FragmentError as exc:
        raise ProfileFolderError(f"{where}: {exc}") from None
    return fragment


def _rpy(mat: np.ndarray) -> list[float]:
    """URDF roll, pitch, yaw of a rotation matrix (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    return [math.atan2(mat[2, 1], mat[2, 2]), math.asin(float(np.clip(-mat[2, 0], -1.0, 1.0))),
            math.atan2(mat[1, 0], mat[0, 0])]


def _origin(parent: ET.Element, pos: np.ndarray, mat: np.ndarray) -> None:
    ET.SubElement(parent, "origin", {"xyz": _fmt(pos), "rpy": _fmt(_rpy(mat))})


def fragment_to_urdf(mjcf: str, name: str) -> str:
    """An agent fragment as a one-link URDF: every geom (box, sphere or cylinder) in the top body's frame, and the
    whole body's mass and inertia about its centre of mass. ProfileFolderError for shapes URDF lacks and for an
    articulated agent."""
    model = check_fragment(mjcf).compile()
    if model.njnt:  # the fragment's own joints are hinges between its bodies
        raise ProfileFolderError(f"agent {name!r} is articulated ({model.njnt} hinge joints held by posture springs, "
                                 "the body of the seat and lie kinds): agent.urdf holds one rigid link, and URDF has "
                                 "no joint springs")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    top_pos, top_mat = data.xpos[1], data.xmat[1].reshape(3, 3)
    robot = ET.Element("robot", {"name": name})
    link = ET.SubElement(robot, "link", {"name": name})
    bodies = np.arange(1, model.nbody)
    mass = float(model.body_mass[bodies].sum())
    com = (model.body_mass[bodies, None] * data.xipos[bodies]).sum(axis=0) / mass
    inertia = np.zeros((3, 3))
    for b in bodies:  # each body's inertia moved to the common centre of mass (parallel axes), world axes
        rot = data.ximat[b].reshape(3, 3)
        d = data.xipos[b] - com
        shift = model.body_mass[b] * (d @ d * np.eye(3) - np.outer(d, d))
        inertia += rot @ np.diag(model.body_inertia[b]) @ rot.T + shift
    inertia = top_mat.T @ inertia @ top_mat
    inertial = ET.SubElement(link, "inertial")
    _origin(inertial, top_mat.T @ (com - top_pos), np.eye(3))
    ET.SubElement(inertial, "mass", {"value": _fmt([mass])})
    ET.SubElement(inertial, "inertia", {f"i{'xyz'[i]}{'xyz'[j]}": _fmt([inertia[i, j]])
                                        for i in range(3) for j in range(i, 3)})
    for g in range(model.ngeom):
        kind = mujoco.mjtGeom(model.geom_type[g]).name[len("mjGEOM_"):].lower()
        size = model.geom_size[g]
        if kind not in ("sphere", "box", "cylinder"):
            raise ProfileFolderError(f"agent {name!r}: its {kind} geom cannot be written as URDF, which has box, "
                                     "sphere and cylinder shapes only")
        pos = top_mat.T @ (data.geom_xpos[g] - top_pos)
        mat = top_mat.T @ data.geom_xmat[g].reshape(3, 3)
        for part in ("visual", "collision"):
            el = ET.SubElement(link, part)
            _origin(el, pos, mat)
            shape = ({"radius": _fmt(size[:1])} if kind == "sphere" else {"size": _fmt(2 * size)} if kind == "box"
                     else {"radius": _fmt(size[:1]), "length": _fmt(2 * size[1:2])})
            ET.SubElement(ET.SubElement(el, "geometry"), kind, shape)
    ET.indent(robot)
    return ET.tostring(robot, encoding="unicode") + "\n"
