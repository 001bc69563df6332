"""The core family's builders: the paper's eight classes, four extra everyday classes, defects, distractors.

Each takes a seeded ``numpy.random.Generator`` and returns a :class:`~rail_mj.dataset.shapes.parts.Built`
in its build frame (see :mod:`rail_mj.dataset.shapes`).
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.interpolate import PchipInterpolator

from rail_mj.dataset.shapes.parts import (
    BASKET_AGENT_MIN,
    BASKET_GAP,
    Built,
    _box,
    _cm,
    _cylinder,
    _difference,
    _revolve,
    _u,
    _union,
)

__all__ = [
    "cup",
    "cup_no_bottom",
    "bowl",
    "bowl_holed",
    "vase",
    "vase_closed",
    "basket",
    "bathtub",
    "plate",
    "pot",
    "trash_bin",
    "tray",
    "table",
    "table_tilted",
    "chair",
    "chair_high_seat",
    "bench",
    "rack",
    "solid_cylinder",
    "solid_box",
    "sphere",
    "cone",
    "torus",
]


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
        tf = (trimesh.transformations.translation_matrix((r_wall + 0.5 * hr, 0.0, zc))
              @ trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0)))
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
        parts.append(_revolve([(R - slat_t - 0.002, h - rim_h), (R + 0.002, h - rim_h), (R + 0.002, h),
                               (R - slat_t - 0.002, h)]))
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
                        parts.append(_box((c - slat_w / 2, min(y_in, y_out), z0),
                                          (c + slat_w / 2, max(y_in, y_out), z1)))
                    else:  # short sides, 1 mm proud of the long sides' ends
                        x_in, x_out = sign * (L / 2 - slat_t + 0.001), sign * (L / 2 + 0.001)
                        parts.append(_box((min(x_in, x_out), c - slat_w / 2, z0),
                                          (max(x_in, x_out), c + slat_w / 2, z1)))
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
        mesh = _union([mesh] + [_cylinder(0.04, 0.0, z0 + 0.01, sx * fx, sy * fy, 16)
                                for sx in (-1, 1) for sy in (-1, 1)])
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
    mesh = _difference(_box((-L / 2, -W / 2, 0.0), (L / 2, W / 2, h)),
                       _box((-L / 2 + t, -W / 2 + t, b), (L / 2 - t, W / 2 - t, h + 0.01)))
    return Built(mesh, f"square trash bin, {_cm(L)} x {_cm(W)}, {_cm(h)} tall")


def tray(rng: np.random.Generator) -> Built:
    L, W, h = _u(rng, 0.36, 0.5), _u(rng, 0.26, 0.36), _u(rng, 0.02, 0.04)
    t = _u(rng, 0.005, 0.008)
    floor = 0.005
    mesh = _difference(_box((-L / 2, -W / 2, 0.0), (L / 2, W / 2, h)),
                       _box((-L / 2 + t, -W / 2 + t, floor), (L / 2 - t, W / 2 - t, h + 0.01)))
    return Built(mesh, f"tray, {_cm(L)} x {_cm(W)}, rim {_cm(h)} tall")


# ---------------------------------------------------------------- furniture


def _four_legs(x: float, y: float, top: float, side: float) -> list[trimesh.Trimesh]:
    return [_box((sx * x - side / 2, sy * y - side / 2, 0.0), (sx * x + side / 2, sy * y + side / 2, top))
            for sx in (-1, 1) for sy in (-1, 1)]


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
    top.apply_transform(trimesh.transformations.translation_matrix((0, 0, zc))
                        @ trimesh.transformations.rotation_matrix(tilt, (1, 0, 0)))
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
        parts += [_box((sx * x - 0.02, -D / 2 + 0.02, 0.0), (sx * x + 0.02, D / 2 - 0.02, s - ts + 0.005))
                  for sx in (-1, 1)]
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
    return Built(_union(parts),
                 f"open shelf rack, {_cm(W)} x {_cm(D)}, {_cm(H)} tall, {n} shelves {_cm(tops[1] - tops[0])} apart")


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
    return Built(trimesh.creation.cone(radius=r, height=h, sections=48),
                 f"solid cone, base Ø {_cm(2 * r)}, {_cm(h)} tall")


def torus(rng: np.random.Generator) -> Built:
    R, r = _u(rng, 0.05, 0.15), _u(rng, 0.01, 0.04)
    mesh = trimesh.creation.torus(R, min(r, 0.5 * R), major_sections=48, minor_sections=16)
    mesh.apply_translation((0, 0, min(r, 0.5 * R)))
    return Built(mesh, f"solid torus, Ø {_cm(2 * R)}, tube Ø {_cm(2 * min(r, 0.5 * R))}")

