"""A chat-completions server that relays each request to files, to record a model this process cannot call.

    python -m rail_mj.llm.relay --dir DIR [--port 8765] [--wait 1800]

Point the OpenAI-compatible provider at it (``OPENAI_BASE_URL=http://127.0.0.1:8765/v1``). Each request becomes
``DIR/NNNN.prompt.md`` (the system prompt, the conversation and the JSON schema the answer must match: everything
the model is shown; its pictures as ``DIR/NNNN-K.png``, named in the prompt where they stand) and
``DIR/NNNN.request.json`` (the body as sent); whoever answers (a person, a model behind
another API, a helper shown nothing but the prompt file) writes the answer's text to ``DIR/NNNN.answer.json``.
The relay sends it back as the completion and appends the exchange to ``DIR/exchanges.jsonl``: the recorded
corpus (:func:`read_exchanges`), which :mod:`rail_mj.llm.replay` serves again with no model. A request nobody
answers within ``--wait`` seconds gets HTTP 504. It listens on 127.0.0.1 only and stops on Ctrl-C.
"""

from __future__ import annotations

import argparse
import base64
import json
import threading
import time
from collections.abc import Sequence
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

__all__ = ["RelayServer", "pictures_of", "prompt_text", "read_exchanges", "main"]

PATH = "/v1/chat/completions"


def pictures_of(body: dict[str, Any]) -> list[bytes]:
    """The PNGs a request carries (``image_url`` blocks with base64 data URLs), in order."""
    return [base64.b64decode(b["image_url"]["url"].split(",", 1)[1])
            for m in body.get("messages", []) if not isinstance(m.get("content"), str)
            for b in m.get("content") or [] if b.get("type") == "image_url"]


def prompt_text(body: dict[str, Any], stem: str = "NNNN") -> str:
    """What the model is shown: every message in order (its k-th picture named as the file ``{stem}-{k}.png``
    beside the prompt), then the schema its answer must match."""
    parts, k = [], 0
    for m in body.get("messages", []):
        content = m.get("content")
        if isinstance(content, str):
            text = content
        else:
            blocks = []
            for b in content or []:
                if b.get("type") == "image_url":
                    k += 1
                    blocks.append(f"[picture: the image file {stem}-{k}.png]")
                else:
                    blocks.append(b.get("text", ""))
            text = "\n\n".join(blocks)
        parts.append(f"## {m.get('role', '?')}\n\n{text}")
    schema = (body.get("response_format") or {}).get("json_schema")
    if schema:
        parts.append(f"## required answer: one JSON object matching this JSON schema "
                     f"({schema.get('name')})\n\n{json.dumps(schema.get('schema'), indent=1)}")
    return "\n\n".join(parts) + "\n"


def read_exchanges(folder: Path) -> list[dict[str, Any]]:
    """The recorded exchanges of a relay folder, in the order they were answered."""
    path = Path(folder) / "exchanges.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


class RelayServer:
    """The relay on 127.0.0.1:``port`` (0: any free port), answering from ``folder``; a context manager."""

    def __init__(self, folder: Path, port: int = 0, wait_s: float = 1800.0) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._n = len(list(self.folder.glob("*.request.json")))
        relay = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
                if self.path.split("?")[0] != PATH:
                    self._send(404, {"error": {"message": f"only POST {PATH}"}})
                    return
                body = json.loads(self.rfile.read(int(self.headers.get("content-length", 0))) or b"{}")
                status, reply = relay.relay(body, wait_s)
                self._send(status, reply)

            def _send(self, status: int, reply: dict[str, Any]) -> None:
                data = json.dumps(reply).encode()
                try:
                    self.send_response(status)
                    self.send_header("content-type", "application/json")
                    self.send_header("content-length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up waiting

            def log_message(self, *args: Any) -> None:
                pass

        self._httpd = ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, daemon=True)

    @property
    def base_url(self) -> str:
        host, port = self._httpd.server_address[:2]
        return f"http://{host}:{port}/v1"

    def relay(self, body: dict[str, Any], wait_s: float) -> tuple[int, dict[str, Any]]:
        """Write the request's files, wait for its answer file, log the exchange; (HTTP status, reply body)."""
        with self._lock:
            self._n += 1
            n = self._n
        stem = self.folder / f"{n:04d}"
        Path(f"{stem}.request.json").write_text(json.dumps(body, indent=1))
        for k, png in enumerate(pictures_of(body), start=1):
            Path(f"{stem}-{k}.png").write_bytes(png)
        Path(f"{stem}.prompt.md").write_text(prompt_text(body, stem.name))
        answer = Path(f"{stem}.answer.json")
        deadline = time.monotonic() + wait_s
        while not answer.exists():
            if time.monotonic() > deadline:
                return 504, {"error": {"message": f"no answer in {answer} within {wait_s:g} s"}}
            time.sleep(0.5)
        time.sleep(0.2)  # let the writer finish the file
        text = answer.read_text()
        schema = ((body.get("response_format") or {}).get("json_schema") or {}).get("name")
        with self._lock, (self.folder / "exchanges.jsonl").open("a") as log:
            log.write(json.dumps({"n": n, "schema": schema, "messages": body.get("messages", []),
                                  "answer": text}) + "\n")
        return 200, {"id": f"relay-{n}", "object": "chat.completion", "created": int(time.time()),
                     "model": body.get("model", "relay"),
                     "choices": [{"index": 0, "finish_reason": "stop",
                                  "message": {"role": "assistant", "content": text, "refusal": None}}]}

    def __enter__(self) -> RelayServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._httpd.shutdown()
        self._httpd.server_close()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rail_mj.llm.relay",
                                     description="A chat-completions server that relays each request to files.")
    parser.add_argument("--dir", type=Path, required=True, help="folder of the requests, answers and exchanges")
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--wait", type=float, default=1800.0, help="seconds a request waits for its answer file")
    args = parser.parse_args(argv)
    with RelayServer(args.dir, args.port, args.wait) as server:
        print(f"relaying {server.base_url}/chat/completions to {args.dir}; Ctrl-C stops", flush=True)
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            return 130


if __name__ == "__main__":
    raise SystemExit(main())
