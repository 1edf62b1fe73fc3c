"""Whether the planner's model can be reached. An OpenAI-compatible server is asked for its model list now and
then, in its own thread (a slow server must never hold the monitor up); the rules planner needs nothing."""

from __future__ import annotations

import os
import threading
import time

import httpx

from robot.interface import DiagnosticStatus, Level
from robot.planning.config import PlannerConfig


class PlannerLink:
    def __init__(self, config: PlannerConfig, period_s: float = 30.0, timeout_s: float = 2.0) -> None:
        self.config = config
        self.period_s = period_s
        self.timeout_s = timeout_s
        self._status = DiagnosticStatus("links/planner", Level.OK, "not checked yet", config.backend)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self.config.backend == "openai" and self._thread is None:
            self._thread = threading.Thread(target=self._run, name="diagnostics-planner-link", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()

    def status(self) -> DiagnosticStatus:
        c = self.config
        if c.backend == "rules":
            return DiagnosticStatus("links/planner", Level.OK, "rules planner (built in)", "rules")
        if c.backend == "local":
            if c.local_model_path and os.path.isfile(c.local_model_path):
                return DiagnosticStatus(
                    "links/planner",
                    Level.OK,
                    f"local model {os.path.basename(c.local_model_path)}",
                    "local",
                    (("model_path", c.local_model_path),),
                )
            return DiagnosticStatus(
                "links/planner", Level.ERROR, f"local model file not found: {c.local_model_path!r}", "local"
            )
        return self._status

    def check_now(self) -> DiagnosticStatus:
        """GET {base_url}/models: answered (even 401: the server is there, the key is wrong) or not."""
        c = self.config
        url = c.openai_base_url.rstrip("/") + "/models"
        headers = {"Authorization": f"Bearer {c.openai_api_key}"} if c.openai_api_key else {}
        started = time.perf_counter()
        try:
            response = httpx.get(url, headers=headers, timeout=self.timeout_s)
            ms = (time.perf_counter() - started) * 1e3
            values = (
                ("url", c.openai_base_url),
                ("model", c.openai_model),
                ("latency_ms", round(ms, 1)),
                ("http_status", response.status_code),
            )
            if response.status_code in (401, 403):
                status = DiagnosticStatus(
                    "links/planner",
                    Level.ERROR,
                    f"{c.openai_base_url} refuses the API key (HTTP {response.status_code}); plans fall back to rules",
                    "openai",
                    values,
                )
            elif response.status_code >= 500:
                status = DiagnosticStatus(
                    "links/planner",
                    Level.WARN,
                    f"{c.openai_base_url} answers HTTP {response.status_code}",
                    "openai",
                    values,
                )
            else:
                status = DiagnosticStatus(
                    "links/planner",
                    Level.OK,
                    f"{c.openai_model} at {c.openai_base_url} ({ms:.0f} ms)",
                    "openai",
                    values,
                )
        except httpx.HTTPError as exc:
            fallback = "; plans fall back to rules" if c.fallback_to_rules else ""
            status = DiagnosticStatus(
                "links/planner",
                Level.ERROR,
                f"{c.openai_base_url} unreachable ({exc}){fallback}",
                "openai",
                (("url", c.openai_base_url),),
            )
        self._status = status
        return status

    def _run(self) -> None:
        while not self._stop.is_set():
            self.check_now()
            self._stop.wait(self.period_s)
