"""Checks of what the app serves and uses: the database and its migrations, the ports it listens on, and the
planner's LLM server when one is configured."""

from __future__ import annotations

import errno
import os
import socket
from pathlib import Path

import httpx
import psutil
from sqlalchemy.engine import make_url
from sqlalchemy.exc import SQLAlchemyError

from app.deploy.doctor.report import Check, Level, Machine, ok

SERVER_COMMAND_MARKS = (("humanoid", "serve"), ("app.cli", "serve"))


def check_database(machine: Machine) -> Check:
    from app.deploy.backup import UnknownRevision, revisions, sqlite_file

    url = machine.settings.database_url
    shown = make_url(url).render_as_string(hide_password=True)
    database = sqlite_file(url)
    if database is not None:
        if not database.exists():
            return Check(
                "database",
                Level.WARN,
                f"{database} does not exist yet (made on the first start)",
                "humanoid db upgrade (or start the app: it migrates first)",
            )
        if not machine.access(str(database.parent), os.W_OK) or not machine.access(str(database), os.W_OK):
            return Check(
                "database",
                Level.ERROR,
                f"{machine.user()} cannot write {database} or its folder",
                f"sudo chown -R {machine.user()} {database.parent}",
            )
    try:
        current, head = revisions(url)
    except UnknownRevision as exc:
        return Check("database", Level.ERROR, str(exc), "update the code (git pull && make run), or restore a backup")
    except SQLAlchemyError as exc:
        reason = str(exc.orig if getattr(exc, "orig", None) else exc).strip().splitlines()[0]
        return Check(
            "database",
            Level.ERROR,
            f"cannot open {shown}: {reason}",
            "check DATABASE_URL, and that the database server runs and accepts this user",
        )
    if current == head:
        return ok("database", f"{shown}: migrations at head ({head})")
    return Check(
        "database",
        Level.WARN,
        f"{shown}: at migration {current or 'none'}, the code's is {head}",
        "humanoid db upgrade --backup (the service does it when it starts)",
    )


def _listener(port: int) -> psutil.Process | None:
    try:
        connections = psutil.net_connections(kind="tcp")
    except (psutil.AccessDenied, OSError):
        return None
    for connection in connections:
        if connection.status == psutil.CONN_LISTEN and connection.laddr and connection.laddr.port == port:
            try:
                return psutil.Process(connection.pid) if connection.pid else None
            except psutil.NoSuchProcess:
                return None
    return None


def _is_our_server(process: psutil.Process | None) -> bool:
    if process is None:
        return False
    try:
        command = " ".join(process.cmdline())
    except psutil.Error:
        return False
    return any(all(mark in command for mark in marks) for marks in SERVER_COMMAND_MARKS)


def _bind_problem(host: str, port: int) -> str:
    """Why `humanoid serve` could not listen on host:port now, or ""."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn and viser do
        try:
            sock.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                process = _listener(port)
                if _is_our_server(process):
                    return ""
                who = f"pid {process.pid} ({process.name()})" if process else "another process"
                return f"{port} is taken by {who}"
            if exc.errno == errno.EACCES:
                return f"{port} needs root (ports below 1024)"
            if exc.errno == errno.EADDRNOTAVAIL:
                return f"{host} is not an address of this computer"
            return f"{host}:{port}: {exc.strerror}"
    return ""


def check_ports(machine: Machine) -> Check:
    s = machine.settings
    wanted = [
        ("HTTP", s.host, s.port, "PORT"),
        ("3D view", s.viser_host, s.viser_port, "HUMANOID_VISER_PORT"),
        ("light 3D view", s.viser_host, s.viser_light_port, "HUMANOID_VISER_LIGHT_PORT"),
        ("replay", s.viser_host, s.replay_port, "HUMANOID_REPLAY_PORT"),
    ]
    problems = [
        (what, variable, problem) for what, host, port, variable in wanted if (problem := _bind_problem(host, port))
    ]
    ours = [port for _, _, port, _ in wanted if _is_our_server(_listener(port))]
    listed = ", ".join(f"{what} {port}" for what, _, port, _ in wanted)
    if not problems:
        running = f" (a running humanoid server holds {', '.join(map(str, ours))})" if ours else ""
        return ok("ports", f"free on {s.host}: {listed}{running}")
    return Check(
        "ports",
        Level.ERROR,
        "; ".join(f"{what}: {problem}" for what, _, problem in problems),
        "stop what holds them, or choose others: " + ", ".join(sorted({v for _, v, _ in problems})),
    )


def check_planner(machine: Machine) -> Check:
    s = machine.settings
    if s.planner_backend == "rules":
        return ok("planner", "the built-in rules planner: no LLM server to reach")
    if s.planner_backend == "local":
        model = Path(s.local_model_path) if s.local_model_path else None
        try:
            import llama_cpp  # noqa: F401
        except ImportError:
            return Check(
                "planner",
                Level.ERROR,
                "the local backend needs llama-cpp-python, which is not installed",
                "make the venv with it: .venv/bin/pip install -e '.[local-llm]'",
            )
        if model is None or not model.is_file():
            return Check(
                "planner",
                Level.ERROR,
                f"no GGUF model file at {model or '(HUMANOID_LOCAL_MODEL_PATH unset)'}",
                "set HUMANOID_LOCAL_MODEL_PATH to a .gguf file",
            )
        return ok("planner", f"local model {model} ({model.stat().st_size / 1e6:.0f} MB)")
    level = Level.WARN if s.planner_fallback else Level.ERROR
    consequence = "plans fall back to the rules planner" if s.planner_fallback else "commands cannot be planned"
    headers = {"Authorization": f"Bearer {s.openai_api_key}"} if s.openai_api_key else {}
    url = s.openai_base_url.rstrip("/") + "/models"
    try:
        reply = httpx.get(url, headers=headers, timeout=machine.timeout_s)
    except httpx.HTTPError as exc:
        return Check(
            "planner",
            level,
            f"the LLM server at {s.openai_base_url} does not answer ({exc}): {consequence}",
            "start it (e.g. llama.cpp's llama-server), or set HUMANOID_OPENAI_BASE_URL",
        )
    if reply.status_code in (401, 403):
        return Check(
            "planner",
            level,
            f"{s.openai_base_url} refuses the API key (HTTP {reply.status_code})",
            "set OPENAI_API_KEY (the service: in /etc/humanoid/humanoid.env)",
        )
    if not reply.is_success:
        return Check(
            "planner",
            level,
            f"{url} answered HTTP {reply.status_code}: {consequence}",
            "check HUMANOID_OPENAI_BASE_URL (it ends in /v1 on most servers)",
        )
    try:
        models = [m.get("id") for m in reply.json().get("data", [])]
    except ValueError:
        models = []
    listed = s.openai_model in models or not models
    detail = f"{s.openai_base_url} answers; model {s.openai_model} " + (
        "offered" if listed else "not among " + ", ".join(models)
    )
    if listed:
        return ok("planner", detail)
    return Check("planner", level, detail, "set HUMANOID_OPENAI_MODEL to one the server offers")
