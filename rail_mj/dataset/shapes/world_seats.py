"""The world family's seats: armchairs, sofas and ottomans (upholstered), bar chairs, shell chairs, lounge chairs and
stools.

Each takes a seeded ``numpy.random.Generator`` and returns a :class:`~rail_mj.dataset.shapes.parts.Built` in its
build frame (see :mod:`rail_mj.dataset.shapes`).
"""

from __future__ import annotations

import numpy as np
import trimesh

from rail_mj.dataset.shapes.parts import (
    Built,
    _ball,
    _box,
    _cm,
    _cylinder,
    _difference,
    _feet,
    _intersection,
    _on_floor,
    _rod,
    _u,
    _union,
)

__all__ = ["armchair", "sofa", "ottoman", "bar_chair", "shell_chair", "lounge_chair", "stool"]


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
            f"seat {_cm(s)} high, rolled arms {_cm(ha)}, back {_cm(hb)}"
            + (f", on {_cm(f)} feet" if legs else ", on a plinth"))
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
    # the hips pass between the armrests: at least 46 cm clear (ANSI/HFES 100-2007), so on a narrower seat the
    # posts stand beside it on brackets under the seat
    clear = _u(rng, 0.46, 0.52)
    for sx in (-1, 1):
        x = sx * (clear / 2 + 0.022)
        parts.append(_box((x - 0.015, -d / 2 + 0.03, s - ts), (x + 0.015, -d / 2 + 0.06, s + ha)))
        parts.append(_box((min(x, sx * (w / 2 - 0.03)) - 0.015, -d / 2 + 0.03, s - ts),
                          (max(x, sx * (w / 2 - 0.03)) + 0.015, -d / 2 + 0.06, s - ts + 0.02)))
        parts.append(_box((x - 0.022, -d / 2 + 0.02, s + ha - 0.025), (x + 0.022, d / 2 - 0.01, s + ha)))
    desc = (f"bar chair, seat {_cm(w)} x {_cm(d)} at {_cm(s)}, footrest rungs at {_cm(fr)} "
            f"({_cm(s - fr)} below the seat), splayed legs, backrest {_cm(hb)}, armrests")
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
    desc = (f"shell lounge chair on a pedestal, shell Ø {_cm(2 * R)}, seat cushion Ø {_cm(2 * r_seat)} at {_cm(s)}, "
            f"{base}")
    return Built(_union(parts), desc)


def _turned(part: trimesh.Trimesh, deg: float, pivot: tuple[float, float, float]) -> trimesh.Trimesh:
    """``part`` turned about an x axis through ``pivot`` by ``deg`` (positive: its +y end up)."""
    part.apply_transform(trimesh.transformations.rotation_matrix(np.radians(deg), (1.0, 0.0, 0.0), pivot))
    return part


def lounge_chair(rng: np.random.Generator) -> Built:
    """A lounge chair facing -y: its seat reclined 10-20° (front edge up), its back 100-125° to the seat, on four legs,
    arms on half of them."""
    f = _u(rng, 0.37, 0.42)  # the seat's front edge, where the knees rest: a chair's seat height (0.36-0.57 m)
    w, d, ts = _u(rng, 0.5, 0.6), _u(rng, 0.5, 0.58), _u(rng, 0.05, 0.09)
    recline, back_deg = _u(rng, 10.0, 20.0), _u(rng, 100.0, 125.0)
    length, tb = _u(rng, 0.5, 0.65), _u(rng, 0.05, 0.09)
    r = np.radians(recline)
    lean = np.radians(back_deg - 90.0 + recline)  # the back's lean from vertical
    seat = _turned(_box((-w / 2, -d / 2, f - ts), (w / 2, d / 2, f)), -recline, (0.0, -d / 2, f))
    y_r, z_r = -d / 2 + d * np.cos(r), f - d * np.sin(r)  # the seat's rear top edge
    back = _box((-w / 2, -0.01, -ts), (w / 2, tb - 0.01, length))
    back.apply_transform(trimesh.transformations.rotation_matrix(-lean, (1.0, 0.0, 0.0)))
    back.apply_translation((0.0, y_r, z_r))
    parts = [seat, back]
    # front legs under the seat's front, rear legs under the back two thirds of the way up: a reclined sitter's
    # trunk and head lean that far back, and the chair must not tip under them
    y_f, z_f = -d / 2 + 0.05, f - ts - 0.05 * np.sin(r)
    y_b, z_b = y_r + 2 * length / 3 * np.sin(lean), z_r + 2 * length / 3 * np.cos(lean) - tb
    for sx in (-1, 1):
        x = sx * (w / 2 - 0.025)
        parts += [_box((x - 0.02, y_f - 0.02, 0.0), (x + 0.02, y_f + 0.02, z_f + 0.01)),
                  _box((x - 0.02, y_b - 0.02, 0.0), (x + 0.02, y_b + 0.02, z_b)),
                  _box((x - 0.015, y_f, 0.04), (x + 0.015, y_b, 0.07))]  # a side rail: a sled frame
    arms = bool(rng.random() < 0.5)
    if arms:
        ha = _u(rng, 0.18, 0.24)
        for sx in (-1, 1):
            x = sx * (w / 2 + 0.035)
            parts += [_box((x - 0.03, y_f - 0.02, f + ha - 0.04), (x + 0.03, y_r, f + ha)),
                      _box((x - 0.02, y_f - 0.02, 0.0), (x + 0.02, y_f + 0.02, f + ha - 0.03))]
    desc = (f"lounge chair, seat {_cm(w)} x {_cm(d)} with its front edge at {_cm(f)}, reclined {recline:.0f} deg, "
            f"back {_cm(length)} at {back_deg:.0f} deg to the seat ({np.degrees(lean):.0f} deg from vertical), four "
            f"legs on a sled frame{', arms ' + _cm(ha) + ' over the seat front' if arms else ''}")
    return Built(_on_floor(_union(parts)), desc)


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
    return Built(_on_floor(_union(parts)),
                 f"backless stool, {seat} at {_cm(s)}, {n_legs} splayed legs, rungs at {_cm(rung)}")
