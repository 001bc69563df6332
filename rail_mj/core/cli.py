"""The one error rule every rail_mj command line follows.

* Exit 0: the command ran and every case succeeded.
* Exit 1: the command ran, but some input failed (a broken mesh, an LLM stage out of retries, an
  imagination error). Each failure is reported with the rest of the output, as a result line that
  carries ``error`` (``--json``) or as an ``error:`` line, and the good cases are still printed.
* Exit 2: the command line itself was wrong and nothing ran: bad usage, an option value that is not
  allowed, an unknown affordance. One ``error: ...`` line on stderr says what is wrong and what is valid.
* Exit 130: interrupted (Ctrl-C); whatever finished was already written.

Errors always go to stderr as ``error: <message>``; with ``--json`` they are also printed on stdout as
one JSON object ``{"error": <message>, "type": <exception class>}`` so a script reading stdout sees them.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rail_mj.core.errors import ConfigError, RailError, UnknownAffordanceError

__all__ = ["EXIT_OK", "EXIT_FAILED", "EXIT_USAGE", "EXIT_INTERRUPTED", "exit_code", "report_error", "object_bar"]

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130

# Errors in what the user typed: nothing was run, the fix is on the command line.
_USAGE_ERRORS = (ConfigError, UnknownAffordanceError)


def exit_code(exc: BaseException) -> int:
    """The exit status for an error that stopped a command (see the module docstring)."""
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    if isinstance(exc, _USAGE_ERRORS):
        return EXIT_USAGE
    return EXIT_FAILED


def report_error(exc: RailError | KeyboardInterrupt, *, json_out: bool = False) -> int:
    """Print ``exc`` by the rule above and return the exit status to use."""
    message = "interrupted" if isinstance(exc, KeyboardInterrupt) else str(exc)
    print(f"error: {message}", file=sys.stderr)
    if json_out:
        print(json.dumps({"error": message, "type": type(exc).__name__}))
    return exit_code(exc)


@contextmanager
def object_bar() -> Iterator[Callable[[int, int, Any], None]]:
    """A progress bar over objects: yields the ``progress(done, total, record)`` callback that the dataset
    builders take (``record.mesh`` is shown), and closes the bar however the block ends."""
    from tqdm import tqdm

    bar = tqdm(unit="obj", disable=None)

    def tick(done: int, total: int, record: Any) -> None:
        bar.total = total
        bar.set_postfix_str(record.mesh, refresh=False)
        bar.update(1)

    try:
        yield tick
    finally:
        bar.close()
