"""Faults a test injects into an emulated bus device (a servo or a sensor board)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class ServoFaults:
    dead: bool = False  # answers nothing at all
    drop_replies: int = 0  # the next n replies are not sent (the master times out)
    corrupt_replies: int = 0  # the next n replies carry a wrong CRC
    late_replies: int = 0  # the next n replies come LATE_REPLY_S after the master stopped waiting for them
    drop_write_replies: int = 0  # the next n writes land, but their status is not sent


LATE_REPLY_S = 0.02  # a slow USB adapter or a loaded host: past the packet timeout, before the next request ends
