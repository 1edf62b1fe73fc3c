"""The Behaviours panel in a real browser on the real server: parameters, a refused one named, start, the live
state machine and feedback, stop."""

from __future__ import annotations

import pytest

from harness.browser import launch_chromium
from harness.server import ServerProcess

pytestmark = pytest.mark.slow

playwright_api = pytest.importorskip("playwright.sync_api")


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    with ServerProcess(tmp_path_factory.mktemp("server"), views=False) as server, playwright_api.sync_playwright() as p:
        browser = launch_chromium(p)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(server.url)
        yield page
        browser.close()


def test_the_panel_starts_watches_and_stops_a_patrol(page) -> None:
    expect = playwright_api.expect
    expect(page.locator("#beh-name option[value=patrol]")).to_have_count(1, timeout=20_000)
    page.select_option("#beh-name", "patrol")
    laps = page.locator("#beh-params input[name=laps]")
    expect(laps).to_have_value("2")
    laps.fill("-1")
    page.click("#beh-start")
    expect(page.locator("#beh-result")).to_contain_text("'laps'")
    expect(page.locator("#beh-params label[data-param=laps]")).to_have_class("param bad")

    laps.fill("1")
    page.select_option("#beh-params select[name=waypoints]", ["charging dock"])
    page.click("#beh-start")
    expect(page.locator("#beh-state")).to_have_text("patrol: running", timeout=20_000)
    expect(page.locator("#beh-machine li.current")).to_have_text("walking", timeout=20_000)
    expect(page.locator("#beh-feedback")).to_contain_text("walking to the charging dock")
    page.click("#beh-stop")
    expect(page.locator("#beh-state")).to_have_text("patrol: stopped", timeout=30_000)
    expect(page.locator("#beh-reason")).to_have_text("stopped by the operator")
    expect(page.locator("#beh-resume")).to_be_disabled()
