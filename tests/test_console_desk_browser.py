"""A desk that warns before it acts (issue 27.4-27.5), in a real browser.

On main a take-over needed no confirmation, and a preview's result stayed on screen after the
fields changed ("timeout after 15.00 s" 14 s later), appeared with no "computing" meanwhile, and
survived the next command.
"""

import time

import httpx
import pytest

from tests.console_page import open_consoles, send, set_fields, until, wait_status

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


# Every (state, exit) the preview line shows, in order, as the browser renders it.
RECORD_PREVIEW = """() => {
  window.ptwlPreview = [];
  new MutationObserver(() => {
    const el = document.querySelector('#ptwl-preview');
    const now = el ? [el.dataset.state, el.dataset.exit] : null;
    const last = window.ptwlPreview[window.ptwlPreview.length - 1];
    if (now && (!last || last[0] !== now[0] || last[1] !== now[1])) window.ptwlPreview.push(now);
  }).observe(document.body, {subtree: true, childList: true, attributes: true});
}"""


def control(page) -> tuple[str, str]:  # type: ignore[no-untyped-def]
    el = page.locator("#ptwl-control")
    return el.get_attribute("data-mine") or "", el.get_attribute("data-holder") or ""


def preview_state(page) -> tuple[str, str]:  # type: ignore[no-untyped-def]
    el = page.locator("#ptwl-preview")
    return el.get_attribute("data-state") or "", el.get_attribute("data-exit") or ""


def test_taking_control_from_another_operator_asks_first(browser, stack) -> None:  # type: ignore[no-untyped-def]
    robot, _, console = stack
    httpx.post(robot.url + "/api/stop").raise_for_status()
    holder, other = open_consoles(browser, console.url, True, False)
    assert control(holder)[0] == "1"
    other.get_by_role("button", name="Take control").click()
    dialog = other.get_by_text("Take control?")
    dialog.wait_for()
    assert "has control now" in other.locator("body").inner_text()
    time.sleep(0.5)
    assert control(holder)[0] == "1" and control(other)[0] == "0"  # nothing taken yet
    other.get_by_role("button", name="Cancel").click()
    time.sleep(0.5)
    assert control(holder)[0] == "1" and control(other)[0] == "0"  # cancelled: nothing taken
    other.get_by_role("button", name="Take control").click()
    other.get_by_role("button", name="Take control from them").click()
    until(other, "document.querySelector('#ptwl-control')?.dataset.mine === '1'")
    until(holder, "document.querySelector('#ptwl-control')?.dataset.mine === '0'")
    assert holder.get_by_text("Control taken").count() >= 1  # the one who lost it is told
    holder.close()
    other.close()


def test_a_preview_says_computing_goes_stale_when_the_fields_change_and_clears_on_send(
    browser, stack
) -> None:  # type: ignore[no-untyped-def]
    robot, _, console = stack
    httpx.post(robot.url + "/api/stop").raise_for_status()
    (page,) = open_consoles(browser, console.url, True)
    set_fields(page, "Translation [mm]", 0, 0, -10)
    set_fields(page, "Duration [s]", 1.0)
    page.evaluate(RECORD_PREVIEW)
    page.get_by_role("button", name="Preview").click()
    until(page, "document.querySelector('#ptwl-preview')?.dataset.exit === 'goal_reached'")
    assert preview_state(page) == ("", "goal_reached")
    seen = page.evaluate("window.ptwlPreview")
    assert seen[seen.index(["computing", ""]) + 1 :][-1] == ["", "goal_reached"]  # computing came first
    set_fields(page, "Duration [s]", 2.0)  # not what was previewed any more
    until(page, "document.querySelector('#ptwl-preview')?.dataset.state === 'stale'")
    assert "STALE" in page.locator("#ptwl-preview").inner_text()
    set_fields(page, "Duration [s]", 1.0)  # what was previewed again: no longer stale
    until(page, "document.querySelector('#ptwl-preview')?.dataset.state === ''")
    assert preview_state(page) == ("", "goal_reached")
    before = send(page, "Send cmd")
    until(page, "document.querySelector('#ptwl-preview')?.dataset.exit === ''")
    assert "no preview" in page.locator("#ptwl-preview").inner_text()
    wait_status(page, "goal_reached", after=before)
    page.close()
