"""``python -m rail_mj.dataset``: ``real ...`` fetches the real-mesh set, anything else makes the procedural one.

CLI::

    python -m rail_mj.dataset --out DIR [...]   # the procedural dataset, see rail_mj.dataset.procedural
    python -m rail_mj.dataset --matrix          # the ground truth as Markdown, see rail_mj.dataset.ground_truth
    python -m rail_mj.dataset real --out DIR    # the real-mesh development set, see rail_mj.dataset.realset
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from rail_mj.dataset import procedural, realset

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (the rule of rail_mj.core.cli, see each command's ``main``)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["real"]:  # the real-mesh development set has its own options (rail_mj.dataset.realset)
        return realset.main(argv[1:])
    return procedural.main(argv)
