"""On-disk cache of validated LLM stage answers, so a repeated run makes no request.

Key: SHA-256 of the canonical JSON of (provider, model, prompt version, stage,
request). Value: a JSON file holding those fields and the answer's JSON text.
``RAIL_MJ_CACHE`` moves the root (see :mod:`rail_mj.core.paths`); ``RAIL_MJ_NO_CACHE=1``
or ``cache=False`` turns it off.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from rail_mj.core.paths import cache_dir

__all__ = ["NO_CACHE_ENV", "cache_enabled", "cache_key", "ResponseCache"]

#: Set to 1 (or true/yes) to disable the LLM response cache.
NO_CACHE_ENV = "RAIL_MJ_NO_CACHE"


def cache_enabled(cache: bool = True) -> bool:
    """``cache`` unless the environment switch turns the cache off."""
    return cache and os.environ.get(NO_CACHE_ENV, "").strip().lower() not in ("1", "true", "yes")


def cache_key(provider: str, model: str, prompt_version: str, stage: str, request: dict[str, Any]) -> str:
    """Content hash of everything that determines a stage's answer."""
    blob = json.dumps(
        {"provider": provider, "model": model, "prompt_version": prompt_version, "stage": stage, "request": request},
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(blob.encode()).hexdigest()


class ResponseCache:
    """JSON files named by key under ``root`` (default ``cache_dir("llm")``)."""

    def __init__(self, root: Path | None = None) -> None:
        self.root = Path(root) if root is not None else cache_dir("llm")

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.json"

    def get(self, key: str) -> str | None:
        """The cached answer text, or None when absent or unreadable."""
        try:
            record = json.loads(self.path(key).read_text())
        except (OSError, ValueError):
            return None
        answer = record.get("answer") if isinstance(record, dict) else None
        return answer if isinstance(answer, str) else None

    def put(self, key: str, answer: str, meta: dict[str, Any]) -> None:
        """Store atomically (write a temporary file, then rename) so readers never see half a file."""
        path = self.path(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".tmp", delete=False) as tmp:
            json.dump({**meta, "answer": answer}, tmp, indent=1, sort_keys=True)
        os.replace(tmp.name, path)
