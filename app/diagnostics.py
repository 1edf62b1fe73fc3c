"""The server's view of diagnostics: the robot's own statuses (marked STALE when the worker stops reporting) plus
what only the server knows: browsers connected, the robot worker process, the session store, the page's speech
recogniser. Also the JSON the API and the page read, and the Prometheus exposition for `/metrics`."""

from __future__ import annotations

import importlib.util
import os
import re
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import GaugeMetricFamily

from robot.interface import DiagnosticArray, DiagnosticStatus, Level, worst_level

if TYPE_CHECKING:
    from app.runtime import Runtime

STALE_AFTER_S = 3.0  # the robot samples once a second: three missed samples and its statuses are STALE
STORE_FAILING_ERROR_S = 5.0


def snapshot(rt: Runtime) -> DiagnosticArray:
    """Every status now: the robot's latest sample and the server's own."""
    now = time.time()
    robot = rt.worker.diagnostics()
    statuses: list[DiagnosticStatus] = []
    if robot is not None:
        age = now - robot.wall_time_s
        if age > STALE_AFTER_S or robot_health(rt)[0] != "ok":
            statuses = [_stale(s, age) for s in robot.statuses]
        else:
            statuses = list(robot.statuses)
    statuses += server_statuses(rt)
    return DiagnosticArray(
        now, robot.sim_time_s if robot else 0.0, tuple(statuses), robot.monitor_cpu_ms if robot else 0.0
    )


def robot_health(rt: Runtime) -> tuple[str, str]:
    """("ok", "") while the robot process runs and answers; else ("worker_down" | "worker_not_answering", why)."""
    sup = rt.supervisor
    if not rt.worker.is_alive():
        reason = "the robot worker is not running: the robot is not driven"
        if sup is not None:
            reason = sup.gave_up or reason + "; the supervisor is restarting it"
        return "worker_down", reason
    silent = rt.worker.silent_for_s()
    if silent:
        then = f"; it is restarted with the e-stop latched after {sup.frozen_grace_s:.0f} s" if sup is not None else ""
        return "worker_not_answering", f"the robot process has not answered for {silent:.1f} s (frozen?){then}"
    return "ok", ""


def _worker_status(rt: Runtime) -> DiagnosticStatus:
    sup = rt.supervisor
    values: tuple[tuple[str, float | str], ...] = ()
    if sup is not None:
        values = (("restarts", sup.restarts), ("last_death", sup.last_death or ""))
    status, reason = robot_health(rt)
    if status == "ok":
        restarted = f"; restarted {sup.restarts} times (last death: {sup.last_death})" if sup and sup.restarts else ""
        return DiagnosticStatus("links/robot_worker", Level.OK, "running" + restarted, values=values)
    return DiagnosticStatus("links/robot_worker", Level.ERROR, reason, values=values)


def _stale(status: DiagnosticStatus, age_s: float) -> DiagnosticStatus:
    return DiagnosticStatus(
        status.name,
        Level.STALE,
        f"no report from the robot for {age_s:.0f} s (last: {status.message})",
        status.hardware_id,
        status.values,
    )


def server_statuses(rt: Runtime) -> list[DiagnosticStatus]:
    out = [
        DiagnosticStatus(
            "links/browsers", Level.OK, f"{rt.browser_clients} connected", values=(("clients", rt.browser_clients),)
        ),
    ]
    out.append(_worker_status(rt))
    out.append(_store_status(rt))
    out.append(_browser_asr_status(rt))
    return out


def _store_status(rt: Runtime) -> DiagnosticStatus:
    stats = rt.recorder.stats
    backlog = rt.recorder.backlog()
    values: tuple[tuple[str, float | str], ...] = (
        ("backlog_rows", backlog),
        ("commits", stats.commits),
        ("session_id", rt.recorder.session_id),
    )
    if stats.failing_since_wall_s is not None:
        failing = time.time() - stats.failing_since_wall_s
        level = Level.ERROR if failing >= STORE_FAILING_ERROR_S else Level.WARN
        return DiagnosticStatus(
            "links/session_store",
            level,
            f"writes failing for {failing:.0f} s ({stats.last_error}); {backlog} rows kept in memory and retried",
            values=values,
        )
    return DiagnosticStatus(
        "links/session_store", Level.OK, f"recording session {rt.recorder.session_id}", values=values
    )


def _browser_asr_status(rt: Runtime) -> DiagnosticStatus:
    from robot.speech.engines import resolve_engine
    from robot.speech.whisper import model_dir

    engine = resolve_engine(rt.settings.asr_engine, rt.settings.whisper_model_dir)
    if engine == "whisper":
        directory = model_dir(rt.settings.whisper_model_dir)
        if importlib.util.find_spec("faster_whisper") is None:
            return DiagnosticStatus("links/asr", Level.ERROR, "faster-whisper is not installed", engine)
        if directory is None or not os.path.isdir(directory):
            return DiagnosticStatus("links/asr", Level.ERROR, f"no whisper model directory ({directory!r})", engine)
        return DiagnosticStatus("links/asr", Level.OK, f"faster-whisper, model {directory}", engine)
    if importlib.util.find_spec("pocketsphinx") is None:
        return DiagnosticStatus("links/asr", Level.ERROR, "pocketsphinx is not installed", engine)
    return DiagnosticStatus("links/asr", Level.OK, "pocketsphinx with the world's grammar", engine)


# ---------------------------------------------------------------------------------------------------------------
# JSON


def status_json(status: DiagnosticStatus) -> dict[str, Any]:
    return {
        "name": status.name,
        "group": status.group,
        "level": int(status.level),
        "level_name": status.level.name,
        "message": status.message,
        "hardware_id": status.hardware_id,
        "values": {k: v for k, v in status.values},
        "stops_motion": status.stops_motion,
    }


def diagnostics_json(array: DiagnosticArray) -> dict[str, Any]:
    groups: dict[str, list[dict[str, Any]]] = {}
    for status in array.statuses:
        groups.setdefault(status.group, []).append(status_json(status))
    alarms = [status_json(s) for s in array.statuses if s.level != Level.OK]
    return {
        "wall_time_s": array.wall_time_s,
        "sim_time_s": array.sim_time_s,
        "level": int(array.level),
        "level_name": array.level.name,
        "monitor_cpu_ms": array.monitor_cpu_ms,
        "alarms": alarms,
        "groups": {
            name: {
                "level": int(w := worst_level(Level(i["level"]) for i in items)),
                "level_name": w.name,
                "statuses": items,
            }
            for name, items in groups.items()
        },
    }


# ---------------------------------------------------------------------------------------------------------------
# Prometheus


class _ArrayCollector:
    """Each status's level as `humanoid_diagnostic_level{name=...}` (0 OK, 1 WARN, 2 ERROR, 3 STALE), and every
    numeric value as a gauge named after its group and key, e.g. `humanoid_servos_temperature_c{name="r_knee"}`."""

    def __init__(self, array: DiagnosticArray) -> None:
        self.array = array

    def collect(self) -> Iterator[GaugeMetricFamily]:
        level = GaugeMetricFamily(
            "humanoid_diagnostic_level", "0 OK, 1 WARN, 2 ERROR, 3 STALE", labels=["name", "group"]
        )
        families: dict[str, GaugeMetricFamily] = {}
        for status in self.array.statuses:
            level.add_metric([status.name, status.group], int(status.level))
            component = status.name.split("/", 1)[-1]
            for key, value in status.values:
                if isinstance(value, bool) or not isinstance(value, int | float):
                    continue
                metric = _metric_name(f"humanoid_{status.group}_{key}")
                if metric not in families:
                    families[metric] = GaugeMetricFamily(metric, f"{status.group} {key}", labels=["name"])
                families[metric].add_metric([component], float(value))
        yield level
        yield from families.values()
        yield GaugeMetricFamily(
            "humanoid_diagnostics_monitor_cpu_ms",
            "CPU time of the last diagnostics sample",
            value=self.array.monitor_cpu_ms,
        )


def _metric_name(raw: str) -> str:
    return re.sub(r"[^a-zA-Z0-9_]", "_", raw)


def prometheus_text(array: DiagnosticArray) -> bytes:
    registry = CollectorRegistry(auto_describe=False)
    registry.register(_ArrayCollector(array))  # type: ignore[arg-type]
    return generate_latest(registry)
