"""The documentation as a newcomer meets it: a README short enough to read, with the two set-up commands; every
page of docs/ reachable from the site's navigation; every setting the app reads explained.

(`make test` also builds the site with `mkdocs build --strict`, which fails on a broken link, and checks that the
generated reference pages match the code: `scripts/docs_reference.py --check`.)"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mkdocs.config import load_config
from pydantic import AliasChoices, BaseModel

from app.settings import Settings

REPO = Path(__file__).resolve().parents[1]
README_MAX_LINES = 250
SET_UP = [
    "make run    # set up (.venv, packages, Debian libraries), migrate the DB, serve http://127.0.0.1:8000",
    "make test   # the same set-up plus test tools, then the whole suite (unit, API, CLI, real browser)",
]


def test_the_readme_is_a_front_door_with_the_two_set_up_commands() -> None:
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines: move details to a page under docs/"
    for command in SET_UP:
        assert command in lines, f"the README lost its set-up command: {command}"
    assert "They are the only set-up." in " ".join(lines)


def _nav_pages(nav: Any) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, dict):
        return [page for value in nav.values() for page in _nav_pages(value)]
    return [page for item in nav for page in _nav_pages(item)]


def test_every_page_under_docs_is_in_the_site_navigation_and_every_entry_exists() -> None:
    config = load_config(str(REPO / "mkdocs.yml"))
    in_nav = _nav_pages(config["nav"])
    on_disk = sorted(str(path.relative_to(REPO / "docs")) for path in (REPO / "docs").rglob("*.md"))
    assert sorted(set(on_disk) - set(in_nav)) == [], "pages missing from mkdocs.yml's nav"
    assert sorted(set(in_nav) - set(on_disk)) == [], "nav entries with no page"
    assert len(in_nav) == len(set(in_nav)), "a page is in the nav twice"


def _variable_names(name: str, field: Any) -> list[str]:
    """The environment variables a settings field is read from."""
    if isinstance(field.validation_alias, AliasChoices):
        return [str(choice) for choice in field.validation_alias.choices]
    if isinstance(field.default_factory, type) and issubclass(field.default_factory, BaseModel):
        return [f"HUMANOID_{name.upper()}__"]  # a group of nested settings (the diagnostics thresholds)
    return [f"HUMANOID_{name.upper()}"]


def test_every_setting_the_app_reads_is_on_the_settings_page() -> None:
    page = (REPO / "docs" / "reference" / "settings.md").read_text()
    variables = [_variable_names(name, field) for name, field in Settings.model_fields.items()]
    missing = [names[0] for names in variables if not any(f"`{name}" in page for name in names)]
    assert missing == [], "settings not explained in docs/reference/settings.md"
