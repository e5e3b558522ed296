"""A console the operator can trust across a delayed link (issue 10), in a real browser.

Each test reproduces what misled an operator on main and asserts what the page shows now.
"""

import itertools
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest

from ptwl.launcher import ServiceProcess, running_console, running_proxy, running_server
from server.client import RobotClient
from tests.console_page import (
    command_id,
    inputs_for,
    open_console,
    open_consoles,
    pixels_of_hue,
    port_mm,
    send,
    set_fields,
    until,
    view_hsv,
    wait_status,
)

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
ARTIFACTS = Path(__file__).resolve().parent.parent / "artifacts"


def set_link(link: ServiceProcess, **profile: object) -> None:
    """PUT merges into the link's profile: name every field a test uses, blackouts included."""
    body = {"uplink": 0.0, "downlink": 0.0, "blackouts": [], "schedule": None, **profile}
    httpx.put(link.url + "/_link/profile", json=body).raise_for_status()


@pytest.fixture
def calm(stack: tuple[ServiceProcess, ServiceProcess, ServiceProcess]) -> Iterator[None]:
    """free_space, nothing queued, a zero-delay link; the same afterwards."""
    robot, link, _ = stack
    set_link(link)
    httpx.post(robot.url + "/api/stop").raise_for_status()
    httpx.post(robot.url + "/api/scene", json={"name": "free_space"}).raise_for_status()
    yield
    set_link(link)


# In the page: every (time, age, seq, level) the bar shows, as the browser renders it.
RECORD_BAR = """() => {
  window.ptwlBar = [];
  const note = () => {
    const el = document.querySelector('#ptwl-telemetry');
    if (el) window.ptwlBar.push([performance.now(), el.dataset.age, el.dataset.seq, el.dataset.level]);
  };
  new MutationObserver(note).observe(document.querySelector('#ptwl-bar').parentElement,
                                     {subtree: true, childList: true, attributes: true});
}"""


def bar(page, key: str) -> str:  # type: ignore[no-untyped-def]
    return page.locator("#ptwl-telemetry").get_attribute(f"data-{key}") or ""


def test_the_age_keeps_counting_through_a_blackout_and_turns_amber_then_red(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main the page said '1.50 s old - connected' in green for all of a 15 s blackout."""
    _, link, console = stack
    # The bar's >= 4 updates/s is read off the page's DOM, which viser updates on animation frames:
    # the default test cap (5 frames/s) would leave one update's slack, so this page draws at 10.
    page = open_console(browser, console.url, control=False, frame_cap_hz=10)
    time.sleep(2.0)  # past the first heavy frames of software WebGL
    assert bar(page, "level") == "fresh"
    page.evaluate(RECORD_BAR)
    set_link(link, blackouts=[{"start": 0.0, "duration": 8.0, "mode": "drop"}])
    time.sleep(7.0)
    stale_text = page.locator("#ptwl-telemetry").inner_text()
    seen = page.evaluate("window.ptwlBar")
    page.close()
    # From the last state that arrived (what was in flight when the blackout began lands within a
    # second idle; under load later: three more states after that second, seen with three test
    # files beside a hogged core), nothing arrived for at least 4.5 s of the 7 watched ...
    last_seq = seen[-1][2]
    quiet = seen[next(i for i, s in enumerate(seen) if s[2] == last_seq) :]
    assert (quiet[-1][0] - quiet[0][0]) / 1000.0 >= 4.5  # (seq only grows: one seq throughout)
    # ... yet the page's age was recomputed at least 4 times a second ...
    per_s = len(quiet) / ((quiet[-1][0] - quiet[0][0]) / 1000.0)
    assert per_s >= 4.0, per_s
    # ... growing with the page's own clock, and the colour followed: amber past RTT + 1 s (RTT 0
    # here), red past RTT + 5 s. Idle, every update is within a tick of the page's clock. Under
    # load an update the console computed can reach the page late (the console, the renderer and
    # its software GPU all starved): measured 0.41 s with two tests beside a hogged core, 0.62 s
    # with three test files on 2 cores, 0.85 s in a hogged CI run, 1.51 s with three workers (two
    # of them on pages) beside a hogged core (tests/scheduling.py). So each update within 2.5 s,
    # and the age's rate (the median slope between updates at least 2 s apart, which one late
    # update cannot move) within 10 % of the page's clock: a frozen age is 5 s off by the end and
    # grows at a rate of 0.
    t_first, age_first = quiet[0][0] / 1000.0, float(quiet[0][1])
    for t_ms, age, _, level in quiet:
        assert float(age) - age_first == pytest.approx(t_ms / 1000.0 - t_first, abs=2.5)
        expected = "fresh" if float(age) <= 1.0 else "late" if float(age) <= 5.0 else "stale"
        assert level == expected, (age, level)
    slopes = [
        (float(b[1]) - float(a[1])) / ((b[0] - a[0]) / 1000.0)
        for a, b in itertools.combinations(quiet, 2)
        if b[0] - a[0] >= 2000.0
    ]
    assert len(slopes) > 20 and float(np.median(slopes)) == pytest.approx(1.0, abs=0.1), slopes
    assert float(quiet[-1][1]) > 6.0 and quiet[-1][3] == "stale"
    assert "STALE" in stale_text


def test_two_tabs_have_their_own_fields_and_only_the_one_in_control_sends(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main tab B showed (25, 7, 0) while C showed (25, 93.3, -15), and Send in C sent B's."""
    robot, _, console = stack
    b, c = open_consoles(browser, console.url, False, True)
    set_fields(b, "Translation [mm]", 25, 7, 0)
    set_fields(c, "Translation [mm]", 0, 20, -15)
    time.sleep(1.0)  # give any cross-tab sync time to happen
    boxes = inputs_for(b, "Translation [mm]")
    shown_b = [float(boxes.nth(i).input_value()) for i in range(3)]
    assert shown_b == [25.0, 7.0, 0.0]
    assert b.get_by_role("button", name="Send cmd").is_disabled()
    assert b.locator("#ptwl-control").get_attribute("data-mine") == "0"
    assert "has control" in b.locator("#ptwl-control").inner_text()
    with RobotClient(robot.url) as client:
        before = send(c, "Send cmd")
        wait_status(c, "goal_reached", after=before)
        record = client.commands(limit=1)[0]
    assert record.params["translation"] == pytest.approx([0.0, 0.02, -0.015])  # C's own fields
    assert record.sender is not None and record.sender.startswith("operator ")
    history = b.get_by_text(record.sender.split(" at console")[0]).first
    history.wait_for()  # the watcher sees who sent it
    b.close()
    c.close()


def test_after_lost_messages_the_console_shows_the_robots_truth(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main, a command whose end event was lost stayed 'running' forever, in every tab."""
    _, link, console = stack
    page = open_console(browser, console.url)
    set_fields(page, "Translation [mm]", 0, 10, 0)
    set_fields(page, "Duration [s]", 2.0)
    before = send(page, "Send cmd")
    wait_status(page, "running", after=before)
    sent_id = command_id(page)
    # Drop everything for 4 s: the goal_reached event (at ~2 s) is lost on the way down.
    set_link(link, blackouts=[{"start": 0.0, "duration": 4.0, "mode": "drop"}])
    time.sleep(4.5)
    wait_status(page, "goal_reached")
    assert command_id(page) == sent_id
    fresh = open_console(browser, console.url, control=False)
    assert fresh.locator("#ptwl-command").get_attribute("data-status") == "goal_reached"
    assert "running" not in fresh.locator("#ptwl-running").inner_text()
    page.close()
    fresh.close()


def test_a_queued_relative_command_is_drawn_relative_then_where_the_robot_resolved_it(
    browser, stack, calm
) -> None:  # type: ignore[no-untyped-def]
    """On main the second of two PTWLs (+60 mm y, then -40 mm y) was drawn at y = 20 mm from the
    delayed port at Send; the robot ended at -17.7 mm. Now the marker says 'relative' until the
    robot reports the goal it resolved, then moves there."""
    _, link, console = stack
    page = open_console(browser, console.url)
    set_link(link, uplink=0.5, downlink=0.5)
    inputs_for(page, "Frame").first.click()
    page.get_by_role("option", name="base").click()
    # The first runs 8 s, so the second is still queued (unresolved) when the page draws it: with
    # 1.5 s the robot resolved it (0.5 s up, 1.5 s, 0.5 s down) before a loaded browser had typed
    # and sent it (seen once with a core hogged), and with 3.5 s a loaded CI run took over 3 s to
    # draw the first's marker. The waits are as long as a loaded page may take; what is asserted
    # is what the marker says while the second is queued, and where it goes once resolved.
    set_fields(page, "Duration [s]", 8.0)
    y0 = port_mm(page)[1]
    set_fields(page, "Translation [mm]", 0, 60, 0)
    send(page, "Send cmd")
    commanded = page.locator("#ptwl-commanded")
    commanded.wait_for()
    second = int(commanded.get_attribute("data-local") or "0") + 1
    time.sleep(0.8)
    set_fields(page, "Duration [s]", 2.0)
    set_fields(page, "Translation [mm]", 0, -40, 0)
    send(page, "Send cmd")
    until(page, f"document.querySelector('#ptwl-commanded')?.dataset.local === '{second}'")
    assert commanded.get_attribute("data-resolved") == "0"
    assert "relative to the port at start" in commanded.inner_text()
    assert float(commanded.get_attribute("data-distance") or "nan") == pytest.approx(40.0, abs=15.0)
    until(page, "document.querySelector('#ptwl-commanded')?.dataset.resolved === '1'")
    y_goal = float(commanded.inner_text().split("(")[1].split(",")[1])
    page.locator("#ptwl-no-commanded").wait_for(state="attached")  # the second is done
    assert page.locator("#ptwl-command").get_attribute("data-status") == "goal_reached"
    time.sleep(1.2)  # the last state, a half second down the link
    y_end = port_mm(page)[1]
    page.close()
    assert y_goal == pytest.approx(y_end, abs=3.0)  # where the robot went, not y0 + 20 - 40 off
    assert y_goal - y0 == pytest.approx(20.0, abs=3.0)


def test_task_progress_and_success_show_in_the_bar(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main /api/task said success and the page never showed it."""
    robot, _, console = stack
    httpx.post(robot.url + "/api/scene", json={"name": "surface"}).raise_for_status()
    page = open_console(browser, console.url)
    until(page, "document.querySelector('#ptwl-task')?.dataset.success === '0'")
    set_fields(page, "Translation [mm]", 0, 0, 60)  # tool z down: 22 mm into the plate
    set_fields(page, "Duration [s]", 3)
    set_fields(page, "Force threshold [N]", 12)
    before = send(page, "Send cmd")
    wait_status(page, "wrench_breach", after=before)
    until(page, "document.querySelector('#ptwl-task')?.dataset.success === '1'")
    # The bar shows the latest state at its tick: the one drawn as the breach's event came may
    # still be on the way up (8 N at 5 N's success); the press then holds.
    time.sleep(1.0)
    progress = float(page.locator("#ptwl-task").get_attribute("data-progress") or "nan")
    text = page.locator("#ptwl-task").inner_text()
    page.close()
    assert progress == pytest.approx(12.0, abs=2.0)  # the held press, from the predicate
    assert "SUCCESS" in text and "/ 5 N" in text


def test_stop_shows_pending_until_the_robot_confirms(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main STOP under delay showed nothing for 3.9 s; on a 1366x768 screen STOP and the status
    line scrolled away, and the open stiffness dropdown covered STOP."""
    _, link, console = stack
    page = open_console(browser, console.url, control=False, viewport=(1366, 768))  # anyone may stop
    set_link(link, uplink=1.5, downlink=1.5)
    page.evaluate("document.querySelector('#ptwl-scene').scrollIntoView()")  # the panel's bottom
    inputs_for(page, "Stiffness preset (PTWL)").first.click()  # and its dropdown open
    page.get_by_role("option", name="soft").wait_for()
    stop = page.get_by_role("button", name="STOP")
    # On screen, once the bar has laid out: the floating bar grows upward as its text wraps, and
    # for a frame in between its last row can stand half a pixel low (768.5 px, once in a run).
    until(
        page,
        "(() => { const b = [...document.querySelectorAll('button')].find(e => e.innerText.trim() === 'STOP')"
        "?.getBoundingClientRect(); return b && b.top >= 0 && b.bottom <= window.innerHeight; })()",
    )
    box = stop.bounding_box()
    assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= 768  # on screen
    assert page.locator("#ptwl-telemetry").is_visible()
    stop.click()  # fails if anything covers it (Playwright retries the click until its timeout)
    # Pending, seen before the robot's confirmation (a page that showed nothing until then never
    # shows 'pending') and at least 2 s before it (the 3 s round trip): shown at once, however
    # slowly a loaded browser draws.
    until(page, "document.querySelector('#ptwl-stop')?.dataset.phase === 'pending'")
    t0 = time.monotonic()
    assert "waiting for the robot" in page.locator("#ptwl-stop").inner_text()
    until(page, "document.querySelector('#ptwl-stop')?.dataset.phase === 'confirmed'")
    confirmed_after = time.monotonic() - t0
    page.close()
    assert confirmed_after >= 2.0  # it waited for the round trip, and said so meanwhile


def test_a_stop_that_fails_stays_on_screen_and_a_dead_console_shows(browser) -> None:  # type: ignore[no-untyped-def]
    """On main the failure toast vanished after 6 s, and a page whose console had died still said
    '0.00 s old - connected'."""
    with (
        running_server("--scene", "free_space") as robot,
        running_proxy(robot.url) as link,
        running_console(link.url) as console,
    ):
        page = open_console(browser, console.url, control=False)
        link.stop()
        page.get_by_role("button", name="STOP").click()
        until(page, "document.querySelector('#ptwl-stop')?.dataset.phase === 'failed'")
        time.sleep(6.5)  # past the 6 s a notification lasts
        stop = page.locator("#ptwl-stop")
        assert stop.get_attribute("data-phase") == "failed" and stop.is_visible()
        assert "NOT CONFIRMED" in stop.inner_text()
        assert not page.locator("#ptwl-dead").is_visible()  # the console is alive: no banner
        t0 = time.monotonic()
        assert console.stop() == 0
        # With a page attached it took 6.3 s: viser waited out its close timeout on the front
        # door's pipes, which had been closed first and were read by nobody. A clean stop takes
        # ~0.5 s idle and took 2.4 s with three tests at once on two cores.
        assert time.monotonic() - t0 < 4.0
        t0 = time.monotonic()
        page.locator("#ptwl-dead").wait_for(state="visible")
        assert time.monotonic() - t0 < 5.0
        page.close()


def plot(page, key: str) -> str:  # type: ignore[no-untyped-def]
    return page.locator("#ptwl-plot").get_attribute(f"data-{key}") or ""


def test_plots_restart_with_the_scene_keep_a_minimum_range_and_mark_commands(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main old samples stayed after a reset (an x axis of 0-250 s for ~220 s), 1e-17 N of
    noise filled the plot, and nothing showed the thresholds or when commands ran."""
    robot, _, console = stack
    page = open_console(browser, console.url)
    until(page, "Number(document.querySelector('#ptwl-plot')?.dataset.t1) > 3")
    lo, hi = (float(v) for v in plot(page, "force-range").split(","))
    assert lo <= -5.0 and hi >= 5.0  # at rest: at least +-5 N, not noise stretched to full height
    assert plot(page, "threshold") == ""  # nothing running: no limit lines
    marks_before = int(plot(page, "marks"))
    set_fields(page, "Translation [mm]", 0, 0, -10)
    set_fields(page, "Duration [s]", 2.0)
    before = send(page, "Send cmd")
    wait_status(page, "running", after=before)
    until(page, "document.querySelector('#ptwl-plot')?.dataset.threshold === '20.0'")
    wait_status(page, "goal_reached", after=before)
    until(
        page,
        f"Number(document.querySelector('#ptwl-plot')?.dataset.marks) === {marks_before + 2}",
    )
    assert plot(page, "threshold") == ""
    clears = int(plot(page, "clears"))
    httpx.post(robot.url + "/api/scene", json={"name": "free_space"}).raise_for_status()
    until(page, f"Number(document.querySelector('#ptwl-plot')?.dataset.clears) === {clears + 1}")
    t0 = float(plot(page, "t0"))
    page.close()
    assert t0 < 1.0  # the time axis starts again with the scene


def values(page, label: str) -> list[float]:  # type: ignore[no-untyped-def]
    boxes = inputs_for(page, label)
    return [float(boxes.nth(i).input_value()) for i in range(boxes.count())]


CLEARED = """[...document.evaluate("//*[normalize-space(text())='Translation [mm]']/ancestor::*[.//input][1]",
  document, null, 9, null).singleNodeValue.querySelectorAll('input')].every(i => Number(i.value) === 0)"""


def test_checks_before_send_and_defaults_that_do_not_bite(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main: translation defaulted to (0, 0, 10) mm, Enter did not send, the watchdog stayed
    7 s so any duration over 7 s was refused a round trip later, and limits were checked only by
    the robot."""
    robot, _, console = stack
    page = open_console(browser, console.url)
    assert values(page, "Translation [mm]") == [0.0, 0.0, 0.0]
    check = page.locator("#ptwl-check-ptwl")
    # Out of range: said at once, in the API's words, and Send is off.
    set_fields(page, "Force threshold [N]", 600)
    until(page, "document.querySelector('#ptwl-check-ptwl')?.dataset.valid === '0'")
    assert "force_threshold" in check.inner_text() and "500" in check.inner_text()
    assert page.get_by_role("button", name="Send cmd").is_disabled()
    before = command_id(page)
    inputs_for(page, "Force threshold [N]").first.press("Enter")  # Enter obeys the same rule:
    page.wait_for_timeout(500)  # nothing goes out, so nothing is refused
    assert command_id(page) == before and page.get_by_text("Command refused").count() == 0
    set_fields(page, "Force threshold [N]", 20)
    until(page, "document.querySelector('#ptwl-check-ptwl')?.dataset.valid === '1'")
    assert page.get_by_role("button", name="Send cmd").is_enabled()
    # Escape (once the focus has left the fields) clears the target.
    set_fields(page, "Translation [mm]", 0, 0, -5)
    page.evaluate("document.activeElement.blur()")
    page.keyboard.press("Escape")
    until(page, CLEARED)
    # Enter in a field sends the tab's command with what the fields show, once.
    with RobotClient(robot.url) as client:
        sent_before = len(client.commands(limit=100))
        z_mm = inputs_for(page, "Translation [mm]").nth(2)
        z_mm.select_text()
        z_mm.press_sequentially("-4", delay=80)  # typed as a person types
        page.wait_for_timeout(150)  # a typist's pause: viser sends typed values at most every 50 ms
        before = command_id(page)
        z_mm.press("Enter")
        wait_status(page, "goal_reached", after=before)
        sent = client.commands(limit=100)
    assert len(sent) == sent_before + 1
    assert sent[-1].params["translation"] == [0.0, 0.0, -0.004]
    # A fast approach: the robot's impact rule, before Send.
    set_fields(page, "Translation [mm]", 0, 0, -100)
    set_fields(page, "Duration [s]", 0.5)
    until(page, "document.querySelector('#ptwl-check-ptwl')?.dataset.warnings === '1'")
    assert "impact will pass it" in check.inner_text()
    # The watchdog follows the duration: a 9 s move is accepted and runs.
    set_fields(page, "Translation [mm]", 0, 0, -5)
    set_fields(page, "Duration [s]", 9)
    page.wait_for_timeout(1000)
    assert values(page, "Watchdog [s]") == [14.0]  # shown as the robot will apply it
    before = send(page, "Send cmd")
    wait_status(page, "running", after=before)
    with RobotClient(robot.url) as client:
        records = client.commands(limit=100)
    assert records[-1].params["duration"] == 9.0 and records[-1].params["watchdog"] == 14.0
    assert len(records) == len(sent) + 1  # the button, inside the tab's form, sends once
    page.close()


def test_every_dither_field_and_the_gains_are_shown(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """On main the Dither tab hid its force limits, the preset's K, B, tau were never shown and
    neither were the gains active on the robot."""
    robot, _, console = stack
    page = open_console(browser, console.url)
    preset = page.locator("#ptwl-preset")
    assert preset.get_attribute("data-k") == "2000,2000,2000,100,100,100"  # medium, from the robot
    assert "τ (0.50, 0.50, 0.50) s" in preset.inner_text()
    inputs_for(page, "Stiffness preset (PTWL)").first.click()
    page.get_by_role("option", name="stiff").click()
    until(page, "document.querySelector('#ptwl-preset')?.dataset.k !== '2000,2000,2000,100,100,100'")
    stiff_k = page.locator("#ptwl-preset").get_attribute("data-k")
    set_fields(page, "Translation [mm]", 0, 0, -5)
    before = send(page, "Send cmd")
    wait_status(page, "goal_reached", after=before)
    until(page, f"document.querySelector('#ptwl-gains')?.dataset.k === '{stiff_k}'")
    page.get_by_role("tab", name="Dither").click()
    inputs_for(page, "Dither preset").first.click()
    page.get_by_role("option", name="translational_pull").click()
    page.get_by_text("Amplitude (radius) [mm]").wait_for()
    assert values(page, "Dither force limit [N]") == [40.0]
    set_fields(page, "Dither force limit [N]", 25)
    set_fields(page, "Travel [mm]", 3)
    before = send(page, "Send dither")
    wait_status(page, "goal_reached", after=before)
    with RobotClient(robot.url) as client:
        record = client.commands(limit=1)[0]
    page.close()
    assert record.params["force_threshold"] == 25.0 and record.params["mode"] == "translational"
    assert record.params["direction"] == "pull" and record.params["travel"] == pytest.approx(0.003)


def test_a_tasks_state_machine_runs_from_its_tab_and_shows_each_step(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """Issue 11's console part: the loaded scene's task is picked, its onboard state machine runs
    as one command, its steps (behavior, exit, why) and its end are shown; a watcher cannot
    start one. (The plug with the outlet nearly under it: in at once, then relieved.)"""
    robot, _, console = stack
    httpx.post(robot.url + "/api/scene", json={"name": "plug", "seed": 4}).raise_for_status()
    watcher, page = open_consoles(browser, console.url, False, True)
    page.get_by_role("tab", name="Machines").click()
    watcher.get_by_role("tab", name="Machines").click()
    assert watcher.get_by_role("button", name="Run machine").is_disabled()
    assert "until the prongs drop in" in page.get_by_text("slide along y").first.inner_text()  # its procedure
    before = send(page, "Run machine")
    wait_status(page, "running", after=before)
    until(page, "document.querySelector('#ptwl-steps')?.dataset.count === '2'")
    wait_status(page, "completed", after=before)
    steps = page.locator("#ptwl-steps li")
    assert [steps.nth(i).get_attribute("data-behavior") for i in range(2)] == ["ptwl", "rwe"]
    assert [steps.nth(i).get_attribute("data-exit") for i in range(2)] == ["wrench_breach", "completed"]
    assert "find the outlet" in steps.nth(0).inner_text() and "fully in" in steps.nth(1).inner_text()
    # The watcher's page shows the same machine and steps.
    until(watcher, "document.querySelector('#ptwl-steps')?.dataset.count === '2'")
    with RobotClient(robot.url) as client:
        record = client.commands(limit=1)[0]
    assert record.type == "state_machine" and record.exit == "completed" and record.sender
    page.close()
    watcher.close()


def test_the_machines_tab_checks_an_edit_as_typed_draws_the_graph_and_answers_a_decision(  # type: ignore[no-untyped-def]
    browser, stack, calm
) -> None:
    """Issue 31's console part: the plug's machine file in the tab, its graph drawn; an edit out of
    range is refused under the text in the robot's words (state and field) and Run is off; run at
    autonomy `low` over a 0.5 s link, the approach's end waits for a decision: the tab shows what it
    proposes and why, Confirm sends it across the link, and the machine completes. A screenshot of
    the tab with the decision pending goes to artifacts/ (docs/machines_tab.png is one)."""
    robot, link, console = stack
    set_link(link, uplink=0.25, downlink=0.25)
    httpx.post(robot.url + "/api/scene", json={"name": "plug", "seed": 4}).raise_for_status()
    page = open_console(browser, console.url, viewport=(1280, 900))
    page.get_by_role("tab", name="Machines").click()
    text = page.locator("textarea").first  # the machine's TOML (the only multi-line field)
    until(page, "document.querySelector('textarea')?.value.includes('name = \"plug\"')")
    original = text.input_value()
    drawn = "[...document.querySelectorAll('img')].some(i => i.naturalWidth >= 400)"  # the graph
    until(page, drawn)
    text.fill(
        original.replace("duration = 4.0, force_threshold = 6.0", "duration = 700.0, force_threshold = 6.0")
    )
    check = page.locator("#ptwl-check-state_machine")
    until(page, "document.querySelector('#ptwl-check-state_machine')?.dataset.valid === '0'")
    assert (
        "states.approach.command.duration: must be in (0, 600] s, got 700"
        in page.locator("body").inner_text()
    )
    assert page.get_by_role("button", name="Run machine").is_disabled()
    text.fill(original)
    until(page, "document.querySelector('#ptwl-check-state_machine')?.dataset.valid === '1'")
    assert check.get_attribute("data-valid") == "1"
    inputs_for(page, "Autonomy").first.click()
    page.get_by_role("option", name="low", exact=True).click()
    before = send(page, "Run machine")
    wait_status(page, "running", after=before)
    until(page, "document.querySelector('#ptwl-machine')?.dataset.pending === '1'")
    shown = page.locator("#ptwl-machine").inner_text()
    assert "decision 1 waits" in shown and "approach ended" in shown and "proposes relieve" in shown
    assert "(level low)" in shown
    page.screenshot(path=str(ARTIFACTS / "machines-tab-decision.png"))
    page.get_by_role("button", name="Confirm").click()
    wait_status(page, "completed", after=before)
    with RobotClient(robot.url) as client:
        record = client.commands(limit=1)[0]
    assert record.exit == "completed" and record.machine is not None
    assert [(h["state"], h["how"]) for h in record.machine["history"]] == [
        ("approach", "confirm"),
        ("relieve", "autonomous"),
    ]
    assert record.machine["history"][0]["waited_s"] >= 0.5  # at least the round trip
    page.close()


YELLOW_HUE = (40.0, 62.0)  # the contemplated marker (250, 204, 21), also seen through a fixture
MAGENTA_HUE = (270.0, 320.0)  # the force arrow (200, 40, 210); nothing else in the scene is


def test_markers_show_through_fixtures_and_the_force_arrow_outside_the_tool(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """In pixels, as the operator sees them. On main a press target inside the plate was hidden
    by it and the force arrow was drawn up into the tool, in the arm's own orange."""
    robot, _, console = stack
    httpx.post(robot.url + "/api/scene", json={"name": "surface"}).raise_for_status()
    page = open_console(browser, console.url)
    page.mouse.move(370, 380)  # closer in, at the tool
    for _ in range(4):
        page.mouse.wheel(0, -200)
    _, _, port_z_mm = port_mm(page)
    inputs_for(page, "Frame").first.click()
    page.get_by_role("option", name="base").click()
    # The whole tool-shaped target below the plate's top (z = 220 mm): tip at 120 mm, shaft up
    # to 218 mm. It shows through the plate (~450 pixels; none with an opaque plate).
    set_fields(page, "Translation [mm]", 0, 0, 120.0 - port_z_mm)
    page.wait_for_timeout(1000)
    view = view_hsv(page)
    assert pixels_of_hue(view, *YELLOW_HUE, min_saturation=0.35) > 150
    assert pixels_of_hue(view, *MAGENTA_HUE, min_saturation=0.15) == 0  # no force, no arrow
    # A press: the plate's push on the port is drawn from below, ending at the port (~35 pixels
    # seen through the plate; none when drawn up inside the tool).
    set_fields(page, "Translation [mm]", 0, 0, 212.0 - port_z_mm)
    before = send(page, "Send cmd")
    wait_status(page, "wrench_breach", after=before)
    page.wait_for_timeout(500)
    assert pixels_of_hue(view_hsv(page), *MAGENTA_HUE, min_saturation=0.15) > 10
    page.close()


CYAN_HUE = (180.0, 196.0)  # the twin's ghost (21, 170, 191); the sky-blue tool tip is ~205


def prediction(page, key: str) -> str:  # type: ignore[no-untyped-def]
    return page.locator("#ptwl-prediction").get_attribute(f"data-{key}") or ""


def test_the_ghost_moves_on_send_and_says_how_far_off_it_was(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """Issue 14's predictive display behind a 1 s + 1 s link: on Send the cyan ghost (the ground
    twin) moves at once, while the delayed robot has not; when telemetry catches up the twin's
    line says its predictions were within 2 mm, unless the ghost said meanwhile that it was
    unsure (issue 27: a twin thread starved by a busy machine lags, says UNSURE, and its readout
    covers that period too). A ghost that stayed sure must have been right."""
    _, link, console = stack
    set_link(link, uplink=1.0, downlink=1.0)
    page = open_console(browser, console.url)
    until(page, "document.querySelector('#ptwl-prediction')?.dataset.x !== ''")
    above_the_bar = view_hsv(page)[:480]  # the status bar floats bottom right; its twin line is cyan too
    assert pixels_of_hue(above_the_bar, *CYAN_HUE, min_saturation=0.35) > 200  # the ghost is drawn
    inputs_for(page, "Frame").first.click()
    page.get_by_role("option", name="base").click()
    set_fields(page, "Translation [mm]", 0, 40, 0)
    y0_mm = port_mm(page)[1]
    # Judged and sure before the move (a fresh ghost is unsure for a round trip: "not judged yet");
    # from then on, every 50 ms: was it marked unsure?
    until(page, "document.querySelector('#ptwl-prediction')?.dataset.sure === '1'")
    page.evaluate(
        "window.unsureSeen = 0; setInterval(() => { if (document.querySelector('#ptwl-prediction')"
        "?.dataset.sure === '0') window.unsureSeen++; }, 50)"
    )
    send(page, "Send cmd")
    # The ghost's first move and the delayed picture's port, read in one turn of the page (the
    # order is the page's, however late a loaded browser draws both):
    until(
        page,
        f"(() => {{ if (!(Number(document.querySelector('#ptwl-prediction').dataset.y) > {y0_mm + 5}))"
        " return false; window.portAtGhostMm = document.querySelector('#ptwl-telemetry').innerText"
        ".match(/port \\((-?[\\d.]+), (-?[\\d.]+)/)[2]; return true; })()",
    )
    port_at_ghost_mm = float(page.evaluate("window.portAtGhostMm"))
    assert abs(port_at_ghost_mm - y0_mm) < 0.5  # the delayed picture had not moved yet
    until(
        page,
        f"(() => {{ const m = document.querySelector('#ptwl-telemetry').innerText"
        f".match(/port \\((-?[\\d.]+), (-?[\\d.]+)/); return m && Number(m[2]) > {y0_mm + 38}; }})()",
    )
    page.wait_for_timeout(500)
    max_mm = prediction(page, "max-mm")
    assert max_mm != ""
    assert float(max_mm) < 2.0 or page.evaluate("window.unsureSeen") > 0, max_mm
    page.close()


def red_pixels(page) -> int:  # type: ignore[no-untyped-def]
    """A frame's x axis (viser's axes: x red, y green, z blue); the arm's orange is ~25 degrees."""
    view = view_hsv(page)[:480]
    return pixels_of_hue(view, 0.0, 10.0, min_saturation=0.6) + pixels_of_hue(view, 350.0, 360.0, 0.6)


def frame_names(page) -> list[str]:  # type: ignore[no-untyped-def]
    names = page.locator("#ptwl-frames").get_attribute("data-names") or ""
    return [n for n in names.split(",") if n]


def test_task_frames_are_listed_drawn_made_and_commanded_in(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """Issue 14's task frames: the scene's own is listed and drawn in 3D; an operator types a
    frame turned 90 degrees about x, and a PTWL's +20 mm along its z goes 20 mm along base -y."""
    robot, _, console = stack
    httpx.post(robot.url + "/api/scene", json={"name": "surface"}).raise_for_status()
    page = open_console(browser, console.url)
    page.get_by_role("tab", name="Frames").click()
    until(page, "document.querySelector('#ptwl-frames')?.dataset.names === 'plate_normal'")
    page.wait_for_timeout(500)
    shown = red_pixels(page)
    page.get_by_text("Show frames in 3D").click()
    page.wait_for_timeout(500)
    hidden = red_pixels(page)
    assert shown > hidden + 20, (shown, hidden)  # the plate's normal, drawn on its top face
    page.get_by_text("Show frames in 3D").click()

    name = inputs_for(page, "New frame name").first
    name.fill("slanted")
    name.press("Tab")
    page.wait_for_timeout(200)  # a typist's pause: viser sends one field change per 50 ms, the latest
    set_fields(page, "Typed rotation [deg]", 90, 0, 0)
    page.wait_for_timeout(200)
    page.get_by_role("button", name="Add typed pose").click()
    until(page, "document.querySelector('#ptwl-frames')?.dataset.names === 'plate_normal,slanted'")
    assert [f["name"] for f in httpx.get(robot.url + "/api/frames").json()] == ["plate_normal", "slanted"]

    page.get_by_role("tab", name="PTWL").click()
    inputs_for(page, "Frame").first.click()
    page.get_by_role("option", name="slanted").click()
    set_fields(page, "Translation [mm]", 0, 0, 20)
    x0, y0, z0 = port_mm(page)
    before = send(page, "Send cmd")
    wait_status(page, "goal_reached", after=before)
    page.wait_for_timeout(300)
    x1, y1, z1 = port_mm(page)
    assert y1 - y0 == pytest.approx(-20.0, abs=2.5) and abs(z1 - z0) < 2.5 and abs(x1 - x0) < 2.5
    assert httpx.get(robot.url + "/api/commands").json()[-1]["params"]["frame"] == "slanted"

    page.get_by_role("tab", name="Frames").click()
    inputs_for(page, "Delete frame").first.click()
    page.get_by_role("option", name="slanted").click()
    page.get_by_role("button", name="Delete").click()
    until(page, "document.querySelector('#ptwl-frames')?.dataset.names === 'plate_normal'")
    assert [f["name"] for f in httpx.get(robot.url + "/api/frames").json()] == ["plate_normal"]
    page.close()


def test_preview_then_send_a_step(browser, stack, calm) -> None:  # type: ignore[no-untyped-def]
    """IPSE's preview and step: Preview runs the typed PTWL on the twin and says how it ends,
    sending nothing; Send step sends its first 25 %, and the robot goes a quarter of the way."""
    robot, _, console = stack
    page = open_console(browser, console.url)
    inputs_for(page, "Frame").first.click()
    page.get_by_role("option", name="base").click()
    set_fields(page, "Translation [mm]", 0, 40, 0)
    page.wait_for_timeout(200)
    sent_before = len(httpx.get(robot.url + "/api/commands").json())
    page.get_by_role("button", name="Preview").click()
    until(page, "document.querySelector('#ptwl-preview')?.dataset.exit === 'goal_reached'")
    preview = page.locator("#ptwl-preview")
    assert 2.0 < float(preview.get_attribute("data-duration") or "nan") < 3.5  # 2 s travel, then settling
    assert float(preview.get_attribute("data-compute-s") or "nan") < 1.0
    assert len(httpx.get(robot.url + "/api/commands").json()) == sent_before  # nothing was sent
    y0 = port_mm(page)[1]
    before = send(page, "Send step")
    wait_status(page, "goal_reached", after=before)
    page.wait_for_timeout(300)
    step = httpx.get(robot.url + "/api/commands").json()[-1]["params"]
    assert step["translation"] == pytest.approx([0.0, 0.010, 0.0], abs=1e-9)  # 25 % of 40 mm
    assert port_mm(page)[1] - y0 == pytest.approx(10.0, abs=2.5)
    page.close()


SCHEDULE_LINE = "document.querySelector('#ptwl-schedule')"


def test_the_bar_counts_down_to_a_loss_of_signal_and_a_send_that_may_outlast_it_asks_first(  # type: ignore[no-untyped-def]
    browser, stack, calm
) -> None:
    """Issue 32: the bar says when the signal will be lost; a PTWL that may run 6 s (its watchdog)
    sent ~1-3 s before a loss at 6.5 s asks first, and its "start by" sends valid_until_sim_time;
    through the loss the line says LOSS OF SIGNAL."""
    robot, link, console = stack
    page = open_console(browser, console.url)
    set_fields(page, "Duration [s]", 1)  # the watchdog follows: duration + 5 = 6 s
    # The schedule starts when the link takes it: between these two (a loaded PUT took 0.26 s).
    put_from = time.monotonic()
    set_link(link, schedule={"contacts": [{"start": 0.0, "end": 6.5}, {"start": 10.5, "end": 600.0}]})
    put_until = time.monotonic()
    until(page, f"{SCHEDULE_LINE}?.innerText.includes('signal lost in')")
    time.sleep(max(0.0, put_until + 1.0 - time.monotonic()))  # past 0.5 s: 6 s can no longer fit
    line = page.locator("#ptwl-schedule").inner_text()
    assert "in contact until" in line and "for 4 s" in line, line
    with RobotClient(robot.url) as client:
        before = len(client.commands(limit=100))
        page.get_by_role("button", name="Send cmd").click()
        page.get_by_text("Signal may be lost before it finishes").wait_for()
        warning = page.locator("#ptwl-los-warning").inner_text()
        assert "It may run 6.0 s (its watchdog)" in warning and "signal is lost in" in warning
        assert len(client.commands(limit=100)) == before  # nothing went before the operator said

        # Its latest start: the loss at 6.5 s less its 1 s, in the robot's sim time: the robot's
        # sim time now plus what is left, read just before the click and again once it is sent,
        # from either end of the PUT; the console's reckoning falls between. (Read once,
        # afterwards, it was 0.5 s off in a hogged run: a starved robot's sim time falls behind
        # the wall clock meanwhile; and from before the PUT, 0.26 s early in another.)
        def latest_start_in_sim_time() -> tuple[float, float]:
            left_from_now_s = client.state().sim_time + 6.5 - 1.0 - time.monotonic()
            return left_from_now_s + put_from, left_from_now_s + put_until

        before_click = latest_start_in_sim_time()
        page.get_by_role("button", name="Send: start by sim time").click()
        deadline = time.monotonic() + 5.0
        while len(client.commands(limit=100)) == before and time.monotonic() < deadline:
            time.sleep(0.05)
        sent = client.commands(limit=1)[-1]
        once_sent = latest_start_in_sim_time()
    low, high = min(before_click + once_sent), max(before_click + once_sent)
    assert low - 0.25 <= sent.params["valid_until_sim_time"] <= high + 0.25, (before_click, once_sent)
    until(page, f"{SCHEDULE_LINE}?.dataset.los === '1'")
    assert page.locator("#ptwl-schedule").inner_text().startswith("LOSS OF SIGNAL for ")
    assert "out of contact" in page.locator("#ptwl-link").inner_text()
