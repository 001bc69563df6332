"""Runs CoACD decompositions in processes of their own, for :func:`rail_mj.mesh.decomposition.decompose`.

CoACD segfaults on some meshes (a closed scanned pen holder, without its own remeshing), which would take
the caller down with it. So each run is a child process, forked from this script's server, which has numpy and
coacd imported once: a fresh interpreter per run spent about 0.2 s of CPU starting Python and importing them, on
each of the 54 runs of the real-mesh set. Run as a script (``python path/to/coacd_child.py``), so the server
imports numpy and coacd only, not rail_mj.

The parent sends requests on the server's stdin and reads answers on its stdout, each a frame (an 8-byte
little-endian length, then that many bytes). A request is an ``.npz`` of the mesh, the options and a CPU-time
limit, which the run's child sets on itself (RLIMIT_CPU). An answer is a JSON header line (the child's exit
status, or the signal that killed it, and its CPU seconds) followed by what the child wrote: the hulls as an
``.npz``, or a Python error's one line (exit status 1). The server ends when its stdin closes.
"""

from __future__ import annotations

import io
import json
import os
import resource
import struct
import sys
from typing import BinaryIO

import coacd
import numpy as np

__all__ = ["main", "read_frame", "write_frame"]

_LENGTH = struct.Struct("<Q")


def read_frame(stream: BinaryIO) -> bytes | None:
    """The next frame's bytes, or None where the stream ends before a whole frame."""
    head = stream.read(_LENGTH.size)
    if len(head) < _LENGTH.size:
        return None
    (size,) = _LENGTH.unpack(head)
    body = stream.read(size)
    return body if len(body) == size else None


def write_frame(stream: BinaryIO, body: bytes) -> None:
    stream.write(_LENGTH.pack(len(body)) + body)
    stream.flush()


def _run(request: bytes, out: int) -> int:
    """One decomposition, in the forked child: the hulls (or the error) written to ``out``; the exit status."""
    with np.load(io.BytesIO(request)) as data:
        vertices, faces = data["vertices"], data["faces"]
        options = json.loads(str(data["options"]))
        cpu_limit_s = int(data["cpu_limit_s"])
    # past the soft limit the kernel sends SIGXCPU, which the parent reads as the run's time-out
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_limit_s, cpu_limit_s + 5))
    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(coacd.Mesh(vertices, faces), **options)
    except Exception as exc:  # noqa: BLE001 - CoACD surfaces C++ failures as assorted Python errors
        answer, status = f"{type(exc).__name__}: {exc}".encode(), 1
    else:
        buffer = io.BytesIO()
        np.savez(buffer, *[np.asarray(v, dtype=np.float64) for v, _ in parts])
        answer, status = buffer.getvalue(), 0
    with os.fdopen(out, "wb") as stream:
        stream.write(answer)
    return status


def main() -> int:
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    while (request := read_frame(stdin)) is not None:
        read_end, write_end = os.pipe()
        pid = os.fork()
        if pid == 0:  # the run's child: whatever CoACD prints must not reach the server's framed stdout
            os.close(read_end)
            os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
            status = 1
            try:
                status = _run(request, write_end)
            finally:
                os._exit(status)
        os.close(write_end)
        with os.fdopen(read_end, "rb") as answer:
            body = answer.read()  # to the end: the child has exited or closed it
        _, wait_status, usage = os.wait4(pid, 0)
        header: dict[str, float] = ({"signal": os.WTERMSIG(wait_status)} if os.WIFSIGNALED(wait_status)
                                    else {"exit": os.waitstatus_to_exitcode(wait_status)})
        # the child is this server's to reap, so its CPU reaches the parent only in words
        header["cpu_s"] = usage.ru_utime + usage.ru_stime
        write_frame(stdout, json.dumps(header).encode() + b"\n" + body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
