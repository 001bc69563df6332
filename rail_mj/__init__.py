"""rail_mj: robot affordance imagination with LLMs, simulated in batched MuJoCo."""

from __future__ import annotations

from rail_mj.errors import RailError

__all__ = ["RailError", "__version__"]

__version__ = "0.1.0"
