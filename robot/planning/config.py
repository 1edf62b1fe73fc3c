"""Which planner the robot uses and how to reach its model: plain values, light to import (the settings and every
process read them; the planners themselves load word tables and compile patterns)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Backend = Literal["rules", "openai", "local"]
BACKENDS: tuple[Backend, ...] = ("rules", "openai", "local")


@dataclass(frozen=True)
class PlannerConfig:
    """Plain values (they cross to the worker's process): which backend, and how to reach its model."""

    backend: Backend = "rules"
    openai_base_url: str = "http://127.0.0.1:8080/v1"
    openai_api_key: str = ""
    openai_model: str = "llama-3.3-70b-versatile"
    openai_timeout_s: float = 20.0
    openai_response_format: Literal["auto", "json_schema", "json_object", "none"] = "auto"
    local_model_path: str = ""
    local_threads: int | None = None
    local_timeout_s: float = 20.0
    local_chat_format: str = ""  # for a GGUF without a chat template; "" chooses from its model family
    max_repairs: int = 1  # re-asks of an LLM whose plan does not validate, with the errors
    fallback_to_rules: bool = True
