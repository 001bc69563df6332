"""Local worker processes: fresh interpreters that run tasks from one queue and are replaced when they die.

See :mod:`rail_mj.pipeline.parallel` for how tasks are spread and what a worker's death becomes.
"""

from __future__ import annotations

import importlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Generator, Iterator, Sequence
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import cast

from rail_mj.core.errors import WorkerError
from rail_mj.imagination.config import THREADS_ENV
from rail_mj.pipeline.tasks import ObjectTask, decode_results, failed_results

__all__ = ["serve", "local_tasks"]

#: the thread pools of CoACD (OpenMP) and numpy's BLAS, sized like MuJoCo's in each worker
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_READY = b"ready"
_PARENT_POLL_S = 0.5  # how often a worker checks that its parent still lives
_STOP_GRACE_S = 3.0  # a stopped worker gets this long before SIGKILL
_TAIL_BYTES = 1500  # how much of a dead worker's output goes into the error


def serve(fd: int, modules: Sequence[str] = ()) -> None:
    """A worker's loop: tasks arrive pickled on socket ``fd`` (from the parent, which it trusts), results go
    back as JSON; it ends when the parent closes the socket or dies. ``modules`` (those of the task callables)
    are imported before the worker says it is ready."""
    conn = Connection(fd)
    parent = os.getppid()

    def watch_parent() -> None:
        while os.getppid() == parent:
            time.sleep(_PARENT_POLL_S)
        os._exit(1)  # orphaned (the parent was killed): stop computing for nobody

    threading.Thread(target=watch_parent, daemon=True).start()
    for module in modules:  # the slow imports, before saying ready
        importlib.import_module(module)
    conn.send_bytes(_READY)
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        conn.send_bytes(task.run(task).encode())


class _Worker:
    """One worker process and its end of the socket; its output goes to a temporary file."""

    def __init__(self, threads: int, modules: Sequence[str]):
        ours, theirs = socket.socketpair()
        self.log = tempfile.TemporaryFile()
        package_root = str(Path(__file__).resolve().parents[2])  # the rail_mj this process runs
        env = {**os.environ, THREADS_ENV: str(threads), **{v: str(threads) for v in _THREAD_VARS}}
        env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c",
                 "import sys; from rail_mj.pipeline.local_pool import serve; serve(int(sys.argv[1]), sys.argv[2:])",
                 str(theirs.fileno()), *modules],
                pass_fds=(theirs.fileno(),), env=env, stdin=subprocess.DEVNULL, stdout=self.log,
                stderr=subprocess.STDOUT, start_new_session=True,
            )
        except OSError as exc:
            self.log.close()
            ours.close()
            raise WorkerError(f"could not start a worker process ({exc}); run with workers=1") from exc
        finally:
            theirs.close()
        self.conn = Connection(ours.detach())
        self.ready = False
        self.task: ObjectTask | None = None

    def death(self) -> str:
        """Why the worker's socket closed: its exit status and the end of its output."""
        try:
            code = self.proc.wait(timeout=_STOP_GRACE_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        how = f"was killed by {signal.Signals(-code).name}" if code < 0 else f"exited with status {code}"
        self.log.seek(max(0, self.log.seek(0, os.SEEK_END) - _TAIL_BYTES))
        tail = self.log.read().decode("utf-8", "replace").strip()
        return f"the worker process (pid {self.proc.pid}) {how}" + (f"; its last output: {tail}" if tail else "")


def _stop(workers: Sequence[_Worker]) -> None:
    """Close every socket (an idle worker then exits), SIGTERM the busy and starting ones, SIGKILL whatever
    is left after the grace time, and free the logs."""
    for w in workers:
        w.conn.close()
        if w.task is not None or not w.ready:
            w.proc.terminate()
    deadline = time.monotonic() + _STOP_GRACE_S
    for w in workers:
        try:
            w.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            w.proc.kill()
            w.proc.wait()
        w.log.close()


def local_tasks(
    tasks: Sequence[ObjectTask], n: int, threads: int
) -> Generator[tuple[ObjectTask, list], None, None]:
    queue = deque(tasks)
    modules = sorted({t.run.__module__ for t in tasks})
    workers: list[_Worker] = []
    try:
        for _ in range(n):
            workers.append(_Worker(threads, modules))
        while queue or any(w.task is not None for w in workers):
            live = [w for w in workers if w.task is not None or not w.ready]
            by_conn = {w.conn: w for w in live}
            try:
                ready = cast(list[Connection], wait(list(by_conn)))  # wait returns some of those it is given
            except KeyboardInterrupt:
                yield from _drain(live)
                raise
            for conn in ready:
                w = by_conn[conn]
                try:
                    reply = conn.recv_bytes()
                except (EOFError, OSError):
                    task, w.task = w.task, None
                    why = w.death()
                    if not w.ready:  # never got through its imports: a problem of this machine, not of a mesh
                        raise WorkerError(f"a worker process could not start: {why}; run with workers=1 to see "
                                          "the error in this process") from None
                    workers.remove(w)
                    _stop([w])
                    if queue:
                        workers.append(_Worker(threads, modules))
                    if task is None:  # died between tasks: nothing was lost
                        continue
                    yield task, failed_results(task, f"WorkerError: {why}, while on {task.label}; nothing was recorded "
                                        "for it (run this object alone to see the crash, or leave it out)")
                    continue
                if not w.ready:
                    w.ready = reply == _READY
                else:
                    task, w.task = w.task, None
                    assert task is not None  # a ready worker replies only to a task
                    yield task, decode_results(task, reply.decode())
                if queue and w.ready and w.task is None:
                    w.task = queue.popleft()
                    w.conn.send(w.task)
    finally:
        _stop(workers)


def _drain(workers: Sequence[_Worker]) -> Iterator[tuple[ObjectTask, list]]:
    """The results already sent back by busy workers (after a Ctrl-C: finished work is kept)."""
    for w in workers:
        if w.task is None or not w.ready:
            continue
        try:
            if w.conn.poll(0):
                task, w.task = w.task, None
                yield task, decode_results(task, w.conn.recv_bytes().decode())
        except (EOFError, OSError):
            continue

