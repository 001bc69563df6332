"""Shared by the tests that run ``python -m rail_mj.eval`` as real processes and crash or kill them."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
GUARD_S = 300  # only against a hang: every wait ends on a file or process event

#: A module whose object segfaults the process that reads its path, like a bad mesh in native code.
CRASHER = '''
import ctypes


class Crasher:
    """An object whose path segfaults the process that reads it, like a bad mesh in native code."""

    def __fspath__(self):
        ctypes.string_at(0)

    def __str__(self):
        return "crasher.obj"
'''


def start_eval(out: Path, args: Sequence[str]) -> subprocess.Popen:
    """``python -m rail_mj.eval ARGS --out OUT`` in the background, its output in a log beside ``out``."""
    log = out.parent / f"{out.name}.{time.monotonic_ns()}.log"
    with open(log, "w") as fh:
        # Ctrl-C's default action in the run, however these tests were started: a shell's background job ignores
        # SIGINT, and a process inherits an ignored signal (nohup pytest ... & made the Ctrl-C test's run ignore it)
        proc = subprocess.Popen([sys.executable, "-m", "rail_mj.eval", *args, "--out", str(out)], cwd=REPO,
                                stdout=fh, stderr=subprocess.STDOUT,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    proc.log = log  # type: ignore[attr-defined]
    return proc


def output(proc: subprocess.Popen) -> str:
    """What a :func:`start_eval` process printed so far."""
    return proc.log.read_text()  # type: ignore[attr-defined]


def wait_until(moment: Callable[[], bool], proc: subprocess.Popen, what: str, poll_s: float = 0.005) -> None:
    """Return as soon as ``moment()`` holds; fail the test if ``proc`` ends first or the guard runs out."""
    deadline = time.monotonic() + GUARD_S
    while not moment():
        if proc.poll() is not None:
            pytest.fail(f"eval ended (status {proc.returncode}) before {what}:\n{output(proc)}")
        if time.monotonic() > deadline:
            proc.kill()
            pytest.fail(f"eval never reached the moment {what}")
        time.sleep(poll_s)
