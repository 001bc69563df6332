"""The registry rows beyond the paper's eight that the robot experiment added (bucket, jar, saucer, nightstand,
cutting board): each one's object passes, as it stands, at its request's scale, and an object of the same size
whose physics is wrong fails on what the kind simulates (not on its size)."""

from __future__ import annotations

import numpy as np
import pytest

from rail_mj.affordances import PAPER_AFFORDANCES, REGISTRY, for_request
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.demo import make_object, object_from_parts
from rail_mj.robot.request import parse_request

NEW = ("bucket", "jar", "saucer", "nightstand", "cutting board")


def _box(lo, hi) -> np.ndarray:
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    return np.asarray(lo, float) + corners * (np.asarray(hi, float) - np.asarray(lo, float))


def _disk(r: float, z0: float, z1: float, n: int = 24) -> np.ndarray:
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.stack([r * np.cos(a), r * np.sin(a)], 1)
    return np.vstack([np.c_[ring, np.full(n, z0)], np.c_[ring, np.full(n, z1)]])


def _ring(r_in: float, wall: float, z0: float, z1: float, n: int = 16) -> list[np.ndarray]:
    half = (r_in + wall) * np.tan(np.pi / n) * 1.05
    out = []
    for k in range(n):
        c, s = np.cos(2 * np.pi * k / n), np.sin(2 * np.pi * k / n)
        out.append(_box([r_in, -half, z0], [r_in + wall, half, z1]) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]))
    return out


def _ridge(hx: float, hy: float, h: float) -> list[np.ndarray]:
    """A roof-shaped prism: its top is a ridge along x."""
    return [np.array([[x, y, 0.0] for x in (-hx, hx) for y in (-hy, hy)] + [[x, 0.0, h] for x in (-hx, hx)])]


#: row -> (the experiment's object kind, its request, a same-sized object whose physics is wrong, what is wrong)
CASES = {
    "bucket": ("bucket", "put the water in the bucket", [_disk(0.1, 0, 0.2)], "a closed drum: no cavity"),
    "jar": ("jar", "put the water in the jar", _ring(0.042, 0.004, 0, 0.13), "a tube without a bottom: it leaks"),
    "saucer": ("saucer", "put the cup on the saucer", _ring(0.04, 0.03, 0, 0.006) + _ring(0.065, 0.005, 0, 0.016, 24),
               "a ring: no centre to hold the food"),
    "nightstand": ("nightstand", "put the doll on the nightstand",
                   [_box([-0.048, -0.038, 0], [0.048, 0.038, 0.01]), _box([-0.006, -0.006, 0.01], [0.006, 0.006, 0.09]),
                    _box([-0.015, -0.015, 0.09], [0.015, 0.015, 0.1])], "a pedestal: its top holds the box only at "
                                                                       "the centre"),
    "cutting board": ("cutting_board", "put the bread on the cutting board", _ridge(0.14, 0.1, 0.035),
                      "a ridge: the box placed beside the ridge slides off"),
}


def _verdict(obj, request: str):
    req = parse_request(request)
    return classify([obj], [req.affordance], config=RunConfig(provider="offline", pose="as_placed", agent=req.agent),
                    progress=False, workers=1)[0]


def test_the_new_rows_are_registered_beyond_the_paper():
    assert set(NEW) <= set(REGISTRY) and not set(NEW) & set(PAPER_AFFORDANCES)
    assert len(set(REGISTRY) - set(PAPER_AFFORDANCES)) >= 13
    for name in NEW:
        row = REGISTRY[name]
        assert row.ibd.startswith(f"A {name} ") and row.envelope.ranges(), name


@pytest.mark.parametrize("name", NEW)
def test_the_object_passes_and_a_same_sized_wrong_one_fails(name):
    kind, request, wrong_parts, why = CASES[name]
    assert parse_request(request).affordance == name
    good = _verdict(make_object(kind, 1), request)
    assert good.error is None and good.dims_fit and good.functional, (name, good.analyzer_reasons)
    wrong = object_from_parts(f"wrong_{kind}", wrong_parts)
    # the wrong object has a size the row accepts: it fails on the simulated interaction alone
    assert for_request(name, parse_request(request).agent).dims_fit(wrong.obb_dims), (name, wrong.obb_dims)
    bad = _verdict(wrong, request)
    assert bad.error is None and bad.dims_fit and not bad.functional, (name, why, bad.analyzer_reasons)


def test_a_nightstand_is_no_table_and_a_saucer_no_plate():
    """The pose envelopes tell the new rows from the paper's: a person's nightstand is too low for a table, a
    person's table too long for a nightstand, and a dinner plate too big for a saucer (half extents)."""
    nightstand, table = REGISTRY["nightstand"], REGISTRY["table"]
    low, wide = [0.25, 0.2, 0.25], [0.7, 0.4, 0.375]
    assert nightstand.pose_fits(low)[0] and not table.pose_fits(low)[0]
    assert not nightstand.pose_fits(wide)[0] and table.pose_fits(wide)[0]
    saucer, plate = REGISTRY["saucer"], REGISTRY["plate"]
    small, dinner = [0.07, 0.07, 0.009], [0.135, 0.135, 0.012]
    assert saucer.pose_fits(small)[0] and not saucer.pose_fits(dinner)[0] and plate.pose_fits(dinner)[0]
