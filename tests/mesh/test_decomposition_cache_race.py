"""One cache folder for many nodes: processes writing the same hull and stable-pose keys at once leave whole entries.

Two writer processes start together (a file both wait for) on the same objects and cache folder, so both miss
the cache and write each key at about the same moment, while a third process reads every entry it can see,
as a node reading shared storage would. Then two processes write different data to one path through the
writer both caches use, many times, while the reader checks each read is one writer's data, whole.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

from paths import REPO

from rail_mj.core.paths import CACHE_ENV

GUARD_S = 300  # only against a hang

#: computes the hulls and stable poses of a few small convex solids into $RAIL_MJ_CACHE once GO exists
WRITER = """
import json, sys, time
from pathlib import Path

import trimesh
from rail_mj.mesh.object import object_from_mesh
from rail_mj.stable_poses import find_stable_poses

go, done = Path(sys.argv[1]), Path(sys.argv[2])
solids = [trimesh.creation.box(extents=(0.1 + 0.05 * i, 0.08, 0.04)) for i in range(3)]
solids.append(trimesh.creation.cylinder(radius=0.05, height=0.12, sections=24))
while not go.exists():
    time.sleep(0.001)
out = []
for i, mesh in enumerate(solids):
    obj = object_from_mesh(mesh, name=f"solid{i}")
    poses = find_stable_poses(obj, n_drops=8, seed=0)
    out.append({"hulls": [h.tolist() for h in obj.hulls], "ups": [p.up_in_mesh_frame.tolist() for p in poses]})
done.write_text(json.dumps(out))
"""

#: reads every cache entry it sees (not the writers' temporary files) until STOP exists; prints what failed
READER = """
import json, sys, time
from pathlib import Path

import numpy as np
from rail_mj.stable_poses.poses import _from_json

cache, stop = Path(sys.argv[1]), Path(sys.argv[2])
reads, bad = 0, []
while True:
    last = stop.exists()
    for path in [*cache.glob("hulls/*.npz"), *cache.glob("stable_poses/*.json")]:
        if path.name.endswith(".tmp"):
            continue
        try:
            if path.suffix == ".npz":
                with np.load(path) as data:
                    assert all(np.isfinite(data[k]).all() and data[k].shape[1] == 3 for k in data.files)
            else:
                _from_json(path.read_text())
            reads += 1
        except FileNotFoundError:
            continue
        except Exception as exc:
            bad.append(f"{path.name}: {type(exc).__name__}: {exc}")
    if last:
        break
print(json.dumps({"reads": reads, "bad": bad}))
"""

#: writes its own payload (a byte repeated) to one path N times with the caches' writer
SAME_PATH_WRITER = """
import sys
from pathlib import Path
from rail_mj.core.runfiles import atomic_write_bytes

path, byte, n = Path(sys.argv[1]), sys.argv[2].encode(), int(sys.argv[3])
for _ in range(n):
    atomic_write_bytes(path, byte * 200_000)
"""

#: reads PATH until STOP exists; prints how many reads were one payload, whole, and what else it saw
SAME_PATH_READER = """
import json, sys
from pathlib import Path

path, stop = Path(sys.argv[1]), Path(sys.argv[2])
whole, bad = 0, []
while not stop.exists():
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        continue
    if len(data) == 200_000 and data.count(data[:1]) == len(data):
        whole += 1
    else:
        bad.append(f"{len(data)} bytes, {len(set(data))} distinct")
print(json.dumps({"whole": whole, "bad": bad[:5]}))
"""


def _start(code: str, *args: object, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", code, *map(str, args)], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _result(proc: subprocess.Popen) -> str:
    try:
        out, err = proc.communicate(timeout=GUARD_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError("a racing process hung") from None
    assert proc.returncode == 0, err
    return out


def test_two_writers_of_the_same_hull_and_pose_keys_leave_whole_entries(tmp_path):
    cache, go, stop = tmp_path / "cache", tmp_path / "go", tmp_path / "stop"
    env = {**os.environ, CACHE_ENV: str(cache),
           "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)}
    writers = [_start(WRITER, go, tmp_path / f"done{i}", env=env) for i in range(2)]
    reader = _start(READER, cache, stop, env=env)
    time.sleep(2.0)  # both writers past their imports, waiting on GO
    go.touch()
    for w in writers:
        _result(w)
    stop.touch()
    seen = json.loads(_result(reader))
    assert seen["bad"] == [] and seen["reads"] > 0
    one, two = (json.loads((tmp_path / f"done{i}").read_text()) for i in range(2))
    assert one == two  # what each writer computed (or read back from the other) is the same
    assert len(list(cache.glob("hulls/*.npz"))) == 4 and len(list(cache.glob("stable_poses/*.json"))) == 4
    assert not [p for p in cache.rglob("*") if p.name.endswith(".tmp")]  # no temporary file left behind


def test_two_writers_of_one_path_never_mix_their_data(tmp_path):
    path, stop = tmp_path / "entry.npz", tmp_path / "stop"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)}
    reader = _start(SAME_PATH_READER, path, stop, env=env)
    writers = [_start(SAME_PATH_WRITER, path, byte, 300, env=env) for byte in "AB"]
    for w in writers:
        _result(w)
    stop.touch()
    seen = json.loads(_result(reader))
    assert seen["bad"] == [] and seen["whole"] > 0
    assert path.read_bytes() in (b"A" * 200_000, b"B" * 200_000)
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []
