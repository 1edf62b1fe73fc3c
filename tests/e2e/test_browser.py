"""The real server and a real browser (Debian Chromium through Playwright), as an operator uses them."""

from __future__ import annotations

import re
import time

import httpx
import pytest

from harness.browser import chromium_path, launch_chromium, wait_for_scene_render
from harness.server import ServerProcess

pytestmark = pytest.mark.slow

playwright_api = pytest.importorskip("playwright.sync_api")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with ServerProcess(tmp_path_factory.mktemp("server")) as running:
        yield running


@pytest.fixture(scope="module")
def playwright():
    with playwright_api.sync_playwright() as p:
        yield p


@pytest.fixture(scope="module")
def page(server, playwright):
    browser = launch_chromium(playwright)
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.goto(server.url)
    yield page
    browser.close()


def test_chromium_is_installed() -> None:
    assert chromium_path()


def test_the_voice_panel_says_the_robot_has_no_microphone_or_speaker_here(page) -> None:
    # test machines have no sound card: the page says so, and push-to-talk in the page still works (below)
    playwright_api.expect(page.locator("#robot-audio")).to_contain_text("no robot microphone: ", timeout=20_000)
    playwright_api.expect(page.locator("#robot-audio")).to_contain_text("no robot speaker: ")


def test_the_3d_mirror_renders_in_a_cross_site_frame(page, server) -> None:
    # Page on 127.0.0.1, scene on localhost: another site. Headless Chromium renders WebGL in software, so the
    # page picks the light view at half resolution (its script sets the frame's source after probing WebGL: wait).
    expected = re.compile(rf"http://localhost:{server.viser_light_port}/s/[\w.-]+/\?fixedDpr=0\.5")
    playwright_api.expect(page.locator("#scene")).to_have_attribute("src", expected)
    assert wait_for_scene_render(page) > 8.0
    # an unchanged view is redrawn every 10 s, not every second: the gate's script found viser's redraw timer
    view = next(f for f in page.frames if f.url.startswith(f"http://localhost:{server.viser_light_port}/s/"))
    assert view.evaluate("window.__humanoidIdleRedraw") == {"stretched": 1, "everyMs": 10_000}
    # the link's round trip is shown with the connection
    playwright_api.expect(page.locator("#conn")).to_have_text(re.compile(r"connected · \d+ ms"), timeout=10_000)


def test_typed_command_runs_and_the_plan_shows_per_step_status(page) -> None:
    expect = playwright_api.expect
    page.fill("#command-text", "say hello from the browser")
    page.click("#send")
    expect(page.locator("#plan-steps li").first).to_have_attribute("data-state", "succeeded", timeout=15_000)
    expect(page.locator("#events")).to_contain_text("hello from the browser")

    page.fill("#command-text", "pick up the red mug from the kitchen counter")
    page.click("#send")
    steps = page.locator("#plan-steps li")
    expect(steps).to_have_count(4)
    expect(steps.first).to_have_attribute("data-state", "running", timeout=15_000)  # walking to the counter
    page.click("#cancel")
    expect(page.locator("#plan-state")).to_have_text("cancelled", timeout=15_000)

    page.fill("#command-text", "pick up the purple elephant")
    page.click("#send")
    expect(page.locator("#command-result")).to_contain_text("unknown object 'purple elephant'")

    page.fill("#command-text", "bring me the blue mug")  # two close readings: a question, not a plan
    page.click("#send")
    expect(page.locator("#command-result")).to_have_text("Did you mean the red mug or the blue bottle?")
    expect(page.locator("#command-result")).to_have_class("result question")


def test_a_misheard_command_is_asked_about_and_runs_once_approved(page) -> None:
    """The page sends what it heard with the recogniser's other wordings (as after push-to-talk); the robot plans
    the first readable one and asks. An edited command goes without them."""
    expect = playwright_api.expect
    heard = {"text": "sail hello there", "alternatives": ["sail hello dare", "say hello there"]}
    page.evaluate(
        "heard => { document.getElementById('command-text').value = heard.text; humanoid.heardAs = heard; }", heard
    )
    page.click("#send")
    expect(page.locator("#command-result")).to_contain_text('did you mean "say hello there"?')
    expect(page.locator("#plan-state")).to_have_text("awaiting approval", timeout=10_000)
    page.click("#approve")
    expect(page.locator("#plan-state")).to_have_text("succeeded", timeout=10_000)
    expect(page.locator("#plan-steps li").first).to_contain_text('said "hello there"')

    page.evaluate(
        "heard => { document.getElementById('command-text').value = heard.text; humanoid.heardAs = heard; }", heard
    )
    page.fill("#command-text", "sail hello everyone")  # edited before sending: only what was typed is planned
    page.click("#send")
    expect(page.locator("#command-result")).to_have_class("result error")


def test_a_transcript_with_a_name_the_hints_may_have_put_there_waits_for_send_and_says_which(page) -> None:
    """What the robot's microphone heard, not sure because whisper's hints may have supplied "apple" ("bring me a
    towel" heard as "Bring the apple."): offered for Send, with the name to check."""
    expect = playwright_api.expect
    heard = {
        "text": "Bring the apple.",
        "confidence": 0.65,
        "in_grammar": False,
        "alternatives": [],
        "unsure_names": ["apple"],
        "will_run": False,
    }
    page.evaluate("heard => humanoid.onRobotHeard(heard)", heard)
    expect(page.locator("#heard")).to_contain_text('"apple" may be a guess: check it')
    expect(page.locator("#heard")).to_contain_text("press Send to run it")
    expect(page.locator("#command-text")).to_have_value("Bring the apple.")


def test_a_transcript_read_as_the_nearest_command_waits_for_send_and_says_what_was_heard_first(page) -> None:
    """Whisper was sure of "Go to your phone position.", no command; the likeliest command it heard is offered for
    Send, saying what it heard first."""
    expect = playwright_api.expect
    heard = {
        "text": "Go to your home position.",
        "confidence": 0.86,
        "in_grammar": False,
        "alternatives": ["Go to your phone position."],
        "unsure_names": [],
        "first_heard": "Go to your phone position.",
        "will_run": False,
    }
    page.evaluate("heard => humanoid.onRobotHeard(heard)", heard)
    expect(page.locator("#heard")).to_contain_text('first heard as "Go to your phone position."')
    expect(page.locator("#heard")).to_contain_text("press Send to run it")
    expect(page.locator("#command-text")).to_have_value("Go to your home position.")


def test_an_operator_approves_edits_and_pauses_plans_from_the_page(page) -> None:
    expect = playwright_api.expect
    expect(page.locator("#planner")).to_contain_text("planner: rules")
    page.check("#approve-toggle")
    expect(page.locator("#command-result")).to_contain_text("plans now wait for approval")
    page.fill("#command-text", "say nothing moves until I approve")
    page.click("#send")
    expect(page.locator("#plan-state")).to_have_text("awaiting approval", timeout=10_000)
    expect(page.locator("#plan-source")).to_contain_text("planned by rules")
    page.click("#edit")
    page.fill("#plan-json", '[{"action": "say", "text": "edited by the operator"}]')
    page.click("#run-edited")
    expect(page.locator("#plan-state")).to_have_text("succeeded", timeout=10_000)
    expect(page.locator("#plan-steps li").first).to_contain_text('said "edited by the operator"')
    expect(page.locator("#plan-source")).to_contain_text("written by the operator")
    page.uncheck("#approve-toggle")
    expect(page.locator("#command-result")).to_contain_text("plans now run when planned")

    page.fill("#command-text", "wait 20 seconds")
    page.click("#send")
    expect(page.locator("#plan-steps li").first).to_have_attribute("data-state", "running", timeout=10_000)
    page.click("#pause")
    expect(page.locator("#plan-state")).to_have_text("paused", timeout=10_000)
    expect(page.locator("#pause")).to_have_text("Resume")
    page.click("#pause")
    expect(page.locator("#plan-state")).to_have_text("running", timeout=10_000)
    page.click("#cancel")
    expect(page.locator("#plan-state")).to_have_text("cancelled", timeout=10_000)


def test_estop_button_latches_the_robot_and_release_is_explicit(page, server) -> None:
    expect = playwright_api.expect
    page.click("#estop")
    expect(page.locator("#mode")).to_have_text("mode: estop", timeout=5_000)
    expect(page.locator("#latched-banner")).to_be_visible()
    state = httpx.get(server.url + "/api/state").json()
    assert state["estop_latched"] and state["mode"] == "estop"
    latencies = page.evaluate("window.humanoid.estopLatencies")
    assert len(latencies) == 1 and 0 <= latencies[0] < 1000

    page.fill("#command-text", "say hello")
    page.click("#send")
    expect(page.locator("#command-result")).to_contain_text("e-stop is latched")

    page.click("#release")
    expect(page.locator("#mode")).to_have_text("mode: idle", timeout=5_000)
    expect(page.locator("#latched-banner")).to_be_hidden()
    assert not httpx.get(server.url + "/api/state").json()["estop_latched"]


def _moved(server, start: dict, metres: float) -> bool:
    pose = httpx.get(server.url + "/api/state").json()["pose"]
    return abs(pose["x"] - start["x"]) + abs(pose["y"] - start["y"]) > metres


def test_keyboard_teleop_walks_the_robot_and_letting_go_stops_it(page, server) -> None:
    expect = playwright_api.expect
    start = httpx.get(server.url + "/api/state").json()["pose"]
    page.locator("body").click(position={"x": 5, "y": 300})  # focus the page, not the command box
    page.keyboard.down("w")
    expect(page.locator("#mode")).to_have_text("mode: teleop", timeout=5_000)
    expect(page.locator("#st-walk")).to_contain_text("walking", timeout=5_000)
    deadline = time.monotonic() + 60
    # held until it walked, however busy (past the 0.1 m asserted below: the estimate may settle back a little as it
    # stops, as the legs' odometry meets the lidar's correction)
    while not _moved(server, start, 0.15) and time.monotonic() < deadline:
        page.wait_for_timeout(200)
    page.keyboard.up("w")
    expect(page.locator("#teleop-cmd")).to_have_text("released: stopping")
    expect(page.locator("#mode")).to_have_text("mode: idle", timeout=10_000)
    end = httpx.get(server.url + "/api/state").json()
    assert not end["fallen"] and end["locomotion"]["phase"] == "standing"
    assert abs(end["pose"]["x"] - start["x"]) + abs(end["pose"]["y"] - start["y"]) > 0.1
    # the joystick drives too: drag the knob up, then let go
    page.locator("#joystick").scroll_into_view_if_needed()  # (below the Behaviours panel: scrolled to, as a user would)
    box = page.locator("#joystick").bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(cx, cy)
    page.mouse.down()
    page.mouse.move(cx, cy - box["height"] / 2)
    expect(page.locator("#mode")).to_have_text("mode: teleop", timeout=5_000)
    page.mouse.up()
    expect(page.locator("#mode")).to_have_text("mode: idle", timeout=10_000)


def test_camera_stream_with_detections_map_and_a_search_from_the_page(page, server) -> None:
    expect = playwright_api.expect
    expect(page.locator("#perc-status")).to_contain_text("camera", timeout=30_000)
    expect(page.locator("#camera-fps")).to_contain_text("fps shown", timeout=15_000)
    # a frame with what is in view boxed on it (where the robot stands after the tests before: not always the mug)
    view = page.wait_for_function(
        "(() => { const c = window.humanoid.camera;"
        " return c.seq > 10 && c.detections.length ? {seq: c.seq, labels: c.detections.map(d => d.label)} : null;"
        " })()",
        timeout=60_000,
    ).json_value()
    # the stream flows (its rate is the perception bench's business: a busy machine leaves sensing what is spare)
    page.wait_for_function(f"window.humanoid.camera.seq > {view['seq']}", timeout=60_000)
    assert set(view["labels"]) <= {"red mug", "blue bottle", "green apple"}  # only the world's objects
    # the camera canvas shows an image, not a blank
    spread = page.evaluate(
        "(() => { const c = document.getElementById('camera').getContext('2d').getImageData(0, 0, 320, 240).data;"
        " let lo = 255, hi = 0;"
        " for (let i = 0; i < c.length; i += 4) { lo = Math.min(lo, c[i]); hi = Math.max(hi, c[i]); }"
        " return hi - lo; })()"
    )
    assert spread > 60
    expect(page.locator("#map-info")).to_contain_text("scans", timeout=10_000)
    expect(page.locator("#known-objects")).to_contain_text("red mug: kitchen counter")

    page.fill("#command-text", "find the green apple")
    page.click("#send")
    expect(page.locator("#plan-steps li").first).to_have_attribute("data-state", "succeeded", timeout=60_000)
    expect(page.locator("#plan-steps li").first).to_contain_text("found green apple at")
    expect(page.locator("#known-objects")).to_contain_text("green apple: kitchen counter")


def test_diagnostics_plot_live_and_an_overheating_servo_alarms_and_stops_the_robot(page, server) -> None:
    expect = playwright_api.expect
    page.goto(server.url)
    expect(page.locator("#diag-groups")).to_contain_text("servos", timeout=10_000)
    expect(page.locator("#v-servo")).to_contain_text("°C", timeout=5_000)
    page.wait_for_function("window.humanoid.diagnostics && document.getElementById('v-cpu').textContent !== '–'")
    # a few samples: a line drawn on the servo's sparkline
    page.wait_for_function(
        "(() => { const c = document.getElementById('spark-servo');"
        " return c.getContext('2d').getImageData(0, 0, c.width, c.height).data.filter((v, i) => i % 4 === 3 && v)"
        ".length > 20; })()",
        timeout=60_000,
    )
    # to 77 C: past the diagnostics' limit (75), short of the servo's own shutdown (80)
    servos = server.get("/api/diagnostics")["groups"]["servos"]["statuses"]
    knee = next(s for s in servos if s["name"] == "servos/l_knee")
    heat = 77.0 - knee["values"]["temperature_c"]
    assert server.post("/api/sim/faults", json={"fault": "servo_heat", "target": "l_knee", "value": heat}).is_success
    banner = page.locator("#alarm-banner")
    expect(banner).to_contain_text("servos/l_knee: overheating: 77 C", timeout=5_000)
    expect(banner).to_contain_text("The robot is stopped")
    expect(page.locator("#health")).to_have_text("health: ERROR")
    expect(page.locator("#mode")).to_have_text("mode: estop")
    expect(page.locator("#latched-banner")).to_be_visible()
    page.click("#release")
    expect(page.locator("#command-result")).to_contain_text("motion is unsafe until this is fixed")
    page.click("#diag-groups summary:has-text('servos')")
    expect(page.locator("#diag-groups tr[data-name='servos/l_knee']")).to_contain_text("temperature_c=")
    assert server.post("/api/sim/faults", json={"fault": "servo_heat", "target": "l_knee", "value": -heat}).is_success
    expect(banner).not_to_contain_text("l_knee", timeout=5_000)
    page.click("#release")
    expect(page.locator("#mode")).to_have_text("mode: idle", timeout=5_000)


SEEN_WHOLE = """(selector) => Array.from(document.querySelectorAll(selector)).map((el) => {
  const r = el.getBoundingClientRect();
  const top = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
  return r.width > 0 && r.top >= 0 && r.left >= 0 && r.bottom <= innerHeight && r.right <= innerWidth
    && !!top && (top === el || el.contains(top));
})"""


def test_on_a_laptop_screen_the_estop_the_command_box_and_the_running_plan_show_together_with_alarms_up(
    server, playwright
) -> None:
    """1280 x 720, two alarms up, a plan running: the e-stop, the command box with its Send button and every step
    of the plan are on the screen at once, none under the alarm banner; no identity controls with access off."""
    expect = playwright_api.expect
    browser = launch_chromium(playwright)
    try:
        page = browser.new_page(viewport={"width": 1280, "height": 720})
        page.goto(server.url)
        expect(page.locator("#conn")).to_contain_text("connected", timeout=20_000)
        servos = server.get("/api/diagnostics")["groups"]["servos"]["statuses"]
        knee = next(s for s in servos if s["name"] == "servos/l_knee")
        warm = 70.0 - knee["values"]["temperature_c"]  # WARN (65-75 C): an alarm that does not stop the robot
        assert server.post(
            "/api/sim/faults", json={"fault": "servo_heat", "target": "l_knee", "value": warm}
        ).is_success
        assert server.post("/api/sim/faults", json={"fault": "battery_soc", "value": 0.15}).is_success
        expect(page.locator("#alarm-banner")).to_contain_text("servos/l_knee", timeout=10_000)
        expect(page.locator("#alarm-banner")).to_contain_text("battery", timeout=10_000)
        page.fill("#command-text", "pick up the red mug from the kitchen counter")
        page.click("#send")
        expect(page.locator("#plan-steps li")).to_have_count(4)
        expect(page.locator("#plan-steps li").first).to_have_attribute("data-state", "running", timeout=15_000)
        for selector in ("#estop", "#command-text", "#send", "#plan-steps li", "#plan-state"):
            assert all(page.evaluate(SEEN_WHOLE, selector)), f"{selector} is off the screen or covered"
        expect(page.locator("#access-logout")).to_be_hidden()  # access control is off: nobody to log out
        expect(page.locator("#access-user")).to_be_hidden()
        page.click("#cancel")
        expect(page.locator("#plan-state")).to_have_text("cancelled", timeout=15_000)
    finally:
        server.post("/api/sim/faults", json={"fault": "battery_soc", "value": 1.0})
        server.post("/api/sim/faults", json={"fault": "clear"})
        browser.close()


def test_sessions_page_shows_the_timeline_and_replays_from_an_entry(page, server) -> None:
    expect = playwright_api.expect
    page.goto(server.url + "/sessions")
    first_row = page.locator("#sessions tr").first
    expect(first_row).to_contain_text("serve")
    expect(first_row.locator("button.danger")).to_be_disabled()  # the live session cannot be deleted
    first_row.click()
    timeline = page.locator("#timeline")
    expect(timeline).to_contain_text('"say hello from the browser" from typed: accepted')
    expect(timeline.locator("li.tl-estop").first).to_contain_text("E-STOP latched")
    expect(page.locator("#plans")).to_contain_text("navigate_to(kitchen counter): cancelled")
    # the replay has the session loaded (3 s cold on an idle machine: more with the browser and server busy)
    expect(page.locator("#replay-time")).to_contain_text(" / ", timeout=30_000)
    entry = timeline.locator("li.tl-estop").first
    target = float(entry.get_attribute("data-t"))
    expect(entry).to_be_visible()
    # (not Playwright's wait for the entry to hold still over two painted frames: with the replay's software 3D
    # view in the same browser a loaded machine painted none for 30 s, and the click itself is what is tested)
    entry.click(force=True)
    expect(page.locator("#replay-time")).to_contain_text(f"{target:.2f} /")
    expect(entry).to_have_class(re.compile("tl-active"))
    # the view is looked at, as an operator would: clicking the entry scrolled the page down to it, and Chromium
    # draws no frames for a cross-site frame out of sight, while viser applies what its server sends only as it
    # draws one (an idle fresh-clone CI: "Connected", and neither scene nor panel after 240 s)
    page.locator("#replay-frame").scroll_into_view_if_needed()
    frame = page.frame_locator("#replay-frame")
    # a viser page in software WebGL, in its own renderer: on a busy machine it takes long (a fresh-clone suite
    # beside two fetch simulations: connected, but neither its scene nor its panel shown after 90 s)
    try:
        expect(frame.get_by_text("Session", exact=False).first).to_be_visible(timeout=240_000)
    except AssertionError as failure:  # twice in CI, never here: say what the frame held, for the next time
        raise AssertionError(f"{failure}\n{_frames_described(page, server)}") from None


def test_sessions_are_filtered_imported_and_deleted_from_the_page(page, server) -> None:
    expect = playwright_api.expect
    page.goto(server.url + "/sessions")
    expect(page.locator("#sessions tr").first).to_contain_text("serve")
    page.fill("#f-q", "no such command at all")
    page.click("#filters button[type=submit]")
    expect(page.locator("#total")).to_have_text("0")
    page.click("#f-reset")
    expect(page.locator("#total")).not_to_have_text("0")
    live = server.get("/api/health")["session_id"]
    exported = httpx.get(f"{server.url}/api/sessions/{live}/export?format=json", timeout=60).content
    page.set_input_files("#import-file", files=[{"name": "s.json", "mimeType": "application/json", "buffer": exported}])
    # the live session has recorded the whole module by now: importing and deleting its copy take a while on a
    # loaded machine (what they cost is measured by `humanoid bench sessions`, not here)
    expect(page.locator("#list-result")).to_contain_text("imported as session", timeout=60_000)
    imported = page.locator("#sessions tr", has_text="import")
    expect(imported).to_have_count(1)
    delete = imported.locator("button.danger")
    delete.click()  # the first click only asks again, on the button
    expect(delete).to_have_text("Delete for good?")
    page.locator("#total").click()  # a click elsewhere: nothing is deleted
    expect(delete).to_have_text("Delete")
    delete.click()
    expect(delete).to_have_text("Delete for good?")
    delete.click()
    expect(page.locator("#list-result")).to_contain_text("deleted", timeout=60_000)
    expect(page.locator("#sessions tr", has_text="import")).to_have_count(0, timeout=30_000)


def test_cli_estop_latches_and_releases_a_running_server(server) -> None:
    import os
    import subprocess
    import sys

    def cli(*args: str) -> subprocess.CompletedProcess:
        command = [sys.executable, "-m", "app.cli", "estop", "--url", server.url, *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=60, env=dict(os.environ))

    done = cli()
    assert done.returncode == 0 and "latched" in done.stdout
    assert httpx.get(server.url + "/api/state").json()["estop_latched"]
    done = cli("--release")
    assert done.returncode == 0 and "released" in done.stdout
    assert cli("--release").returncode == 1  # nothing to release: said, not hidden


def test_the_served_websocket_closes_on_a_frame_over_64_kib_and_refuses_one_over_4_kib(server) -> None:
    """Frames are limited where they are read (uvicorn closes the socket, 1009), and messages are limited again
    by the handler (said, the socket stays open); the server and robot go on. (The synchronous client: this
    module's Playwright runs an event loop on this thread.)"""
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    def send(size: int) -> str:
        with connect(server.url.replace("http", "ws") + "/ws", max_size=None) as ws:
            ws.send('{"type": "ping", "t": "' + "x" * size + '"}')
            try:
                while True:
                    message = ws.recv(timeout=10)
                    if '"error"' in message[:20]:
                        return message
            except ConnectionClosed as closed:
                return f"closed {closed.rcvd.code if closed.rcvd else None}"

    assert "larger than 4096 bytes" in send(5_000)
    assert send(70_000) == "closed 1009"  # message too big
    assert httpx.get(server.url + "/api/health").status_code == 200


def test_a_command_spoken_into_the_microphone_is_heard_and_run(server, playwright, tmp_path) -> None:
    import numpy as np

    from robot.speech.audio import Audio
    from robot.speech.tts import synthesize_audio

    expect = playwright_api.expect
    speech = synthesize_audio("wait for two seconds", "en-us", 150)
    silence = np.zeros(16000, np.int16)  # the fake microphone loops its file: room before it comes round again
    wav = tmp_path / "command.wav"
    wav.write_bytes(Audio(np.concatenate([silence[:4000], speech.samples, silence, silence])).wav_bytes())
    browser = launch_chromium(playwright, microphone_wav=str(wav))
    try:
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(server.url)
        expect(page.locator("#conn")).to_contain_text("connected", timeout=20_000)
        page.locator("#ptt").dispatch_event("pointerdown")
        page.wait_for_timeout(int((0.25 + speech.duration_s + 0.6) * 1000))
        page.locator("#ptt").dispatch_event("pointerup")
        # (whisper, the default recogniser, writes it as a sentence, the number in words or digits; its tiny model
        # hears this voice's "three" as "free" even from the clean file: the test is of the path, not of whisper)
        said = re.compile(r'heard "wait for (two|2) seconds\.?"', re.IGNORECASE)
        # the server's first recording starts its recogniser process (whisper's model, the spotter's grammar): on a
        # busy machine that took over 20 s before it decoded (its own start may take 60 s, the decoding 15 more)
        expect(page.locator("#heard")).to_contain_text(said, timeout=90_000)
        expect(page.locator("#command-text")).to_have_value(re.compile(r"wait for (two|2) seconds\.?", re.IGNORECASE))
        if "press Send" in page.locator("#heard").inner_text():  # not sure enough to run unasked: confirm
            page.click("#send")
        try:
            expect(page.locator("#plan-steps li").first).to_contain_text("waited 2 s", timeout=30_000)
        except AssertionError as failure:  # (once: a robot left fallen by the tests before refused it) say why
            raise AssertionError(
                f"{failure}\nthe page said: {page.locator('#command-result').inner_text()!r}"
            ) from None
        # what was said is kept with the session, and can be listened to again
        session_id = httpx.get(f"{server.url}/api/health").json()["session_id"]
        page.goto(f"{server.url}/sessions?id={session_id}")
        heard = page.locator("#timeline li.tl-heard").filter(has_text=said)
        expect(heard).to_have_count(1, timeout=15_000)
        expect(heard.locator("audio")).to_have_count(1)
    finally:
        browser.close()


def _frames_described(page, server) -> str:
    """What each frame of `page` shows and what its address answers now (for a 3D view that never appeared)."""
    lines = [f"replay: {server.get('/api/replay')}"]
    for frame in page.frames:
        try:
            shown = frame.evaluate(
                "[document.readyState, document.body ? document.body.innerText.slice(0, 500) : null]"
            )
            lines.append(f"frame {frame.url}: {shown!r}")
        except Exception as exc:  # a frame gone or crashed says so
            lines.append(f"frame {frame.url}: {exc}")
        if frame.url.startswith("http") and "/s/" in frame.url:
            try:
                answer = httpx.get(frame.url, timeout=10)
                lines.append(f"  GET now: {answer.status_code}, {len(answer.content)} bytes")
            except httpx.HTTPError as exc:
                lines.append(f"  GET now: {exc!r}")
    return "\n".join(lines)
