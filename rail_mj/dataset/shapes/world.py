"""The world family's builders: the shapes real meshes have and the core family lacks.

The seats (armchairs, bar chairs, shell chairs, lounge chairs, stools, ottomans and sofas) are
:mod:`rail_mj.dataset.shapes.world_seats`'. Here: bowls of real proportions, long-handled pans and
pots, scoops, goblets and plates on a foot ring; open-front boxes; beds, desks and consoles; near misses (ladles,
ashtrays, risers, cartons). Each takes a seeded ``numpy.random.Generator`` and returns a
:class:`~rail_mj.dataset.shapes.parts.Built` in its build frame (see :mod:`rail_mj.dataset.shapes`).
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.interpolate import PchipInterpolator

from rail_mj.dataset.shapes.parts import (
    Built,
    _ball,
    _box,
    _cm,
    _difference,
    _revolve,
    _rod,
    _u,
    _union,
)

__all__ = [
    "bowl_real",
    "saucepan",
    "handle_pot",
    "scoop",
    "ladle",
    "ashtray",
    "goblet",
    "cubby",
    "wall_shelf_box",
    "riser",
    "bed",
    "desk",
    "console",
    "carton",
    "plate_real",
]


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
    return Built(mesh, f"flat-bottomed round scoop (dipper), Ø {_cm(d)} x {_cm(h)}, handle {_cm(L)} at "
                       f"{np.rad2deg(ang):.0f}°")


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
                 f"ladle, hemispherical cup Ø {_cm(2 * r_rim)} x {_cm(dd)} deep on a {_cm(L)} handle at "
                 f"{np.rad2deg(ang):.0f}°")


def ashtray(rng: np.random.Generator) -> Built:
    R = _u(rng, 0.05, 0.06)
    h = _u(rng, 0.025, 0.036)
    tw = _u(rng, 0.008, 0.014)
    dd = _u(rng, 0.015, min(0.024, h - 0.008))
    ri = R - tw
    floor = h - dd
    profile = [(0.0, 0.0), (R - 0.003, 0.0), (R, 0.003), (R, h), (ri + 0.004, h), (ri, h - 0.004), (ri - 0.006, floor),
               (0.0, floor)]
    mesh = _revolve(profile)
    n = int(rng.integers(3, 5))
    rn = _u(rng, 0.005, 0.006)
    for j in range(n):
        ang = 2 * np.pi * j / n
        c, sn = np.cos(ang), np.sin(ang)
        mesh = _difference(mesh, _rod(((ri - 0.008) * c, (ri - 0.008) * sn, h), ((R + 0.01) * c, (R + 0.01) * sn, h),
                                      rn))
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
    return Built(_open_front_box(W, D, H, t, tb),
                 f"open-front cubby, {_cm(W)} x {_cm(D)} x {_cm(H)}, walls {1000 * t:.0f} mm")


def wall_shelf_box(rng: np.random.Generator) -> Built:
    W, D, H = _u(rng, 0.45, 0.7), _u(rng, 0.14, 0.2), _u(rng, 0.2, 0.26)
    t = _u(rng, 0.012, 0.018)
    dividers = int(rng.integers(0, 2))
    mesh = _open_front_box(W, D, H, t, _u(rng, 0.005, 0.01), dividers)
    return Built(mesh,
                 f"open-front wall shelf box, {_cm(W)} x {_cm(D)} x {_cm(H)}" + (", one divider" if dividers else ""))


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
        parts.append(_box((L / 2 - hbt - 0.45, y0, top - 0.01),
                          (L / 2 - hbt - 0.06, y0 + pw, top + _u(rng, 0.09, 0.13))))
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
        parts.append(_box(((x0 + x1) / 2 - 0.05, -D / 2 + 0.005, zc - 0.008),
                          ((x0 + x1) / 2 + 0.05, -D / 2 + 0.025, zc + 0.008)))
    return parts


def desk(rng: np.random.Generator) -> Built:
    H, tt = _u(rng, 0.72, 0.77), _u(rng, 0.025, 0.04)
    L, D = _u(rng, 1.1, 1.6), _u(rng, 0.55, 0.8)
    parts = [_box((-L / 2, -D / 2, H - tt), (L / 2, D / 2, H))]
    under = H - tt + 0.005
    kind = int(rng.integers(0, 3))
    pw = _u(rng, 0.38, 0.45)
    if kind == 0:
        parts += (_pedestal(-L / 2 + 0.01, -L / 2 + 0.01 + pw, D, under, rng)
                  + _pedestal(L / 2 - 0.01 - pw, L / 2 - 0.01, D, under, rng))
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
        parts.append(_box((-x_in - 0.01, D / 2 - 0.06, H - tt - _u(rng, 0.3, 0.4)),
                          (x_in + 0.01, D / 2 - 0.035, under)))
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
    profile = ([(0.0, fh), (rf - fw, fh), (rf - fw, 0.0), (rf, 0.0), (rf + 0.002, fh), (r_m, z_b - t), (R, h - t),
                (R, h)]
               + top[::-1] + [(0.0, z_a)])
    return Built(_revolve(profile, sections=64),
                 f"plate with a foot ring, Ø {_cm(2 * R)} x {_cm(h)}, rim {_cm(R - r_m)} wide")

