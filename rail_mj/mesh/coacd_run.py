"""CoACD runs in child processes, with their limits, for :mod:`rail_mj.mesh.decomposition`.

Each run is a child forked by a server (:mod:`rail_mj.mesh.coacd_child`, run as a script) that has numpy and
coacd imported once, so a segfault in CoACD takes only the child down. A server serves one run at a time and is
kept for the next; a stalled run is killed with its server, and the next run starts a new one.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import json
import math
import os
import select
import signal
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import IO, cast

import numpy as np

from rail_mj.core.errors import DecompositionError, DecompositionTimeout

__all__ = ["CoacdCrash", "coacd_child", "cpu_seconds"]

_WALL_PER_CPU = 4.0
_WALL_SLACK_S = 10.0
_FRAME = struct.Struct("<Q")  # coacd_child.py's frame header: the body's length


class CoacdCrash(Exception):
    """The CoACD child process died (a signal, not a Python error)."""


#: coacd_child.py servers waiting for a run; one per run in flight, so threads never wait on each other
_idle: list[subprocess.Popen] = []
_idle_lock = threading.Lock()


#: CPU seconds of the runs this process's servers have answered for
_spent = 0.0


def cpu_seconds() -> float:
    """CPU seconds of every CoACD run this process has had answered. A run's child is its server's to reap, so its
    CPU is not in this process's ``RUSAGE_CHILDREN`` until the server ends (at exit, or killed after a stall)."""
    return _spent


def _forget_servers() -> None:
    """A forked copy of this process starts servers of its own: two processes writing to one server's stdin would
    interleave their frames."""
    global _idle_lock, _spent
    _idle.clear()
    _spent = 0.0  # like getrusage, a fork counts from nothing
    _idle_lock = threading.Lock()


os.register_at_fork(after_in_child=_forget_servers)


def _server() -> subprocess.Popen:
    while True:
        with _idle_lock:
            server = _idle.pop() if _idle else None
        if server is None:
            break
        if server.poll() is None:
            return server
        _discard(server)
    # a session of its own: a stalled run is killed with its server's process group
    server = subprocess.Popen([sys.executable, str(Path(__file__).with_name("coacd_child.py"))],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                              start_new_session=True)
    os.set_blocking(cast(IO[bytes], server.stdin).fileno(), False)
    return server


def _discard(server: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(server.pid, signal.SIGKILL)
    server.wait()
    for stream in (server.stdin, server.stdout):
        if stream is not None:
            stream.close()


@atexit.register
def _close_idle() -> None:
    """Idle servers end when their stdin closes."""
    with _idle_lock:
        servers, _idle[:] = list(_idle), []
    for server in servers:
        with contextlib.suppress(OSError):
            cast(IO[bytes], server.stdin).close()
        try:
            server.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            _discard(server)


def _wait(fd: int, deadline: float, write: bool) -> None:
    """Until ``fd`` can be written (or read, or has closed); TimeoutError past ``deadline``. poll, not select: a
    process with over 1,024 open files gives select descriptors it cannot take."""
    poller = select.poll()
    poller.register(fd, select.POLLOUT if write else select.POLLIN)
    if not poller.poll(max(0.0, deadline - time.monotonic()) * 1000.0):
        raise TimeoutError


def _exchange(server: subprocess.Popen, request: bytes, deadline: float) -> bytes | None:
    """Sends one frame, reads one back: the answer's bytes, or None where the server died first.
    TimeoutError past ``deadline``."""
    fd_in, fd_out = cast(IO[bytes], server.stdin).fileno(), cast(IO[bytes], server.stdout).fileno()
    view = memoryview(_FRAME.pack(len(request)) + request)
    while view:
        _wait(fd_in, deadline, write=True)
        try:
            view = view[os.write(fd_in, view):]
        except BlockingIOError:
            continue
        except BrokenPipeError:
            return None

    def read(n: int) -> bytes | None:
        got = bytearray()
        while len(got) < n:
            _wait(fd_out, deadline, write=False)
            chunk = os.read(fd_out, min(n - len(got), 1 << 20))
            if not chunk:
                return None
            got += chunk
        return bytes(got)

    head = read(_FRAME.size)
    return None if head is None else read(_FRAME.unpack(head)[0])


def coacd_child(vertices: np.ndarray, faces: np.ndarray, options: dict, time_limit_s: float) -> list[np.ndarray]:
    """One CoACD run in a child process (:mod:`rail_mj.mesh.coacd_child`): its hulls' vertices.

    The child may use ``time_limit_s`` seconds of CPU (a limit that holds however loaded the machine is),
    and :data:`_WALL_PER_CPU` times that plus :data:`_WALL_SLACK_S` of wall time, in case it stalls without
    spending CPU (CoACD's threads on a loaded machine take longer on the wall than on the CPU).
    """
    global _spent
    payload = io.BytesIO()
    np.savez(payload, vertices=vertices, faces=faces, options=json.dumps(options),
             cpu_limit_s=max(1, math.ceil(time_limit_s)))
    wall_s = _WALL_PER_CPU * time_limit_s + _WALL_SLACK_S

    def late(what: str) -> DecompositionTimeout:
        return DecompositionTimeout(
            f"CoACD did not finish within {what} on this mesh ({len(faces):,} faces); a mesh of many loose "
            "pieces or a triangle soup does this: repair or simplify it, or raise DecompositionConfig.time_limit_s"
        )

    server = _server()
    try:
        answer = _exchange(server, payload.getvalue(), time.monotonic() + wall_s)
    except TimeoutError:
        _discard(server)
        raise late(f"{wall_s:g} s of wall time") from None
    except BaseException:
        _discard(server)  # a frame half sent or half read leaves the server out of step
        raise
    if answer is None:  # the server itself died: what killed it, if anything did
        _discard(server)
        code = server.returncode
        raise CoacdCrash(f"killed by signal {-code}" if code < 0 else f"its server ended with exit status {code}")
    header, _, body = answer.partition(b"\n")
    status = json.loads(header)
    with _idle_lock:
        _idle.append(server)
        _spent += float(status.get("cpu_s", 0.0))
    if status.get("signal") == signal.SIGXCPU:
        raise late(f"{time_limit_s:g} s of CPU")
    if "signal" in status:
        raise CoacdCrash(f"killed by signal {status['signal']}")
    if status["exit"] != 0:
        why = body.decode(errors="replace").strip().splitlines() or [f"exit status {status['exit']}"]
        raise DecompositionError(f"CoACD failed ({why[-1]})")
    with np.load(io.BytesIO(body)) as data:
        return [np.asarray(data[f"arr_{i}"], dtype=np.float64) for i in range(len(data.files))]
