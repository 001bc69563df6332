"""Procedural object generators for the labelled dataset (metres, z up, base on z = 0).

Every generator takes a seeded ``numpy.random.Generator`` and returns a
:class:`Built`: one watertight mesh in its *build frame* (the functional or
natural pose: +z up, resting on z = 0, roughly centred on the z axis) plus a
one-line description of the instance. Parts are joined with manifold3d
booleans so each object is a single closed surface that CoACD can decompose.

The core family's generators come first; the world family's (armchairs to
cartons: the shapes real meshes have) follow them, then the scan-like
corruptions (:data:`GEOMETRIC_CORRUPTIONS`), which take a built mesh and a
generator of their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import trimesh
from scipy.interpolate import PchipInterpolator

__all__ = ["Built", "GENERATORS", "GEOMETRIC_CORRUPTIONS", "DENSE_FACES", "densify", "BASKET_GAP", "BASKET_AGENT_MIN"]

#: Width of the slots between basket slats (m).
BASKET_GAP = 0.01
#: Smallest agent (sphere diameter, m) a basket is guaranteed to hold.
BASKET_AGENT_MIN = 0.015

_SECTIONS = 48  # revolve resolution: ~400-1500 faces per revolved part


@dataclass(frozen=True)
class Built:
    """A generated object in its build frame and a description of the instance."""

    mesh: trimesh.Trimesh
    notes: str


# ---------------------------------------------------------------- primitives


def _revolve(profile: list[tuple[float, float]], sections: int = _SECTIONS) -> trimesh.Trimesh:
    """Revolve a closed (r, z) polygon about z; the winding is fixed so the volume is positive."""
    pts = np.asarray(profile + [profile[0]], dtype=np.float64)
    mesh = trimesh.creation.revolve(pts, sections=sections)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    lo_a, hi_a = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return trimesh.creation.box(extents=hi_a - lo_a, transform=trimesh.transformations.translation_matrix((lo_a + hi_a) / 2))


def _cylinder(radius: float, z0: float, z1: float, x: float = 0.0, y: float = 0.0, sections: int = 32) -> trimesh.Trimesh:
    tf = trimesh.transformations.translation_matrix((x, y, (z0 + z1) / 2))
    return trimesh.creation.cylinder(radius=radius, height=z1 - z0, sections=sections, transform=tf)


def _union(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    return trimesh.boolean.union(parts, engine="manifold")


def _difference(a: trimesh.Trimesh, b: trimesh.Trimesh) -> trimesh.Trimesh:
    return trimesh.boolean.difference([a, b], engine="manifold")


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _cm(x: float) -> str:
    return f"{100 * x:.1f} cm"


# ---------------------------------------------------------------- containers


def _cup_body(rng: np.random.Generator, *, bottom: bool) -> tuple[trimesh.Trimesh, str, float, float]:
    d_top = _u(rng, 0.06, 0.12)
    tapered = bool(rng.random() < 0.5)
    rt = d_top / 2
    rb = rt * _u(rng, 0.72, 0.9) if tapered else rt
    h = _u(rng, max(0.08, 0.75 * d_top), 0.14)
    t = _u(rng, 0.003, 0.005)
    b = _u(rng, 0.004, 0.008)
    if bottom:
        profile = [(0.0, 0.0), (rb, 0.0), (rt, h), (rt - t, h), (rb - t, b), (0.0, b)]
    else:
        profile = [(rb - t, 0.0), (rb, 0.0), (rt, h), (rt - t, h)]
    desc = f"{'tapered' if tapered else 'straight'} cup, rim Ø {_cm(d_top)}, {_cm(h)} tall, wall {1000 * t:.1f} mm"
    desc += f", bottom {1000 * b:.1f} mm" if bottom else ", NO bottom (open tube)"
    body = _revolve(profile)
    if rng.random() < 0.5:
        # a C-shaped handle: a vertical torus with the part inside the cup's outer surface removed
        hr = _u(rng, 0.022, min(0.035, 0.3 * h))
        mr = _u(rng, 0.005, 0.007)
        zc = h * _u(rng, 0.45, 0.55)
        r_wall = rb + (rt - rb) * zc / h
        tf = trimesh.transformations.translation_matrix((r_wall + 0.5 * hr, 0.0, zc)) @ trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0))
        ring = trimesh.creation.torus(hr, mr, major_sections=32, minor_sections=12, transform=tf)
        # cut 1.5 mm inside the outer surface so the stub overlaps the wall instead of touching it
        outer = _revolve([(0.0, 0.0), (rb - 0.0015, 0.0), (rt - 0.0015, h), (0.0, h)])
        body = _union([body, _difference(ring, outer)])
        desc += ", with handle"
    return body, desc, d_top, h


def cup(rng: np.random.Generator) -> Built:
    mesh, desc, _, _ = _cup_body(rng, bottom=True)
    return Built(mesh, desc)


def cup_no_bottom(rng: np.random.Generator) -> Built:
    mesh, desc, _, _ = _cup_body(rng, bottom=False)
    return Built(mesh, desc)


def _bowl_body(rng: np.random.Generator, *, hole: float) -> tuple[trimesh.Trimesh, str]:
    d = _u(rng, 0.13, 0.25)
    R = d / 2
    h = _u(rng, max(0.05, 0.3 * d), min(0.10, 0.5 * d))
    rb = max(R * _u(rng, 0.35, 0.55), hole + 0.015)
    p = _u(rng, 0.5, 0.8)  # < 1: the wall flares out near the rim
    t = _u(rng, 0.003, 0.006)
    b = _u(rng, 0.005, 0.008)
    zs = np.linspace(0.0, h, 9)
    outer = [(rb + (R - rb) * (z / h) ** p, z) for z in zs]
    inner_z = np.linspace(h, b, 9)
    inner = [(rb + (R - rb) * (z / h) ** p - t, z) for z in inner_z]
    profile = ([(hole, 0.0)] if hole > 0 else [(0.0, 0.0)]) + outer + inner + [(hole, b)]
    desc = f"bowl, Ø {_cm(d)}, {_cm(h)} tall, wall {1000 * t:.1f} mm"
    if hole > 0:
        desc += f", HOLE Ø {_cm(2 * hole)} in the base"
    return _revolve(profile), desc


def bowl(rng: np.random.Generator) -> Built:
    return Built(*_bowl_body(rng, hole=0.0))


def bowl_holed(rng: np.random.Generator) -> Built:
    return Built(*_bowl_body(rng, hole=_u(rng, 0.02, 0.03)))


def _vase_outer(rng: np.random.Generator) -> tuple[PchipInterpolator, float, float, float, str]:
    h = _u(rng, 0.18, 0.45)
    rn = _u(rng, 0.02, 0.045)  # inner neck radius: opening Ø 4-9 cm
    t = _u(rng, 0.004, 0.006)
    bulbous = bool(rng.random() < 0.5)
    rbody = _u(rng, max(rn + t + 0.015, 0.05), 0.1) if bulbous else _u(rng, rn + t + 0.005, rn + t + 0.03)
    flare = _u(rng, 0.0, 0.012)
    if bulbous:
        zs = [0.0, h * _u(rng, 0.3, 0.45), 0.8 * h, h]
        rs = [rbody * _u(rng, 0.55, 0.8), rbody, rn + t, rn + t + flare]
    else:
        zs = [0.0, 0.5 * h, 0.85 * h, h]
        rs = [rbody, rbody * 0.97, rn + t, rn + t + flare]
    kind = "bulbous" if bulbous else "slender"
    return PchipInterpolator(zs, rs), h, rn, t, f"{kind} vase, {_cm(h)} tall, body Ø {_cm(2 * rbody)}"


def vase(rng: np.random.Generator) -> Built:
    r_of, h, rn, t, desc = _vase_outer(rng)
    b = _u(rng, 0.006, 0.01)
    outer = [(float(r_of(z)), float(z)) for z in np.linspace(0.0, h, 14)]
    inner = [(float(r_of(z)) - t, float(z)) for z in np.linspace(h, b, 14)]
    mesh = _revolve([(0.0, 0.0)] + outer + inner + [(0.0, b)])
    return Built(mesh, f"{desc}, opening Ø {_cm(2 * rn)}")


def vase_closed(rng: np.random.Generator) -> Built:
    r_of, h, _, _, desc = _vase_outer(rng)
    outer = [(float(r_of(z)), float(z)) for z in np.linspace(0.0, h, 14)]
    mesh = _revolve([(0.0, 0.0)] + outer + [(0.0, h)])
    return Built(mesh, f"{desc}, SEALED at the top (solid, no opening)")


def basket(rng: np.random.Generator) -> Built:
    h = _u(rng, 0.10, 0.18)
    floor = 0.008
    rim_h = 0.015
    slat_t = 0.006
    round_ = bool(rng.random() < 0.5)
    parts: list[trimesh.Trimesh] = []
    if round_:
        R = _u(rng, 0.10, 0.18)
        # floor and rim are 2 mm off the slat faces: flush faces make pinched, non-manifold edges
        parts.append(_cylinder(R - 0.002, 0.0, floor, sections=48))
        parts.append(_revolve([(R - slat_t - 0.002, h - rim_h), (R + 0.002, h - rim_h), (R + 0.002, h), (R - slat_t - 0.002, h)]))
        n = int(np.ceil(2 * np.pi * R / (_u(rng, 0.015, 0.03) + BASKET_GAP)))
        slat_w = 2 * np.pi * R / n - BASKET_GAP  # slots exactly BASKET_GAP wide at the outer face
        for k in range(n):
            ang = 2 * np.pi * k / n
            slat = _box((-slat_w / 2, R - slat_t, floor - 0.002), (slat_w / 2, R, h - rim_h + 0.002))
            slat.apply_transform(trimesh.transformations.rotation_matrix(ang, (0, 0, 1)))
            parts.append(slat)
        desc = f"round slatted basket, Ø {_cm(2 * R)}, {_cm(h)} tall, {n} slats"
    else:
        L, W = _u(rng, 0.22, 0.36), _u(rng, 0.16, 0.26)
        # floor and rim stand 2 mm off the slat faces, and the end slats overlap by volume:
        # flush faces make pinched, non-manifold edges
        parts.append(_box((-L / 2 + 0.002, -W / 2 + 0.002, 0.0), (L / 2 - 0.002, W / 2 - 0.002, floor)))
        parts.append(_difference(_box((-L / 2 - 0.003, -W / 2 - 0.003, h - rim_h), (L / 2 + 0.003, W / 2 + 0.003, h)),
                                 _box((-L / 2 + slat_t + 0.002, -W / 2 + slat_t + 0.002, h - rim_h - 0.01),
                                      (L / 2 - slat_t - 0.002, W / 2 - slat_t - 0.002, h + 0.01))))
        pitch = _u(rng, 0.015, 0.03) + BASKET_GAP
        z0, z1 = floor - 0.002, h - rim_h + 0.002
        for side_len, along_x in ((L, True), (W - slat_t, False)):
            n = int(np.ceil((side_len + BASKET_GAP) / pitch))
            slat_w = (side_len + BASKET_GAP) / n - BASKET_GAP
            for k in range(n):
                c = -side_len / 2 + slat_w / 2 + k * (slat_w + BASKET_GAP)
                for sign in (-1.0, 1.0):
                    if along_x:  # long sides, outer face at |y| = W/2
                        y_in, y_out = sign * (W / 2 - slat_t), sign * W / 2
                        parts.append(_box((c - slat_w / 2, min(y_in, y_out), z0), (c + slat_w / 2, max(y_in, y_out), z1)))
                    else:  # short sides, 1 mm proud of the long sides' ends
                        x_in, x_out = sign * (L / 2 - slat_t + 0.001), sign * (L / 2 + 0.001)
                        parts.append(_box((min(x_in, x_out), c - slat_w / 2, z0), (max(x_in, x_out), c + slat_w / 2, z1)))
        desc = f"rectangular slatted basket, {_cm(L)} x {_cm(W)}, {_cm(h)} tall"
    desc += f", {_cm(BASKET_GAP)} slots (holds agents Ø >= {_cm(BASKET_AGENT_MIN)})"
    return Built(_union(parts), desc)


def bathtub(rng: np.random.Generator) -> Built:
    L, W, H = _u(rng, 1.4, 1.8), _u(rng, 0.7, 0.85), _u(rng, 0.5, 0.6)
    t = _u(rng, 0.05, 0.08)
    floor = 0.05
    feet = bool(rng.random() < 0.3)
    z0 = _u(rng, 0.08, 0.12) if feet else 0.0
    taper = _u(rng, 0.05, 0.2)  # sloped inner walls: the floor is smaller than the opening
    outer = _box((-L / 2, -W / 2, z0), (L / 2, W / 2, H))
    lo = z0 + floor
    corners_lo = [(sx * (L / 2 - t - taper), sy * (W / 2 - t - taper / 2), lo) for sx in (-1, 1) for sy in (-1, 1)]
    corners_hi = [(sx * (L / 2 - t), sy * (W / 2 - t), H + 0.05) for sx in (-1, 1) for sy in (-1, 1)]
    cavity = trimesh.convex.convex_hull(np.array(corners_lo + corners_hi))
    mesh = _difference(outer, cavity)
    if feet:
        fx, fy = L / 2 - 0.15, W / 2 - 0.1
        mesh = _union([mesh] + [_cylinder(0.04, 0.0, z0 + 0.01, sx * fx, sy * fy, 16) for sx in (-1, 1) for sy in (-1, 1)])
    desc = f"bathtub, {_cm(L)} x {_cm(W)}, {_cm(H)} tall, rim {_cm(t)}" + (", on four feet" if feet else "")
    return Built(mesh, desc)


def plate(rng: np.random.Generator) -> Built:
    d = _u(rng, 0.18, 0.28)
    R = d / 2
    h = _u(rng, 0.015, 0.03)
    rb = R * _u(rng, 0.55, 0.7)
    tb = _u(rng, 0.004, 0.006)
    t = _u(rng, 0.003, 0.005)
    mesh = _revolve([(0.0, 0.0), (rb, 0.0), (R, h - t), (R, h), (R - t, h), (rb, tb), (0.0, tb)])
    return Built(mesh, f"plate, Ø {_cm(d)}, {_cm(h)} tall, raised rim")


def pot(rng: np.random.Generator) -> Built:
    d = _u(rng, 0.16, 0.30)
    R = d / 2
    h = _u(rng, max(0.12, 0.6 * d), min(0.22, 1.0 * d))
    t = _u(rng, 0.003, 0.005)
    b = _u(rng, 0.005, 0.008)
    body = _revolve([(0.0, 0.0), (R, 0.0), (R, h), (R - t, h), (R - t, b), (0.0, b)])
    lug_z = h - _u(rng, 0.02, 0.04)
    lugs = [_box((R - t / 2, -0.03, lug_z - 0.008), (R + 0.04, 0.03, lug_z + 0.008))]
    lugs.append(lugs[0].copy().apply_transform(trimesh.transformations.rotation_matrix(np.pi, (0, 0, 1))))
    return Built(_union([body] + lugs), f"cooking pot, Ø {_cm(d)}, {_cm(h)} tall, two side lugs")


def trash_bin(rng: np.random.Generator) -> Built:
    h = _u(rng, 0.40, 0.65)
    t = _u(rng, 0.004, 0.008)
    b = 0.01
    if rng.random() < 0.5:
        rt = _u(rng, 0.11, 0.175)
        rb = rt * _u(rng, 0.8, 0.95)
        mesh = _revolve([(0.0, 0.0), (rb, 0.0), (rt, h), (rt - t, h), (rb - t, b), (0.0, b)])
        return Built(mesh, f"round trash bin, top Ø {_cm(2 * rt)}, {_cm(h)} tall")
    L, W = _u(rng, 0.25, 0.35), _u(rng, 0.2, 0.3)
    mesh = _difference(_box((-L / 2, -W / 2, 0.0), (L / 2, W / 2, h)), _box((-L / 2 + t, -W / 2 + t, b), (L / 2 - t, W / 2 - t, h + 0.01)))
    return Built(mesh, f"square trash bin, {_cm(L)} x {_cm(W)}, {_cm(h)} tall")


def tray(rng: np.random.Generator) -> Built:
    L, W, h = _u(rng, 0.36, 0.5), _u(rng, 0.26, 0.36), _u(rng, 0.02, 0.04)
    t = _u(rng, 0.005, 0.008)
    floor = 0.005
    mesh = _difference(_box((-L / 2, -W / 2, 0.0), (L / 2, W / 2, h)), _box((-L / 2 + t, -W / 2 + t, floor), (L / 2 - t, W / 2 - t, h + 0.01)))
    return Built(mesh, f"tray, {_cm(L)} x {_cm(W)}, rim {_cm(h)} tall")


# ---------------------------------------------------------------- furniture


def _four_legs(x: float, y: float, top: float, side: float) -> list[trimesh.Trimesh]:
    return [_box((sx * x - side / 2, sy * y - side / 2, 0.0), (sx * x + side / 2, sy * y + side / 2, top)) for sx in (-1, 1) for sy in (-1, 1)]


def table(rng: np.random.Generator) -> Built:
    H = _u(rng, 0.6, 0.8)
    tt = _u(rng, 0.025, 0.04)
    round_top = bool(rng.random() < 0.5)
    if round_top:
        R = _u(rng, 0.375, 0.6)
        top = _cylinder(R, H - tt, H, sections=48)
        half_x = half_y = R
        desc = f"round table, Ø {_cm(2 * R)}"
    else:
        half_x, half_y = _u(rng, 0.375, 0.7), _u(rng, 0.375, 0.5)
        top = _box((-half_x, -half_y, H - tt), (half_x, half_y, H))
        desc = f"rectangular table, {_cm(2 * half_x)} x {_cm(2 * half_y)}"
    if rng.random() < 0.6:
        side = _u(rng, 0.04, 0.06)
        k = 0.6 if round_top else 1.0  # legs of a round top sit inside the circle
        legs = _four_legs(k * half_x - 0.06, k * half_y - 0.06, H - tt + 0.005, side)
        desc += ", four legs"
    else:
        base_r = _u(rng, 0.5, 0.65) * min(half_x, half_y)
        legs = [_cylinder(base_r, 0.0, 0.03, sections=48), _cylinder(_u(rng, 0.04, 0.06), 0.02, H - tt + 0.005)]
        desc += f", pedestal with Ø {_cm(2 * base_r)} base"
    return Built(_union([top] + legs), f"{desc}, top {_cm(H)} high")


def table_tilted(rng: np.random.Generator) -> Built:
    tilt = np.deg2rad(30.0)
    half_x, half_y = _u(rng, 0.35, 0.6), _u(rng, 0.3, 0.45)
    tt = _u(rng, 0.025, 0.04)
    side = _u(rng, 0.04, 0.06)
    yl = half_y * np.cos(tilt) - 0.06
    xl = half_x - 0.06
    zc = 0.3 + tt / (2 * np.cos(tilt)) + yl * np.tan(tilt) + _u(rng, 0.0, 0.08)
    top = _box((-half_x, -half_y, -tt / 2), (half_x, half_y, tt / 2))
    top.apply_transform(trimesh.transformations.translation_matrix((0, 0, zc)) @ trimesh.transformations.rotation_matrix(tilt, (1, 0, 0)))
    legs = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            y = sy * yl
            # each leg reaches 1.5 cm into the tilted slab, so its length depends on y
            z_top = zc - tt / (2 * np.cos(tilt)) + y * np.tan(tilt) + 0.015
            legs.append(_box((sx * xl - side / 2, y - side / 2, 0.0), (sx * xl + side / 2, y + side / 2, z_top)))
    desc = f"table with its top TILTED 30° (legs of different lengths), top {_cm(2 * half_x)} x {_cm(2 * half_y)}"
    return Built(_union([top] + legs), desc)


def _chair(rng: np.random.Generator, seat_height: tuple[float, float]) -> Built:
    s = _u(rng, *seat_height)
    w, d = _u(rng, 0.4, 0.5), _u(rng, 0.38, 0.48)
    ts = _u(rng, 0.03, 0.05)
    parts = [_box((-w / 2, -d / 2, s - ts), (w / 2, d / 2, s))]
    pedestal = seat_height[1] < 0.6 and rng.random() < 0.3
    if pedestal:
        base_r = _u(rng, 0.24, 0.3)
        parts += [_cylinder(base_r, 0.0, 0.03, sections=48), _cylinder(_u(rng, 0.03, 0.04), 0.02, s - ts + 0.005)]
        desc = f"pedestal chair, seat {_cm(s)} high"
    else:
        side = _u(rng, 0.035, 0.05)
        parts += _four_legs(w / 2 - side / 2 - 0.01, d / 2 - side / 2 - 0.01, s - ts + 0.005, side)
        desc = f"four-legged chair, seat {_cm(s)} high"
    desc += f", seat {_cm(w)} x {_cm(d)}"
    if rng.random() < 0.7:
        tb, hb = _u(rng, 0.025, 0.04), _u(rng, 0.35, 0.5)
        parts.append(_box((-w / 2, d / 2 - tb, s - ts), (w / 2, d / 2, s + hb)))
        desc += f", backrest {_cm(hb)}"
        if rng.random() < 0.4:
            ha = _u(rng, 0.2, 0.25)
            for sx in (-1, 1):
                x = sx * (w / 2 - 0.02)
                parts.append(_box((x - 0.02, -d / 2 + 0.03, s - 0.01), (x + 0.02, -d / 2 + 0.07, s + ha)))
                parts.append(_box((x - 0.025, -d / 2 + 0.02, s + ha - 0.03), (x + 0.025, d / 2 - 0.01, s + ha)))
            desc += ", armrests"
    else:
        desc += ", no backrest"
    return Built(_union(parts), desc)


def chair(rng: np.random.Generator) -> Built:
    return _chair(rng, (0.4, 0.5))


def chair_high_seat(rng: np.random.Generator) -> Built:
    built = _chair(rng, (1.15, 1.25))
    return Built(built.mesh, built.notes + " (seat far TOO HIGH to sit on)")


def bench(rng: np.random.Generator) -> Built:
    L, D, s = _u(rng, 1.0, 1.6), _u(rng, 0.3, 0.4), _u(rng, 0.42, 0.48)
    ts = 0.04
    parts = [_box((-L / 2, -D / 2, s - ts), (L / 2, D / 2, s))]
    if rng.random() < 0.5:
        x = L / 2 - _u(rng, 0.08, 0.15)
        parts += [_box((sx * x - 0.02, -D / 2 + 0.02, 0.0), (sx * x + 0.02, D / 2 - 0.02, s - ts + 0.005)) for sx in (-1, 1)]
        desc = "panel-legged bench"
    else:
        parts += _four_legs(L / 2 - 0.06, D / 2 - 0.04, s - ts + 0.005, 0.045)
        desc = "four-legged bench"
    desc += f", {_cm(L)} x {_cm(D)}, seat {_cm(s)} high"
    if rng.random() < 0.4:
        hb = _u(rng, 0.3, 0.45)
        parts.append(_box((-L / 2, D / 2 - 0.03, s - ts), (L / 2, D / 2, s + hb)))
        desc += ", backrest"
    return Built(_union(parts), desc)


def rack(rng: np.random.Generator) -> Built:
    H, W, D = _u(rng, 1.2, 1.8), _u(rng, 0.6, 1.0), _u(rng, 0.25, 0.4)
    post, st = 0.03, 0.02
    bottom = _u(rng, 0.05, 0.1)
    n = int(np.ceil((H - bottom) / 0.45)) + 1  # shelf spacing <= 45 cm
    tops = np.linspace(bottom, H, n)
    parts = _four_legs(W / 2 - post / 2, D / 2 - post / 2, H, post)
    # shelves 1 mm inside the posts' outer faces: flush faces make pinched, non-manifold edges
    parts += [_box((-W / 2 + 0.001, -D / 2 + 0.001, z - st), (W / 2 - 0.001, D / 2 - 0.001, z)) for z in tops]
    return Built(_union(parts), f"open shelf rack, {_cm(W)} x {_cm(D)}, {_cm(H)} tall, {n} shelves {_cm(tops[1] - tops[0])} apart")


# ---------------------------------------------------------------- distractors


def solid_cylinder(rng: np.random.Generator) -> Built:
    r, h = _u(rng, 0.025, 0.075), _u(rng, 0.05, 0.2)
    return Built(_cylinder(r, 0.0, h, sections=48), f"solid cylinder, Ø {_cm(2 * r)}, {_cm(h)} tall")


def solid_box(rng: np.random.Generator) -> Built:
    a, b, c = (_u(rng, 0.05, 0.25) for _ in range(3))
    return Built(_box((-a / 2, -b / 2, 0.0), (a / 2, b / 2, c)), f"solid box {_cm(a)} x {_cm(b)} x {_cm(c)}")


def sphere(rng: np.random.Generator) -> Built:
    r = _u(rng, 0.025, 0.125)
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=r)
    mesh.apply_translation((0, 0, r))
    return Built(mesh, f"solid sphere, Ø {_cm(2 * r)}")


def cone(rng: np.random.Generator) -> Built:
    r, h = _u(rng, 0.025, 0.1), _u(rng, 0.05, 0.25)
    return Built(trimesh.creation.cone(radius=r, height=h, sections=48), f"solid cone, base Ø {_cm(2 * r)}, {_cm(h)} tall")


def torus(rng: np.random.Generator) -> Built:
    R, r = _u(rng, 0.05, 0.15), _u(rng, 0.01, 0.04)
    mesh = trimesh.creation.torus(R, min(r, 0.5 * R), major_sections=48, minor_sections=16)
    mesh.apply_translation((0, 0, min(r, 0.5 * R)))
    return Built(mesh, f"solid torus, Ø {_cm(2 * R)}, tube Ø {_cm(2 * min(r, 0.5 * R))}")


# ---------------------------------------------------------------- the world family: shapes real meshes have


def _rod(p0: tuple[float, float, float], p1: tuple[float, float, float], radius: float, sections: int = 16) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([p0, p1], dtype=np.float64), sections=sections)


def _intersection(a: trimesh.Trimesh, b: trimesh.Trimesh) -> trimesh.Trimesh:
    return trimesh.boolean.intersection([a, b], engine="manifold")


def _ball(radius: float, centre: tuple[float, float, float], subdivisions: int = 3) -> trimesh.Trimesh:
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    mesh.apply_translation(centre)
    return mesh


def _on_floor(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh cut at z = 0: the tilted end caps of splayed legs become flat feet."""
    lo, hi = mesh.bounds
    return _intersection(mesh, _box((lo[0] - 0.1, lo[1] - 0.1, 0.0), (hi[0] + 0.1, hi[1] + 0.1, hi[2] + 0.1)))


def _feet(x: float, y: float, top: float, radius: float) -> list[trimesh.Trimesh]:
    return [_cylinder(radius, 0.0, top, sx * x, sy * y, 16) for sx in (-1, 1) for sy in (-1, 1)]


def _upholstered(rng: np.random.Generator, seats: int) -> tuple[list[trimesh.Trimesh], str, float, float]:
    """Blocks of an upholstered seat (armchair or sofa): base, seat cushions, rolled arms, back; the
    seat faces -y. Returns the parts, a description, the seat height and the seat's width between the arms."""
    cushion_w = _u(rng, 0.48, 0.58) if seats == 1 else _u(rng, 0.5, 0.6)
    sw = seats * cushion_w
    ta = _u(rng, 0.12, 0.18)  # arm thickness
    W = sw + 2 * ta
    tb = _u(rng, 0.16, 0.22)  # back thickness
    D = tb + (_u(rng, 0.5, 0.58) if seats == 1 else _u(rng, 0.62, 0.68))
    s = _u(rng, 0.41, 0.46)  # top of the seat cushions
    ct = _u(rng, 0.1, 0.14)
    ha, hb = _u(rng, 0.57, 0.66), _u(rng, 0.77, 0.9)
    legs = bool(rng.random() < 0.6)
    f = _u(rng, 0.06, 0.12) if legs else 0.0
    r_arm = ta / 2 + 0.012  # rolled arms overhang the arm block by 1.2 cm each side
    parts = [_box((-W / 2 + 0.01, -D / 2 + 0.01, f), (W / 2 - 0.01, D / 2 - 0.01, s - ct + 0.005))]
    gap = 0.01  # between cushions, and between cushions and arms
    for k in range(seats):
        x0 = -sw / 2 + k * cushion_w
        parts.append(_box((x0 + gap / 2, -D / 2 + 0.015, s - ct), (x0 + cushion_w - gap / 2, D / 2 - tb + 0.01, s)))
    for sx in (-1, 1):
        xc = sx * (W / 2 - ta / 2)
        parts.append(_box((xc - ta / 2, -D / 2, f), (xc + ta / 2, D / 2 - 0.02, ha - r_arm)))
        tf = trimesh.transformations.translation_matrix((xc, (D / 2 - 0.02 - D / 2) / 2, ha - r_arm))
        tf = tf @ trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0))
        parts.append(trimesh.creation.cylinder(radius=r_arm, height=D - 0.02, sections=24, transform=tf))
    parts.append(_box((-W / 2 + 0.005, D / 2 - tb, f), (W / 2 - 0.005, D / 2, hb - tb / 2)))
    tf = trimesh.transformations.translation_matrix((0.0, D / 2 - tb / 2, hb - tb / 2))
    tf = tf @ trimesh.transformations.rotation_matrix(np.pi / 2, (0, 1, 0))
    parts.append(trimesh.creation.cylinder(radius=tb / 2, height=W - 0.01, sections=24, transform=tf))
    if legs:
        parts += _feet(W / 2 - 0.06, D / 2 - 0.06, f + 0.01, 0.025)
    desc = (f"{W:.2f} x {D:.2f} m overall, {seats} seat cushion{'s' if seats > 1 else ''} {_cm(cushion_w)} wide, "
            f"seat {_cm(s)} high, rolled arms {_cm(ha)}, back {_cm(hb)}" + (f", on {_cm(f)} feet" if legs else ", on a plinth"))
    return parts, desc, s, sw


def armchair(rng: np.random.Generator) -> Built:
    parts, desc, _, _ = _upholstered(rng, 1)
    return Built(_union(parts), f"upholstered armchair, {desc}")


def sofa(rng: np.random.Generator) -> Built:
    parts, desc, _, _ = _upholstered(rng, int(rng.integers(2, 4)))
    return Built(_union(parts), f"upholstered sofa, {desc}")


def ottoman(rng: np.random.Generator) -> Built:
    # round: a square block on its side has a level seat at its width, which would make the pose ambiguous
    H = _u(rng, 0.4, 0.46)
    ct = _u(rng, 0.05, 0.08)
    f = _u(rng, 0.03, 0.06) if rng.random() < 0.5 else 0.0
    R = _u(rng, 0.2, 0.29)
    parts = [_cylinder(R, f, H - ct + 0.005, sections=48), _cylinder(R + 0.006, H - ct, H, sections=48)]
    if f > 0:
        parts += _feet(0.5 * R, 0.5 * R, f + 0.01, 0.02)
    desc = f"upholstered ottoman (round pouf), Ø {_cm(2 * R)}, {_cm(H)} high, cushion top {_cm(ct)}"
    return Built(_union(parts), desc + (", on feet" if f else ""))


def bar_chair(rng: np.random.Generator) -> Built:
    s = _u(rng, 0.64, 0.78)
    w, d = _u(rng, 0.4, 0.46), _u(rng, 0.38, 0.44)
    ts = _u(rng, 0.03, 0.05)
    splay = _u(rng, 0.02, 0.05)
    r_leg = _u(rng, 0.014, 0.02)
    parts = [_box((-w / 2, -d / 2, s - ts), (w / 2, d / 2, s))]
    fr = s - _u(rng, 0.43, 0.5)  # footrest height
    legs = {}
    for sx in (-1, 1):
        for sy in (-1, 1):
            top = (sx * (w / 2 - 0.03), sy * (d / 2 - 0.03), s - ts + 0.005)
            bottom = (sx * (w / 2 - 0.03 + splay), sy * (d / 2 - 0.03 + splay), 0.0)
            parts.append(_rod(bottom, top, r_leg))
            k = fr / top[2]
            legs[(sx, sy)] = tuple(b + k * (t - b) for b, t in zip(bottom, top))
    for a, b in (((-1, -1), (1, -1)), ((1, -1), (1, 1)), ((1, 1), (-1, 1)), ((-1, 1), (-1, -1))):
        parts.append(_rod(legs[a], legs[b], 0.015 if a[1] == b[1] == -1 else 0.011))  # the front rung is the footrest
    tb, hb = _u(rng, 0.02, 0.03), _u(rng, 0.28, 0.38)
    parts.append(_box((-w / 2, d / 2 - tb, s - ts), (w / 2, d / 2, s + hb)))
    ha = _u(rng, 0.2, 0.25)
    for sx in (-1, 1):
        x = sx * (w / 2 - 0.02)
        parts.append(_box((x - 0.015, -d / 2 + 0.03, s - 0.01), (x + 0.015, -d / 2 + 0.06, s + ha)))
        parts.append(_box((x - 0.022, -d / 2 + 0.02, s + ha - 0.025), (x + 0.022, d / 2 - 0.01, s + ha)))
    desc = (f"bar chair, seat {_cm(w)} x {_cm(d)} at {_cm(s)}, footrest rungs at {_cm(fr)} ({_cm(s - fr)} below the seat), "
            f"splayed legs, backrest {_cm(hb)}, armrests")
    return Built(_on_floor(_union(parts)), desc)


def shell_chair(rng: np.random.Generator) -> Built:
    s = _u(rng, 0.39, 0.45)  # top of the seat cushion
    R, t = _u(rng, 0.34, 0.38), _u(rng, 0.015, 0.025)
    zc = s + _u(rng, 0.08, 0.12)
    shell = _difference(_ball(R, (0.0, 0.0, zc)), _ball(R - t, (0.0, 0.0, zc)))
    r_seat = 0.85 * np.sqrt((R - t) ** 2 - (zc - s) ** 2)
    # cut away everything above a plane high at the back (+y) and below the cushion's front edge, so the
    # shell is open at the front and holds no basin on the seat
    k = _u(rng, 0.6, 0.9)
    z0 = s + k * r_seat - _u(rng, 0.005, 0.03)
    n = np.array([0.0, -k, 1.0]) / np.hypot(k, 1.0)
    cutter = trimesh.creation.box(extents=(3.0, 3.0, 3.0))
    cutter.apply_transform(trimesh.geometry.align_vectors([0, 0, 1], n))
    cutter.apply_translation(np.array([0.0, 0.0, z0]) + 1.5 * n)
    shell = _difference(shell, cutter)
    cushion = _intersection(_cylinder(r_seat, zc - R, s, sections=48), _ball(R - t + 0.004, (0.0, 0.0, zc)))
    bottom = zc - R
    col_r = _u(rng, 0.03, 0.04)
    parts = [shell, cushion, _cylinder(col_r, 0.02, bottom + 0.03)]
    base_r = _u(rng, 0.25, 0.3)
    if rng.random() < 0.5:
        parts.append(_cylinder(base_r, 0.0, 0.025, sections=48))
        base = f"round base Ø {_cm(2 * base_r)}"
    else:
        n_arms = int(rng.integers(4, 6))
        for j in range(n_arms):
            arm = _box((-0.02, -0.022, 0.0), (base_r, 0.022, 0.03))
            arm.apply_transform(trimesh.transformations.rotation_matrix(2 * np.pi * j / n_arms, (0, 0, 1)))
            parts.append(arm)
        parts.append(_cylinder(col_r + 0.01, 0.0, 0.045))
        base = f"{n_arms}-arm star base, {_cm(2 * base_r)} across"
    desc = f"shell lounge chair on a pedestal, shell Ø {_cm(2 * R)}, seat cushion Ø {_cm(2 * r_seat)} at {_cm(s)}, {base}"
    return Built(_union(parts), desc)


def stool(rng: np.random.Generator) -> Built:
    s = _u(rng, 0.43, 0.5)
    ts = _u(rng, 0.025, 0.045)
    round_ = bool(rng.random() < 0.6)
    n_legs = int(rng.integers(3, 5)) if round_ else 4
    if round_:
        r = _u(rng, 0.15, 0.19)
        parts = [_cylinder(r, s - ts, s, sections=48)]
        seat = f"round seat Ø {_cm(2 * r)}"
    else:
        a = _u(rng, 0.3, 0.36)
        r = a / 2
        parts = [_box((-a / 2, -a / 2, s - ts), (a / 2, a / 2, s))]
        seat = f"square seat {_cm(a)}"
    r_top = 0.72 * r
    r_bottom = r_top + _u(rng, 0.03, 0.07)
    r_leg = _u(rng, 0.015, 0.022)
    rung = _u(rng, 0.15, 0.25)
    feet, at_rung = [], []
    for j in range(n_legs):
        ang = 2 * np.pi * j / n_legs + np.pi / 4
        c, sn = np.cos(ang), np.sin(ang)
        top, bottom = (r_top * c, r_top * sn, s - ts + 0.005), (r_bottom * c, r_bottom * sn, 0.0)
        feet.append(_rod(bottom, top, r_leg))
        k = rung / top[2]
        at_rung.append(tuple(b + k * (q - b) for b, q in zip(bottom, top)))
    parts += feet + [_rod(at_rung[j], at_rung[(j + 1) % n_legs], 0.01) for j in range(n_legs)]
    return Built(_on_floor(_union(parts)), f"backless stool, {seat} at {_cm(s)}, {n_legs} splayed legs, rungs at {_cm(rung)}")


def bowl_real(rng: np.random.Generator) -> Built:
    d = _u(rng, 0.13, 0.28)
    R = d / 2
    h = _u(rng, max(0.056, d / 3.5), d / 1.9)
    t = _u(rng, 0.003, 0.006)
    foot = bool(rng.random() < 0.6)
    fh = _u(rng, 0.004, 0.007) if foot else 0.0
    zf = fh + _u(rng, 0.004, 0.005)  # the inner floor
    rf = R * _u(rng, 0.35, 0.5)
    p = _u(rng, 1.6, 2.6)  # > 1: the wall leaves the base flat and meets the rim upright

    def wall(z: float, z_start: float, r_start: float, r_rim: float) -> float:
        return r_start + (r_rim - r_start) * (1 - (1 - (z - z_start) / (h - z_start)) ** p)

    outer = [(wall(z, fh, rf, R), z) for z in np.linspace(fh, h, 12)]
    # the inner wall starts at the floor, so it stays >= t inside the outer one at every height
    inner = [(wall(z, zf, rf - t, R - t), z) for z in np.linspace(h, zf, 12)]
    if foot:
        fw = _u(rng, 0.004, 0.006)
        base = [(0.0, fh), (rf - fw, fh), (rf - fw, 0.0), (rf, 0.0)]
        outer = outer[1:]
    else:
        base = [(0.0, 0.0)]
    mesh = _revolve(base + outer + inner + [(0.0, zf)])
    desc = f"bowl of real proportions, Ø {_cm(d)} x {_cm(h)} (width/height {d / h:.2f}), wall {1000 * t:.1f} mm"
    return Built(mesh, desc + (f", foot ring {1000 * fh:.0f} mm" if foot else ", flat base"))


def _handled_vessel(rng: np.random.Generator, d: float, h: float, *, t: float, flare: float, handle_len: float,
                    handle_angle: float, handle_w: float, handle_t: float) -> trimesh.Trimesh:
    """A straight-walled (or flared) open vessel with one long handle at the rim along +x."""
    R = d / 2
    rb = R - flare
    b = _u(rng, 0.004, 0.007)
    body = _revolve([(0.0, 0.0), (rb, 0.0), (R, h), (R - t, h), (rb - t, b), (0.0, b)])
    z_att = h - _u(rng, 0.012, 0.025)
    r_att = rb + (R - rb) * z_att / h
    handle = _box((0.0, -handle_w / 2, -handle_t / 2), (handle_len, handle_w / 2, handle_t / 2))
    handle.apply_transform(trimesh.transformations.rotation_matrix(-handle_angle, (0, 1, 0)))
    handle.apply_translation((r_att - t / 2, 0.0, z_att))
    cavity = _revolve([(0.0, b), (rb - t, b), (R - t, h), (R - t, h + 0.05), (0.0, h + 0.05)])
    return _union([body, _difference(handle, cavity)])


def saucepan(rng: np.random.Generator) -> Built:
    d = _u(rng, 0.15, 0.22)
    h = _u(rng, max(0.065, 0.3 * d), 0.48 * d)
    L = _u(rng, 0.16, 0.22)
    ang = np.deg2rad(_u(rng, 5.0, 15.0))
    mesh = _handled_vessel(rng, d, h, t=_u(rng, 0.0025, 0.004), flare=0.0, handle_len=L, handle_angle=ang,
                           handle_w=_u(rng, 0.022, 0.03), handle_t=_u(rng, 0.012, 0.018))
    return Built(mesh, f"saucepan, Ø {_cm(d)} x {_cm(h)}, long handle {_cm(L)} rising {np.rad2deg(ang):.0f}°")


def handle_pot(rng: np.random.Generator) -> Built:
    d = _u(rng, 0.16, 0.21)
    h = _u(rng, max(0.11, 0.62 * d), 0.17)
    L = _u(rng, 0.16, 0.22)
    ang = np.deg2rad(_u(rng, 5.0, 15.0))
    mesh = _handled_vessel(rng, d, h, t=_u(rng, 0.003, 0.004), flare=0.0, handle_len=L, handle_angle=ang,
                           handle_w=_u(rng, 0.022, 0.03), handle_t=_u(rng, 0.012, 0.018))
    return Built(mesh, f"deep pot with a long handle, Ø {_cm(d)} x {_cm(h)}, handle {_cm(L)}")


def scoop(rng: np.random.Generator) -> Built:
    d = _u(rng, 0.13, 0.17)
    h = _u(rng, 0.056, min(0.075, d / 2.1))
    L = _u(rng, 0.1, 0.16)
    ang = np.deg2rad(_u(rng, 20.0, 35.0))
    mesh = _handled_vessel(rng, d, h, t=_u(rng, 0.0025, 0.0035), flare=_u(rng, 0.005, 0.015), handle_len=L,
                           handle_angle=ang, handle_w=_u(rng, 0.02, 0.026), handle_t=_u(rng, 0.008, 0.012))
    return Built(mesh, f"flat-bottomed round scoop (dipper), Ø {_cm(d)} x {_cm(h)}, handle {_cm(L)} at {np.rad2deg(ang):.0f}°")


def ladle(rng: np.random.Generator) -> Built:
    R = _u(rng, 0.035, 0.05)
    dd = R * _u(rng, 0.7, 0.95)
    t = _u(rng, 0.002, 0.003)
    zs = np.linspace(0.0, dd, 10)
    outer = [(float(np.sqrt(max(R**2 - (R - z) ** 2, 0.0))), float(z)) for z in zs]
    zi = np.linspace(dd, t, 10)
    inner = [(float(np.sqrt((R - t) ** 2 - (R - z) ** 2)), float(z)) for z in zi]
    cup_ = _revolve([(0.0, 0.0)] + outer[1:] + inner)  # the inner curve ends on the axis at z = t
    L = _u(rng, 0.22, 0.32)
    ang = np.deg2rad(_u(rng, 55.0, 70.0))
    r_rim = outer[-1][0]
    p0 = (r_rim - t / 2, 0.0, dd - 0.006)
    p1 = (p0[0] + L * np.cos(ang), 0.0, p0[2] + L * np.sin(ang))
    r_rod = _u(rng, 0.005, 0.0065)
    rod = _difference(_rod(p0, p1, r_rod), _ball(R - t, (0.0, 0.0, R), subdivisions=3))
    hook = _rod(p1, (p1[0] + 0.03 * np.cos(ang + 2.2), 0.0, p1[2] + 0.03 * np.sin(ang + 2.2)), r_rod)
    return Built(_union([cup_, rod, hook, _ball(r_rod, p1, subdivisions=2)]),
                 f"ladle, hemispherical cup Ø {_cm(2 * r_rim)} x {_cm(dd)} deep on a {_cm(L)} handle at {np.rad2deg(ang):.0f}°")


def ashtray(rng: np.random.Generator) -> Built:
    R = _u(rng, 0.05, 0.06)
    h = _u(rng, 0.025, 0.036)
    tw = _u(rng, 0.008, 0.014)
    dd = _u(rng, 0.015, min(0.024, h - 0.008))
    ri = R - tw
    floor = h - dd
    profile = [(0.0, 0.0), (R - 0.003, 0.0), (R, 0.003), (R, h), (ri + 0.004, h), (ri, h - 0.004), (ri - 0.006, floor), (0.0, floor)]
    mesh = _revolve(profile)
    n = int(rng.integers(3, 5))
    rn = _u(rng, 0.005, 0.006)
    for j in range(n):
        ang = 2 * np.pi * j / n
        c, sn = np.cos(ang), np.sin(ang)
        mesh = _difference(mesh, _rod(((ri - 0.008) * c, (ri - 0.008) * sn, h), ((R + 0.01) * c, (R + 0.01) * sn, h), rn))
    return Built(mesh, f"round ashtray, Ø {_cm(2 * R)} x {_cm(h)}, {_cm(dd)} deep inside, {n} cigarette rests")


def goblet(rng: np.random.Generator) -> Built:
    H = _u(rng, 0.12, 0.145)
    rf, ft = _u(rng, 0.03, 0.04), _u(rng, 0.003, 0.005)
    rs, stem = _u(rng, 0.004, 0.0065), _u(rng, 0.03, 0.05)
    z0 = ft + stem
    hb = H - z0
    rmax = _u(rng, 0.035, 0.047)
    rrim = rmax * _u(rng, 0.8, 1.0)
    t = _u(rng, 0.002, 0.003)
    bb = _u(rng, 0.004, 0.007)
    zk = [z0, z0 + 0.15 * hb, z0 + _u(rng, 0.5, 0.65) * hb, H]
    r_of = PchipInterpolator(zk, [rs + 0.002, 0.6 * rmax, rmax, rrim])
    outer = [(float(r_of(z)), float(z)) for z in np.linspace(z0, H, 16)]
    zi = np.linspace(H, z0 + bb, 16)
    inner = [(max(float(r_of(z)) - t, 0.002), float(z)) for z in zi]
    foot_and_stem = [(0.0, 0.0), (rf, 0.0), (rf, ft), (rs + 0.006, ft + 0.004), (rs, ft + 0.012), (rs, z0 - 0.004)]
    profile = foot_and_stem + outer + inner + [(0.0, z0 + bb)]
    return Built(_revolve(profile), f"goblet on a stem, {_cm(H)} tall, rim Ø {_cm(2 * rrim)}, bowl Ø {_cm(2 * rmax)}, "
                 f"stem Ø {_cm(2 * rs)} x {_cm(stem)}, foot Ø {_cm(2 * rf)}")


def _open_front_box(W: float, D: float, H: float, t: float, t_back: float, dividers: int = 0) -> trimesh.Trimesh:
    """A box open at the front (-y): walls ``t`` thick, back ``t_back``; ``dividers`` split it into equal bays."""
    outer = _box((-W / 2, -D / 2, 0.0), (W / 2, D / 2, H))
    n = dividers + 1
    bay = (W - 2 * t - dividers * t) / n
    voids = []
    for k in range(n):
        x0 = -W / 2 + t + k * (bay + t)
        voids.append(_box((x0, -D / 2 - 0.01, t), (x0 + bay, D / 2 - t_back, H - t)))
    return _difference(outer, _union(voids) if len(voids) > 1 else voids[0])


def cubby(rng: np.random.Generator) -> Built:
    W, D, H = _u(rng, 0.26, 0.36), _u(rng, 0.26, 0.36), _u(rng, 0.26, 0.34)
    t = _u(rng, 0.012, 0.018)
    tb = _u(rng, 0.005, t)
    return Built(_open_front_box(W, D, H, t, tb), f"open-front cubby, {_cm(W)} x {_cm(D)} x {_cm(H)}, walls {1000 * t:.0f} mm")


def wall_shelf_box(rng: np.random.Generator) -> Built:
    W, D, H = _u(rng, 0.45, 0.7), _u(rng, 0.14, 0.2), _u(rng, 0.2, 0.26)
    t = _u(rng, 0.012, 0.018)
    dividers = int(rng.integers(0, 2))
    mesh = _open_front_box(W, D, H, t, _u(rng, 0.005, 0.01), dividers)
    return Built(mesh, f"open-front wall shelf box, {_cm(W)} x {_cm(D)} x {_cm(H)}" + (", one divider" if dividers else ""))


def riser(rng: np.random.Generator) -> Built:
    W, D, H = _u(rng, 0.2, 0.4), _u(rng, 0.12, 0.25), _u(rng, 0.08, 0.22)
    t = _u(rng, 0.005, 0.01)
    if rng.random() < 0.5:
        void = _box((-W / 2 + t, -D / 2 - 0.01, -0.01), (W / 2 - t, D / 2 + 0.01, H - t))
        kind = "U-shaped (open front, back and bottom)"
    else:
        void = _box((-W / 2 + t, -D / 2 + t, -0.01), (W / 2 - t, D / 2 - t, H - t))
        kind = "hollow box open at the bottom"
    mesh = _difference(_box((-W / 2, -D / 2, 0.0), (W / 2, D / 2, H)), void)
    return Built(mesh, f"display riser, {kind}, {_cm(W)} x {_cm(D)} x {_cm(H)}, panels {1000 * t:.0f} mm")


def bed(rng: np.random.Generator) -> Built:
    L, W = _u(rng, 2.0, 2.2), _u(rng, 0.95, 1.65)
    top = _u(rng, 0.42, 0.52)
    mt = _u(rng, 0.15, 0.22)
    legs = bool(rng.random() < 0.5)
    f = _u(rng, 0.06, min(0.16, top - mt - 0.06)) if legs else 0.0  # the frame under the mattress stays >= 6 cm
    hbt, hh = _u(rng, 0.04, 0.07), _u(rng, 0.9, 1.2)
    parts = [_box((-L / 2 + 0.01, -W / 2, f), (L / 2 - 0.01, W / 2, top - mt + 0.01)),
             _box((-L / 2 + 0.06, -W / 2 + 0.02, top - mt), (L / 2 - hbt - 0.01, W / 2 - 0.02, top)),
             _box((L / 2 - hbt, -W / 2 - 0.01, 0.0), (L / 2, W / 2 + 0.01, hh))]
    desc = f"bed, {_cm(L)} x {_cm(W)}, mattress top {_cm(top)} high, headboard {_cm(hh)}"
    if rng.random() < 0.5:
        fh = top + _u(rng, -0.12, 0.1)
        parts.append(_box((-L / 2, -W / 2 - 0.01, 0.0), (-L / 2 + _u(rng, 0.03, 0.05), W / 2 + 0.01, fh)))
        desc += f", footboard {_cm(fh)}"
    n_p = 1 if W < 1.2 else 2
    pw = (W - 0.1) / n_p - 0.05
    for k in range(n_p):
        y0 = -W / 2 + 0.05 + k * (pw + 0.05)
        parts.append(_box((L / 2 - hbt - 0.45, y0, top - 0.01), (L / 2 - hbt - 0.06, y0 + pw, top + _u(rng, 0.09, 0.13))))
    if legs:
        parts += [_box((x - 0.03, y - 0.03, 0.0), (x + 0.03, y + 0.03, f + 0.01))
                  for x in (-L / 2 + 0.08, L / 2 - 0.08) for y in (-W / 2 + 0.08, W / 2 - 0.08)]
        desc += f", on {_cm(f)} legs"
    return Built(_union(parts), desc + f", {n_p} pillow{'s' if n_p > 1 else ''}")


def _pedestal(x0: float, x1: float, D: float, top: float, rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """A drawer pedestal under a desk top: a closed block with drawer fronts and pulls on its front (-y)."""
    parts = [_box((x0, -D / 2 + 0.02, 0.0), (x1, D / 2 - 0.02, top))]
    n = int(rng.integers(2, 4))
    h = (top - 0.06) / n
    for k in range(n):
        zc = 0.06 + (k + 0.5) * h
        parts.append(_box(((x0 + x1) / 2 - 0.05, -D / 2 + 0.005, zc - 0.008), ((x0 + x1) / 2 + 0.05, -D / 2 + 0.025, zc + 0.008)))
    return parts


def desk(rng: np.random.Generator) -> Built:
    H, tt = _u(rng, 0.72, 0.77), _u(rng, 0.025, 0.04)
    L, D = _u(rng, 1.1, 1.6), _u(rng, 0.55, 0.8)
    parts = [_box((-L / 2, -D / 2, H - tt), (L / 2, D / 2, H))]
    under = H - tt + 0.005
    kind = int(rng.integers(0, 3))
    pw = _u(rng, 0.38, 0.45)
    if kind == 0:
        parts += _pedestal(-L / 2 + 0.01, -L / 2 + 0.01 + pw, D, under, rng) + _pedestal(L / 2 - 0.01 - pw, L / 2 - 0.01, D, under, rng)
        desc = "two drawer pedestals"
        x_in = L / 2 - 0.01 - pw
    else:
        pt = _u(rng, 0.03, 0.05)
        if kind == 1:
            parts += _pedestal(L / 2 - 0.01 - pw, L / 2 - 0.01, D, under, rng)
            desc = "one drawer pedestal and a panel leg"
        else:
            parts.append(_box((L / 2 - 0.01 - pt, -D / 2 + 0.03, 0.0), (L / 2 - 0.01, D / 2 - 0.03, under)))
            desc = "two panel legs"
        parts.append(_box((-L / 2 + 0.01, -D / 2 + 0.03, 0.0), (-L / 2 + 0.01 + pt, D / 2 - 0.03, under)))
        x_in = L / 2 - 0.03
    if rng.random() < 0.6:
        parts.append(_box((-x_in - 0.01, D / 2 - 0.06, H - tt - _u(rng, 0.3, 0.4)), (x_in + 0.01, D / 2 - 0.035, under)))
        desc += ", modesty panel"
    return Built(_union(parts), f"desk, top {_cm(L)} x {_cm(D)} at {_cm(H)}, {desc}")


def console(rng: np.random.Generator) -> Built:
    L, D, H = _u(rng, 1.2, 1.8), _u(rng, 0.52, 0.6), _u(rng, 0.6, 0.72)
    legs = bool(rng.random() < 0.6)
    f = _u(rng, 0.08, 0.15) if legs else 0.0
    t = _u(rng, 0.018, 0.025)
    n = int(rng.integers(2, 5))
    carcass = _open_front_box(L, D, H - f, t, _u(rng, 0.006, 0.012), dividers=n - 1)
    carcass.apply_translation((0.0, 0.0, f))
    parts = [carcass]
    if legs:
        parts += [_box((x - 0.02, y - 0.02, 0.0), (x + 0.02, y + 0.02, f + 0.01))
                  for x in (-L / 2 + 0.05, L / 2 - 0.05) for y in (-D / 2 + 0.05, D / 2 - 0.05)]
    desc = f"TV console, {_cm(L)} x {_cm(D)}, top {_cm(H)} high, {n} open compartments"
    desc += f", on {_cm(f)} legs" if legs else ", on a plinth"
    return Built(_union(parts) if len(parts) > 1 else carcass, desc)


def carton(rng: np.random.Generator) -> Built:
    if rng.random() < 0.6:
        a, b, c = _u(rng, 0.05, 0.09), _u(rng, 0.14, 0.24), _u(rng, 0.2, 0.32)
        kind = "product box standing on its end"
    else:
        a, b, c = _u(rng, 0.15, 0.34), _u(rng, 0.15, 0.34), _u(rng, 0.12, 0.34)
        kind = "shipping carton"
    e = _u(rng, 0.002, 0.004)
    # chamfered edges: the hull of three boxes, each shrunk by e in two of the three axes
    pts = [(sx * (a / 2 - e * (k != 0)), sy * (b / 2 - e * (k != 1)), sz * (c / 2 - e * (k != 2)))
           for k in range(3) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    mesh = trimesh.convex.convex_hull(np.array(pts))
    mesh.apply_translation((0.0, 0.0, c / 2))
    return Built(mesh, f"closed {kind}, {_cm(a)} x {_cm(b)} x {_cm(c)}")


def plate_real(rng: np.random.Generator) -> Built:
    R = _u(rng, 0.1, 0.14)
    h = _u(rng, 0.02, 0.032)
    rf = R * _u(rng, 0.45, 0.6)
    fh, fw = _u(rng, 0.003, 0.005), _u(rng, 0.004, 0.006)
    tb, t = _u(rng, 0.004, 0.006), _u(rng, 0.004, 0.005)
    r_m = R - _u(rng, 0.02, 0.035)
    z_a, z_b = fh + tb, h - 0.004
    us = np.linspace(0.0, 1.0, 10)
    top = [(rf + (r_m - rf) * u, z_a + (z_b - z_a) * (1 - (1 - u) ** 2)) for u in us]
    profile = ([(0.0, fh), (rf - fw, fh), (rf - fw, 0.0), (rf, 0.0), (rf + 0.002, fh), (r_m, z_b - t), (R, h - t), (R, h)]
               + top[::-1] + [(0.0, z_a)])
    return Built(_revolve(profile, sections=64), f"plate with a foot ring, Ø {_cm(2 * R)} x {_cm(h)}, rim {_cm(R - r_m)} wide")


# ---------------------------------------------------------------- scan-like corruption
#
# Each takes a mesh in its build frame and a generator of its own (so one corruption does the same to an
# object alone or with others) and returns the corrupted mesh and what was done. None of them changes what
# the object affords: they model what a scanner or an exporter does to the file, not the object.

#: Face count :func:`densify` aims under (the dataset's cap keeps CoACD fast).
DENSE_FACES = 4500
_ALREADY_DENSE = 2500


def densify(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The same surface split into smaller triangles (<= :data:`DENSE_FACES`), as a scan's would be, so
    noise, holes and seams are local; meshes of over 2,500 faces (revolved ones) are returned as they are."""
    if len(mesh.faces) >= _ALREADY_DENSE:
        return mesh.copy()
    edge = float(np.sqrt(4 * mesh.area / (np.sqrt(3) * 1000)))
    for _ in range(12):
        v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=edge, max_iter=20)
        if len(f) <= DENSE_FACES:
            return trimesh.Trimesh(vertices=v, faces=f, process=True)
        edge *= 1.05 * float(np.sqrt(len(f) / (0.9 * DENSE_FACES)))
    return mesh.copy()


def _scan_scale(mesh: trimesh.Trimesh) -> float:
    """Scanner error grows with the object: 1 below 30 cm, proportional above."""
    return max(1.0, float(np.max(mesh.extents)) / 0.3)


def add_noise(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """Vertices moved along their normals by Gaussian noise clipped at 2 sigma (sigma 0.1-0.25 mm below 30 cm)."""
    sigma = _u(rng, 0.0001, 0.00025) * _scan_scale(mesh)
    step = np.clip(rng.normal(0.0, sigma, len(mesh.vertices)), -2 * sigma, 2 * sigma)
    out = trimesh.Trimesh(vertices=mesh.vertices + step[:, None] * mesh.vertex_normals, faces=mesh.faces, process=False)
    return out, f"noise: vertices moved along their normals, sigma {1000 * sigma:.2f} mm"


def punch_holes(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """2-4 missing patches of the surface (Ø 2-5 % of the largest extent), each on one side of a wall only:
    a patch takes the faces near its seed facing the same way, never the opposite face of a thin wall."""
    centres, normals = mesh.triangles_center, mesh.face_normals
    n = int(rng.integers(2, 5))
    radius = _u(rng, 0.01, 0.025) * float(np.max(mesh.extents))
    seeds = rng.choice(len(mesh.faces), size=n, replace=False, p=mesh.area_faces / mesh.area)
    drop = np.zeros(len(mesh.faces), dtype=bool)
    for s in seeds:
        near = np.linalg.norm(centres - centres[s], axis=1) <= radius
        drop |= near & (normals @ normals[s] > 0.5)
        drop[s] = True
    out = trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces[~drop], process=False)
    out.remove_unreferenced_vertices()
    return out, f"holes: {n} missing surface patches of Ø {_cm(2 * radius)} ({int(drop.sum())} faces), none through a wall"


def open_seams(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """The surface cut into 2-4 unwelded shells (the faces nearest each of random seed points), each shifted
    0.2-0.5 mm (more on large objects, at most 1.5 mm), so the seams are open cracks: not watertight."""
    k = int(rng.integers(2, 5))
    centres = mesh.triangles_center
    seeds = centres[rng.choice(len(centres), size=k, replace=False)]
    group = np.argmin(np.linalg.norm(centres[:, None] - seeds[None], axis=-1), axis=1)
    shells, widest = [], 0.0
    for g in range(k):
        faces = mesh.faces[group == g]
        if len(faces) == 0:
            continue
        used, inv = np.unique(faces, return_inverse=True)
        direction = rng.normal(size=3)
        size = min(_u(rng, 0.0002, 0.0005) * _scan_scale(mesh), 0.0015)
        widest = max(widest, size)
        shells.append(trimesh.Trimesh(vertices=mesh.vertices[used] + size * direction / np.linalg.norm(direction),
                                      faces=inv.reshape(-1, 3), process=False))
    out = trimesh.util.concatenate(shells)
    return out, f"open shell: {len(shells)} unwelded shells, seams open by up to {1000 * 2 * widest:.1f} mm"


def uneven_bottom(mesh: trimesh.Trimesh, rng: np.random.Generator) -> tuple[trimesh.Trimesh, str]:
    """The base warped by up to ``a`` (1.5-3 mm below 50 cm, 4-8 mm above: legs of different lengths):
    a tilt plus a dome or dish, fading out over the lowest ``4 a`` (at least 1 cm), so the object rocks."""
    large = float(np.max(mesh.extents)) >= 0.5
    a = _u(rng, 0.004, 0.008) if large else _u(rng, 0.0015, 0.003)
    band = max(4 * a, 0.01)
    v = np.array(mesh.vertices, dtype=np.float64)
    z0 = v[:, 2].min()
    low = v[:, 2] - z0 < band
    centre = v[low, :2].mean(axis=0)
    rel = v[:, :2] - centre
    reach = float(np.max(np.linalg.norm(rel[low], axis=1)))
    phi = _u(rng, 0.0, 2 * np.pi)
    tilt = _u(rng, -1.0, 1.0)
    dome = (1.0 - abs(tilt)) * (1.0 if rng.random() < 0.5 else -1.0)
    f = tilt * (rel @ np.array([np.cos(phi), np.sin(phi)])) / reach + dome * (1.0 - 2.0 * np.sum(rel**2, axis=1) / reach**2)
    fade = np.clip(1.0 - (v[:, 2] - z0) / band, 0.0, 1.0)
    v[:, 2] += a * np.clip(f, -1.0, 1.0) * fade
    out = trimesh.Trimesh(vertices=v, faces=mesh.faces, process=False)
    shape = "dome" if dome > 0 else "dish"
    return out, f"uneven bottom: base warped by up to {1000 * a:.1f} mm (tilt {tilt:+.2f}, {shape} {abs(dome):.2f})"


#: The corruptions that change the mesh, in the order they are applied.
GEOMETRIC_CORRUPTIONS: dict[str, Callable[[trimesh.Trimesh, np.random.Generator], tuple[trimesh.Trimesh, str]]] = {
    "uneven_bottom": uneven_bottom,
    "noise": add_noise,
    "holes": punch_holes,
    "open_shell": open_seams,
}


#: Generator of every class, by class name.
GENERATORS: dict[str, Callable[[np.random.Generator], Built]] = {
    "cup": cup,
    "bowl": bowl,
    "vase": vase,
    "basket": basket,
    "bathtub": bathtub,
    "plate": plate,
    "table": table,
    "chair": chair,
    "pot": pot,
    "trash_bin": trash_bin,
    "tray": tray,
    "bench": bench,
    "cup_no_bottom": cup_no_bottom,
    "bowl_holed": bowl_holed,
    "chair_high_seat": chair_high_seat,
    "table_tilted": table_tilted,
    "vase_closed": vase_closed,
    "solid_cylinder": solid_cylinder,
    "solid_box": solid_box,
    "sphere": sphere,
    "cone": cone,
    "torus": torus,
    "rack": rack,
    "armchair": armchair,
    "bar_chair": bar_chair,
    "shell_chair": shell_chair,
    "stool": stool,
    "ottoman": ottoman,
    "sofa": sofa,
    "bowl_real": bowl_real,
    "saucepan": saucepan,
    "handle_pot": handle_pot,
    "scoop": scoop,
    "goblet": goblet,
    "plate_real": plate_real,
    "cubby": cubby,
    "wall_shelf_box": wall_shelf_box,
    "bed": bed,
    "desk": desk,
    "console": console,
    "ladle": ladle,
    "ashtray": ashtray,
    "riser": riser,
    "carton": carton,
}
