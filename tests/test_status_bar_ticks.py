"""The status bar's ticker outlives a tick that fails (it died on the first exception, and the
bar froze for every page until the console restarted): while ticks fail the bar says so in red
and the robot is drawn stale; the first tick that works shows the robot's state again."""

import itertools
import logging
import re
import threading
import time

import pytest
import viser

from tests.helpers import robot_state, wait_until
from tests.worker_rounds import Rounds
from web.status_bar import BarInputs, Level, StatusBar
from web.stop_sender import StopState
from web.telemetry_health import LinkLine

WAIT_S = 30.0  # a bound on the ticker's next few ticks (0.08 s apart), never reached when it works


def failed_ticks(shown: str) -> int:
    found = re.search(r'data-failed="(\d+)"', shown)
    return int(found[1]) if found else 0


def test_a_failing_tick_is_said_on_the_bar_and_the_next_good_one_shows_the_robot_again(
    caplog: pytest.LogCaptureFixture,
) -> None:
    state = robot_state()
    failing = threading.Event()
    failures = itertools.count(1)

    def inputs() -> BarInputs:
        if failing.is_set():  # e.g. a state without a field the bar reads, said anew each tick
            raise KeyError(f"<b>port</b> #{next(failures)}")
        return BarInputs(
            {**state, "sent_at": time.time()}, time.time(), True, LinkLine("fresh", "up"), 0.0, "", ""
        )

    levels: list[Level] = []
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    bar = StatusBar(server.gui, inputs, levels.append)
    bar.start()
    try:
        wait_until(lambda: "robot state #7" in bar.html.content and levels == ["fresh"], WAIT_S)
        with caplog.at_level(logging.ERROR, logger="web.status_bar"):
            failing.set()
            wait_until(lambda: failed_ticks(bar.html.content) >= 3, WAIT_S)  # three ticks failed in a row
        shown = bar.html.content
        assert "STATUS UNKNOWN" in shown and "robot state" not in shown
        assert "&lt;b&gt;port&lt;/b&gt;" in shown and "<b>port</b>" not in shown  # data, not markup
        assert 'id="ptwl-dead"' in shown  # the page's own countdown still restarts with each tick
        assert levels == ["fresh", "stale"]
        # The text changed with each tick: logged once all the same (at most one in LOG_EVERY_S).
        assert len([r for r in caplog.records if "tick failed" in r.getMessage()]) == 1
        failing.clear()
        # The level is told after the bar is drawn: wait for both.
        wait_until(lambda: "robot state #7" in bar.html.content and len(levels) == 3, WAIT_S)
        assert bar.running and levels == ["fresh", "stale", "fresh"]
    finally:
        bar.close()
        server.stop()
    assert not bar.running


def test_the_bar_ticks_every_80_ms_and_draws_each_new_stop_state() -> None:
    """12.5 updates a second whatever arrives; the STOP row shows each state the sender goes
    through (a press, the robot's answer) at the next tick."""
    state = robot_state()
    stops = iter([StopState(), StopState(), StopState("pending", "STOP sent", 1)])

    def inputs() -> BarInputs:
        stop = next(stops, StopState("confirmed", "stopped", 1))
        now = time.time()
        link = LinkLine("fresh", "up")
        return BarInputs({**state, "sent_at": now}, now, True, link, 0.0, "", "", stop=stop)

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        bar = StatusBar(server.gui, inputs, lambda _: None)  # drawn first from the idle STOP
        phases: list[str] = []  # what the STOP row shows at each wait

        def note_phase() -> None:
            phases.append(re.search(r'data-phase="(\w+)"', bar.stop_html.content)[1])  # type: ignore[index]

        ticks = Rounds(3, note_phase)
        bar._closed = ticks  # type: ignore[assignment]
        bar._run()  # three ticks on this thread, then closed
    finally:
        server.stop()
    assert ticks.waits == [0.08] * 4
    assert phases == ["idle", "idle", "pending", "confirmed"]
