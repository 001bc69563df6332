"""Pictures that go with a request to a model that sees them: stage 7's poses, each with its plan's end state.

A picture is sent beside the request's text, its caption as text before it. The response cache keys a request
with pictures by what they draw (``drawn``: the pose, the plan and the agents' end positions to the millimetre),
not by their pixels, which another renderer draws a little differently.
"""

from __future__ import annotations

import base64
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["Picture", "pictures_key", "picture_b64"]


@dataclass(frozen=True)
class Picture:
    """One picture for a model: what it shows in words, the PNG, and what it draws in numbers."""

    caption: str
    png: bytes
    drawn: str


def pictures_key(pictures: Sequence[Picture]) -> list[str]:
    """What a request's pictures add to its cache key."""
    return [f"{p.caption}\n{p.drawn}" for p in pictures]


def picture_b64(picture: Picture) -> str:
    return base64.b64encode(picture.png).decode("ascii")
