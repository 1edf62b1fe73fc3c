"""Logging in from Chromium: the login page, an operator taking control, a viewer's page that can only watch
and stop, and both pages showing who has control as it changes."""

from __future__ import annotations

import pytest

from app.auth.roles import Role
from app.auth.store import UserStore
from app.bench.browser import launch_chromium
from app.bench.server import ServerProcess
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head

pytestmark = pytest.mark.slow

playwright_api = pytest.importorskip("playwright.sync_api")
PASSWORD = "correct horse battery"


def test_login_roles_and_control_from_the_page(tmp_path) -> None:
    expect = playwright_api.expect
    workdir = tmp_path / "server"
    workdir.mkdir()
    url = f"sqlite:///{workdir / 'server.db'}"
    upgrade_to_head(url)
    store = UserStore(make_session_factory(make_engine(url)))
    store.add("ada", Role.OPERATOR, PASSWORD)
    store.add("vic", Role.VIEWER, PASSWORD)
    with ServerProcess(workdir, extra_env={"HUMANOID_PERCEPTION": "false"}) as server, \
            playwright_api.sync_playwright() as playwright:  # fmt: skip
        browser = launch_chromium(playwright)
        ada = browser.new_context().new_page()
        ada.goto(server.url)
        expect(ada).to_have_url(server.url + "/login")
        ada.fill("#login-name", "ada")
        ada.fill("#login-password", "wrong horse battery")
        ada.click("#login-submit")
        expect(ada.locator("#login-error")).to_contain_text("wrong name or password")
        ada.fill("#login-password", PASSWORD)
        ada.click("#login-submit")
        expect(ada.locator("#access-user")).to_have_text("ada (operator)", timeout=20_000)
        expect(ada.locator("#access-holder")).to_have_text("control: free")
        ada.click("#access-take")
        expect(ada.locator("#access-holder")).to_have_text("control: ada")

        vic = browser.new_context().new_page()  # another person, another browser profile
        vic.goto(server.url + "/login")
        vic.fill("#login-name", "vic")
        vic.fill("#login-password", PASSWORD)
        vic.click("#login-submit")
        expect(vic.locator("#access-user")).to_have_text("vic (viewer)", timeout=20_000)
        expect(vic.locator("#access-holder")).to_have_text("control: ada", timeout=10_000)
        expect(vic.locator("#access-take")).to_be_hidden()
        assert vic.evaluate("document.body.classList.contains('viewer')")
        vic.click("#estop")  # a viewer may stop the robot
        expect(vic.locator("#mode")).to_have_text("mode: estop", timeout=5_000)
        expect(ada.locator("#mode")).to_have_text("mode: estop", timeout=5_000)

        ada.click("#access-release")
        expect(vic.locator("#access-holder")).to_have_text("control: free", timeout=10_000)
        ada.click("#access-logout")
        expect(ada).to_have_url(server.url + "/login")
        browser.close()
