"""A fuzz run of the whole OpenAPI surface with schemathesis: for every operation, requests that fit its schema
and requests that do not. None may answer with a server error (5xx), and the robot must come out of it safe:
its worker alive, its state finite. (The e-stop and reset operations are among those fuzzed.)"""

from __future__ import annotations

import math

import pytest

from app.runtime import Runtime
from app.web.main import create_app

schemathesis = pytest.importorskip("schemathesis")
hypothesis = pytest.importorskip("hypothesis")

EXAMPLES_PER_MODE = 12  # per operation; ~50 operations, both modes: ~1200 requests, a minute or two here


def _server_errors(operation, mode) -> list[str]:  # type: ignore[no-untyped-def]
    found: list[str] = []

    @hypothesis.settings(
        max_examples=EXAMPLES_PER_MODE,
        deadline=None,
        database=None,
        derandomize=True,
        suppress_health_check=list(hypothesis.HealthCheck),
        phases=[hypothesis.Phase.generate],
    )
    @hypothesis.given(case=operation.as_strategy(generation_mode=mode))
    def run(case) -> None:  # type: ignore[no-untyped-def]
        response = case.call()
        if response.status_code >= 500 and response.status_code not in (501, 503):
            found.append(
                f"{operation.method.upper()} {operation.path} -> {response.status_code}: "
                f"{response.text[:200]!r} for {case.as_curl_command()[:300]}"
            )

    try:
        run()
    except hypothesis.errors.Unsatisfiable:  # nothing invalid to send (an operation without parameters or body)
        assert mode.value == "negative", f"{operation.method} {operation.path}: no valid request to generate"
    return found


def test_no_operation_answers_a_server_error_and_the_robot_stays_safe(settings, make_worker) -> None:
    from schemathesis.generation.modes import GenerationMode

    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    app = create_app(settings, runtime=runtime)
    app.state.runtime = runtime  # schemathesis calls the app without running its lifespan
    try:
        schema = schemathesis.openapi.from_asgi("/openapi.json", app)
        operations = [result.ok() for result in schema.get_all_operations()]
        assert len(operations) >= 40
        errors = [
            e
            for op in operations
            for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE)
            for e in _server_errors(op, mode)
        ]
        assert not errors, "\n".join(errors[:20])
        assert runtime.worker.is_alive()
        state = runtime.worker.state()
        assert all(math.isfinite(v) for v in state.qpos) and all(math.isfinite(v) for v in state.base_position)
    finally:
        runtime.stop()
