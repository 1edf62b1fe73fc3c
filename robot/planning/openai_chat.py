"""A chat model behind any OpenAI-compatible HTTP server (OpenAI, Groq, Ollama, vLLM, llama.cpp's server, ...),
through the `openai` client with its `base_url`.

Servers differ in how they constrain output to a JSON schema: OpenAI, Groq, vLLM and Ollama take
`response_format={"type": "json_schema", ...}`; llama.cpp's servers take `{"type": "json_object", "schema": ...}`.
`response_format="auto"` tries them in that order and then plain prompting, and remembers what the server took.
"""

from __future__ import annotations

import threading
from typing import Any, Literal

from robot.planning.planner import PlanningError
from robot.planning.prompt import Message

ResponseFormat = Literal["auto", "json_schema", "json_object", "none"]
_AUTO_ORDER: tuple[ResponseFormat, ...] = ("json_schema", "json_object", "none")


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
        self.response_format: ResponseFormat = response_format
        # Local servers want no key, but the client insists on one.
        self._client = openai.OpenAI(
            base_url=base_url, api_key=api_key or "not-needed", timeout=timeout_s, max_retries=0
        )
        self._lock = threading.Lock()

    def describe(self) -> str:
        return f"{self.model} at {self.base_url}"

    def chat(self, messages: list[Message], schema: dict[str, Any]) -> str:
        with self._lock:
            mode = self.response_format
        modes = _AUTO_ORDER if mode == "auto" else (mode,)
        last_refusal: PlanningError | None = None
        for candidate in modes:
            try:
                answer = self._complete(messages, schema, candidate)
            except self._openai.APIStatusError as exc:
                # 400/422, or a 500 naming the field (llama-cpp-python's server): it does not take this format
                refused = isinstance(exc, self._openai.BadRequestError | self._openai.UnprocessableEntityError) or (
                    candidate != "none" and "response_format" in str(getattr(exc, "body", "") or exc)
                )
                if not refused:
                    raise PlanningError(f"{self.describe()} answered {_status_text(exc)}") from exc
                if mode != "auto":
                    raise PlanningError(f"{self.describe()} refused the request: {_status_text(exc)}") from exc
                last_refusal = PlanningError(f"{self.describe()} refused every response format: {_status_text(exc)}")
                continue
            except self._openai.APITimeoutError as exc:
                raise PlanningError(f"{self.describe()} timed out after {self.timeout_s:g} s") from exc
            except self._openai.APIConnectionError as exc:
                raise PlanningError(f"cannot reach {self.base_url}: {exc.__cause__ or exc}") from exc
            except self._openai.OpenAIError as exc:
                raise PlanningError(f"{self.describe()} failed: {exc}") from exc
            if mode == "auto":
                with self._lock:
                    self.response_format = candidate  # what this server takes: ask that way from now on
            return answer
        assert last_refusal is not None
        raise last_refusal

    def _complete(self, messages: list[Message], schema: dict[str, Any], mode: ResponseFormat) -> str:
        extra: dict[str, Any] = {}
        if mode == "json_schema":
            extra["response_format"] = {"type": "json_schema", "json_schema": {"name": "plan", "schema": schema}}
        elif mode == "json_object":
            extra["response_format"] = {"type": "json_object", "schema": schema}
        response = self._client.chat.completions.create(
            model=self.model,
            messages=messages,  # type: ignore[arg-type]
            temperature=0.0,
            max_tokens=self.max_tokens,
            **extra,
        )
        if not response.choices:
            raise PlanningError(f"{self.describe()} returned no choices")
        content = response.choices[0].message.content
        if not content:
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
