"""The computer the robot runs on, through psutil: CPU per core, memory, disk, temperatures; NVIDIA GPUs through
NVML when the `nvidia-ml-py` package and a driver are there."""

from __future__ import annotations

import os
from collections import deque
from typing import Any

import psutil

from robot.diagnostics.thresholds import Thresholds
from robot.interface import DiagnosticStatus, Level

CPU_AVERAGE_SAMPLES = 3  # CPU load is judged over the last three samples (~3 s at 1 Hz)


class ComputeProbe:
    """Call `statuses()` about once a second: CPU use is measured between calls."""

    def __init__(self, disk_path: str, limits: Thresholds) -> None:
        self.disk_path = disk_path if os.path.exists(disk_path) else os.path.abspath(os.sep)
        self.limits = limits
        self._cpu_history: deque[float] = deque(maxlen=CPU_AVERAGE_SAMPLES)
        psutil.cpu_percent(percpu=True)  # the first call only starts the measurement
        self._nvml: Any = _open_nvml()

    def statuses(self) -> list[DiagnosticStatus]:
        out = [self._cpu(), self._memory(), self._disk()]
        temperatures = self._temperatures()
        if temperatures is not None:
            out.append(temperatures)
        if self._nvml is not None:
            out.extend(self._gpus())
        return out

    def _cpu(self) -> DiagnosticStatus:
        per_core = psutil.cpu_percent(percpu=True)
        total = sum(per_core) / max(1, len(per_core))
        self._cpu_history.append(total)
        average = sum(self._cpu_history) / len(self._cpu_history)
        load1, load5, _ = os.getloadavg()
        values: list[tuple[str, float | str]] = [
            ("usage_pct", round(total, 1)),
            ("usage_avg_pct", round(average, 1)),
            ("cores", len(per_core)),
            ("load_1m", round(load1, 2)),
            ("load_5m", round(load5, 2)),
        ]
        values += [(f"core{i}_pct", round(p, 1)) for i, p in enumerate(per_core)]
        if average >= self.limits.cpu_warn_pct:
            return DiagnosticStatus(
                "compute/cpu",
                Level.WARN,
                f"CPU overloaded: {average:.0f} % over {len(self._cpu_history)} s",
                values=tuple(values),
            )
        return DiagnosticStatus(
            "compute/cpu", Level.OK, f"{average:.0f} % of {len(per_core)} cores", values=tuple(values)
        )

    def _memory(self) -> DiagnosticStatus:
        memory = psutil.virtual_memory()
        values = (
            ("used_pct", memory.percent),
            ("available_mb", round(memory.available / 2**20)),
            ("total_mb", round(memory.total / 2**20)),
            ("process_rss_mb", round(psutil.Process().memory_info().rss / 2**20)),
        )
        level = (
            Level.ERROR
            if memory.percent >= self.limits.memory_error_pct
            else Level.WARN
            if memory.percent >= self.limits.memory_warn_pct
            else Level.OK
        )
        return DiagnosticStatus("compute/memory", level, f"{memory.percent:.0f} % used", values=values)

    def _disk(self) -> DiagnosticStatus:
        disk = psutil.disk_usage(self.disk_path)
        values = (("used_pct", disk.percent), ("free_gb", round(disk.free / 2**30, 2)), ("path", self.disk_path))
        level = (
            Level.ERROR
            if disk.percent >= self.limits.disk_error_pct
            else Level.WARN
            if disk.percent >= self.limits.disk_warn_pct
            else Level.OK
        )
        note = "; sessions cannot be recorded much longer" if level != Level.OK else ""
        return DiagnosticStatus("compute/disk", level, f"{disk.percent:.0f} % used{note}", values=values)

    def _temperatures(self) -> DiagnosticStatus | None:
        reader = getattr(psutil, "sensors_temperatures", None)
        sensors = reader() if reader is not None else {}
        readings = [
            (f"{chip}_{t.label or i}", t.current)
            for chip, entries in sensors.items()
            for i, t in enumerate(entries)
            if t.current
        ]
        if not readings:
            return None  # virtual machines expose none: nothing to say
        hottest = max(c for _, c in readings)
        level = Level.WARN if hottest >= self.limits.cpu_temperature_warn_c else Level.OK
        values = tuple((f"{k}_c".replace(" ", "_"), round(v, 1)) for k, v in readings)
        return DiagnosticStatus("compute/temperatures", level, f"hottest {hottest:.0f} C", values=values)

    def _gpus(self) -> list[DiagnosticStatus]:
        nvml = self._nvml
        out = []
        try:
            for i in range(nvml.nvmlDeviceGetCount()):
                handle = nvml.nvmlDeviceGetHandleByIndex(i)
                use = nvml.nvmlDeviceGetUtilizationRates(handle)
                memory = nvml.nvmlDeviceGetMemoryInfo(handle)
                temperature = nvml.nvmlDeviceGetTemperature(handle, nvml.NVML_TEMPERATURE_GPU)
                values = (
                    ("usage_pct", use.gpu),
                    ("memory_used_pct", round(100 * memory.used / memory.total, 1)),
                    ("temperature_c", temperature),
                )
                level = Level.WARN if temperature >= self.limits.cpu_temperature_warn_c else Level.OK
                out.append(DiagnosticStatus(f"compute/gpu{i}", level, f"{use.gpu} %, {temperature} C", values=values))
        except Exception as exc:  # a driver that went away
            out.append(DiagnosticStatus("compute/gpu", Level.WARN, f"NVML failed: {exc}"))
        return out


def _open_nvml() -> Any:
    try:
        import pynvml  # type: ignore[import-not-found]

        pynvml.nvmlInit()
        return pynvml
    except Exception:  # no package, no driver, no GPU: no GPU statuses
        return None
