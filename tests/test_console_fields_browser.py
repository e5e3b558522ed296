"""Number fields keep what was typed (issue 27), in a real browser on a 1366x768 screen.

On main, with translation x = 15 mm, typing "abc" blanked the field while the marker still read
15.0 mm, the check said "within the robot's limits" and Send moved 15 mm; "1e9" became 19, "0x10"
10, and a duration of "-5" became 0.01 s, with an impact warning for a speed nobody typed. Here
each string is typed into the field and the page is read: the field, the reason beside it, the
contemplated target's line (the DOM's mirror of the WebGL marker), the check line, Send, and the
robot's own list of commands (Enter must send nothing).
"""

import time

import httpx
import pytest
from playwright.sync_api import expect

from ptwl.launcher import ServiceProcess
from tests.console_page import inputs_for, open_console, set_fields

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

WIDTH, HEIGHT = 1366, 768
RED = "rgb(224, 49, 49)"  # #e03131
NOT_A_NUMBER = "x: not a number (write e.g. 12.5 or 2.5e1)"
# Typed into translation x, and what the field must say of it: each was rewritten on main. One of
# each kind the page must show (not a number, out of range, a refused notation); every other
# refused text (nan, inf, 1_0, 2,5, empty, 5000) is judged by the same Panel code, which
# tests/test_typed_number.py runs without a browser, each with its reason, Send and check line.
REFUSED = [
    ("abc", NOT_A_NUMBER),
    ("1e9", "magnitude must be <= 1000 mm, got 1e+09 mm"),  # 1e9 mm, not 19
    ("0x10", "x: not a decimal number (0x, 0o and 0b are refused)"),  # not 10
]


def commands_on_record(robot: ServiceProcess) -> int:
    """How many commands the robot has on record (read from the robot, not the link)."""
    return len(httpx.get(robot.url + "/api/commands", params={"limit": 1000}).json())


def wait_sent(robot: ServiceProcess, before: int, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while commands_on_record(robot) <= before:
        assert time.monotonic() < deadline, "nothing was sent"
        time.sleep(0.1)


def in_view_near(page, reason, field) -> None:  # type: ignore[no-untyped-def]
    """The reason is on screen, red, and right under the field it is about."""
    box, under = reason.bounding_box(), field.bounding_box()
    assert box is not None and under is not None
    assert box["y"] >= 0 and box["y"] + box["height"] <= HEIGHT and 0 <= box["x"] < WIDTH, box
    assert 0 <= box["y"] - under["y"] < 140, (box, under)  # below x, y and z of its own folder
    assert reason.evaluate("e => getComputedStyle(e).color") == RED


def test_typed_numbers_are_what_the_console_uses_or_refused_at_the_field(browser, stack) -> None:  # type: ignore[no-untyped-def]
    robot, _, console = stack
    httpx.post(robot.url + "/api/stop").raise_for_status()
    httpx.post(robot.url + "/api/scene", json={"name": "free_space"}).raise_for_status()
    page = open_console(browser, console.url, viewport=(WIDTH, HEIGHT))
    x = inputs_for(page, "Translation [mm]").nth(0)
    reason = page.locator("#field-reason-translation")
    target = page.locator("#ptwl-contemplated")
    check = page.locator("#ptwl-check-ptwl")
    send = page.get_by_role("button", name="Send cmd")
    set_fields(page, "Translation [mm]", 15, 0, 0)
    expect(target).to_have_attribute("data-distance", "15.0")
    expect(send).to_be_enabled()
    sent = commands_on_record(robot)

    for typed, said in REFUSED:
        x.fill(typed)
        expect(reason).to_have_attribute("data-reason", said)
        expect(reason).to_be_visible()
        assert x.input_value() == typed  # the field shows what was typed, not a rewrite of it
        in_view_near(page, reason, x)
        expect(check).to_have_attribute("data-valid", "0")
        assert "within the robot's limits" not in check.inner_text()
        expect(send).to_be_disabled()
        expect(target).to_have_attribute("data-shown", "0")  # not the 15.0 mm of before
        assert "15.0 mm" not in target.inner_text()
        x.press("Enter")  # Enter obeys the same rule as Send
        page.wait_for_timeout(300)
        assert commands_on_record(robot) == sent, typed

    x.fill("2.5e1")  # 25 mm, not 2.51
    expect(target).to_have_attribute("data-distance", "25.0")
    expect(reason).to_be_hidden()
    expect(send).to_be_enabled()
    assert "within the robot's limits" in check.inner_text()
    x.press("Enter")  # and what is sent is what is typed
    wait_sent(robot, sent)
    last = httpx.get(robot.url + "/api/commands", params={"limit": 1000}).json()[-1]
    assert last["params"]["translation"] == [0.025, 0.0, 0.0]
    sent += 1

    # A duration of -5 s with 70 mm: refused at the duration field, in s, and nothing downstream
    # (impact warning, Send) uses another duration. First, 0.01 s: the warning main showed.
    duration = inputs_for(page, "Duration [s]").first
    set_fields(page, "Translation [mm]", 0, 0, 70)
    set_fields(page, "Duration [s]", 0.01)
    expect(check).to_have_attribute("data-warnings", "1")
    expect(check).to_contain_text("approach speed 7 m/s")  # waited for: the 2 s check warned too
    duration.fill("-5")
    duration_reason = page.locator("#field-reason-duration")
    expect(duration_reason).to_have_attribute("data-reason", "must be in (0, 600] s, got -5 s")
    in_view_near(page, duration_reason, duration)
    assert duration.input_value() == "-5"
    expect(check).to_have_attribute("data-warnings", "0")
    assert "m/s" not in check.inner_text() and "within the robot's limits" not in check.inner_text()
    expect(send).to_be_disabled()
    expect(reason).to_be_hidden()  # the translation itself is fine
    duration.press("Enter")
    page.wait_for_timeout(300)
    assert commands_on_record(robot) == sent
    page.close()
