"""Where rail_mj keeps its on-disk caches."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["CACHE_ENV", "cache_dir"]

#: Environment variable that overrides the cache root (default ``~/.cache/rail_mj``).
CACHE_ENV = "RAIL_MJ_CACHE"


def cache_dir(*parts: str) -> Path:
    """Return (and create) a folder under the cache root."""
    root = Path(os.environ.get(CACHE_ENV) or Path.home() / ".cache" / "rail_mj")
    path = root.joinpath(*parts)
    path.mkdir(parents=True, exist_ok=True)
    return path
