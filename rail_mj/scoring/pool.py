"""Parent side of the scoring sandbox: a module-level pool of warm worker processes.

Workers are fresh interpreters (``subprocess`` → fork+exec, safe from a
multithreaded JAX process; no ``multiprocessing`` main-module re-import)
running :mod:`rail_mj.scoring.sandbox` in an empty temporary directory with a
minimal environment (no API keys). Inputs go through a per-worker memfd that
both sides map, so 10k rollouts cost one memcpy; replies are JSON plus raw
float64 bytes, never pickle (requests are pickled: the worker trusts its parent, not the
reverse). A worker that times out or dies is killed and
replaced; one that reports an error in the code stays warm, unless it ends a
call (after its garbage collection) more than :data:`RESTING_SLACK_MB` above
the size it started with: then it is retired and the next call starts a fresh one.
"""

from __future__ import annotations

import atexit
import json
import mmap
import os
import pickle
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from multiprocessing.connection import Connection

import numpy as np

import rail_mj.scoring.sandbox as sandbox
from rail_mj.core.errors import ScoringRuntimeError

__all__ = ["run_in_worker", "warm_up", "close_workers", "worker_count", "RESTING_SLACK_MB", "WorkerStartError"]

#: How far (MB of address space) above its starting size a worker may rest between calls. A call's cap is
#: fixed: the starting size plus its inputs, its ``memory_mb`` and this slack, so what one call leaves behind
#: never raises the next one's cap and every call has at least ``memory_mb`` to itself.
RESTING_SLACK_MB = 16

_START_TIMEOUT_S = 60.0  # a cold interpreter + numpy import on a loaded 2-core box
_GRACE_S = 1.0  # the worker's own alarm answers at timeout_s; the kill is the backstop
_MAX_IDLE = 2
_ALIGN = 64
_MIN_SHM = 1 << 20
_ENV_KEEP = ("PATH", "PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "LANG", "LC_ALL", "LD_LIBRARY_PATH", "TMPDIR")
_THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


class WorkerStartError(ScoringRuntimeError):
    """No scoring worker could be started: a problem of this machine, not of the scoring code."""


def _worker_env() -> dict[str, str]:
    env = {k: os.environ[k] for k in _ENV_KEEP if k in os.environ}
    env.update(_THREAD_ENV)
    return env


def _death_reason(returncode: int | None) -> str:
    if returncode is None:
        return "stopped answering"
    if returncode < 0:
        sig = signal.Signals(-returncode)
        why = {
            signal.SIGXCPU: "hit its CPU-time limit",
            signal.SIGKILL: "was killed (out of memory or timeout)",
            signal.SIGSEGV: "crashed (segmentation fault)",
            signal.SIGXFSZ: "tried to write a file",
        }.get(sig, "was terminated")
        return f"{why} ({sig.name})"
    return f"exited with status {returncode}"


@dataclass(eq=False)
class _Worker:
    proc: subprocess.Popen
    request: Connection
    reply: Connection
    shm_fd: int
    tmpdir: str
    owner_pid: int
    shm: mmap.mmap | None = None
    ready: bool = False

    @classmethod
    def start(cls) -> "_Worker":
        req_r, req_w = os.pipe()
        rep_r, rep_w = os.pipe()
        shm_fd = os.memfd_create("rail_mj_scoring", os.MFD_CLOEXEC)
        tmpdir = tempfile.mkdtemp(prefix="rail_mj_scoring_")
        try:
            proc = subprocess.Popen(
                [sys.executable, "-P", "-B", sandbox.__file__, str(req_r), str(rep_w), str(shm_fd)],
                pass_fds=(req_r, rep_w, shm_fd),
                cwd=tmpdir,
                env=_worker_env(),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError as exc:
            for fd in (req_r, req_w, rep_r, rep_w, shm_fd):
                os.close(fd)
            shutil.rmtree(tmpdir, ignore_errors=True)
            raise WorkerStartError(f"could not start a scoring worker: {exc}") from exc
        os.close(req_r)
        os.close(rep_w)
        return cls(proc, Connection(req_w, readable=False), Connection(rep_r, writable=False), shm_fd, tmpdir,
                   os.getpid())

    def wait_ready(self) -> None:
        if self.ready:
            return
        if not self.reply.poll(_START_TIMEOUT_S):
            raise WorkerStartError(f"the scoring worker did not start within {_START_TIMEOUT_S} s")
        try:
            json.loads(self.reply.recv_bytes(maxlength=4096))
        except (EOFError, OSError, ValueError) as exc:
            raise WorkerStartError(
                f"the scoring worker failed to start: {_death_reason(self.proc.poll())}") from exc
        # the worker has started in its empty folder (Python's start may read it: an empty PYTHONPATH entry);
        # removed now, nothing can be written there, and a parent that exits without its clean-up leaves no folder
        # behind (a forked eval worker's os._exit skips atexit: 269 of them had piled up in /tmp)
        shutil.rmtree(self.tmpdir, ignore_errors=True)
        self.ready = True

    def write_inputs(self, arrays: dict[str, np.ndarray]) -> tuple[int, list]:
        layout, offset = [], 0
        for name, arr in arrays.items():
            layout.append((name, arr.dtype.str, arr.shape, offset))
            offset += -(-arr.nbytes // _ALIGN) * _ALIGN
        if self.shm is None or len(self.shm) < offset:
            size = max(_MIN_SHM, 1 << (offset - 1).bit_length())
            if self.shm is not None:
                self.shm.close()
            os.ftruncate(self.shm_fd, size)
            self.shm = mmap.mmap(self.shm_fd, size)
        for (_name, _dtype, _shape, off), arr in zip(layout, arrays.values()):
            dst = np.frombuffer(self.shm, dtype=arr.dtype, count=arr.size, offset=off).reshape(arr.shape)
            np.copyto(dst, arr)
            del dst
        return len(self.shm), layout

    def close(self) -> None:
        """Stop the process (EOF first, kill if it lingers) and remove its files."""
        if self.owner_pid != os.getpid():
            return  # inherited through fork: the parent owns it
        for conn in (self.request, self.reply):
            conn.close()
        try:
            self.proc.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            self.kill()
        if self.shm is not None:
            self.shm.close()
            self.shm = None
        os.close(self.shm_fd)
        shutil.rmtree(self.tmpdir, ignore_errors=True)

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait()


_LOCK = threading.Lock()
_IDLE: list[_Worker] = []
_LIVE: set[_Worker] = set()


def _acquire() -> _Worker:
    while True:
        with _LOCK:
            if not _IDLE:
                break
            worker = _IDLE.pop()
            if worker.proc.poll() is None:
                return worker
            _LIVE.discard(worker)
        worker.close()  # died while idle (killed from outside): nothing of the caller's ran, start afresh
    worker = _Worker.start()
    with _LOCK:
        _LIVE.add(worker)
    return worker


def _release(worker: _Worker) -> None:
    with _LOCK:
        if len(_IDLE) < _MAX_IDLE:
            _IDLE.append(worker)
            return
        _LIVE.discard(worker)
    worker.close()


def _retire(worker: _Worker) -> None:
    """Stop a worker that rests above its budget (memory it cannot give back); the next call starts afresh."""
    with _LOCK:
        _LIVE.discard(worker)
    worker.kill()
    worker.close()


def _settle(worker: _Worker, header: dict) -> None:
    resting = header.get("resting_mb")
    if isinstance(resting, (int, float)) and resting <= RESTING_SLACK_MB:
        _release(worker)
    else:
        _retire(worker)


def _discard(worker: _Worker) -> str:
    """Kill a worker that timed out or died, start its replacement, and say why it went."""
    if worker.proc.poll() is None:
        worker.kill()
    reason = _death_reason(worker.proc.returncode)
    with _LOCK:
        _LIVE.discard(worker)
    worker.close()
    replacement = _Worker.start()
    with _LOCK:
        _LIVE.add(replacement)
        _IDLE.append(replacement)
    return reason


def run_in_worker(code: bytes, digest: str, arrays: dict[str, np.ndarray], batch: int,
                  timeout_s: float, memory_mb: int) -> np.ndarray:
    """Run compiled scoring ``code`` on ``arrays`` in a warm worker; float64 (batch,) or ScoringRuntimeError."""
    worker = _acquire()
    try:
        worker.wait_ready()
    except ScoringRuntimeError:
        _discard(worker)
        raise
    try:
        shm_size, layout = worker.write_inputs(arrays)
        request = {"digest": digest, "code": code, "arrays": layout, "shm_size": shm_size, "batch": batch,
                   "timeout_s": timeout_s, "memory_mb": memory_mb, "slack_mb": RESTING_SLACK_MB}
        worker.request.send_bytes(pickle.dumps(request, protocol=pickle.HIGHEST_PROTOCOL))
        if not worker.reply.poll(timeout_s + _GRACE_S):
            _discard(worker)
            raise ScoringRuntimeError(
                f"scoring timed out after {timeout_s:g} s (the wall-time limit); its worker was killed")
        header = json.loads(worker.reply.recv_bytes(maxlength=1 << 16))
        raw = worker.reply.recv_bytes(maxlength=8 * batch + 8) if header.get("ok") else None
    except (EOFError, OSError, ValueError) as exc:
        reason = _discard(worker)
        raise ScoringRuntimeError(f"the scoring worker {reason} while running the code") from exc
    except ScoringRuntimeError:
        raise
    except BaseException:
        _discard(worker)  # e.g. KeyboardInterrupt mid-call: its reply would desynchronise the protocol
        raise
    _settle(worker, header)
    if raw is None:
        line = header.get("line")
        where = f" at line {line}" if line else ""
        raise ScoringRuntimeError(f"scoring failed ({header.get('kind')}){where}: {header.get('message')}")
    scores = np.frombuffer(raw, dtype="<f8").astype(np.float64)
    if scores.shape != (batch,) or not np.isfinite(scores).all():
        raise ScoringRuntimeError(f"the scoring worker returned {scores.shape[0]} scores; expected {batch} finite ones")
    return scores


def warm_up(n: int = 1) -> None:
    """Start ``n`` idle workers (at most the pool size) and wait until they are ready."""
    with _LOCK:
        missing = max(0, min(n, _MAX_IDLE) - len(_IDLE))
    started = [_Worker.start() for _ in range(missing)]
    for worker in started:
        worker.wait_ready()
    with _LOCK:
        _LIVE.update(started)
        _IDLE.extend(started)


def worker_count() -> int:
    """Live workers owned by this process (idle or busy)."""
    with _LOCK:
        return sum(1 for w in _LIVE if w.owner_pid == os.getpid())


def close_workers() -> None:
    """Stop every worker of this process; the next call starts a fresh one. Runs at exit."""
    with _LOCK:
        workers = list(_LIVE)
        _LIVE.clear()
        _IDLE.clear()
    for worker in workers:
        worker.close()


def _forget_after_fork() -> None:
    # a forked child must neither use nor kill its parent's workers, nor inherit a held lock
    global _LOCK
    _LOCK = threading.Lock()
    _IDLE.clear()
    _LIVE.clear()


os.register_at_fork(after_in_child=_forget_after_fork)
atexit.register(close_workers)
