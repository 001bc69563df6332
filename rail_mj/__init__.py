"""rail_mj: robot affordance imagination with LLMs, simulated in batched MuJoCo.

Library API::

    import rail_mj
    from rail_mj.pipeline.config import RunConfig

    results = rail_mj.classify(["mug.obj"], ["cup", "chair"], config=RunConfig(provider="offline"))

Heavy modules (MuJoCo, JAX) load on first use of the names below.
"""

# the lazy names of __all__ come from the module __getattr__ below, which pyright does not follow
# pyright: reportUnsupportedDunderAll=false

from __future__ import annotations

import importlib
import os

# MuJoCo picks its GL backend when first imported; default to headless EGL (reports render offscreen)
# unless the user chose one.
os.environ.setdefault("MUJOCO_GL", "egl")

from rail_mj.core.errors import RailError

__all__ = [
    "RailError",
    "classify",
    "rank",
    "imagine",
    "find_stable_poses",
    "load_object",
    "AffordanceResult",
    "ObjectInput",
    "RunConfig",
    "__version__",
]

__version__ = "0.1.0"

_LAZY = {
    "classify": "rail_mj.pipeline.chain",
    "rank": "rail_mj.pipeline.rank",
    "ObjectInput": "rail_mj.pipeline.config",
    "RunConfig": "rail_mj.pipeline.config",
    "AffordanceResult": "rail_mj.core.results",
    "imagine": "rail_mj.imagination",
    "find_stable_poses": "rail_mj.stable_poses",
    "load_object": "rail_mj.mesh",
}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'rail_mj' has no attribute {name!r}; public names: {', '.join(__all__)}")
