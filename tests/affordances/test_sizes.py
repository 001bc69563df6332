"""A use's typical sizes as a model states them: the prior they give an object, and the boxes a profile for every
object of the use is checked on."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from rail_mj.affordances.prior import FUNCTIONAL, NEGLIGIBLE
from rail_mj.affordances.sizes import UseSizes

SIZES = UseSizes(largest=(0.2, 0.45), smallest=(0.06, 0.2), basis=["fruit bowls in catalogues"])


def test_an_object_inside_the_ranges_has_prior_one_and_falls_off_outside() -> None:
    assert SIZES.prior([0.12, 0.3, 0.3]).value == 1.0  # any order
    assert FUNCTIONAL < SIZES.prior([0.48, 0.48, 0.12]).value < 1.0  # 7% past the largest's hi
    assert SIZES.prior([0.28, 0.28, 0.027]).value < NEGLIGIBLE  # a plate: far too shallow
    assert "smallest dim 0.027 (typical 0.06-0.2" in SIZES.prior([0.28, 0.28, 0.027]).doc()


def test_the_extreme_boxes_span_each_range_end() -> None:
    boxes = SIZES.boxes()
    assert [0.2, 0.2, 0.06] in boxes and [0.45, 0.06, 0.06] in boxes and [0.45, 0.45, 0.2] in boxes
    assert all(b[0] >= b[1] >= b[2] for b in boxes)


@pytest.mark.parametrize("largest, smallest, words", [
    ((0.3, 0.2), (0.1, 0.2), "0 < lo <= hi"),
    ((0.0, 0.2), (0.1, 0.2), "0 < lo <= hi"),
    ((0.2, float("inf")), (0.1, 0.2), "finite"),
    ((0.2, 0.3), (0.4, 0.5), "exceeds largest's hi"),
])
def test_ranges_that_no_object_has_are_refused_naming_why(largest, smallest, words) -> None:
    with pytest.raises(ValidationError, match=words):
        UseSizes(largest=largest, smallest=smallest, basis=["x"])


def test_the_sizes_say_what_they_rest_on() -> None:
    with pytest.raises(ValidationError, match="basis"):
        UseSizes(largest=(0.2, 0.3), smallest=(0.1, 0.2), basis=[])
