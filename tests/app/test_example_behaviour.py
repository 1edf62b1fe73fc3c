"""The example external package (examples/wave-hello): its behaviour is found through its entry point as if
installed (a dist-info of its own pyproject's entry points, and its sources, on the path) and runs headless; its
own test passes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

from tests.support.cli import humanoid as run_humanoid

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "wave-hello"


def installed_like(tmp_path: Path) -> dict[str, str]:
    """The environment of a Python that sees the example as `pip install -e` leaves it."""
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    site = tmp_path / "site"
    info = site / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    points = project["entry-points"]
    (info / "entry_points.txt").write_text(
        "".join(
            f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()) for group, entries in points.items()
        )
    )
    path = os.pathsep.join([str(site), str(EXAMPLE / "src"), os.environ.get("PYTHONPATH", "")])
    return {
        **os.environ,
        "PYTHONPATH": path,
        "DATABASE_URL": f"sqlite:///{tmp_path / 'cli.db'}",
        "HUMANOID_AUDIO_DIR": str(tmp_path / "audio"),
    }


def humanoid(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return run_humanoid(*args, env=env)


def test_the_example_is_listed_and_runs_once_installed(tmp_path: Path) -> None:
    env = installed_like(tmp_path)
    listed = json.loads(humanoid(env, "behaviours", "list", "--json").stdout)
    example = next(b for b in listed["behaviours"] if b["name"] == "wave_hello")
    assert example["package"] == "humanoid-wave-hello"
    assert [p["name"] for p in example["params"]] == ["times", "greeting"]

    done = humanoid(env, "behaviours", "run", "wave_hello", "--set", "times=1", "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["success"] is True and result["fell"] is False
    assert result["feedback"] == ["said 'Hello there!'", "wave 1 of 1"]


def test_the_examples_own_test_passes(tmp_path: Path) -> None:
    env = installed_like(tmp_path)
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(EXAMPLE / "tests")],
        capture_output=True,
        text=True,
        env=env,
        cwd=EXAMPLE,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
