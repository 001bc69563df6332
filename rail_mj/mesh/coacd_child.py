"""Runs one CoACD decomposition in its own process, for :func:`rail_mj.mesh.decomposition.decompose`.

CoACD segfaults on some meshes (a closed scanned pen holder, without its own remeshing), which would take
the caller down with it. The parent sends the mesh and the options as an ``.npz`` on stdin and reads the
hulls back as an ``.npz`` on stdout; a Python error is one line on stderr and exit status 1. Run as a
script (``python path/to/coacd_child.py``), so the child imports numpy and coacd only, not rail_mj. The
parent also sends a CPU-time limit, which the child sets on itself (RLIMIT_CPU).
"""

from __future__ import annotations

import io
import json
import resource
import sys

import numpy as np

__all__ = ["main"]


def main() -> int:
    import coacd

    with np.load(io.BytesIO(sys.stdin.buffer.read())) as data:
        vertices, faces = data["vertices"], data["faces"]
        options = json.loads(str(data["options"]))
        cpu_limit_s = int(data["cpu_limit_s"])
    # past the soft limit the kernel sends SIGXCPU, which the parent reads as the run's time-out
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_limit_s, cpu_limit_s + 5))
    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(coacd.Mesh(vertices, faces), **options)
    except Exception as exc:  # noqa: BLE001 - CoACD surfaces C++ failures as assorted Python errors
        print(f"{type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    out = io.BytesIO()
    np.savez(out, *[np.asarray(v, dtype=np.float64) for v, _ in parts])
    sys.stdout.buffer.write(out.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
