"""STOP until confirmed (issue 27.1): on main a STOP the link lost was said once, drawn below the
status window's edge, and never sent again. Timing runs on a simulated clock."""

import threading

import httpx
import pytest

from server.client import RobotError
from server.models import StopResult
from tests.fake_clock import FakeClock
from tests.helpers import wait_until
from web.history import CommandHistory
from web.stop_sender import CONFIRM_MARGIN_S, RETRY_S, StopSender, StopState


class FlakyLink:
    """POST /api/stop that fails `failures` times (as the link does in a drop blackout), then
    answers; each attempt records the timeout it was given."""

    def __init__(self, failures: list[Exception], result: StopResult) -> None:
        self.failures, self.result = failures, result
        self.timeouts: list[float] = []

    def __call__(self, timeout_s: float) -> StopResult:
        self.timeouts.append(timeout_s)
        if self.failures:
            raise self.failures.pop(0)
        return self.result


def run(link: FlakyLink, rtt_s: float = 3.0) -> tuple[list[StopState], list[StopResult], FakeClock]:
    clock = FakeClock(1000.0)
    shown: list[StopState] = []
    confirmed: list[StopResult] = []

    def wait(seconds: float) -> bool:
        clock.now += seconds
        return False

    sender = StopSender(link, lambda: rtt_s, shown.append, confirmed.append, wait=wait, clock=clock)
    sender.run("operator 1")
    assert sender.state == shown[-1]
    return shown, confirmed, clock


def test_a_lost_stop_is_said_in_red_and_sent_again_until_the_robot_confirms() -> None:
    blackout = RobotError(503, "link dropped the request (blackout)")
    link = FlakyLink(
        [blackout, blackout, httpx.ReadTimeout("no answer")], StopResult(aborted=7, dropped=[8, 9])
    )
    shown, confirmed, clock = run(link)
    assert [s.phase for s in shown] == ["pending", "failed", "failed", "failed", "confirmed"]
    assert [s.attempts for s in shown] == [1, 1, 2, 3, 4]
    assert len(link.timeouts) == 4  # sent four times, once a second after each failure
    assert RETRY_S == 1.0 and clock.now == pytest.approx(1003.0)
    assert "NOT CONFIRMED (link dropped the request (blackout))" in shown[1].text
    assert "the robot may still be moving" in shown[1].text and "2 sent" in shown[2].text
    assert "no answer within the round trip" in shown[3].text
    assert confirmed == [StopResult(aborted=7, dropped=[8, 9])]  # told once, when it is true
    assert shown[-1].text.endswith("on attempt 4): aborted #7, dropped 2 queued")


def test_each_attempt_waits_the_round_trip_and_a_margin_not_the_consoles_two_minutes() -> None:
    link = FlakyLink([], StopResult(aborted=None, dropped=[]))
    shown, confirmed, _ = run(link, rtt_s=3.0)
    assert len(confirmed) == 1
    assert CONFIRM_MARGIN_S == 2.0 and link.timeouts == [5.0]  # a 3 s round trip and 2 s
    assert [s.phase for s in shown] == ["pending", "confirmed"]
    assert "aborted nothing running, dropped 0 queued" in shown[-1].text and "attempt" not in shown[-1].text


def test_closing_the_console_ends_the_retries() -> None:
    calls: list[float] = []

    def never(timeout_s: float) -> StopResult:
        calls.append(timeout_s)
        raise RobotError(503, "link dropped the request (blackout)")

    waits = iter([False, False, True])  # the console closes during the third wait
    sender = StopSender(never, lambda: 0.0, lambda _: None, lambda _: None, wait=lambda _: next(waits))
    sender.run("console")
    assert len(calls) == 3 and sender.state.phase == "failed"


def test_a_confirmed_stop_ends_the_commands_it_names_at_once_and_only_once() -> None:
    """On main the bar said "stopped: aborted #494" while the line above said "PTWL #494: running"
    for about 7 s more."""
    history = CommandHistory()
    views = [history.sent("ptwl") for _ in range(3)]
    for command_id, view in zip((494, 495, 496), views, strict=True):
        history.accepted(view, command_id)
    history.event({"id": 494, "behavior": "ptwl", "status": "running", "instance": "a"})
    ended = history.stopped(494, [495])
    assert [(v.id, v.status) for v in ended] == [(494, "aborted"), (495, "aborted")]
    assert [v.id for v in history.live()] == [496]  # not named by the robot: still queued
    assert history.stopped(494, [495]) == []  # a retried STOP's answer ends nothing twice
    view, just_ended = history.event({"id": 494, "behavior": "ptwl", "status": "done", "exit": "aborted"})
    assert view is views[0] and not just_ended  # the robot's own event: no second notification


def test_a_second_press_while_one_is_being_sent_starts_no_second_loop_and_close_ends_it() -> None:
    """Pressing STOP again while the first is unanswered (a 3 s round trip) must not start a
    second loop of attempts beside it; closing the console ends the loop and joins its thread."""
    answer = threading.Event()
    calls: list[float] = []

    def slow_link(timeout_s: float) -> StopResult:
        calls.append(timeout_s)
        answer.wait(5.0)
        raise RobotError(503, "link dropped the request (blackout)")

    sender = StopSender(slow_link, lambda: 3.0, lambda _: None, lambda _: None)
    sender.close()  # never pressed: nothing to end
    sender = StopSender(slow_link, lambda: 3.0, lambda _: None, lambda _: None)
    sender.press("operator 1")
    wait_until(lambda: len(calls) == 1, 5.0)
    sender.press("operator 1")
    sender.press("operator 2")
    stop_threads = [t for t in threading.enumerate() if t.name == "ptwl-stop"]
    assert len(stop_threads) == 1 and len(calls) == 1
    sender.close()  # closed while an attempt waits: the loop ends after it, without a retry
    answer.set()
    stop_threads[0].join(5.0)
    assert not stop_threads[0].is_alive() and len(calls) == 1
    assert sender.state.phase == "failed"
