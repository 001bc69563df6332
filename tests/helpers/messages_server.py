"""A loopback HTTP server that speaks enough of the Anthropic Messages API for the SDK client.

Each POST /v1/messages is recorded (headers and JSON body) and answered by
the ``responder``: a callable taking the request body and returning a
:class:`Reply`. The default responder answers every stage with the offline
library, so the real SDK client runs end to end with no key and no internet.
The server listens on 127.0.0.1 only, takes a bounded number of bounded
requests, and stops itself after ``lifetime_s`` should a test never close it.
(:mod:`chat_server` serves OpenAI's chat completions on the same server.)
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from rail_mj.llm import offline
from rail_mj.llm.schemas import (
    AgentModelRequest,
    AnalyzerRequest,
    FunctionalPoseRequest,
    LayoutRequest,
    PlannerRequest,
    ScoringRequest,
    TrajectoryRequest,
)

__all__ = ["Reply", "MessagesServer", "error_reply", "offline_answer", "request_payload", "schema_title", "text_reply"]


@dataclass
class Reply:
    """What the server sends back: an HTTP status, a body, headers, after an optional delay.

    ``body`` is sent as JSON (any JSON value); ``raw`` text, when given, is sent instead, verbatim.
    """

    status: int
    body: Any
    headers: dict[str, str] = field(default_factory=dict)
    delay_s: float = 0.0
    raw: str | None = None


def text_reply(text: str, model: str = "test-model") -> Reply:
    """A successful Messages API answer whose only content block is ``text``."""
    return Reply(200, {
        "id": "msg_test", "type": "message", "role": "assistant", "model": model,
        "content": [{"type": "text", "text": text}],
        "stop_reason": "end_turn", "stop_sequence": None,
        "usage": {"input_tokens": 10, "output_tokens": 10},
    })


def error_reply(status: int, kind: str) -> Reply:
    """An API error; ``retry-after-ms`` keeps the SDK's backoff short."""
    return Reply(status, {"type": "error", "error": {"type": kind, "message": f"test {kind}"}},
                 headers={"retry-after-ms": "10"})


def schema_title(body: dict[str, Any]) -> str:
    """The title of the structured-output JSON schema the SDK sent (the stage's answer type)."""
    return body["output_config"]["format"]["schema"]["title"]


def request_payload(body: dict[str, Any]) -> dict[str, Any]:
    """The stage request JSON from the first user message (``Request:\\n{...}``), in either API's shape (OpenAI's
    messages open with the system prompt; a message's content is text or a list of text blocks)."""
    content = next(m["content"] for m in body["messages"] if m["role"] == "user")
    # with pictures, the request is the first text block; each picture follows its caption
    text = content if isinstance(content, str) else next(b["text"] for b in content if b.get("type") == "text")
    return json.loads(text.split("\n", 1)[1])


_STAGE_REQUESTS = {
    "AffordanceAnalysis": (AnalyzerRequest, lambda r: offline.offline_analysis(r.task)),
    "AgentModel": (AgentModelRequest, lambda r: offline.offline_agent(r.task)),
    "AgentLayout": (LayoutRequest, lambda r: offline.offline_layout(r.task)),
    "MotionPlans": (PlannerRequest, lambda r: offline.offline_plans(r.task)),
    "Trajectories": (TrajectoryRequest, lambda r: offline.offline_trajectories(r.task, r.layout)),
    "ScoringCode": (ScoringRequest, lambda r: offline.offline_scoring(r.task)),
    "FunctionalPoseVerdict": (FunctionalPoseRequest, offline.offline_functional_poses),
}


def offline_answer(body: dict[str, Any]) -> Reply:
    """Answer a stage request the way the offline library would."""
    request_type, answer = _STAGE_REQUESTS[schema_title(body)]
    return text_reply(answer(request_type.model_validate(request_payload(body))).model_dump_json(), body["model"])


class MessagesServer:
    """ThreadingHTTPServer on 127.0.0.1 with an ephemeral port; use as a context manager.

    POSTs to ``path`` go to the responder; other paths get 404, bodies over ``max_body`` bytes 413, and
    requests after the first ``max_requests`` 503.
    """

    def __init__(self, responder: Callable[[dict[str, Any]], Reply] = offline_answer, *,
                 path: str = "/v1/messages", max_requests: int = 200, max_body: int = 8 << 20,
                 lifetime_s: float = 120.0) -> None:
        self.responder = responder
        self.requests: list[dict[str, Any]] = []
        self.headers: list[dict[str, str]] = []
        self._lock = threading.Lock()
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
                size = int(self.headers.get("content-length", 0))
                if size > max_body:
                    self.close_connection = True
                    self._send(Reply(413, {"error": {"type": "too_large", "message": f"{size} bytes"}}))
                    return
                body = json.loads(self.rfile.read(size) or b"{}")
                with server._lock:
                    server.requests.append(body)
                    server.headers.append(dict(self.headers))
                    served = len(server.requests)
                if served > max_requests:
                    reply = Reply(503, {"error": {"type": "test_server_limit", "message": f"over {max_requests}"}})
                elif self.path.split("?")[0] != path:
                    reply = Reply(404, {"type": "error", "error": {"type": "not_found_error", "message": self.path}})
                else:
                    reply = server.responder(body)
                self._send(reply)

            def _send(self, reply: Reply) -> None:
                time.sleep(reply.delay_s)
                data = (json.dumps(reply.body) if reply.raw is None else reply.raw).encode()
                try:
                    self.send_response(reply.status)
                    self.send_header("content-type", "application/json")
                    self.send_header("content-length", str(len(data)))
                    for k, v in reply.headers.items():
                        self.send_header(k, v)
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (timeout test)

            def log_message(self, *args: Any) -> None:
                pass

        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, daemon=True)
        self._timer = threading.Timer(lifetime_s, self._httpd.shutdown)
        self._timer.daemon = True

    @property
    def base_url(self) -> str:
        host, port = self._httpd.server_address[:2]
        return f"http://{host}:{port}"

    def __enter__(self) -> "MessagesServer":
        self._thread.start()
        self._timer.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._timer.cancel()
        self._httpd.shutdown()
        self._httpd.server_close()
