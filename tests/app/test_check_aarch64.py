"""scripts/check-aarch64 (run whole by `make test`): a dependency with no aarch64 wheel fails it unless it is a
named source build; an unreachable index is no proof either way (skipped, a failure under CI)."""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest
from packaging.requirements import Requirement

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "check-aarch64"


@pytest.fixture(scope="module")
def check() -> Iterator[ModuleType]:
    loader = importlib.machinery.SourceFileLoader("check_aarch64", str(SCRIPT))
    spec = importlib.util.spec_from_loader("check_aarch64", loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules["check_aarch64"] = module  # its dataclasses look their module up
    loader.exec_module(module)
    yield module
    del sys.modules["check_aarch64"]


def _resolve(check: ModuleType, requirement: str) -> dict:
    try:
        return check.check_python("3.12", [Requirement(requirement)])
    except check.IndexUnreachable as exc:
        pytest.skip(f"package index unreachable: {exc}")


def test_a_dependency_without_an_aarch64_wheel_fails(check: ModuleType) -> None:
    with pytest.raises(check.Unresolvable, match="llama-cpp-python"):
        _resolve(check, "llama-cpp-python>=0.3,<0.4")  # source distributions only


def test_a_named_source_build_passes_with_its_runtime_dependencies_as_wheels(check: ModuleType) -> None:
    outcome = _resolve(check, "pocketsphinx>=5.0,<6")
    (build,) = outcome["source_builds"]
    assert build.name == "pocketsphinx"
    assert build.filename.endswith(".tar.gz")  # no cp312 aarch64 wheel: built on the robot's computer
    assert {w.name.lower() for w in outcome["wheels"]} >= {"sounddevice", "cffi"}
    assert all(w.filename.endswith("aarch64.whl") or "-none-any" in w.filename for w in outcome["wheels"])


def test_the_supported_pythons_come_from_pyproject(check: ModuleType) -> None:
    assert check.supported_pythons(">=3.11,<3.14") == ["3.11", "3.12", "3.13"]
    assert check.supported_pythons(">=3.12")[:2] == ["3.12", "3.13"]


@pytest.mark.parametrize(("ci", "code"), [("", 0), ("true", 1)])
def test_an_unreachable_index_is_skipped_except_under_ci(tmp_path: Path, ci: str, code: int) -> None:
    env = {
        **os.environ,
        "PIP_CONFIG_FILE": os.devnull,
        "PIP_INDEX_URL": "https://127.0.0.1:9/simple",
        "PIP_EXTRA_INDEX_URL": "",
        "PIP_FIND_LINKS": "",
        "XDG_CACHE_HOME": str(tmp_path),
        "CI": ci,
    }
    done = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == code
    assert "the package index is unreachable" in done.stderr
