"""`humanoid run` runs its robot with the diagnostics limits the settings give (`HUMANOID_DIAGNOSTICS__*`), as
`humanoid serve` does: a team that widened a limit for its machine gets the same robot from both."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.cli import headless
from app.settings import Settings


class _Built(Exception):
    """Raised by the stand-in worker: the test only needs what the robot was built with."""


def test_humanoid_run_builds_its_robot_with_the_diagnostics_limits_from_the_environment(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("HUMANOID_DIAGNOSTICS__CONTROL_STALE_S", "7.5")
    monkeypatch.setenv("HUMANOID_DIAGNOSTICS__IMU_STALE_S", "4.25")
    settings = Settings(database_url=f"sqlite:///{tmp_path / 'run.db'}")
    built: dict = {}

    def stand_in(*args, **kwargs):  # type: ignore[no-untyped-def]
        built.update(kwargs)
        raise _Built

    monkeypatch.setattr(headless, "RobotWorker", stand_in)
    with pytest.raises(_Built):
        headless.run_command("walk forward one meter", seed=0, settings=settings)
    limits = built["diagnostics"]
    assert (limits.control_stale_s, limits.imu_stale_s) == (7.5, 4.25)
    assert limits == settings.diagnostics  # and every other limit as the settings say
