"""The replay page in real headless Chromium (Debian's ``chromium``), driven with Playwright."""

import os
import shutil
from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
DOCS_SCREENSHOT = Path(__file__).resolve().parents[2] / "docs" / "replay.png"

if not CHROMIUM.is_file():
    pytest.skip(f"{CHROMIUM} is missing: install Debian's chromium (apt-get install chromium; make test does it "
                "as root)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is missing: pip install -e '.[test]'")


@pytest.fixture(scope="module")
def page(emergency_run):
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 820})
        errors: list[str] = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.route("http*://**", lambda route: (errors.append(f"network request {route.request.url}"), route.abort()))
        page.goto((emergency_run / "replay.html").as_uri())
        page.wait_for_function("window.replayState !== undefined")
        page.errors = errors
        yield page
        browser.close()


def test_ego_ambulance_and_caption_at_the_message_time(page, tmp_path):
    state = page.evaluate("window.replaySeek(3.0)")
    assert state["t"] == pytest.approx(3.0)
    assert "ego" in state["drawn"] and "ambulance" in state["drawn"]
    assert any("ambulance is coming behind us" in text for text in state["captions"])
    assert any(text.startswith("run_left_lane(") for text in state["captions"])
    assert "lane=left" in state["spec"]
    shown = page.inner_text("#captions")
    assert "Passenger: An ambulance is coming behind us" in shown and "Tool call: run_left_lane" in shown
    page.screenshot(path=str(tmp_path / "replay.png"))
    assert (tmp_path / "replay.png").stat().st_size > 20_000
    if os.environ.get("AGENTIC_MPC_UPDATE_DOCS"):  # refresh the README's screenshot on request only
        shutil.copyfile(tmp_path / "replay.png", DOCS_SCREENSHOT)
    # before the message: no caption yet
    assert page.evaluate("window.replaySeek(0.5)")["captions"] == []
    assert page.errors == []


def test_slider_moves_the_scene(page):
    before = page.evaluate("window.replaySeek(0.5)")
    page.locator("#slider").fill("12")  # sets the value and fires input, as a drag does
    after = page.evaluate("window.replayState")
    assert after["t"] == pytest.approx(12.0, abs=0.02)
    assert after["ego"]["x"] - before["ego"]["x"] > 30  # the ego drove on (it stopped a while for the ambulance)
    assert "lane=center" in after["spec"]  # the agent resumed the centre lane after the ambulance passed
    assert page.evaluate("document.getElementById('time').textContent").startswith("12.00")


def test_play_advances_time(page):
    page.evaluate("window.replaySeek(2.0)")
    page.select_option("#speed", "4")
    page.click("#play")
    page.wait_for_timeout(600)
    page.click("#play")
    state = page.evaluate("window.replayState")
    assert not state["playing"] and state["t"] > 2.5
    assert page.errors == []
