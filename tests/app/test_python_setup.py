"""`make run` / `make test` on a machine whose python3 is too old (Ubuntu 22.04 on a Jetson: 3.10): the set-up
finds a supported interpreter, uv's managed one, or stops with the commands that get one. Fake interpreters are
scripts that answer the version query."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet

REPO = Path(__file__).resolve().parents[2]
FIND = REPO / "scripts" / "find-python.sh"


def _fake_python(folder: Path, name: str, version: str) -> Path:
    """A script that says it is Python `version` when asked (and fails anything else)."""
    path = folder / name
    path.write_text(f'#!/bin/sh\ncase "$*" in *version_info*) echo {version} ;; *) exit 3 ;; esac\n')
    path.chmod(0o755)
    return path


def _not_python(folder: Path, name: str) -> None:
    """Shadows an interpreter of that name elsewhere on PATH."""
    path = folder / name
    path.write_text("#!/bin/sh\nexit 1\n")
    path.chmod(0o755)


def _find(folder: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["/bin/bash", str(FIND)],
        capture_output=True,
        text=True,
        timeout=60,
        env={"PATH": str(folder), "HOME": str(folder), **env},
    )


@pytest.fixture
def bin_dir(tmp_path: Path) -> Path:
    folder = tmp_path / "bin"
    folder.mkdir()
    _fake_python(folder, "python3", "3.10")
    return folder


def test_the_script_accepts_exactly_the_pythons_pyproject_allows() -> None:
    text = FIND.read_text()
    low = int(re.search(r"^MIN_MINOR=(\d+)", text, re.M).group(1))
    high = int(re.search(r"^MAX_MINOR=(\d+)", text, re.M).group(1))
    spec = SpecifierSet(tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["requires-python"])
    assert [m for m in range(5, 25) if f"3.{m}" in spec] == list(range(low, high + 1))


def test_an_old_python3_alone_stops_with_the_commands_that_get_a_newer_one(bin_dir: Path) -> None:
    done = _find(bin_dir)
    assert done.returncode == 1
    assert done.stdout == ""
    assert "python3 is Python 3.10" in done.stderr
    assert "uv python install 3.13" in done.stderr
    assert "sudo apt-get install -y python3.13 python3.13-venv python3.13-dev" in done.stderr
    assert "PYTHON=" in done.stderr


def test_a_newer_interpreter_on_path_is_chosen_over_an_old_python3(bin_dir: Path) -> None:
    _fake_python(bin_dir, "python3.11", "3.11")
    chosen = _fake_python(bin_dir, "python3.12", "3.12")
    done = _find(bin_dir)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(chosen)


def test_a_too_new_interpreter_is_passed_over(bin_dir: Path) -> None:
    _fake_python(bin_dir, "python3.13", "3.14")  # a misnamed one: what it runs counts, not its name
    chosen = _fake_python(bin_dir, "python3.11", "3.11")
    assert _find(bin_dir).stdout.strip() == str(chosen)


def _fake_uv(folder: Path, managed: Path, *, can_install: bool) -> Path:
    """uv: `python find` names the managed interpreter once `python install` has put it there."""
    log = folder / "uv.log"
    install = f'>{folder}/installed; echo "$*" >> {log}' if can_install else f'echo "$*" >> {log}; exit 2'
    uv = folder / "uv"
    uv.write_text(
        "#!/bin/sh\n"
        f'case "$1 $2" in\n'
        f'  "python find") [ -e {folder}/installed ] && echo {managed} && exit 0; exit 2 ;;\n'
        f'  "python install") {install} ;;\n'
        "esac\n"
    )
    uv.chmod(0o755)
    return log


def test_uv_provides_a_managed_python_when_none_is_on_path(bin_dir: Path, tmp_path: Path) -> None:
    managed_dir = tmp_path / "uv-python"
    managed_dir.mkdir()
    managed = _fake_python(managed_dir, "python3.13", "3.13")
    log = _fake_uv(bin_dir, managed, can_install=True)
    done = _find(bin_dir)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(managed)
    assert log.read_text().split() == ["python", "install", "3.13"]


def test_uv_that_cannot_download_still_ends_with_the_commands(bin_dir: Path, tmp_path: Path) -> None:
    _fake_uv(bin_dir, tmp_path / "none", can_install=False)
    done = _find(bin_dir)
    assert done.returncode == 1
    assert "uv has none and could not install one" in done.stderr
    assert "sudo add-apt-repository -y ppa:deadsnakes/ppa" in done.stderr


def test_an_explicit_python_that_is_too_old_is_refused(bin_dir: Path) -> None:
    _fake_python(bin_dir, "python3.12", "3.12")
    done = _find(bin_dir, PYTHON="python3")
    assert done.returncode == 1
    assert "PYTHON=python3 cannot be used: python3 is Python 3.10" in done.stderr


def _make_env(bin_dir: Path) -> dict[str, str]:
    """PATH: the fakes first (python3 is 3.10, 3.12 and 3.13 shadowed, uv absent), then the system's tools."""
    for name in ("python3.12", "python3.13", "uv"):
        _not_python(bin_dir, name)
    return {**os.environ, "PATH": f"{bin_dir}:/usr/bin:/bin", "PYTHON": "", "HOME": str(bin_dir)}


def test_make_venv_with_an_old_python3_stops_with_the_commands(bin_dir: Path, tmp_path: Path) -> None:
    _not_python(bin_dir, "python3.11")
    venv = tmp_path / "venv"
    done = subprocess.run(
        ["make", "-s", "-C", str(REPO), "venv", f"VENV={venv}"],
        capture_output=True,
        text=True,
        env=_make_env(bin_dir),
        timeout=120,
    )
    assert done.returncode != 0
    assert "python3 is Python 3.10" in done.stderr
    assert "uv python install 3.13" in done.stderr
    assert not venv.exists()


def test_make_venv_replaces_a_venv_of_an_old_python_with_a_supported_one(bin_dir: Path, tmp_path: Path) -> None:
    """The real interpreter running this test stands for the python3.11 a Jetson gets from deadsnakes or uv."""
    real = Path(sys.executable)
    (bin_dir / "python3.11").symlink_to(real)
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    _fake_python(venv / "bin", "python", "3.10")  # a venv made before, with JetPack's Python 3.10
    done = subprocess.run(
        ["make", "-s", "-C", str(REPO), "venv", f"VENV={venv}"],
        capture_output=True,
        text=True,
        env=_make_env(bin_dir),
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "unsupported Python: making it again" in done.stderr
    version = subprocess.run(
        [str(venv / "bin" / "python"), "-c", "import sys, pip; print(sys.version_info[:2])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert version.strip() == str(tuple(sys.version_info[:2]))
