"""Faults a test injects into an emulated bus device (a servo or a sensor board)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class ServoFaults:
    dead: bool = False  # answers nothing at all
    drop_replies: int = 0  # the next n replies are not sent (the master times out)
    corrupt_replies: int = 0  # the next n replies carry a wrong CRC
