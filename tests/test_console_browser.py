"""The operator console in a real browser (Debian Chromium driven by Playwright).

Outside CI these skip when /usr/bin/chromium is missing; under CI=true its absence fails.
The 3D scene is WebGL, which the DOM cannot see, so the console mirrors what it draws in its
status lines (port position, telemetry age and sequence, commanded target), updated in the same
atomic batch as the scene; the tests read those.
"""

import math
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import pytest

from ptwl.launcher import free_port, running_console, running_proxy, running_server
from ptwl.recording.reader import read
from ptwl.up import RestartBudget
from tests.console_page import (
    PAGE_WAIT_MS,
    command_id,
    command_status,
    inputs_for,
    open_console,
    port_mm,
    reset,
    send,
    set_fields,
    until,
    wait_status,
    wait_text,
)

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

ARTIFACTS = Path(__file__).resolve().parent.parent / "artifacts"


def test_console_loads_with_the_three_tabs_and_the_preset_dropdown(browser, stack) -> None:  # type: ignore[no-untyped-def]
    page = open_console(browser, stack[2].url)
    assert page.get_by_role("tab").all_inner_texts()[:3] == ["PTWL", "RWE", "Dither"]
    for label in (
        "Translation [mm]",
        "Rotation [deg]",
        "Duration [s]",
        "Force threshold [N]",
        "Watchdog [s]",
    ):
        assert inputs_for(page, label).count() >= 1, label
    assert inputs_for(page, "Translation [mm]").count() == 3
    preset = inputs_for(page, "Stiffness preset (PTWL)").first
    assert preset.input_value() == "medium"  # from config/console.toml
    preset.click()
    options = page.get_by_role("option").all_inner_texts()
    assert {"stiff", "medium", "soft", "planar", "hinge"} <= set(options)
    page.keyboard.press("Escape")
    assert page.get_by_role("button", name="STOP").is_visible()
    page.close()


def test_ptwl_typed_and_sent_from_the_page_reaches_its_goal_or_warns_first(browser, stack) -> None:  # type: ignore[no-untyped-def]
    reset(stack[1])
    page = open_console(browser, stack[2].url)
    start = port_mm(page)
    set_fields(page, "Translation [mm]", 0, 0, -20)  # tool z points down: 20 mm up
    set_fields(page, "Duration [s]", 1.5)
    previous = send(page, "Send cmd")
    wait_status(page, "goal_reached", after=previous)
    time.sleep(1.0)
    end = port_mm(page)
    assert end[2] - start[2] == pytest.approx(20.0, abs=2.0)
    assert "PTWL" in page.locator("#ptwl-command").inner_text()
    # A fast approach is accepted with the robot's warning on the page.
    set_fields(page, "Translation [mm]", 0, 0, -100)  # 100 mm in 1 s: B v = 100 N against 20 N
    set_fields(page, "Duration [s]", 1.0)
    previous = send(page, "Send cmd")
    page.get_by_text("check the approach").first.wait_for()
    assert page.get_by_text("force_threshold 20 N").first.is_visible()
    wait_status(page, "goal_reached", after=previous)  # free space: nothing to hit, still accepted
    page.close()


def test_rwe_and_dither_from_the_page_end_with_their_exits(browser, stack) -> None:  # type: ignore[no-untyped-def]
    reset(stack[1])
    page = open_console(browser, stack[2].url)
    page.get_by_role("tab", name="RWE").click()
    before = send(page, "Send RWE")
    wait_status(page, "completed", after=before)
    page.get_by_role("tab", name="Dither").click()
    chooser = inputs_for(page, "Dither preset").first
    chooser.click()
    page.get_by_role("option", name="translational_pull").click()
    set_fields(page, "Travel [mm]", 4)
    before = send(page, "Send dither")
    wait_status(page, "goal_reached", after=before)
    history = page.get_by_text("RWE", exact=False).all_inner_texts()
    assert any("Dither" in text or "RWE" in text for text in history)
    page.close()


# [s] The link of the next test: a 3 s round trip, the time by which a commanded target drawn only
# on the robot's word would come.
UPLINK_S, DOWNLINK_S = 2.0, 1.0


def test_three_second_round_trip_shows_intent_at_once_and_the_robot_later(browser, stack) -> None:  # type: ignore[no-untyped-def]
    reset(stack[1])
    link = stack[1]
    page = open_console(browser, stack[2].url)
    profile = {"uplink": UPLINK_S, "downlink": DOWNLINK_S}
    httpx.put(link.url + "/_link/profile", json=profile).raise_for_status()
    until(page, "Number(document.querySelector('#ptwl-telemetry')?.dataset.age) > 0.9")
    set_fields(page, "Translation [mm]", 0, 0, 10)  # tool z down: 10 mm down
    time.sleep(0.5)
    start = port_mm(page)
    before = send(page, "Send cmd")
    # From when the click was delivered: Playwright's click() first waits for the button to be
    # stable over several animation frames, which takes ~1 s with software WebGL.
    t0 = time.monotonic()
    page.locator("#ptwl-commanded").wait_for()
    commanded_after = time.monotonic() - t0
    moved_after = None
    while time.monotonic() - t0 < PAGE_WAIT_MS / 1000:
        if abs(port_mm(page)[2] - start[2]) > 0.2:
            moved_after = time.monotonic() - t0
            break
        time.sleep(0.02)
    # The bar's age over the next 1.5 s of steady telemetry (one read at one instant under load
    # caught the console 1.2 s late in drawing: 2.22 s shown in a hogged CI run).
    ages = []
    while not ages or time.monotonic() - t0 < (moved_after or 0.0) + 1.5:  # one read at least
        ages.append(float(page.locator("#ptwl-telemetry").get_attribute("data-age") or "nan"))
        time.sleep(0.05)
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "console-mid-task.png"))
    wait_status(page, "goal_reached", after=before)
    reset(link)
    page.close()
    # The commanded target shows at least a second before the robot's port moves: drawn only on
    # the robot's word it would come with the move, a round trip (3 s) after the click. (It shows
    # in 0.2-0.5 s on a quiet machine, the browser drawing ~10 frames/s in software WebGL; that
    # figure is a wall-clock latency, not asserted here: a loaded browser took 1.2 s once.)
    assert moved_after is not None and moved_after - commanded_after >= 1.0
    # The robot's port shows moving a round trip (3 s) after the click; t0 comes after the click
    # by as long as click() took to return, so at least the uplink after t0.
    assert moved_after is not None and moved_after >= UPLINK_S
    # "robot state is ~1 s old": never less than the downlink's 1 s, and more only by the console's
    # own lag in drawing (0.0-0.1 s on an idle machine; 0.30 s, and once 0.60 s, measured with a
    # core hogged beside another browser file; once 1.22 s at one instant of a hogged CI run): the
    # freshest age shown over 1.5 s within 0.75 s of it. An age that counted the uplink too (3 s)
    # is never under 3 s, and fails. (NaN: the bar showed no age.)
    assert not any(math.isnan(age) for age in ages), ages
    assert DOWNLINK_S - 0.05 <= min(ages) <= DOWNLINK_S + 0.75, ages


def test_console_says_when_the_robot_restarts_and_reconnects(browser) -> None:  # type: ignore[no-untyped-def]
    server_port = free_port()
    with (
        running_server("--scene", "free_space", port=server_port) as robot,
        running_proxy(robot.url) as link,
        running_console(link.url) as console,
    ):
        page = open_console(browser, console.url)
        set_fields(page, "Translation [mm]", 0, 0, -30)
        set_fields(page, "Duration [s]", 30.0)
        previous = send(page, "Send cmd")
        wait_status(page, "running", after=previous)
        cut_off = command_id(page)
        robot.stop()
        wait_text(page, "no telemetry", 15.0)
        with running_server("--scene", "free_space", port=server_port):
            # "robot restarted at": the new run seen; "the link or robot restarted" is the 1012
            # close the old one sent as it went down.
            wait_text(page, "robot restarted at", 20.0)
            # The cut-off command is lost, never shown as a later command's result.
            assert command_id(page) == cut_off and command_status(page) == "lost"
            set_fields(page, "Duration [s]", 1.0)
            before = send(page, "Send cmd")
            wait_status(page, "goal_reached", after=before)
        page.close()


def pkill(pattern: str) -> None:
    subprocess.run(["pkill", "-f", pattern], check=True)


def wait_line(lines: list[str], text: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not any(text in line for line in lines):
        assert time.monotonic() < deadline, f"no {text!r} in: {''.join(lines)}"
        time.sleep(0.1)


def test_ptwl_up_restarts_a_crashed_child_and_the_old_tab_carries_on(browser, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """On main a crashed link took the robot and console down with it, and an old tab never came
    back to a restarted console. Recording all along: the restarted link records anew."""
    ports = [free_port(), free_port(), free_port()]
    session = tmp_path / "s.mcap"
    cmd = [sys.executable, "-m", "ptwl.cli", "up", "--scene", "free_space", "--record", str(session)]
    cmd += ["--server-port", str(ports[0]), "--proxy-port", str(ports[1]), "--console-port", str(ports[2])]
    process = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert process.stdout is not None
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(process.stdout or []), daemon=True).start()
    try:
        wait_line(lines, "ptwl up: open", 120.0)
        assert f"ptwl up: open http://127.0.0.1:{ports[2]}" in "".join(lines)
        robot = f"http://127.0.0.1:{ports[0]}"
        instance = httpx.get(robot + "/api/health").json()["instance"]
        page = open_console(browser, f"http://127.0.0.1:{ports[2]}")
        # The link crashes: it is restarted, the robot is untouched, the page reconnects through it.
        pkill(f"proxy --upstream {robot} --port {ports[1]}")
        wait_text(page, "no telemetry", 15.0)  # in plain words, not a Python exception
        assert "Error" not in page.locator("#ptwl-bar").inner_text()
        wait_line(lines, "the link proxy exited", 10.0)
        wait_line(lines, "the link proxy is back", 30.0)
        assert "restarting it (restart 1)" in "".join(lines)
        assert httpx.get(robot + "/api/health").json()["instance"] == instance
        wait_text(page, "connected", 30.0)
        set_fields(page, "Translation [mm]", 0, 0, -5)
        before = send(page, "Send cmd")
        wait_status(page, "goal_reached", after=before)
        # The console crashes: restarted on its port; the same old tab comes back to it by itself.
        pkill(f"console --robot http://127.0.0.1:{ports[1]} --port {ports[2]}")
        wait_line(lines, "the console is back", 120.0)
        seq = int(page.locator("#ptwl-telemetry").get_attribute("data-seq") or "0")
        until(
            page,
            f"Number(document.querySelector('#ptwl-telemetry')?.dataset.seq) > {seq + 50}",
        )
        assert not page.locator("#ptwl-dead").is_visible()
        page.close()
    finally:
        process.send_signal(signal.SIGINT)
        assert process.wait(30) == 0
    for port in ports:
        with pytest.raises(httpx.TransportError):
            httpx.get(f"http://127.0.0.1:{port}/", timeout=1.0)
    robot_file = read(session)
    assert robot_file.complete  # Ctrl-C finished it
    [done] = [e for e in robot_file.values("/commands") if e["status"] == "done"]
    assert done["exit"] == "goal_reached" and " at console 127.0.0.1:" in done["sender"]
    assert done["params"]["translation"] == pytest.approx([0.0, 0.0, -0.005])
    before_crash, after_crash = read(tmp_path / "s.link.mcap"), read(tmp_path / "s.link.restart1.mcap")
    assert before_crash.complete and after_crash.complete  # the crash was a SIGTERM: finished too
    posted = [m for m in after_crash.values("/link/messages") if m["kind"] == "http_request"]
    assert posted and all(m["drop_reason"] is None for m in posted)


def test_ptwl_up_gives_up_on_a_child_that_keeps_dying() -> None:
    budget = RestartBudget(limit=3, window_s=60.0)
    assert [budget.allow(t) for t in (0.0, 1.0, 2.0, 3.0)] == [True, True, True, False]
    assert budget.allow(61.5)  # the first restart has left the window


def test_a_fresh_console_behind_a_3_s_link_shows_send_before_the_robot_answers(browser) -> None:  # type: ignore[no-untyped-def]
    """On main it took 8.7 s (each of four start-up answers waited for the last), then 4.1-4.35 s
    (one round trip, then the panels); the panels no longer wait for the robot at all."""
    with (
        running_server("--scene", "surface") as robot,
        running_proxy(robot.url, "--uplink", "1.5", "--downlink", "1.5") as link,
        running_console(link.url) as console,
    ):
        started = time.monotonic()  # the console has just begun to reach the robot
        page = browser.new_page(viewport={"width": 1100, "height": 720}, bypass_csp=True)  # string predicates
        page.goto(console.url, wait_until="commit")
        # No wall-clock bound in the waits either (what is asserted is the order): a page took
        # over 10 s to show Send in a hogged CI run (b83a735); they wait PAGE_WAIT_MS, like every page.
        page.get_by_role("button", name="Send cmd").wait_for()
        send_after = time.monotonic() - started
        # Behind the link for real: the robot's first state comes at least a downlink later.
        until(page, "document.querySelector('#ptwl-telemetry')?.dataset.seq > 0")
        state_after = time.monotonic() - started
        page.close()
    # Send came before anything the robot sent could arrive: the panels did not wait for it. (The
    # figure, 2-4 s on a quiet machine and up to 7 s on a busy one, is bench.console's:
    # fresh_console_send_visible_s_at_3s_rtt; a wall-clock bound here failed under load.)
    assert state_after >= 1.5, state_after
    assert send_after < state_after, (send_after, state_after)


def test_the_harness_closes_the_pages_a_test_left_open(browser) -> None:  # type: ignore[no-untyped-def]
    """A failed test skips its own `page.close()`; the harness closes what it left (conftest's
    pages_closed), so no page goes on drawing under the tests after it."""
    kept, closed = browser.new_page(), browser.new_page()
    closed.close()
    assert browser.close_pages() == 1
    assert kept.is_closed()
    assert browser.close_pages() == 0
