"""The imagination backends by name: ``auto`` resolved by the JAX device, one shared instance per (name, config).

``get_backend`` keeps one instance per (name, config), so what a backend caches (MJX's compiled rollouts)
lives as long as the process.
"""

from __future__ import annotations

import functools

from rail_mj.core.errors import ImaginationError
from rail_mj.imagination.backend import Backend
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.imagination.native import NativeBackend

__all__ = ["BACKENDS", "resolve_backend", "get_backend"]

BACKENDS = ("auto", "native", "mjx")


def resolve_backend(backend: str) -> str:
    """``auto`` → ``mjx`` when JAX runs on a GPU/TPU, else ``native``."""
    if backend not in BACKENDS:
        raise ImaginationError(f"unknown imagination backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if backend != "auto":
        return backend
    import jax

    return "mjx" if jax.default_backend() in ("gpu", "tpu", "cuda", "rocm") else "native"


@functools.lru_cache(maxsize=16)
def _shared(name: str, config: ImaginationConfig) -> Backend:
    if name == "native":
        return NativeBackend(config)
    # jax takes seconds to import and only the mjx backend needs it: mjx.py is imported when first asked for
    from rail_mj.imagination.mjx import MjxBackend

    return MjxBackend(config)


def get_backend(name: str = "auto", config: ImaginationConfig | None = None) -> Backend:
    """The process-wide backend ``name`` (``auto``, ``native``, ``mjx``) with ``config`` (default settings if None)."""
    return _shared(resolve_backend(name), config or ImaginationConfig())  # pyright: ignore[reportArgumentType]  # frozen: hashable
