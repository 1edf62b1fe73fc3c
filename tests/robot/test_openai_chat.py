"""The OpenAI-compatible client's side of the protocol, against a small HTTP server on loopback that answers as
servers do when they refuse a response format, fail, or hang: what is sent, and how each failure reads."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from robot.planning.openai_chat import OpenAIChat
from robot.planning.planner import PlanningError
from robot.planning.schema import flat_plan_schema

PLAN = {"steps": [{"action": "say", "text": "hello"}]}
Responder = Callable[[dict[str, Any]], tuple[int, dict[str, Any]]]


def completion(content: str) -> dict[str, Any]:
    return {
        "id": "x",
        "object": "chat.completion",
        "created": 0,
        "model": "m",
        "choices": [{"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": content}}],
    }


def chunk(content: str) -> dict[str, Any]:
    return {
        "id": "x",
        "object": "chat.completion.chunk",
        "created": 0,
        "model": "m",
        "choices": [{"index": 0, "finish_reason": None, "delta": {"content": content}}],
    }


class Server:
    """Answers as an OpenAI-compatible server: a JSON error, or the reply streamed as server-sent events, a word
    every `word_s` seconds (and notes when the client hangs up before the end)."""

    def __init__(self) -> None:
        self.requests: list[dict[str, Any]] = []
        self.respond: Responder = lambda body: (200, completion(json.dumps(PLAN)))
        self.word_s = 0.0
        self.hung_up = threading.Event()
        outer = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def do_POST(self) -> None:
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                body["_path"] = self.path
                body["_auth"] = self.headers.get("Authorization")
                outer.requests.append(body)
                status, answer = outer.respond(body)
                if status != 200 or not body.get("stream"):
                    data = json.dumps(answer).encode()
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                    return
                self.send_response(200)
                self.send_header("Content-Type", "text/event-stream")
                self.send_header("Connection", "close")
                self.end_headers()
                content = answer["choices"][0]["message"]["content"]
                try:
                    for word in [*content.split(" "), None]:
                        time.sleep(outer.word_s)
                        event = "[DONE]" if word is None else json.dumps(chunk(word + " "))
                        self.wfile.write(f"data: {event}\n\n".encode())
                        self.wfile.flush()
                except (BrokenPipeError, ConnectionResetError):
                    outer.hung_up.set()

            def log_message(self, *args: Any) -> None:
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def server() -> Iterator[Server]:
    s = Server()
    yield s
    s.close()


MESSAGES = [{"role": "system", "content": "plan"}, {"role": "user", "content": "say hello"}]


def test_a_request_carries_the_model_the_messages_the_key_and_the_schema(server: Server) -> None:
    chat = OpenAIChat(server.url, "llama-3.3-70b-versatile", api_key="sk-test", response_format="json_schema")
    assert json.loads(chat.chat(MESSAGES, flat_plan_schema())) == PLAN
    sent = server.requests[0]
    assert sent["_path"] == "/v1/chat/completions"
    assert sent["_auth"] == "Bearer sk-test"
    assert sent["model"] == "llama-3.3-70b-versatile" and sent["messages"] == MESSAGES
    assert sent["temperature"] == 0.0
    assert sent["response_format"]["type"] == "json_schema"
    assert sent["response_format"]["json_schema"]["schema"] == flat_plan_schema()


def test_auto_steps_down_to_json_object_on_a_server_that_refuses_json_schema_and_remembers(server: Server) -> None:
    def respond(body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
        if body.get("response_format", {}).get("type") == "json_schema":
            return 400, {"error": {"message": "response_format type json_schema is not supported"}}
        return 200, completion(json.dumps(PLAN))

    server.respond = respond
    chat = OpenAIChat(server.url, "m")
    chat.chat(MESSAGES, flat_plan_schema())
    assert [r["response_format"]["type"] for r in server.requests] == ["json_schema", "json_object"]
    assert server.requests[1]["response_format"]["schema"] == flat_plan_schema()
    assert chat.response_format == "json_object"
    chat.chat(MESSAGES, flat_plan_schema())
    assert len(server.requests) == 3 and server.requests[2]["response_format"]["type"] == "json_object"


def test_a_500_that_names_the_response_format_is_a_refusal_too(server: Server) -> None:
    # llama-cpp-python's server answers an unknown response_format type with a 500 naming the field
    def respond(body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
        if body.get("response_format", {}).get("type") == "json_schema":
            return 500, {
                "error": {
                    "message": "1 validation error: ('body', 'response_format', 'type') Input should "
                    "be 'text' or 'json_object'"
                }
            }
        return 200, completion(json.dumps(PLAN))

    server.respond = respond
    chat = OpenAIChat(server.url, "m")
    assert json.loads(chat.chat(MESSAGES, flat_plan_schema())) == PLAN
    assert chat.response_format == "json_object"


def test_a_server_that_refuses_every_format_is_asked_without_one(server: Server) -> None:
    def respond(body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
        if "response_format" in body:
            return 400, {"error": {"message": "unsupported response_format"}}
        return 200, completion(json.dumps(PLAN))

    server.respond = respond
    chat = OpenAIChat(server.url, "m")
    chat.chat(MESSAGES, flat_plan_schema())
    assert chat.response_format == "none"
    assert "response_format" not in server.requests[-1]


@pytest.mark.parametrize(
    ("status", "body", "reason"),
    [
        (500, {"error": {"message": "model crashed"}}, "answered HTTP 500: model crashed"),
        (401, {"error": {"message": "Invalid API Key"}}, "answered HTTP 401: Invalid API Key"),
        (429, {"error": {"message": "Rate limit reached"}}, "answered HTTP 429: Rate limit reached"),
        (200, completion(""), "returned an empty message"),
    ],
)
def test_server_failures_are_planning_errors_with_the_reason(server: Server, status, body, reason) -> None:
    server.respond = lambda _: (status, body)
    with pytest.raises(PlanningError, match=reason):
        OpenAIChat(server.url, "m", response_format="json_schema").chat(MESSAGES, flat_plan_schema())


def test_a_server_that_hangs_times_out(server: Server) -> None:
    def respond(body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
        time.sleep(1.5)
        return 200, completion(json.dumps(PLAN))

    server.respond = respond
    started = time.monotonic()
    with pytest.raises(PlanningError, match=r"timed out after 0\.3 s"):
        OpenAIChat(server.url, "m", timeout_s=0.3, response_format="json_object").chat(MESSAGES, flat_plan_schema())
    assert time.monotonic() - started < 1.4


def test_a_reply_still_coming_at_the_deadline_is_cut_and_the_server_sees_the_client_go(server: Server) -> None:
    server.respond = lambda body: (200, completion(" ".join(["word"] * 400)))
    server.word_s = 0.02  # a model that rambles: 8 s of words
    with pytest.raises(PlanningError, match=r"timed out after 0\.5 s"):
        OpenAIChat(server.url, "m", timeout_s=0.5, response_format="json_object").chat(MESSAGES, flat_plan_schema())
    assert server.hung_up.wait(timeout=5.0), "the server went on sending to a client that had given up"
    assert server.requests[0]["stream"] is True and server.requests[0]["max_tokens"] > 0


def test_what_a_server_takes_is_remembered_for_every_client_of_it(server: Server) -> None:
    def respond(body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
        if body.get("response_format", {}).get("type") == "json_schema":
            return 500, {"error": {"message": "Internal Server Error"}}  # as llama-cpp-python's server answers
        return 200, completion(json.dumps(PLAN))

    server.respond = respond
    OpenAIChat(server.url, "remembered-model").chat(MESSAGES, flat_plan_schema())
    assert [r["response_format"]["type"] for r in server.requests] == ["json_schema", "json_object"]
    later = OpenAIChat(server.url, "remembered-model")  # a new client (the next command, another planner)
    assert json.loads(later.chat(MESSAGES, flat_plan_schema())) == PLAN
    assert [r["response_format"]["type"] for r in server.requests] == ["json_schema", "json_object", "json_object"]


def test_no_server_at_all_says_it_cannot_be_reached() -> None:
    with pytest.raises(PlanningError, match=r"cannot reach http://127.0.0.1:9/v1"):
        OpenAIChat("http://127.0.0.1:9/v1", "m", timeout_s=2).chat(MESSAGES, flat_plan_schema())
