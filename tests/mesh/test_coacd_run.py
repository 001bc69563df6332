"""CoACD runs in child processes forked by a kept server: the hulls, the errors, the limits."""

from __future__ import annotations

import io
import os
import resource
import signal
from collections.abc import Iterator
from typing import Any

import coacd
import numpy as np
import pytest
import trimesh
from meshes import small_cup  # tests/helpers

import rail_mj.mesh.coacd_run as coacd_run
from rail_mj.core.errors import ConfigError, DecompositionError, DecompositionTimeout
from rail_mj.mesh import DecompositionConfig
from rail_mj.mesh.coacd_child import read_frame, write_frame
from rail_mj.mesh.decomposition import _run_coacd

OPTIONS: dict[str, Any] = dict(threshold=0.05, max_convex_hull=8, preprocess_mode="off", preprocess_resolution=30,
                               resolution=500, mcts_nodes=10, mcts_iterations=10, mcts_max_depth=2, decimate=True,
                               max_ch_vertex=32, seed=0)


def arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int32)


@pytest.fixture
def own_servers(monkeypatch: pytest.MonkeyPatch) -> Iterator[list]:
    """A test's own idle servers, none of another test's; those it leaves are stopped."""
    idle: list = []
    monkeypatch.setattr(coacd_run, "_idle", idle)
    yield idle
    for server in list(idle):
        coacd_run._discard(server)


def test_a_run_gives_coacds_own_hulls_and_its_server_serves_the_next(own_servers) -> None:
    vertices, faces = arrays(small_cup())
    first = coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)
    (server,) = own_servers
    again = coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)
    assert own_servers == [server] and server.poll() is None  # one server, kept, not a new one per run
    coacd.set_log_level("error")
    here = [np.asarray(v, dtype=np.float64) for v, _ in coacd.run_coacd(coacd.Mesh(vertices, faces), **OPTIONS)]
    assert len(first) == len(here) > 1
    for a, b, c in zip(first, again, here, strict=True):
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(b, c)


def test_the_runs_cpu_is_counted_though_their_server_reaps_them(own_servers) -> None:
    vertices, faces = arrays(small_cup())
    before = coacd_run.cpu_seconds()
    coacd_run.coacd_child(vertices, faces, {**OPTIONS, "preprocess_mode": "on"}, 60.0)  # remeshing: ~1 s of CPU
    assert coacd_run.cpu_seconds() - before > 0.1  # CoACD's own seconds, from the server's reaping
    assert len(own_servers) == 1  # and the server lives on, so RUSAGE_CHILDREN has none of them yet


def test_a_python_error_in_the_run_is_named_and_the_server_lives_on(own_servers) -> None:
    vertices, faces = arrays(small_cup())
    with pytest.raises(DecompositionError, match=r"CoACD failed \(TypeError: .*'no_such_option'"):
        coacd_run.coacd_child(vertices, faces, {**OPTIONS, "no_such_option": 1}, 60.0)
    (server,) = own_servers
    assert len(coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)) > 1
    assert own_servers == [server]


def test_a_server_that_died_is_replaced(own_servers) -> None:
    vertices, faces = arrays(small_cup())
    coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)
    (server,) = own_servers
    os.kill(server.pid, signal.SIGKILL)
    server.wait()
    assert len(coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)) > 1
    (fresh,) = own_servers
    assert fresh.pid != server.pid


def test_a_run_past_its_cpu_limit_is_stopped_however_loaded_the_machine(own_servers) -> None:
    # the run's child sets RLIMIT_CPU on itself; CoACD remeshing a cup needs several CPU seconds
    with pytest.raises(DecompositionTimeout, match=r"within 1 s of CPU"):
        _run_coacd(small_cup(), DecompositionConfig(preprocess_mode="on", time_limit_s=1))
    assert len(own_servers) == 1  # the server itself lives on


def test_a_run_past_its_wall_time_is_stopped_with_its_server(tmp_path, monkeypatch, own_servers) -> None:
    hang = tmp_path / "hang"
    hang.write_text("#!/bin/sh\nexec sleep 60\n")
    hang.chmod(0o755)
    monkeypatch.setattr(coacd_run.sys, "executable", str(hang))
    monkeypatch.setattr(coacd_run, "_WALL_SLACK_S", 0.0)
    with pytest.raises(DecompositionTimeout, match=r"within 2 s of wall time .*time_limit_s"):
        _run_coacd(small_cup(), DecompositionConfig(preprocess_mode="off", time_limit_s=0.5))
    assert own_servers == []  # killed, not kept
    with pytest.raises(ConfigError, match="time_limit_s"):
        DecompositionConfig(time_limit_s=0)


def test_a_frame_cut_short_reads_as_the_end() -> None:
    stream = io.BytesIO()
    write_frame(stream, b"hulls")
    whole = stream.getvalue()
    assert read_frame(io.BytesIO(whole)) == b"hulls"
    assert read_frame(io.BytesIO(whole[:-1])) is None
    assert read_frame(io.BytesIO(whole[:3])) is None
    assert read_frame(io.BytesIO(b"")) is None


def test_a_forked_copy_of_the_process_starts_servers_of_its_own(own_servers) -> None:
    vertices, faces = arrays(small_cup())
    coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)
    (server,) = own_servers
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the copy: no server of the parent's to take, and a run of its own works
        status = 1
        try:
            idle_before = len(coacd_run._idle)
            hulls = coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)
            ok = idle_before == 0 and len(hulls) > 1 and coacd_run._idle[0].pid != server.pid
            os.write(write_end, b"ok" if ok else b"no")
            for mine in list(coacd_run._idle):
                coacd_run._discard(mine)
            status = 0
        finally:
            os._exit(status)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as answer:
        said = answer.read()
    os.waitpid(pid, 0)
    assert said == b"ok"
    assert own_servers == [server] and server.poll() is None


def test_a_caller_with_over_1024_open_files_is_served(own_servers) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 1200:
        pytest.skip(f"this machine allows {hard} open files")
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, 1200), hard))
    files = [os.open(os.devnull, os.O_RDONLY) for _ in range(1100)]  # the server's pipes get numbers past 1,024
    try:
        vertices, faces = arrays(small_cup())
        assert len(coacd_run.coacd_child(vertices, faces, OPTIONS, 60.0)) > 1
    finally:
        for fd in files:
            os.close(fd)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
