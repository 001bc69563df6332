"""The LLM options every command that imagines takes (``--model``, ``--llm-timeout``, ``--max-repairs``): they reach
the provider, and a server that never answers is given up on after ``--llm-timeout`` with an error naming it."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import trimesh
from paths import REPO

from rail_mj.eval import cli as eval_cli
from rail_mj.pipeline import cli as classify_cli
from rail_mj.pipeline.chain import Pipeline, provider_for
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot import __main__ as robot_cli

LLM = ["--model", "llama3.1", "--llm-timeout", "300", "--max-repairs", "5"]


class SilentServer:
    """A loopback TCP server that takes every connection and reads the request, then never answers."""

    def __init__(self) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.open: list[socket.socket] = []
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.sock.getsockname()[1]}/v1"

    def _serve(self) -> None:
        deadline = time.monotonic() + 120  # bounded: it stops by itself
        while not self.done.is_set() and time.monotonic() < deadline:
            try:
                conn, _ = self.sock.accept()
            except TimeoutError:
                continue
            self.open.append(conn)

    def __enter__(self) -> SilentServer:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.done.set()
        self.thread.join()
        for conn in self.open:
            conn.close()
        self.sock.close()


def test_the_llm_options_reach_the_provider_from_every_command_line(tmp_path: Path) -> None:
    expected = {"model": "llama3.1", "llm_timeout": 300.0, "max_retries": 5}
    assert classify_cli.llm_settings(classify_cli._parser().parse_args(["mesh.obj", "-a", "cup", *LLM])) == expected
    cfg = eval_cli._config(eval_cli._parser().parse_args(["--out", str(tmp_path), *LLM]))
    assert (cfg.run.model, cfg.run.llm_timeout, cfg.run.max_retries) == ("llama3.1", 300.0, 5)
    provider = provider_for(RunConfig(provider="openai", provider_options={"base_url": "http://127.0.0.1:9/v1"},
                                      **expected))
    assert (provider.model, provider.config.max_retries) == ("llama3.1", 5)
    assert provider.config.timeout == 300.0  # type: ignore[attr-defined]  # an LLMConfig


def test_the_robot_takes_the_llm_options() -> None:
    args = robot_cli._parser().parse_args(["--request", "put the apple in the bowl", "--provider", "openai", *LLM])
    assert robot_cli.llm_settings(args) == {"model": "llama3.1", "llm_timeout": 300.0, "max_retries": 5}


def test_a_bad_option_value_is_refused_naming_what_is_valid(capsys: pytest.CaptureFixture[str]) -> None:
    for argv, message in ((["--llm-timeout", "0"], "is not a number of seconds > 0"),
                          (["--max-repairs", "-1"], "is not a whole number >= 0")):
        with pytest.raises(SystemExit) as exc:
            eval_cli._parser().parse_args(["--out", "o", *argv])
        assert exc.value.code == 2 and message in capsys.readouterr().err


def test_the_offline_provider_refuses_llm_options_by_name() -> None:
    with pytest.raises(Exception, match=r"offline provider takes no LLM options; got \['model', 'timeout'\]"):
        Pipeline(RunConfig(provider="offline", model="m", llm_timeout=5.0))


def test_a_server_that_never_answers_is_given_up_on_after_the_timeout(tmp_path: Path) -> None:
    mesh = tmp_path / "box.stl"
    trimesh.creation.box(extents=(0.3, 0.2, 0.1)).export(mesh)
    with SilentServer() as server:
        env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "RAIL_MJ_CACHE": str(tmp_path / "cache"),
               "OPENAI_BASE_URL": server.base_url, "RAIL_MJ_MODEL": "m", "JAX_PLATFORMS": "cpu",
               "PYTHONPATH": str(REPO)}
        t = time.monotonic()
        done = subprocess.run([sys.executable, "-m", "rail_mj", str(mesh), "-a", "pet ramp", "--provider", "openai",
                               "--llm-timeout", "2", "--max-repairs", "0", "--backend", "native"],
                              capture_output=True, text=True, env=env, timeout=300)
        took = time.monotonic() - t
    assert done.returncode == 1, done.stderr
    assert "did not answer within 2 s" in done.stderr and "--llm-timeout SECONDS" in done.stderr, done.stderr
    assert took < 120  # the load and the stable poses, then 2 s for the one request: never the 120 s default
