"""A loopback HTTP server that speaks enough of OpenAI's chat-completions API for the openai provider.

The server of :mod:`messages_server` (127.0.0.1 only, bounded requests, stops itself) serving
``POST /v1/chat/completions``: each request is recorded and answered by the ``responder``. The default
responder answers every stage with the offline library, so the provider runs end to end with no key, no
model and no internet.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from messages_server import _STAGE_REQUESTS, MessagesServer, Reply, request_payload

__all__ = ["ChatServer", "chat_error", "completion", "offline_completion", "request_payload", "schema_name"]


def completion(content: str | None, finish_reason: str = "stop", model: str = "test-model",
               **message: Any) -> Reply:
    """A chat completion whose one choice's message holds ``content`` (and any other ``message`` fields)."""
    return Reply(200, {
        "id": "chatcmpl-test", "object": "chat.completion", "created": 0, "model": model,
        "choices": [{"index": 0, "finish_reason": finish_reason,
                     "message": {"role": "assistant", "content": content, "refusal": None, **message}}],
        "usage": {"prompt_tokens": 10, "completion_tokens": 10, "total_tokens": 20},
    })


def chat_error(status: int, message: str = "test error") -> Reply:
    """An API error in OpenAI's shape; ``retry-after-ms`` keeps the provider's backoff short."""
    return Reply(status, {"error": {"message": message, "type": "test_error", "code": None}},
                 headers={"retry-after-ms": "10"})


def schema_name(body: dict[str, Any]) -> str:
    """The name of the structured-output schema the provider sent (the stage's answer type)."""
    return body["response_format"]["json_schema"]["name"]


def offline_completion(body: dict[str, Any]) -> Reply:
    """Answer a stage request the way the offline library would."""
    request_type, answer = _STAGE_REQUESTS[schema_name(body)]
    text = answer(request_type.model_validate(request_payload(body))).model_dump_json()
    return completion(text, model=body["model"])


class ChatServer(MessagesServer):
    """The loopback server at ``/v1/chat/completions``; its ``base_url`` ends in ``/v1`` like OpenAI's."""

    def __init__(self, responder: Callable[[dict[str, Any]], Reply] = offline_completion, **limits: Any) -> None:
        super().__init__(responder, path="/v1/chat/completions", **limits)

    @property
    def base_url(self) -> str:
        return f"{super().base_url}/v1"
