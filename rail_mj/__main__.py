"""``rail-mj COMMAND ...`` (or ``python -m rail_mj COMMAND ...``): the one command line, dispatching to each tool.

Each command is its module's ``main(argv)``, imported when it runs; ``rail-mj MESH -a NAME`` with no command is
``rail-mj classify MESH -a NAME``, as ``python -m rail_mj MESH -a NAME`` always was. Exit status and error output
follow rail_mj.core.cli: an unknown command is a usage error (exit 2) naming the valid ones.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from rail_mj.core.cli import EXIT_OK, report_error
from rail_mj.core.errors import ConfigError

__all__ = ["COMMANDS", "main"]

#: command -> ("module:function" taking the command's arguments and returning the exit status, what it does)
COMMANDS: dict[str, tuple[str, str]] = {
    "classify": ("rail_mj.pipeline.cli:main", "one mesh, one verdict: classify MESH -a NAME [--json] [--explain] "
                                              "[--render PNG] [--save-scene DIR]"),
    "eval": ("rail_mj.eval.cli:main", "the paper's Tables 1 and 2 on a labelled dataset; `eval merge` joins shards"),
    "dataset": ("rail_mj.dataset.cli:main", "generate the labelled procedural dataset; `dataset real` fetches "
                                                   "the real-mesh set"),
    "robot": ("rail_mj.robot.__main__:main", "fetch the Panda model, run the execution demo or the robot experiment"),
}
_DEFAULT = "classify"


def _command(name: str) -> Callable[[Sequence[str]], int]:
    module, function = COMMANDS[name][0].split(":")
    return getattr(importlib.import_module(module), function)


def _help() -> str:
    width = max(map(len, COMMANDS))
    rows = "\n".join(f"  {name:<{width}}  {what}" for name, (_, what) in COMMANDS.items())
    return (f"usage: rail-mj COMMAND [ARGS ...]\n"
            f"       rail-mj MESH -a NAME [...]   (the same as rail-mj {_DEFAULT})\n\n"
            f"commands:\n{rows}\n\n`rail-mj COMMAND --help` shows a command's options.")


def _names_a_command(word: str) -> bool:
    """Whether ``word``, first on the command line, is meant as a command rather than a mesh file."""
    return not word.startswith("-") and not Path(word).suffix and not Path(word).exists()


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] and argv[0] in COMMANDS:
        return _command(argv[0])(argv[1:])
    if argv[:1] in (["-h"], ["--help"]):
        print(_help())
        return EXIT_OK
    if not argv:
        print(_help(), file=sys.stderr)
        return report_error(ConfigError(f"give a command ({', '.join(COMMANDS)}) or a mesh file"))
    if _names_a_command(argv[0]):
        return report_error(ConfigError(
            f"unknown command {argv[0]!r}; valid: {', '.join(COMMANDS)} (or a mesh file: rail-mj MESH -a NAME)"
        ))
    return _command(_DEFAULT)(argv)


if __name__ == "__main__":
    sys.exit(main())
