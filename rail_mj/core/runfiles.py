"""Files that stay whole when the process writing them is killed at any moment (SIGKILL included).

* :func:`atomic_write_text` writes a temporary file next to the target, fsyncs it and ``os.replace``\\ s
  the target: readers, and a later run, see the old content or the new, never a part of it.
* :func:`staging_dir` + :func:`publish` build a set of files in a hidden folder inside the destination
  and move them into place once all are written, a marker file (e.g. ``labels.jsonl``) last and only
  after the old marker was removed: where the marker exists, the whole set is there.
* :func:`folder_lock` keeps one run per output folder: an ``fcntl`` lock (filelock) that the kernel
  releases when the holder dies, however it dies, and a sidecar record of the holder (pid, host,
  start time, command) that a second run's error names.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import socket
import sys
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path

from filelock import FileLock, Timeout

from rail_mj.core.errors import FolderInUseError

__all__ = [
    "LOCK_FILE",
    "HOLDER_FILE",
    "STAGING_PREFIX",
    "fsync_dir",
    "write_synced",
    "atomic_write_text",
    "atomic_write_bytes",
    "staging_dir",
    "publish",
    "folder_lock",
]

LOCK_FILE = ".lock"
HOLDER_FILE = ".lock.holder.json"
STAGING_PREFIX = ".partial-"


def fsync_dir(path: Path) -> None:
    """Make a rename or unlink in ``path`` durable (POSIX; a no-op where folders cannot be opened)."""
    if os.name != "posix":
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_synced(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8, ``\\n`` line ends) and fsync it, so a later rename publishes whole data."""
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def atomic_write_text(path: Path, text: str) -> None:
    """Replace ``path`` with ``text`` in one step (temporary file in the same folder, fsync, ``os.replace``)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Replace ``path`` with ``data`` in one step, like :func:`atomic_write_text`. Each writer has its own
    temporary file, so two processes writing the same path at once leave one's data whole, never a mix."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    fsync_dir(path.parent)


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def _remove_abandoned(dest: Path, host: str) -> None:
    """Staging folders of dead processes on this host (killed before they could clean up)."""
    for folder in dest.glob(STAGING_PREFIX + "*"):
        owner_host, _, rest = folder.name[len(STAGING_PREFIX) :].rpartition("@")
        pid = rest.split("-", 1)[0]
        if owner_host == host and pid.isdigit() and not _process_alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


@contextmanager
def staging_dir(dest: str | Path) -> Iterator[Path]:
    """A fresh hidden folder inside ``dest`` (created) to build files in; removed on exit.

    Its name records host and pid, so a later call removes the leftovers of a killed process
    without touching a live one's.
    """
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    host = socket.gethostname()
    _remove_abandoned(dest, host)
    stage = dest / f"{STAGING_PREFIX}{host}@{os.getpid()}-{uuid.uuid4().hex[:8]}"
    stage.mkdir()
    try:
        yield stage
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def publish(stage: Path, dest: Path, marker: str) -> None:
    """Move every file of ``stage`` to the same place under ``dest``, ``marker`` last.

    The old marker goes first, so a kill part way leaves no marker rather than an old marker over
    new files; each file is replaced in one step and files already in ``dest`` that ``stage`` does
    not hold are left alone. Files must be fsynced already (see :func:`write_synced`).
    """
    (dest / marker).unlink(missing_ok=True)
    fsync_dir(dest)
    folders: set[Path] = set()
    for src in sorted(p for p in stage.rglob("*") if p.is_file() and p != stage / marker):
        target = dest / src.relative_to(stage)
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(src, target)
        folders.add(target.parent)
    for folder in folders:
        fsync_dir(folder)
    os.replace(stage / marker, dest / marker)
    fsync_dir(dest)


def _holder_text(folder: Path) -> str:
    try:
        h = json.loads((folder / HOLDER_FILE).read_text(encoding="utf-8"))
        return f"pid {h['pid']} on {h['host']}, started {h['started']}: {h['command']}"
    except (OSError, ValueError, KeyError, TypeError):
        return f"no record in {folder / HOLDER_FILE}: it may have just ended"


@contextmanager
def folder_lock(folder: str | Path, *, advice: str) -> Iterator[None]:
    """Hold ``folder``'s lock for the block, or raise :class:`FolderInUseError` naming the holder.

    Never waits: a second run on the same folder fails at once. ``advice`` ends the error message
    (what the user can do). The folder is created.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lock = FileLock(folder / LOCK_FILE, timeout=0)
    try:
        lock.acquire()
    except Timeout:
        raise FolderInUseError(f"{folder} is in use by another run ({_holder_text(folder)}); {advice}") from None
    try:
        holder = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "command": shlex.join([Path(sys.executable).name, *sys.argv]),
        }
        atomic_write_text(folder / HOLDER_FILE, json.dumps(holder) + "\n")
        yield
    finally:
        (folder / HOLDER_FILE).unlink(missing_ok=True)
        lock.release()
