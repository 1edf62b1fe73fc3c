"""Logging in from Chromium: the login page, an operator taking control, a viewer's page that can only watch
and stop (its 3D view's clicks refused), both pages showing who has control as it changes, and the 3D views
closed to anyone without a login."""

from __future__ import annotations

import httpx
import pytest

from app.auth.roles import Role
from app.auth.store import UserStore
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from harness.browser import launch_chromium, wait_for_scene_render
from harness.server import ServerProcess
from tests.support.scene_viewer import run_apart, shift_click, view_url

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
    with (
        ServerProcess(workdir, extra_env={"HUMANOID_PERCEPTION": "false"}) as server,
        playwright_api.sync_playwright() as playwright,
    ):
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
        # the 3D views: nothing without a login on any of their ports; the logged-in page's frame renders
        for port in (server.viser_port, server.viser_light_port, server.replay_port):
            assert httpx.get(f"http://127.0.0.1:{port}/", timeout=10).status_code == 401
        assert wait_for_scene_render(ada) > 8.0
        frame_src = ada.locator("#scene").get_attribute("src")
        assert "/s/" in frame_src and frame_src.startswith("http://localhost:")

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

        vic_views = vic.evaluate("fetch('/api/scene').then((r) => r.json())")
        run_apart(shift_click(view_url(server.viser_port, vic_views["token"]), (-2.4, -2.4, 3.0), (0.6, 0.4, -0.6)))
        expect(vic.locator("#events")).to_contain_text("3D view click by vic refused", timeout=10_000)

        ada.click("#access-release")
        expect(vic.locator("#access-holder")).to_have_text("control: free", timeout=10_000)
        ada.click("#access-logout")
        expect(ada).to_have_url(server.url + "/login")
        assert httpx.get(frame_src.replace("localhost", "127.0.0.1"), timeout=10).status_code == 401  # logged out
        browser.close()
