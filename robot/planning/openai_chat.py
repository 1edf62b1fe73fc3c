"""A chat model behind any OpenAI-compatible HTTP server (OpenAI, Groq, Ollama, vLLM, llama.cpp's server, ...),
through the `openai` client with its `base_url`.

Servers differ in how they constrain output to a JSON schema: OpenAI, Groq, vLLM and Ollama take
`response_format={"type": "json_schema", ...}`; llama.cpp's servers take `{"type": "json_object", "schema": ...}`.
`response_format="auto"` tries them in that order and then plain prompting, and remembers what each server took
(for the life of the process, whichever client asks).

Replies are streamed, so a reply still coming at the deadline is cut there: the connection is closed, which stops
the generation on servers that watch for it (llama-cpp-python's does), instead of leaving it running for a client
that gave up. `max_tokens` caps a reply that rambles.
"""

from __future__ import annotations

import threading
import time
from typing import Any, Literal

from robot.planning.planner import PlanningError
from robot.planning.prompt import Message

ResponseFormat = Literal["auto", "json_schema", "json_object", "none"]
_AUTO_ORDER: tuple[ResponseFormat, ...] = ("json_schema", "json_object", "none")
# (base URL, model) -> the response format that server took
_TAKEN: dict[tuple[str, str], ResponseFormat] = {}
_TAKEN_LOCK = threading.Lock()


class OpenAIChat:
    name = "openai"

    def __init__(
        self,
        base_url: str,
        model: str,
        api_key: str = "",
        timeout_s: float = 20.0,
        response_format: ResponseFormat = "auto",
        max_tokens: int = 512,
    ) -> None:
        import openai  # imported here: the rules planner must work without it

        self._openai = openai
        self.base_url = base_url
        self.model = model
        self.timeout_s = timeout_s
        self.max_tokens = max_tokens
        self.finds_out = response_format == "auto"  # tries the formats in turn (else asks one way only)
        with _TAKEN_LOCK:
            taken = _TAKEN.get((base_url, model))
        self.response_format: ResponseFormat = taken if self.finds_out and taken else response_format
        # Local servers want no key, but the client insists on one.
        self._client = openai.OpenAI(
            base_url=base_url, api_key=api_key or "not-needed", timeout=timeout_s, max_retries=0
        )
        self._lock = threading.Lock()

    def describe(self) -> str:
        return f"{self.model} at {self.base_url}"

    def chat(self, messages: list[Message], schema: dict[str, Any]) -> str:
        with self._lock:
            known = self.response_format
        if not self.finds_out:
            modes: tuple[ResponseFormat, ...] = (known,)
        else:  # from what the server took last (if known) down to plain prompting
            modes = _AUTO_ORDER[_AUTO_ORDER.index(known) :] if known != "auto" else _AUTO_ORDER
        last_refusal: PlanningError | None = None
        for candidate in modes:
            try:
                answer = self._complete(messages, schema, candidate)
            except self._openai.APIStatusError as exc:
                # 400/422, or a 500 naming the field or any 5xx while finding out what the server takes
                # (llama-cpp-python's server answers json_schema so): it does not take this format
                refused = isinstance(exc, self._openai.BadRequestError | self._openai.UnprocessableEntityError) or (
                    candidate != "none"
                    and (
                        "response_format" in str(getattr(exc, "body", "") or exc)
                        or (self.finds_out and exc.status_code >= 500)
                    )
                )
                if not refused:
                    raise PlanningError(f"{self.describe()} answered {_status_text(exc)}") from exc
                if not self.finds_out:
                    raise PlanningError(f"{self.describe()} refused the request: {_status_text(exc)}") from exc
                last_refusal = PlanningError(f"{self.describe()} refused every response format: {_status_text(exc)}")
                continue
            except self._openai.APITimeoutError as exc:
                raise PlanningError(f"{self.describe()} timed out after {self.timeout_s:g} s") from exc
            except self._openai.APIConnectionError as exc:
                raise PlanningError(f"cannot reach {self.base_url}: {exc.__cause__ or exc}") from exc
            except self._openai.OpenAIError as exc:
                raise PlanningError(f"{self.describe()} failed: {exc}") from exc
            if self.finds_out:  # what this server takes: every client asks that way from now on
                with self._lock:
                    self.response_format = candidate
                with _TAKEN_LOCK:
                    _TAKEN[(self.base_url, self.model)] = candidate
            return answer
        assert last_refusal is not None
        raise last_refusal

    def _complete(self, messages: list[Message], schema: dict[str, Any], mode: ResponseFormat) -> str:
        extra: dict[str, Any] = {}
        if mode == "json_schema":
            extra["response_format"] = {"type": "json_schema", "json_schema": {"name": "plan", "schema": schema}}
        elif mode == "json_object":
            extra["response_format"] = {"type": "json_object", "schema": schema}
        deadline = time.monotonic() + self.timeout_s
        stream = self._client.chat.completions.create(
            model=self.model,
            messages=messages,  # type: ignore[arg-type]
            temperature=0.0,
            max_tokens=self.max_tokens,
            stream=True,
            **extra,
        )
        parts: list[str] = []
        try:
            for chunk in stream:
                if chunk.choices:
                    parts.append(chunk.choices[0].delta.content or "")
                if time.monotonic() > deadline:
                    raise PlanningError(f"{self.describe()} timed out after {self.timeout_s:g} s")
        finally:
            stream.close()  # the server sees the connection close and stops generating
        content = "".join(parts)
        if not content.strip():
            raise PlanningError(f"{self.describe()} returned an empty message")
        return content


def _status_text(exc: Any) -> str:
    status = getattr(exc, "status_code", "?")
    body = getattr(exc, "body", None)
    message = body.get("message") if isinstance(body, dict) else None
    if isinstance(body, dict) and isinstance(body.get("error"), dict):
        message = body["error"].get("message", message)
    text = str(message or exc)
    return f"HTTP {status}: {text[:200]}"
