"""A chat model run in this process by llama-cpp-python from a GGUF file, for robots with no network.

An optional extra (`pip install .[local-llm]`): it compiles llama.cpp on install (about 3 minutes on 2 cores). Output is
constrained by a grammar built from the plan's JSON schema, so a small model still answers in the right shape.

A GGUF usually carries its chat template. One that does not (a base model, such as the Gemma 3 270M that ships in
packages) would be prompted in llama.cpp's fallback, Llama 2's [INST] format, which its family never saw: it is
prompted in its own family's format instead (`chat_format`, or chosen from the file's architecture).
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path
from typing import Any

from robot.planning.planner import PlanningError
from robot.planning.prompt import Message

# a model family (the GGUF's general.architecture) -> the chat format of its instruction-tuned models
FAMILY_CHAT_FORMATS = {
    "gemma": "gemma",
    "gemma2": "gemma",
    "gemma3": "gemma",
    "llama": "llama-3",
    "qwen2": "chatml",
    "qwen3": "chatml",
    "phi3": "chatml",
    "mistral": "mistral-instruct",
}


class LocalChat:
    name = "local"

    def __init__(
        self,
        model_path: str,
        n_ctx: int = 4096,
        n_threads: int | None = None,
        max_tokens: int = 512,
        timeout_s: float = 20.0,
        chat_format: str = "",
    ) -> None:
        path = Path(model_path).expanduser()
        if not model_path or not path.is_file():
            raise PlanningError(f"local model file not found: {model_path!r} (set HUMANOID_LOCAL_MODEL_PATH to a GGUF)")
        # llama.cpp's OpenMP threads spin while they wait for each other: on a busy machine (the control loop, the
        # browsers) a reply took 20x longer (47 s instead of 2.3 s on 2 cores) and took CPU from the robot. Waiting
        # threads sleep instead; read when the library loads, so set before its first import.
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
        try:
            import llama_cpp
        except ImportError as exc:
            raise PlanningError(
                "the local backend needs llama-cpp-python: pip install '.[local-llm]' (it builds llama.cpp)"
            ) from exc
        self.model_path = path
        self.max_tokens = max_tokens
        self.timeout_s = timeout_s
        self._llama = llama_cpp.Llama(model_path=str(path), n_ctx=n_ctx, n_threads=n_threads, verbose=False)
        self.chat_format = chat_format or self._own_format()
        if self.chat_format:
            self._llama.chat_format = self.chat_format
        self._lock = threading.Lock()  # one generation at a time: the model holds one context

    def _own_format(self) -> str:
        """The file's own template when it has one (""), else its family's chat format, else ChatML."""
        metadata = self._llama.metadata
        if metadata.get("tokenizer.chat_template"):
            return ""
        return FAMILY_CHAT_FORMATS.get(metadata.get("general.architecture", ""), "chatml")

    def describe(self) -> str:
        prompted = f", {self.chat_format} chat format" if self.chat_format else ""
        return f"{self.model_path.name} in-process (llama.cpp{prompted})"

    def chat(self, messages: list[Message], schema: dict[str, Any]) -> str:
        """Streams the reply so that a model that rambles is stopped at `timeout_s`, as a server's would be."""
        parts: list[str] = []
        with self._lock:
            deadline = time.monotonic() + self.timeout_s
            try:
                stream = self._llama.create_chat_completion(
                    messages=messages,  # type: ignore[arg-type]
                    response_format={"type": "json_object", "schema": schema},
                    temperature=0.0,
                    max_tokens=self.max_tokens,
                    stream=True,
                )
                for chunk in stream:
                    parts.append(chunk["choices"][0]["delta"].get("content") or "")  # type: ignore[index]
                    if time.monotonic() > deadline:
                        stream.close()  # type: ignore[union-attr]
                        raise PlanningError(f"the local model timed out after {self.timeout_s:g} s")
            except PlanningError:
                raise
            except Exception as exc:  # llama.cpp reports context overflow and the like as plain exceptions
                raise PlanningError(f"the local model failed: {exc}") from exc
        content = "".join(parts)
        if not content.strip():
            raise PlanningError("the local model returned an empty message")
        return content
